/*
 * fmu_model_exchange.c: Model Exchange (FMU_MODEL_EXCHANGE). The importer integrates q, u,
 * the works and the impulses; the event indicators are the machine's event functions
 * (unwatched ones read 1), and at each event the machine switches (fmu_event_update). The
 * nominals are the machine's tolerance scales, changed at the start and end of an impact.
 * After each completed step the floor net (model_machine_below, as ig_run's) ends a run that
 * went through the surface, and a crossing an importer did not locate still enters event mode.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmu_instance.h"

#ifdef FMU_MODEL_EXCHANGE
fmi2Status fmi2EnterEventMode(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_ENTER_EVENT_MODE)) return fmi2Error;
    c->mode = EVENT;
    c->t_done = c->t;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo *info)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_NEW_DISCRETE_STATES)) return fmi2Error;
    if (fmu_null_array(c, "fmi2NewDiscreteStates", 1, info, info)) return fmi2Error;
    const int act = fmu_event_update(c);
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = (act & MODEL_ACT_TOLERANCES) || c->nominals_changed;
    info->valuesOfContinuousStatesChanged = fmi2False;
    info->nextEventTimeDefined = fmi2False;
    info->nextEventTime = 0.0;
    c->nominals_changed = 0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_ENTER_CONTINUOUS_TIME_MODE)) return fmi2Error;
    c->mode = CONTINUOUS;
    return fmi2OK;
}

/* The floor net after a step: a point deeper below the surface than any contact's depth ends
 * the run (FAILED, logged), naming it. Returns 1 then, else 0. */
static int went_through(fmu_instance *c)
{
    double depth = 0.0;
    const int point = model_machine_below(&c->p, c->y, &depth);
    if (point == 0) return 0;
    char name[32];
    if (point < MODEL_NQ) snprintf(name, sizeof name, "joint %d", point);
    else if (point > MODEL_NQ) snprintf(name, sizeof name, "the base point");  /* a free chain's, after the tip */
    else snprintf(name, sizeof name, "the tip");
    c->mode = FAILED;
    fmu_say(c, fmi2Error, "logStatusError", "%s is %.3g m below the surface at t = %.6g s (deeper than %g %% of "
            "the shortest link, beyond any contact's depth): the chain went through the surface", name, depth, c->t,
            100.0 * MODEL_FLOOR_DEPTH);
    return 1;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    fmu_instance *c = (fmu_instance *)comp;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!fmu_allowed(c, CALL_COMPLETED_INTEGRATOR_STEP)) return fmi2Error;
    if (fmu_null_array(c, "fmi2CompletedIntegratorStep", 1, enterEventMode, terminateSimulation)) return fmi2Error;
    if (went_through(c)) {
        *enterEventMode = fmi2False;
        *terminateSimulation = fmi2True;
        return fmi2Error;
    }
    /* an importer that does not locate roots still gets its events at the next step */
    double ev[MODEL_NEVENT];
    int fired[MODEL_NEVENT];
    model_events(c->t, c->y, ev, &c->p);
    c->t_done = c->t;
    *enterEventMode = model_machine_crossed(&c->m, ev, fired) > 0;
    if (!*enterEventMode) model_machine_sides(&c->m, ev);
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_SET_TIME)) return fmi2Error;
    /* an integrator may go back within its step (a retried step, a root search), never before
     * the last completed step or event: this FMU keeps no earlier state to go back to */
    if (!isfinite(time)) return fmu_fail(c, "%s", "fmi2SetTime: the time must be a finite number");
    if (time < c->t_done) {
        fmu_say(c, fmi2Error, "logStatusError", "fmi2SetTime: t = %.17g s is before the last completed step or "
                "event at t = %.17g s: time cannot go backwards", time, c->t_done);
        return fmi2Error;
    }
    if (time != c->t) fmu_invalidate(c);
    c->t = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_SET_CONTINUOUS_STATES)) return fmi2Error;
    if (fmu_null_array(c, "fmi2SetContinuousStates", nx, x, x)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fmu_fail(c, "%s", "fmi2SetContinuousStates: wrong number of states");
    memcpy(c->y, x, sizeof(double) * MODEL_NSTATE);
    fmu_invalidate(c);
    return fmi2OK;
}

