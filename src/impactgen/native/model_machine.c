/*
 * model_machine.c: the phase machine of MODEL section 4 over the contact points of a generated
 * model, written once (model_machine.h). A contact point is a contact point: the joints with
 * contact code and the tip follow the same rules; what differs about the tip is only what
 * the scene says (the surface "initial" passes through it).
 *
 *     free --contact--> elastic --yield--> elastoplastic --max_compression--> restitution
 *     elastic --max_compression--> restitution          restitution --separation--> free
 *     restitution --rate rises--> reloading --rate falls--> restitution
 *     reloading --passes delta_m--> elastic or elastoplastic (the curve it left)
 *     elastic/elastoplastic --max_compression, impacts chattering--> sustained --lift_off--> free
 *
 * Exact Coulomb friction (MODEL_COULOMB) keeps a stick-slip state beside the contact phase:
 * model_stick_slip.c.
 *
 * The model supplies, per point, its outputs (penetration, rates, velocity, forces), its
 * events (model_events, MODEL_NTIP_EVENT per point), its acceleration into the surface and
 * the switch laws printed from sympy (model_residual_deformation, model_unloading_radius,
 * model_yielded, model_phase_of).
 */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "model_machine_points.h"
#include "roots.h"

#define RISING 1
#define FALLING (-1)
#define TIP MODEL_TIP_POINT
#define POINT_EVENTS MODEL_NTIP_EVENT  /* each point's events, in the order of the tip's MODEL_EVENT_* */

/* Whether a point at (t, y), with the outputs `out`, has no normal speed (up to rounding) but
 * the free chain pulls it into the surface (d2(delta)/dt2 beyond rounding of g): a resting or
 * grazing contact, which no crossing of the contact event would announce. */
static int pulled_in(const model_params *p, int point, double t, const double *y, const double *out)
{
    const point_outputs o = outputs_at(out, point);
    if (fabs(o.delta_rate) > MODEL_TANGENTIAL_TOLERANCE * (fabs(o.v_x) + fabs(o.v_y))) return 0;
    model_params free_flight = *p;
    double ydot[MODEL_NMOTION];  /* the motion's alone: the works and impulses play no part */
    free_flight.point[point].phase = MODEL_PHASE_FREE;
    if (model_motion_rhs(t, y, ydot, &free_flight) != 0) return 0;
    return model_delta_acceleration(point, y, ydot, &free_flight) > MODEL_TANGENTIAL_TOLERANCE * fmax(p->g, 1.0);
}

/* The state scales of an impact at a point of contact radius R approaching at v_n with speed
 * (v_x, v_y): a Hertz estimate of its penetration
 * delta_est = (15 m_eff v_n^2 / (16 E* R^1/2))^(2/5), with the effective mass
 * m_eff ~ 2 T / |v|^2, over the chain's length for the angles (the penetration is a
 * difference of heights); the speeds and the works at contact. */
static void impact_scales(const model_params *p, double R, double v_x, double v_y, double v_n, double T,
                          const double *y, double *scale)
{
    const double v2 = v_x * v_x + v_y * v_y;
    const double m_total = model_chain_mass(p), length = model_chain_length(p);
    const double m_eff = v2 > 0.0 ? fmin(2.0 * T / v2, m_total) : m_total;
    double delta_est = pow(15.0 * m_eff * v_n * v_n / (16.0 * p->E_star * sqrt(R)), 0.4);
    double speed = 0.0, energy = T;
    for (int i = 0; i < MODEL_NDOF; ++i) speed = fmax(speed, fabs(y[MODEL_NDOF + i]));
    if (!(delta_est > 0.0)) {  /* a resting or grazing start: the scales of settling under the chain's weight */
        delta_est = pow(3.0 * m_total * p->g / (4.0 * p->E_star * sqrt(R)), 2.0 / 3.0);
        speed = fmax(speed, sqrt(2.0 * p->g * delta_est) / length);
        energy = fmax(energy, m_total * p->g * delta_est);
    }
    for (int i = 0; i < MODEL_NDOF; ++i) {  /* a free chain's base point's x_0, y_0 in m, not over the length */
        scale[i] = MODEL_ANGLE_RESOLUTION * delta_est / (i < MODEL_NQ ? length : 1.0);
        scale[MODEL_NDOF + i] = speed;
    }
    /* the works (the impulses after them are left out of the error test: machine_atol) */
    for (int i = MODEL_NMOTION; i < MODEL_NSTATE; ++i) scale[i] = energy;
}

