/*
 * model_machine.h: the phase machine of MODEL section 4, over the contact points of a generated
 * model (model.h). Plain C99 beside the model: no globals, no allocation, no SUNDIALS. The
 * rules of a contact point do not depend on the chain; what the model supplies is per point
 * (its kinematics and forces as outputs, its events, its switch laws) and what the scene
 * chose (MODEL_PLASTIC, MODEL_COULOMB, MODEL_FROZEN, MODEL_SUSTAINED: only what it uses is
 * compiled in).
 *
 * With it an embedder sets the materials (not E*, delta_c, ...), asks which events to watch
 * in which direction, and at each event asks what comes next. A loop with any integrator
 * that finds roots:
 *
 *     model_params p = {...inputs...};          // lengths, masses, materials, mu
 *     if (model_derive(&p, &range) != MODEL_PARAMS_OK) ...  // names the bad input
 *     model_machine m;
 *     model_machine_start(&m, &p, t, y, run_to_time);
 *     for (;;) {
 *         int ev[MODEL_NEVENT], dir[MODEL_NEVENT];
 *         int k = model_machine_events(&m, ev, dir);  // watch ev[0..k) in direction dir
 *         ... integrate model_rhs(t, y, ydot, &p) until one of them crosses: fired[0..k) ...
 *         int act = model_machine_switch(&m, &p, t, y, fired);
 *         if (act & MODEL_ACT_END) break;
 *         if (act & MODEL_ACT_TOLERANCES) model_machine_atol(&m, &p, rtol, atol, atol_now);
 *         ... restart the integrator at (t, y): the force law changed ...
 *     }
 *
 * An integrator without directional root finding keeps the sides of the event functions:
 * model_machine_sides after each restart, model_machine_crossed after each step (roots.h).
 *
 * `impactgen generate --prefix P` writes this file as P_machine.h with every model_ and
 * MODEL_ name given the prefix P.
 */
#ifndef MODEL_MACHINE_H
#define MODEL_MACHINE_H

#include "model.h"

#ifndef MODEL_NDOF  /* a pinned chain's coordinates are its angles (a free chain's model.h adds x_0, y_0) */
#define MODEL_NDOF MODEL_NQ
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* cdef-begin: the declarations below are read by cffi as they stand. */
/* Machine states: the contact phases of MODEL section 4, plus reloading (restitution's force
 * law, watching the maximum compression). Codes are fixed (codegen/spec.py, STATES); a model
 * without the elasto-plastic law or sustained contact never enters some. */
enum {
    MODEL_MACHINE_FREE = 0,
    MODEL_MACHINE_ELASTIC = 1,
    MODEL_MACHINE_ELASTOPLASTIC = 2,
    MODEL_MACHINE_RESTITUTION = 3,
    MODEL_MACHINE_RELOADING = 4,
    MODEL_MACHINE_SUSTAINED = 5
};

/* What model_machine_start found. */
enum {
    MODEL_START_FREE = 0,     /* free flight towards the surface (or away: it may come back) */
    MODEL_START_CONTACT = 1,  /* touching and pressing in: the impact starts now */
    MODEL_START_ALONG = 2,    /* touching, moving along the surface: no impact */
    MODEL_START_AWAY = 3      /* touching, moving away from it: no impact */
};

/* Bits of what model_machine_switch did. */
enum {
    MODEL_ACT_RESTART = 1,          /* the force law or the watched events changed: restart the integrator */
    MODEL_ACT_END = 2,              /* the run ends here (separation, when not running to a time) */
    MODEL_ACT_TOLERANCES = 4,       /* the state scales changed: call model_machine_atol */
    MODEL_ACT_IMPACT_BEGIN = 8,     /* a new impact began */
    MODEL_ACT_IMPACT_END = 16,      /* the impact ended (separation or lift-off) */
    MODEL_ACT_MAX_COMPRESSION = 32, /* delta_max, P_max, delta_r and R_res were recorded */
    MODEL_ACT_SLIP = 64             /* the stick-slip state changed within the impact */
};

/* A contact point's machine, machine.point[k] (the joints', then the tip's at MODEL_TIP_POINT).
 * Its force law and the values fixed at its switches are in the point's record
 * params.point[k] (phase, y_s, delta_m, delta_r, R_res, slip, as the model has them). */
typedef struct {
    int state;          /* MODEL_MACHINE_* */
    int impacts;        /* impacts begun */
    int was;            /* its state before its latest switch */
    int act;            /* MODEL_ACT_* bits of its switch at the latest event (0: it had none) */
    int turned;         /* its restitution turned back into reloading in this impact: it vibrates on the surface */
    double delta_max;   /* maximum compression of the current (or last) impact, m */
    double P_max;       /* force there, N */
    double delta_r;     /* its permanent deformation, m */
    double R_res;       /* its unloading radius, m */
    double slip, was_slip;  /* exact Coulomb: +1 or -1 slipping along +x or -x, 0 stuck; and before its latest switch */
    double stick_excess; /* exact Coulomb: the largest |F_f| - mu F while stuck in this segment, N */
    double stick_F;      /* and the largest F there, N */
    double t_start;     /* start of the current (or last) impact, s */
    double t_end;       /* its end, s (NaN while it lasts) */
    double t_prev_start, t_prev_end;  /* the impact before it */
    double scale[MODEL_NSTATE];  /* typical size of each state in this impact (nominals) */
} model_point_machine;

