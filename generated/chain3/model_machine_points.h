/*
 * model_machine_points.h: what the phase machine's two files share (model_machine.c, the
 * contact phases; model_stick_slip.c, exact Coulomb friction's stick and slip): a contact
 * point's quantities among the model's outputs, and the stick-slip decisions the phases call
 * at their switches. Internal to the machine: not part of its API (model_machine.h).
 */
#ifndef MODEL_MACHINE_POINTS_H
#define MODEL_MACHINE_POINTS_H

#include "model_machine.h"

/* A point's quantities among the model's outputs. */
typedef struct {
    double delta, delta_rate, v_x, v_y, F, F_f;
} point_outputs;

static inline point_outputs outputs_at(const double *out, int k)
{
    point_outputs o;
    o.delta = out[model_point_output(k, MODEL_POINT_DELTA)];
    o.delta_rate = out[model_point_output(k, MODEL_POINT_DELTA_RATE)];
    o.v_x = out[model_point_output(k, MODEL_POINT_V_X)];
    o.v_y = out[model_point_output(k, MODEL_POINT_V_Y)];
    o.F = out[model_point_output(k, MODEL_POINT_F)];
#if MODEL_HAS_FRICTION
    o.F_f = out[model_point_output(k, MODEL_POINT_F_F)];
#else
    o.F_f = 0.0;
#endif
    return o;
}

#if MODEL_CONSTRAINED
/* A point's outputs at (t, y) were it under the force law `law` and (exact Coulomb) the slip
 * state `slip`, the other points as they are: what its force would be, for a decision. */
static inline point_outputs outputs_as(const model_params *p, int point, int law, double slip, double t, const double *y)
{
    model_params as = *p;
    as.point[point].phase = law;
#if MODEL_COULOMB
    as.point[point].slip = slip;
#else
    (void)slip;
#endif
    double out[MODEL_NOUT];
    model_outputs(t, y, out, &as);
    return outputs_at(out, point);
}
#endif


#if MODEL_COULOMB
/* A point stuck under exact Coulomb friction: in contact, v_x held at 0. */
static inline int stuck(const model_point_machine *r)
{
    return r->state != MODEL_MACHINE_FREE && r->slip == 0.0;
}

/* The slip state of a point that comes into contact with velocity (v_x, v_y) under normal
 * force F: slipping the way it moves, or, arriving with no tangential speed, as at a stop
 * with the holding force under the contact's first law (as the reference engine's). */
double model_arriving_slip(const model_params *p, int point, double t, const double *y, double v_x, double v_y,
                           double F);
/* After a slip event of a point in contact (under normal force F): a stuck point slips the
 * way it is pushed (`backward`: along -x); at a stop the holding force lies within mu F or
 * pushes the point back the way it came; one pushing it on (only by rounding,
 * |F_hold| ~ mu F) means stick. */
double model_slip_after_event(const model_params *p, int point, double t, const double *y, double old, int backward,
                              double F);
/* A slip whose point has stopped, or moves the other way, after a contact event with no
 * stick-slip event is decided as at a stop: its own event can coincide with the contact
 * event and go unreported (a single bar stops sliding exactly when it stops penetrating). */
double model_slip_unless_stopped(const model_params *p, int point, double t, const double *y, double slip,
                                 double v_x, double v_y, double F);
/* After a switch: stuck points pushed past mu F by it slip, one at a time. Returns the
 * MODEL_ACT_SLIP bit if a point was released. */
int model_release_overloaded(model_machine *m, model_params *p, double t, const double *y);
#endif

#endif /* MODEL_MACHINE_POINTS_H */