/* A new impact of a point at (t, y), whose outputs under the force laws so far are `out`. */
static void impact_begins(model_machine *m, model_params *p, int point, double t, const double *y,
                          const double *out, int into_dent)
{
    model_point_machine *r = &m->point[point];
    model_point_contact *c = &p->point[point];
    const point_outputs o = outputs_at(out, point);
    r->impacts += 1;
    r->t_prev_start = r->t_start;
    r->t_prev_end = r->t_end;
    r->t_start = t;
    r->t_end = NAN;
    r->turned = 0;
    if (!into_dent) {  /* a new impact on the undeformed surface (back into its own dent: its law kept) */
        r->delta_max = r->P_max = r->delta_r = 0.0;
        r->R_res = c->R;
        c->delta_m = 0.0;
#if MODEL_PLASTIC
        c->delta_r = 0.0;
        c->R_res = c->R;
#elif MODEL_RATE_LAW
        c->delta_r = 0.0;
#endif
    }
    impact_scales(p, c->R, o.v_x, o.v_y, fmax(o.delta_rate, 0.0), out[MODEL_OUT_T], y, r->scale);
#if MODEL_RATE_LAW
    /* a damped law scales its damping by the normal speed at contact; an impact that starts
     * with none (resting, grazing) is undamped */
    c->v_0 = o.delta_rate > 0.0 ? o.delta_rate : INFINITY;
#endif
#if MODEL_COULOMB
    r->slip = c->slip = model_arriving_slip(p, point, t, y, o.v_x, o.v_y, o.F);
#endif
#if MODEL_FROZEN
    /* frozen friction: the direction the point slides at contact start, kept to separation */
    c->s_frozen = o.v_x > 0.0 ? 1.0 : (o.v_x < 0.0 ? -1.0 : 0.0);
#endif
}

/* Set a point free before its first contact, on the surface at the level y_s. */
static void starts_free(model_machine *m, model_params *p, int point, double y_s)
{
    model_point_machine *r = &m->point[point];
    model_point_contact *c = &p->point[point];
    r->state = r->was = MODEL_MACHINE_FREE;
    r->t_start = r->t_end = r->t_prev_start = r->t_prev_end = NAN;
    r->slip = r->was_slip = 1.0;  /* free flight: no friction, whatever the state */
    r->stick_excess = -INFINITY;
    r->R_res = c->R;
    for (int i = 0; i < MODEL_NSTATE; ++i) r->scale[i] = 1.0;
    c->phase = MODEL_PHASE_FREE;
    c->y_s = y_s;
    c->delta_m = 0.0;
#if MODEL_PLASTIC
    c->delta_r = 0.0;
    c->R_res = c->R;
#elif MODEL_RATE_LAW
    c->delta_r = 0.0;
#endif
#if MODEL_COULOMB
    c->slip = r->slip;
#endif
#if MODEL_FROZEN
    c->s_frozen = 0.0;
#endif
#if MODEL_RATE_LAW
    c->v_0 = INFINITY;  /* no damping before an impact sets it (the force_zero event stays finite) */
#endif
}

/* How a free point starts at (t, y): touching and pressing in, or (running to a time)
 * touching with no normal speed but pulled into the surface (the free flight's
 * d2(delta)/dt2 beyond rounding of g: a resting or grazing start), its impact begins now:
 * MODEL_START_CONTACT; else MODEL_START_ALONG or _AWAY when touching, _FREE when not. */