/* The machine's state. Everything it decides lives here and in the parameters it sets. */
typedef struct {
    int run_to_time;    /* 1: separation does not end the run; later impacts follow */
    double side[MODEL_NEVENT];   /* last nonzero side of each event function (0: none yet) */
    model_point_machine point[MODEL_NCONTACT];  /* each contact point's, the tip's last */
} model_machine;

/* Begin at (t, y): sets the surface level (the tip's height when p->surface_initial), the
 * force laws and the first impact of each point that starts pressing in. Returns the tip's
 * MODEL_START_* (a run to a time: MODEL_START_CONTACT or MODEL_START_FREE). */
int model_machine_start(model_machine *m, model_params *p, double t, const double *y, int run_to_time);
/* The events to watch now: indices into model_events' output and their crossing
 * directions (+1 rising, -1 falling). Returns how many. */
int model_machine_events(const model_machine *m, int *events, int *directions);
/* At an event: fired[k] nonzero for each watched event k (in the order of
 * model_machine_events) that crossed at (t, y). Records what the switch fixes, moves to
 * the next state and sets the parameters. Returns MODEL_ACT_* bits. */
int model_machine_switch(model_machine *m, model_params *p, double t, const double *y, const int *fired);
/* 1 while a constraint force holds a point's velocity (a stuck point, a resting one): an
 * analytic Jacobian of the unconstrained equations does not hold then. */
int model_machine_constrained(const model_machine *m);
/* Absolute tolerances now, for relative tolerance rtol and the scene's atol: atol on angles
 * and speeds in free flight (the works scaled by a typical energy), tightened inside an
 * impact to its own scales. */
void model_machine_atol(const model_machine *m, const model_params *p, double rtol, double atol,
                        double *atol_out);
/* After each accepted step within a segment: keeps what model_machine_stick_missed judges
 * (a no-op unless a point sticks under exact Coulomb friction). */
void model_machine_observe(model_machine *m, const model_params *p, double t, const double *y);
/* At the end of a segment, before model_machine_switch: 1 when a stuck point needed a
 * friction force beyond mu F (by more than MODEL_STICK_EXCESS of the largest F in the
 * segment), so a slip event was missed and the run cannot be trusted; else 0. */
int model_machine_stick_missed(const model_machine *m, const model_params *p);
/* For integrators without directional root finding (FMI importers, fixed-step loops): after
 * each accepted step, model_machine_crossed flags in fired[k] the watched events whose
 * function crossed in their direction since the sides were stored (an exact 0 counts as
 * crossed) and returns how many; when none did, or after the switch, store the sides with
 * model_machine_sides. model_machine_start stores none: call it once at the start. */
void model_machine_sides(model_machine *m, const double *ev);
int model_machine_crossed(const model_machine *m, const double *ev, int *fired);
/* Exact Coulomb: the stick-slip state of a point at v_x = 0 under normal force F, when the
 * friction force that would hold it is F_hold: stick (0) when |F_hold| is strictly within
 * mu F, else slip (+1 or -1) the way the point is pushed, against F_hold. */
double model_slip_when_stopped(double F, double F_hold, double mu);
/* The name of a machine state ("free", "elastic", ...). */
const char *model_machine_state_name(int state);
/* The stick-slip label of a point in machine state `state` with slip state `slip` under exact
 * Coulomb friction: "slip+", "slip-" or "stick"; "" in free flight or without that friction. */
const char *model_machine_slip_name(int state, double slip);
/* The floor net, after each accepted step: the first point of the chain (1 to MODEL_NQ - 1:
 * that joint, MODEL_NQ: the tip, MODEL_NQ + 1: a free chain's base point; model_heights'
 * order) found deeper below the surface than MODEL_FLOOR_DEPTH of the shortest link, with its
 * depth in *depth, m; 0 when none is. */
int model_machine_below(const model_params *p, const double *y, double *depth);
/* The start check: a point of the chain that starts inside the surface deeper than
 * MODEL_TOUCH_TOLERANCE of the chain's length (at least 1 m), with its depth in *depth, m: the
 * tip (MODEL_NQ) if it is, else the first from the pivot (0; a free chain's base point) through
 * the joints (1 to MODEL_NQ - 1); -1 when every point starts on or above it (the joints and the
 * tip may touch it). The surface is p->surface_height, or the
 * tip's height when p->surface_initial is set (the scene checks refuse the same starts); a free
 * chain's, its lowest contact point's. */
int model_machine_start_inside(const model_params *p, const double *y, double *depth);
/* cdef-end */

#ifdef __cplusplus
}
#endif

#endif /* MODEL_MACHINE_H */