/* In initialization mode the state is the start values' (fmu_prepare): refuses an input out
 * of range. */
static fmi2Status ready(fmu_instance *c)
{
    if (c->mode != INITIALIZATION) return fmi2OK;
    const char *range = "";
    const int bad = fmu_prepare(c, &range);
    return bad == MODEL_PARAMS_OK ? fmi2OK : fmu_refuse_input(c, bad, range);
}

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_DERIVATIVES)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetDerivatives", nx, derivatives, derivatives)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fmu_fail(c, "%s", "fmi2GetDerivatives: wrong number of states");
    if (ready(c) != fmi2OK) return fmi2Error;
    int flag = 0;
    const double *ydot = fmu_derivatives(c, &flag);
    memcpy(derivatives, ydot, sizeof(double) * MODEL_NSTATE);
    if (flag != 0) {
        fmu_say(c, fmi2Error, "logStatusError", "the right-hand side is not finite at t = %g in phase %s%s", c->t,
                model_machine_state_name(c->m.point[MODEL_TIP_POINT].state),
                flag < 0 ? ": the mass matrix is not positive definite (check chain.mass and chain.length)" : "");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real indicators[], size_t ni)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_EVENT_INDICATORS)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetEventIndicators", ni, indicators, indicators)) return fmi2Error;
    if (ni != MODEL_NEVENT) return fmu_fail(c, "%s", "fmi2GetEventIndicators: wrong number of indicators");
    if (ready(c) != fmi2OK) return fmi2Error;
    double ev[MODEL_NEVENT];
    int events[MODEL_NEVENT], directions[MODEL_NEVENT];
    model_events(c->t, c->y, ev, &c->p);
    for (int e = 0; e < MODEL_NEVENT; ++e) indicators[e] = 1.0;  /* not watched now */
    const int watched = model_machine_events(&c->m, events, directions);
    for (int k = 0; k < watched; ++k) indicators[events[k]] = ev[events[k]];
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_CONTINUOUS_STATES)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetContinuousStates", nx, x, x)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fmu_fail(c, "%s", "fmi2GetContinuousStates: wrong number of states");
    if (ready(c) != fmi2OK) return fmi2Error;
    memcpy(x, c->y, sizeof(double) * MODEL_NSTATE);
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[], size_t nx)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_NOMINALS)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetNominalsOfContinuousStates", nx, x_nominal, x_nominal)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fmu_fail(c, "%s", "fmi2GetNominalsOfContinuousStates: wrong number of states");
    /* the machine's tolerance scales: 1 for angles and speeds in flight, the impact's own
     * scales inside it (an importer's absolute tolerance is rtol times the nominal) */
    model_machine_atol(&c->m, &c->p, 1.0, 1.0, x_nominal);
    /* the impulses (N s) are left out of the machine's error test (MODEL_QUADRATURE_ATOL),
     * which is no scale: their nominal is 1 */
    for (size_t i = MODEL_Y_P_normal; i < nx; ++i) x_nominal[i] = 1.0;
    return fmi2OK;
}
#else
#define NOT_BUILT_IN(c) fmu_fail((const fmu_instance *)(c), "%s", "Model Exchange is not built in")
fmi2Status fmi2EnterEventMode(fmi2Component c) { return NOT_BUILT_IN(c); }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *i) { (void)i; return NOT_BUILT_IN(c); }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return NOT_BUILT_IN(c); }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean a, fmi2Boolean *b, fmi2Boolean *d) { (void)a; (void)b; (void)d; return NOT_BUILT_IN(c); }
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { (void)t; return NOT_BUILT_IN(c); }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) { (void)x; (void)n; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return NOT_BUILT_IN(c); }
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return NOT_BUILT_IN(c); }
#endif