static int starts_at(model_machine *m, model_params *p, int point, double t, const double *y)
{
    double out[MODEL_NOUT];
    model_outputs(t, y, out, p);  /* under the laws the points before it start with */
    const point_outputs o = outputs_at(out, point);
    const int touching = o.delta >= -MODEL_TOUCH_TOLERANCE * fmax(1.0, model_chain_length(p));
    double rate = o.delta_rate;
    if (fabs(rate) <= MODEL_TANGENTIAL_TOLERANCE * (fabs(o.v_x) + fabs(o.v_y))) rate = 0.0;  /* a tangential start */
    if (touching && (rate > 0.0 || (m->run_to_time && pulled_in(p, point, t, y, out)))) {
        impact_begins(m, p, point, t, y, out, 0);
        m->point[point].state = MODEL_MACHINE_ELASTIC;
        p->point[point].phase = model_phase_of(MODEL_MACHINE_ELASTIC);
        return MODEL_START_CONTACT;
    }
    if (!touching) return MODEL_START_FREE;
    return rate == 0.0 ? MODEL_START_ALONG : MODEL_START_AWAY;
}

int model_machine_start(model_machine *m, model_params *p, double t, const double *y, int run_to_time)
{
    memset(m, 0, sizeof *m);
    m->run_to_time = run_to_time;
    const double y_s = model_surface_at_start(p, y);
    for (int point = 0; point < MODEL_NCONTACT; ++point) starts_free(m, p, point, y_s);
    int start = MODEL_START_FREE;
    for (int point = 0; point < MODEL_NCONTACT; ++point) start = starts_at(m, p, point, t, y);  /* the tip's last */
    /* touching, not pressing in: no impact in a run to the first separation (a resting start
     * is MODEL_START_ALONG); a run to a time waits for one */
    return run_to_time && start != MODEL_START_CONTACT ? MODEL_START_FREE : start;
}

#define WATCH(e, d) (events[k] = (e), directions[k] = (d), ++k)
/* The contact events a point watches in machine state `state`, from events[0], as the tip's
 * event indices plus `base` (the point's first event). Returns how many. */
static int watch_state(int state, int base, int *events, int *directions)
{
    int k = 0;
    switch (state) {
    case MODEL_MACHINE_FREE:
        WATCH(MODEL_EVENT_CONTACT, RISING);
#if MODEL_PLASTIC || MODEL_RATE_LAW
        /* a point that separated inside its dent (delta = delta_r > 0) and comes back down
         * before it has left the surface never sees delta rise through 0: at its return to
         * delta_r it reloads along its restitution curve, a new impact in the same dent (a
         * damped law that let go while penetrating: a new impact where it let go) */
        WATCH(MODEL_EVENT_SEPARATION, RISING);
#endif
        break;
    case MODEL_MACHINE_ELASTIC:
        WATCH(MODEL_EVENT_MAX_COMPRESSION, FALLING);
#if MODEL_PLASTIC
        WATCH(MODEL_EVENT_YIELD, RISING);
#endif
        break;
    case MODEL_MACHINE_ELASTOPLASTIC:
        WATCH(MODEL_EVENT_MAX_COMPRESSION, FALLING);
        break;
    case MODEL_MACHINE_RESTITUTION:
#if MODEL_PLASTIC
        WATCH(MODEL_EVENT_SEPARATION, FALLING);  /* delta = delta_r */
#else
        WATCH(MODEL_EVENT_CONTACT, FALLING);  /* Hertz only: delta_r = 0 */
#endif
#if MODEL_RATE_LAW
        WATCH(MODEL_EVENT_FORCE_ZERO, FALLING);  /* a damped force reaches 0 while penetrating */
#endif
        WATCH(MODEL_EVENT_MAX_COMPRESSION, RISING);
        break;
    case MODEL_MACHINE_RELOADING:
        WATCH(MODEL_EVENT_MAX_COMPRESSION, FALLING);
        WATCH(MODEL_EVENT_PASSES_DELTA_M, RISING);
        break;
#if MODEL_SUSTAINED
    case MODEL_MACHINE_SUSTAINED:
        WATCH(MODEL_EVENT_LIFT_OFF, FALLING);
        break;
#endif
    default:
        break;
    }
    for (int e = 0; e < k; ++e) events[e] += base;
    return k;
}

