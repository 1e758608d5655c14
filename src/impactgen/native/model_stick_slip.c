/*
 * model_stick_slip.c: exact Coulomb friction's stick and slip at the contact points
 * (MODEL_COULOMB), beside the contact phases of model_machine.c. A point in contact slips
 * along +x (slip = +1) or -x (-1), or sticks (0) while its friction force F_f holds v_x at 0:
 *     slip +1 --v_x falls to 0--> stick if the holding force is within mu F, else slip -1
 *     slip -1 --v_x rises to 0--> stick, or slip +1
 *     stick --F_f rises to +mu F--> slip -1        stick --F_f falls to -mu F--> slip +1
 * A stuck point's friction force is watched after every step (model_machine_observe): one
 * beyond mu F means a slip event was missed (model_machine_stick_missed).
 */
#include <math.h>

#include "model_machine_points.h"

double model_slip_when_stopped(double F, double F_hold, double mu)
{
    if (fabs(F_hold) < mu * F) return 0.0;
    return F_hold > 0.0 ? -1.0 : (F_hold < 0.0 ? 1.0 : 0.0);
}

const char *model_machine_slip_name(int state, double slip)
{
#if MODEL_COULOMB
    if (state == MODEL_MACHINE_FREE) return "";
    return slip > 0.0 ? "slip+" : (slip < 0.0 ? "slip-" : "stick");
#else
    (void)state;
    (void)slip;
    return "";
#endif
}

void model_machine_observe(model_machine *m, const model_params *p, double t, const double *y)
{
#if MODEL_COULOMB
    int any = 0;  /* a stuck point, whose friction force to keep */
    for (int point = 0; point < MODEL_NCONTACT; ++point) any |= stuck(&m->point[point]);
    if (!any) return;
    double out[MODEL_NOUT];
    model_outputs(t, y, out, p);
    for (int point = 0; point < MODEL_NCONTACT; ++point) {
        model_point_machine *r = &m->point[point];
        if (!stuck(r)) continue;
        const point_outputs o = outputs_at(out, point);
        r->stick_excess = fmax(r->stick_excess, fabs(o.F_f) - p->mu * o.F);
        r->stick_F = fmax(r->stick_F, o.F);
    }
#else
    (void)m;
    (void)p;
    (void)t;
    (void)y;
#endif
}

int model_machine_stick_missed(const model_machine *m, const model_params *p)
{
#if MODEL_COULOMB
    for (int point = 0; point < MODEL_NCONTACT; ++point) {
        const model_point_machine *r = &m->point[point];
        if (r->stick_excess > MODEL_STICK_EXCESS * p->mu * fmax(r->stick_F, 1e-300)) return 1;
    }
#else
    (void)m;
    (void)p;
#endif
    return 0;
}

#if MODEL_COULOMB
static double sign_of(double x)
{
    return x > 0.0 ? 1.0 : -1.0;
}

/* The holding force of a point: the friction force that keeps its v_x at 0 at (t, y), under
 * the force law `law`. */
static double holding_force(const model_params *p, int point, int law, double t, const double *y)
{
    return outputs_as(p, point, law, 0.0, t, y).F_f;
}

double model_arriving_slip(const model_params *p, int point, double t, const double *y, double v_x, double v_y,
                            double F)
{
    const double speed = hypot(v_x, v_y);
    if (fabs(v_x) > MODEL_TANGENTIAL_TOLERANCE * fmax(speed, 1e-300)) return sign_of(v_x);
    const double hold = fabs(v_x) <= MODEL_TANGENTIAL_TOLERANCE * speed
                            ? holding_force(p, point, MODEL_PHASE_ELASTIC, t, y) : 0.0;
    return model_slip_when_stopped(F, hold, p->mu);
}

double model_slip_after_event(const model_params *p, int point, double t, const double *y, double old,
                               int backward, double F)
{
    if (old == 0.0) return backward ? -1.0 : 1.0;
    const double now = model_slip_when_stopped(F, holding_force(p, point, p->point[point].phase, t, y), p->mu);
    return now == old ? 0.0 : now;
}

double model_slip_unless_stopped(const model_params *p, int point, double t, const double *y, double slip,
                                  double v_x, double v_y, double F)
{
    if (v_x * slip > MODEL_STOPPED_TOLERANCE * hypot(v_x, v_y)) return slip;
    return model_slip_when_stopped(F, holding_force(p, point, p->point[point].phase, t, y), p->mu);
}

/* Several stuck points share the holding force (dependent rows, such as both ends of a link
 * lying flat, have no unique split), so a point that sticks can push another stuck point past
 * mu F at once, with no event left to cross. After each switch the stuck point loaded furthest
 * beyond mu F (by STICK_EXCESS) slips the way it is pushed, one at a time, until none is.
 * Returns the ACT_SLIP bit if a point was released. */
int model_release_overloaded(model_machine *m, model_params *p, double t, const double *y)
{
    int act = 0;
    for (int pass = 0; pass < MODEL_NCONTACT; ++pass) {
        double out[MODEL_NOUT];
        model_outputs(t, y, out, p);
        int worst = -1;  /* none yet */
        double worst_excess = 0.0, worst_F_f = 0.0;
        for (int point = 0; point < MODEL_NCONTACT; ++point) {
            if (!stuck(&m->point[point])) continue;
            const point_outputs o = outputs_at(out, point);
            const double excess = fabs(o.F_f) - p->mu * o.F;
            if (excess > MODEL_STICK_EXCESS * p->mu * fmax(o.F, 1e-300) && excess > worst_excess) {
                worst = point;
                worst_excess = excess;
                worst_F_f = o.F_f;
            }
        }
        if (worst < 0) return act;
        model_point_machine *r = &m->point[worst];
        r->slip = p->point[worst].slip = -sign_of(worst_F_f);
        r->act |= MODEL_ACT_SLIP | MODEL_ACT_RESTART;
        act |= MODEL_ACT_SLIP;
    }
    return act;
}
#endif
