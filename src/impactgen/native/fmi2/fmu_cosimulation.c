/*
 * fmu_cosimulation.c: Co-Simulation (FMU_CO_SIMULATION). The phase machine runs in ig_run
 * (run.c, SUNDIALS linked statically), the same loop as impactgen's engine, at the tolerance
 * of fmi2SetupExperiment. The integrator steps on its own across communication points (the
 * states there are interpolated), so the step size a master chooses does not change the
 * events; each switch ig_run records is logged (fmu_log_switch) and followed in the tally of
 * the run's summaries.
 */
#include <math.h>
#include <string.h>

#include "fmu_instance.h"

#ifdef FMU_CO_SIMULATION
#include "model_scene.h"

/* the analytic Jacobian, when the model has one and the method is implicit */
#define USE_JACOBIAN (MODEL_HAS_JACOBIAN && IG_METHOD_USES_JACOBIAN(MODEL_SCENE_METHOD))
#define STOP_SLACK 1e-9  /* a last step may pass the stop time by this much (relative): rounding of t + h */
#define RUN_CAPACITY 8   /* samples per ig_run call of fmi2DoStep */
/* switch records per ig_run call: a switch writes one per contact point whose switch acted
 * (run.c, SWITCH_RECORDS) */
#define RUN_SEGMENTS (RUN_CAPACITY * MODEL_NCONTACT)
#define MAX_SEGMENTS 100000  /* phase segments within one fmi2DoStep (chattering impacts beyond) */

fmi2Status fmu_start_stepping(fmu_instance *c)
{
    double atol[MODEL_NSTATE];
    char err[256];
    model_machine_atol(&c->m, &c->p, c->rtol, MODEL_SCENE_ATOL, atol);
    c->solver = ig_solver_new(MODEL_SCENE_METHOD, USE_JACOBIAN, c->rtol, atol, MODEL_SCENE_MAX_STEPS, err,
                              (int)sizeof err);
    if (!c->solver) {
        c->mode = FAILED;
        return fmu_fail(c, "cannot create CVODE: %s", err);
    }
    c->t_int = c->t;
    memcpy(c->y_int, c->y, sizeof c->y);
    c->mode = STEPPING;
    return fmi2OK;
}

void fmu_free_solver(fmu_instance *c)
{
    ig_solver_free(c->solver);
    c->solver = NULL;
}

/* The switches in the segment records ig_run wrote: each point's (seg->point: MODEL_NQ the
 * tip, else the joint) that changed its state or its stick-slip state. */
static void log_switches(const fmu_instance *c, const ig_segment *segments, int n)
{
    for (int k = 0; k < n; ++k) {
        const ig_segment *seg = &segments[k];
        fmu_log_switch(c, seg->t, seg->point, seg->state, seg->next_state, seg->slip, seg->next_slip, seg->act);
    }
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    fmu_instance *c = (fmu_instance *)comp;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!fmu_allowed(c, CALL_DO_STEP)) return fmi2Error;
    if (!isfinite(t) || !isfinite(h)) {
        return fmu_fail(c, "%s", "fmi2DoStep: the communication point and the step size must be finite numbers");
    }
    if (!(h >= 0.0) || !(fabs(t - c->t) <= 1e-9 * fmax(1.0, fabs(t)))) {
        fmu_say(c, fmi2Error, "logStatusError", "fmi2DoStep: the step must start where the last one ended "
                "(t = %.17g s), with h >= 0; got t = %.17g s, h = %g s", c->t, t, h);
        return fmi2Error;
    }
    const double target = t + h;
    const double t_stop = c->stop_time + STOP_SLACK * fmax(1.0, fabs(c->stop_time));
    if (c->t_int >= t_stop && target > c->t_int) {
        return fmu_fail(c, "%s", "fmi2DoStep: the step goes beyond the stop time of fmi2SetupExperiment");
    }
    double t_buf[RUN_CAPACITY], y_buf[RUN_CAPACITY * MODEL_NSTATE], out_buf[RUN_CAPACITY * MODEL_NOUT];
    ig_segment segments[RUN_SEGMENTS];
    int flag = IG_TARGET;
    long begun = 0;
    while (c->t_int <= target) {  /* (at target only to switch at a root left there) */
        int n = 0, n_segments = 0;
        flag = ig_run(c->solver, &c->m, &c->p, &c->t_int, c->y_int, t_stop, target, MODEL_SCENE_ATOL,
                      MAX_SEGMENTS - begun, 0, t_buf, y_buf, out_buf, NULL, RUN_CAPACITY, &n, segments,
                      RUN_SEGMENTS, &n_segments, &c->tally);
        begun += n_segments;
        log_switches(c, segments, n_segments);
        if (flag != IG_BUFFER_FULL && flag != IG_SEGMENTS_FULL) break;
    }
    fmu_invalidate(c);  /* the machine may have switched: the parameters changed */
    if (flag < 0) {
        c->mode = FAILED;
        fmu_say(c, fmi2Error, "logStatusError", "the integrator failed in phase %s near t = %g: %s",
                model_machine_state_name(c->m.point[MODEL_TIP_POINT].state), c->t_int, ig_solver_message(c->solver));
        return fmi2Error;
    }
    if (c->t_int < target) {  /* the run ended before the communication point */
        return fmu_fail(c, "%s", "fmi2DoStep: the step goes beyond the stop time of fmi2SetupExperiment");
    }
    if (c->t_int == target || h == 0.0) {
        if (c->t_int == target) memcpy(c->y, c->y_int, sizeof c->y);
    } else if (ig_interpolate(c->solver, target, c->y) != 0) {
        c->mode = FAILED;
        return fmu_fail(c, "cannot interpolate the state at the communication point: %s", ig_solver_message(c->solver));
    }
    c->t = target;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp)
{
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2DoStep never runs asynchronously");
}
fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s; (void)value;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2GetStatus: no asynchronous steps");
}
fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (s == fmi2LastSuccessfulTime && c) {
        *value = c->t;
        return fmi2OK;
    }
    return fmu_fail(c, "%s", "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s; (void)value;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2GetIntegerStatus: not provided");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value)
{
    (void)s; (void)value;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2GetBooleanStatus: not provided");
}
fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value)
{
    (void)s; (void)value;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2GetStringStatus: not provided");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return fmu_fail((fmu_instance *)comp, "%s", "this FMU has no inputs");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    return fmu_fail((fmu_instance *)comp, "%s", "output derivatives are not provided");
}
#else
fmi2Status fmu_start_stepping(fmu_instance *c)
{
    c->mode = FAILED;
    return fmu_fail(c, "%s", "Co-Simulation is not built in");
}
void fmu_free_solver(fmu_instance *c) { (void)c; }

#define NOT_BUILT_IN(c) fmu_fail((const fmu_instance *)(c), "%s", "Co-Simulation is not built in")
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean b) { (void)t; (void)h; (void)b; return NOT_BUILT_IN(c); }
fmi2Status fmi2CancelStep(fmi2Component c) { return NOT_BUILT_IN(c); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { (void)s; (void)v; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) { (void)s; (void)v; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { (void)s; (void)v; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) { (void)s; (void)v; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { (void)s; (void)v; return NOT_BUILT_IN(c); }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]) { (void)vr; (void)n; (void)o; (void)v; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]) { (void)vr; (void)n; (void)o; (void)v; return NOT_BUILT_IN(c); }
#endif