#if MODEL_COULOMB
/* The stick-slip events a point in contact watches with slip state `slip`, as watch_state. */
static int watch_slip(double slip, int base, int *events, int *directions)
{
    int k = 0;
    if (slip > 0.0) {
        WATCH(MODEL_EVENT_SLIP_STOPS, FALLING);
    } else if (slip < 0.0) {
        WATCH(MODEL_EVENT_SLIP_STOPS, RISING);
    } else {
        WATCH(MODEL_EVENT_SLIP_BACKWARD, FALLING);
        WATCH(MODEL_EVENT_SLIP_FORWARD, FALLING);
    }
    for (int e = 0; e < k; ++e) events[e] += base;
    return k;
}
#endif
#undef WATCH

int model_machine_events(const model_machine *m, int *events, int *directions)
{
    int k = 0;
    for (int point = 0; point < MODEL_NCONTACT; ++point) {
        const model_point_machine *r = &m->point[point];
        const int base = model_first_event(point);
        k += watch_state(r->state, base, events + k, directions + k);
#if MODEL_COULOMB
        if (r->state != MODEL_MACHINE_FREE) k += watch_slip(r->slip, base, events + k, directions + k);
#endif
    }
    return k;
}

/* The machine state after `state` when the contact events in `has` fired. */
static int next_state(int state, const int *has, const model_point_contact *pc)
{
    (void)pc;
    switch (state) {
    case MODEL_MACHINE_FREE:  /* a new impact, or back into its own dent (delta_r), reloading */
#if MODEL_PLASTIC
        return has[MODEL_EVENT_CONTACT] || !(pc->delta_r > 0.0) ? MODEL_MACHINE_ELASTIC : MODEL_MACHINE_RELOADING;
#else
        return MODEL_MACHINE_ELASTIC;
#endif
    case MODEL_MACHINE_ELASTIC:
    case MODEL_MACHINE_ELASTOPLASTIC:
        return has[MODEL_EVENT_MAX_COMPRESSION] ? MODEL_MACHINE_RESTITUTION : MODEL_MACHINE_ELASTOPLASTIC;
    case MODEL_MACHINE_RESTITUTION:
#if MODEL_PLASTIC
        return has[MODEL_EVENT_SEPARATION] ? MODEL_MACHINE_FREE : MODEL_MACHINE_RELOADING;
#elif MODEL_RATE_LAW
        return has[MODEL_EVENT_CONTACT] || has[MODEL_EVENT_FORCE_ZERO] ? MODEL_MACHINE_FREE : MODEL_MACHINE_RELOADING;
#else
        return has[MODEL_EVENT_CONTACT] ? MODEL_MACHINE_FREE : MODEL_MACHINE_RELOADING;
#endif
    case MODEL_MACHINE_RELOADING:  /* back past delta_m onto the curve it left, or unloading again */
        if (!has[MODEL_EVENT_PASSES_DELTA_M]) return MODEL_MACHINE_RESTITUTION;
#if MODEL_PLASTIC
        return model_yielded(pc) ? MODEL_MACHINE_ELASTOPLASTIC : MODEL_MACHINE_ELASTIC;
#else
        return MODEL_MACHINE_ELASTIC;
#endif
    default:  /* sustained: lift-off */
        return MODEL_MACHINE_FREE;
    }
}

#if MODEL_SUSTAINED
/* Whether a point at (t, y), held on the surface (phase sustained, its stick-slip state kept),
 * would press onto it: the constraint force that holds its v_y is positive. */
static int pressed_on(const model_machine *m, const model_params *p, int point, double t, const double *y)
{
    return outputs_as(p, point, MODEL_PHASE_SUSTAINED, m->point[point].slip, t, y).F > 0.0;
}
#endif

/* What a point fixes at its maximum compression, at penetration delta_max under force P_m. */
static void max_compression(model_point_machine *r, model_point_contact *c, const model_params *p,
                            double delta_max, double P_m)
{
#if MODEL_PLASTIC
    const double delta_r = model_residual_deformation(delta_max, c);
    const double R_res = model_unloading_radius(delta_max, P_m, delta_r, p);
    c->delta_r = delta_r;
    c->R_res = R_res;
#else
    const double delta_r = 0.0, R_res = c->R;
    (void)p;
#endif
    c->delta_m = delta_max;
    r->delta_max = delta_max;
    r->P_max = P_m;
    r->delta_r = delta_r;
    r->R_res = R_res;
}

/* A point's switch at (t, y) when its events in `has` (indexed as the tip's) fired, with
 * the outputs under the force laws acting now (the points switched before it: their new
 * ones). Returns MODEL_ACT_* bits. */
static int point_switch(model_machine *m, model_params *p, int point, const int *has, double t, const double *y)
{
    model_point_machine *r = &m->point[point];
    model_point_contact *c = &p->point[point];
    double out[MODEL_NOUT];
    model_outputs(t, y, out, p);
    const point_outputs o = outputs_at(out, point);
    const int state = r->state;
    int act = MODEL_ACT_RESTART;
#if MODEL_COULOMB
    const int slip_fired = has[MODEL_EVENT_SLIP_STOPS] || has[MODEL_EVENT_SLIP_BACKWARD] || has[MODEL_EVENT_SLIP_FORWARD];
    int contact_fired = 0;
    for (int e = 0; e < POINT_EVENTS; ++e) {
        contact_fired |= has[e] && e != MODEL_EVENT_SLIP_STOPS && e != MODEL_EVENT_SLIP_BACKWARD &&
                         e != MODEL_EVENT_SLIP_FORWARD;
    }
    if (slip_fired && state != MODEL_MACHINE_FREE) {
        r->slip = c->slip = model_slip_after_event(p, point, t, y, r->slip, has[MODEL_EVENT_SLIP_BACKWARD], o.F);
        act |= MODEL_ACT_SLIP;
    }
    if (!contact_fired) {  /* only the friction state changed */
        r->act = act;
        return act;
    }
#endif
    int next = next_state(state, has, c);
    if (state == MODEL_MACHINE_FREE) {
        impact_begins(m, p, point, t, y, out, next == MODEL_MACHINE_RELOADING);
        act |= MODEL_ACT_IMPACT_BEGIN | MODEL_ACT_TOLERANCES;
    } else if (next == MODEL_MACHINE_RESTITUTION &&
               (state == MODEL_MACHINE_ELASTIC || state == MODEL_MACHINE_ELASTOPLASTIC)) {
        max_compression(r, c, p, o.delta, o.F);
        act |= MODEL_ACT_MAX_COMPRESSION;
#if MODEL_SUSTAINED
        /* chattering: hold the point on the surface, if pressed onto it, rather than rebound
         * into ever shorter flights */
        if (r->impacts > 1 && r->t_start - r->t_prev_end < MODEL_CHATTER_RATIO * (r->t_prev_end - r->t_prev_start) &&
            pressed_on(m, p, point, t, y)) {
            next = MODEL_MACHINE_SUSTAINED;
        }
#endif
    }
#if MODEL_SUSTAINED
    if (next == MODEL_MACHINE_RESTITUTION && state != MODEL_MACHINE_RESTITUTION && r->turned && m->run_to_time &&
        pressed_on(m, p, point, t, y)) {
        /* vibrating on the surface: the point's restitution turned back into reloading in this
         * impact before it separated (or it left its dent with no normal speed and was pulled
         * back in), and now it has reached a maximum compression again (its reload's peak, or,
         * having passed delta_m, the loading curve's). An undamped compliant contact would
         * oscillate so about its static depth to the end of the run, a vibration of the order
         * of that depth that any real damping, or a rough surface, takes out at once: the
         * limit of chattering, a flight of length zero. It is held at this maximum
         * compression, where its normal speed is 0 (no velocity jumps, no impulse): the
         * elastic energy left in its dent, the vibration's, is not returned and stays in
         * W_normal as a loss, as at the chatter switch, so the budget still closes. */
        next = MODEL_MACHINE_SUSTAINED;
    }
#endif
#if MODEL_COULOMB
    if (state != MODEL_MACHINE_FREE && next != MODEL_MACHINE_FREE && r->slip != 0.0 && !slip_fired) {
        const double old = r->slip;
        r->slip = c->slip = model_slip_unless_stopped(p, point, t, y, old, o.v_x, o.v_y, o.F);
        if (r->slip != old) act |= MODEL_ACT_SLIP;
    }
#endif
    if (next == MODEL_MACHINE_FREE && state == MODEL_MACHINE_RESTITUTION && pulled_in(p, point, t, y, out)) {
        /* a grazing separation: the point leaves the dent with no normal speed but is pulled
         * back in, so the contact event (delta rising through 0) would never fire: it reloads */
        next = MODEL_MACHINE_RELOADING;
    }
    if (state == MODEL_MACHINE_RESTITUTION && next == MODEL_MACHINE_RELOADING) r->turned = 1;
    if (next == MODEL_MACHINE_FREE) {
        r->t_end = t;
#if MODEL_RATE_LAW
        /* a damped law lets go while the point still penetrates: that depth is its set, and
         * where a new impact begins should the point come back before it leaves the surface */
        if (state == MODEL_MACHINE_RESTITUTION) r->delta_r = c->delta_r = fmax(o.delta, 0.0);
#endif
        act |= MODEL_ACT_IMPACT_END | MODEL_ACT_TOLERANCES;
        for (int i = 0; i < MODEL_NSTATE; ++i) r->scale[i] = 1.0;  /* no impact's scales */
        /* the surface is where a point left it after resting on it */
        if (state == MODEL_MACHINE_SUSTAINED) c->y_s -= o.delta;
    }
    r->state = next;
    c->phase = model_phase_of(next);
    r->act = act;
    return act;
}

int model_machine_switch(model_machine *m, model_params *p, double t, const double *y, const int *fired)
{
    int events[MODEL_NEVENT] = {0}, directions[MODEL_NEVENT] = {0};  /* (filled by model_machine_events) */
    int has[MODEL_NEVENT] = {0};
    int point_fired[MODEL_NCONTACT] = {0};
    const int watched = model_machine_events(m, events, directions);
    for (int point = 0; point < MODEL_NCONTACT; ++point) {
        model_point_machine *r = &m->point[point];
        r->act = 0;
        r->was = r->state;  /* what its record names as before the switch, whatever changes it */
        r->was_slip = r->slip;
        r->stick_excess = -INFINITY;  /* a new segment follows */
        r->stick_F = 0.0;
    }
    for (int k = 0; k < watched; ++k) {
        if (!fired[k]) continue;
        has[events[k]] = 1;
        point_fired[model_event_point(events[k])] = 1;
    }
    /* point after point, each under the force laws the points before it switched to */
    int act = 0, separated = 0, touching = 0;
    for (int point = 0; point < MODEL_NCONTACT; ++point) {
        if (!point_fired[point]) continue;
        const int point_act = point_switch(m, p, point, has + model_first_event(point), t, y);
        act |= point_act & (MODEL_ACT_RESTART | MODEL_ACT_TOLERANCES);
        if (point_act & MODEL_ACT_IMPACT_END) separated = 1;
    }
    /* a run to separation ends where no point touches the surface any more */
    for (int point = 0; point < MODEL_NCONTACT; ++point) touching |= m->point[point].state != MODEL_MACHINE_FREE;
    if (!m->run_to_time && separated && !touching) act |= MODEL_ACT_END;
#if MODEL_COULOMB
    if (act) act |= model_release_overloaded(m, p, t, y);
#endif
    return act;
}

int model_machine_constrained(const model_machine *m)
{
    for (int point = 0; point < MODEL_NCONTACT; ++point) {  /* a resting point, or a stuck one */
        const model_point_machine *r = &m->point[point];
#if MODEL_SUSTAINED
        if (r->state == MODEL_MACHINE_SUSTAINED) return 1;
#endif
#if MODEL_COULOMB
        if (stuck(r)) return 1;
#endif
        (void)r;
    }
    return 0;
}

void model_machine_atol(const model_machine *m, const model_params *p, double rtol, double atol, double *atol_out)
{
    /* free flight: the works get atol times a typical energy */
    const double energy = fmax(model_chain_mass(p) * fmax(p->g, 1.0) * model_chain_length(p), 1e-30);
    for (int i = 0; i < MODEL_NMOTION; ++i) atol_out[i] = atol;
    for (int i = MODEL_NMOTION; i < MODEL_NSTATE; ++i) atol_out[i] = atol * energy;
    for (int point = 0; point < MODEL_NCONTACT; ++point) {
        /* inside a point's impact: rtol times its scales, never looser than outside it */
        const model_point_machine *r = &m->point[point];
        if (r->state == MODEL_MACHINE_FREE) continue;
        for (int i = 0; i < MODEL_NDOF; ++i) atol_out[i] = fmin(fmax(rtol * r->scale[i], MODEL_ANGLE_ATOL_FLOOR), atol_out[i]);
        for (int i = MODEL_NDOF; i < MODEL_NSTATE; ++i) atol_out[i] = fmin(atol_out[i], fmax(rtol * r->scale[i], 1e-300));
    }
    /* the impulses and each joint's own works follow the steps the other states set (with
     * them in the error test, the paper's impact took 68 steps instead of 59 for the same
     * motion) */
    for (int i = MODEL_Y_P_normal; i < MODEL_NSTATE; ++i) atol_out[i] = MODEL_QUADRATURE_ATOL;
}

void model_machine_sides(model_machine *m, const double *ev)
{
    for (int e = 0; e < MODEL_NEVENT; ++e) m->side[e] = ig_side_after(m->side[e], ev[e]);
}

int model_machine_crossed(const model_machine *m, const double *ev, int *fired)
{
    int events[MODEL_NEVENT] = {0}, directions[MODEL_NEVENT] = {0};  /* (filled by model_machine_events) */
    const int watched = model_machine_events(m, events, directions);
    int count = 0;
    for (int k = 0; k < watched; ++k) {
        fired[k] = ig_crossed(m->side[events[k]], ev[events[k]], directions[k]);
        count += fired[k];
    }
    return count;
}

const char *model_machine_state_name(int state)
{
    static const char *const names[] = {"free", "elastic", "elastoplastic", "restitution", "reloading", "sustained"};
    return state >= 0 && state < (int)(sizeof names / sizeof names[0]) ? names[state] : "unknown";
}

/* Where point `number` (0: a free chain's base point, k: joint k, MODEL_NQ: the tip) sits
 * in model_heights' output: the joints and the tip in order, the base point after them. */
static inline int height_index(int number)
{
    return number == 0 ? MODEL_NQ : number - 1;
}

int model_machine_below(const model_params *p, const double *y, double *depth)
{
    double h[MODEL_NPOINT];
    const double shortest = model_shortest_link(p);
    model_heights(y, h, p);
    /* a point with contact is measured from its own surface level (where it last lifted off
     * from rest, as the tip's y_s) */
    for (int k = 0; k < MODEL_NCONTACT; ++k) h[height_index(model_point_number(k))] += p->point[TIP].y_s - p->point[k].y_s;
    for (int k = 0; k < MODEL_NPOINT; ++k) {
        if (h[k] < -MODEL_FLOOR_DEPTH * shortest) {
            *depth = -h[k];
            return k + 1;
        }
    }
    *depth = 0.0;
    return 0;
}

int model_machine_start_inside(const model_params *p, const double *y, double *depth)
{
    double h[MODEL_NPOINT];
    model_heights(y, h, p);  /* above the tip's surface level p->point[TIP].y_s */
    const double y_tip = h[MODEL_NQ - 1] + p->point[TIP].y_s;  /* heights above the pivot */
    const double y_s = model_surface_at_start(p, y);
    const double slack = MODEL_TOUCH_TOLERANCE * fmax(1.0, model_chain_length(p));
    if (y_s - y_tip > slack) {  /* the tip first, as the scene checks it (a surface set by its height) */
        *depth = y_s - y_tip;
        return MODEL_NQ;
    }
#ifdef MODEL_FREE
    const double y_base = h[height_index(0)] + p->point[TIP].y_s;  /* a free chain's base point */
#else
    const double y_base = 0.0;  /* the pivot, at height 0 */
#endif
    if (y_s - y_base > slack) {
        *depth = y_s - y_base;
        return 0;
    }
    for (int k = 0; k < MODEL_NQ - 1; ++k) {  /* the joints */
        const double below = y_s - (h[k] + p->point[TIP].y_s);
        if (below > slack) {
            *depth = below;
            return k + 1;
        }
    }
    *depth = 0.0;
    return -1;
}
