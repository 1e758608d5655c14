/*
 * fmu_api.c: the FMI 2.0 functions common to Model Exchange and Co-Simulation (instantiate,
 * set up, initialize, terminate, reset, free) and the one table of which function is allowed
 * in which mode of the instance (as the Reference-FMUs' MASK_ table, fmi2Functions.c); the
 * logger every file writes through. Functions this FMU does not provide (FMU states,
 * directional derivatives) say so.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_instance.h"
#include "model_fmu.h"

#define FAR_FUTURE 1e30  /* the end of a run with no stop time */

/* ---- which function is allowed in which mode ---- */
#define IN(m) (1 << (m))
#define SETUP (IN(INSTANTIATED) | IN(INITIALIZATION))
#define RUNNING (IN(EVENT) | IN(CONTINUOUS) | IN(STEPPING))
#define ANY (SETUP | RUNNING | IN(TERMINATED) | IN(FAILED))

static const struct {
    const char *name;
    int modes;  /* IN(mode) bits */
} calls[FMU_NCALL] = {
    [CALL_SETUP_EXPERIMENT] = {"fmi2SetupExperiment", IN(INSTANTIATED)},
    [CALL_ENTER_INITIALIZATION] = {"fmi2EnterInitializationMode", IN(INSTANTIATED)},
    [CALL_EXIT_INITIALIZATION] = {"fmi2ExitInitializationMode", IN(INITIALIZATION)},
    [CALL_TERMINATE] = {"fmi2Terminate", RUNNING | IN(FAILED)},
    [CALL_RESET] = {"fmi2Reset", ANY},
    [CALL_GET_REAL] = {"fmi2GetReal", ANY & ~IN(FAILED)},
    [CALL_GET_INTEGER] = {"fmi2GetInteger", ANY & ~IN(FAILED)},
    [CALL_GET_BOOLEAN] = {"fmi2GetBoolean", ANY & ~IN(FAILED)},
    [CALL_SET_REAL] = {"fmi2SetReal", SETUP},
    [CALL_SET_BOOLEAN] = {"fmi2SetBoolean", SETUP},
    [CALL_ENTER_EVENT_MODE] = {"fmi2EnterEventMode", IN(EVENT) | IN(CONTINUOUS)},
    [CALL_NEW_DISCRETE_STATES] = {"fmi2NewDiscreteStates", IN(EVENT)},
    [CALL_ENTER_CONTINUOUS_TIME_MODE] = {"fmi2EnterContinuousTimeMode", IN(EVENT)},
    [CALL_COMPLETED_INTEGRATOR_STEP] = {"fmi2CompletedIntegratorStep", IN(CONTINUOUS)},
    [CALL_SET_TIME] = {"fmi2SetTime", IN(EVENT) | IN(CONTINUOUS)},
    [CALL_SET_CONTINUOUS_STATES] = {"fmi2SetContinuousStates", IN(EVENT) | IN(CONTINUOUS)},
    [CALL_GET_DERIVATIVES] = {"fmi2GetDerivatives", RUNNING | IN(INITIALIZATION)},
    [CALL_GET_EVENT_INDICATORS] = {"fmi2GetEventIndicators", RUNNING | IN(INITIALIZATION)},
    [CALL_GET_CONTINUOUS_STATES] = {"fmi2GetContinuousStates", RUNNING | IN(INITIALIZATION) | IN(TERMINATED)},
    [CALL_GET_NOMINALS] = {"fmi2GetNominalsOfContinuousStates", ANY},
    [CALL_DO_STEP] = {"fmi2DoStep", IN(STEPPING)},
};

int fmu_allowed(const fmu_instance *c, enum fmu_call call)
{
    if (!c) return 0;
    if (calls[call].modes & IN(c->mode)) return 1;
    fmu_say(c, fmi2Error, "logStatusError", "%s is not allowed in this state of the FMU", calls[call].name);
    return 0;
}

/* ---- logging: the FMI 2 logger is printf-like, so a message has its % doubled ---- */
void fmu_say(const fmu_instance *c, fmi2Status status, const char *category, const char *fmt, ...)
{
    if (!c || !c->cb.logger) return;
    if (status == fmi2OK && !c->logging) return;
    char text[768], escaped[1536];
    va_list args;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    size_t j = 0;
    for (size_t i = 0; text[i] && j + 2 < sizeof escaped; ++i) {
        if (text[i] == '%') escaped[j++] = '%';
        escaped[j++] = text[i];
    }
    escaped[j] = '\0';
    c->cb.logger(c->cb.componentEnvironment, c->name, status, category, escaped);
}

fmi2Status fmu_fail(const fmu_instance *c, const char *fmt, const char *what)
{
    fmu_say(c, fmi2Error, "logStatusError", fmt, what);
    return fmi2Error;
}

/* An array argument that is NULL while its count is not 0 (outside the FMI contract) is an
 * fmi2Error, not a crash, as in the Reference-FMUs. */
int fmu_null_array(const fmu_instance *c, const char *function, size_t n, const void *a, const void *b)
{
    if (n == 0 || (a && b)) return 0;
    fmu_say(c, fmi2Error, "logStatusError", "%s: an array argument is NULL", function);
    return 1;
}

/* ---- the lifecycle ---- */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n, const fmi2String categories[])
{
    fmu_instance *c = (fmu_instance *)comp;
    (void)n; (void)categories;
    if (!c) return fmi2Error;
    c->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)location; (void)visible;
    if (!functions || !name) return NULL;
    fmu_instance probe = {0};
    probe.cb = *functions;
    probe.name = (char *)name;
#ifndef FMU_MODEL_EXCHANGE
    if (type == fmi2ModelExchange) {
        fmu_say(&probe, fmi2Error, "logStatusError", "this FMU was built for Co-Simulation only");
        return NULL;
    }
#endif
#ifndef FMU_CO_SIMULATION
    if (type == fmi2CoSimulation) {
        fmu_say(&probe, fmi2Error, "logStatusError", "this FMU was built for Model Exchange only");
        return NULL;
    }
#endif
    if (guid && strcmp(guid, FMU_GUID) != 0) {
        fmu_say(&probe, fmi2Error, "logStatusError", "GUID %s does not match this FMU (%s): rebuild it", guid,
                FMU_GUID);
        return NULL;
    }
    fmu_instance *c = (fmu_instance *)calloc(1, sizeof *c);
    if (!c) return NULL;
    c->name = (char *)malloc(strlen(name) + 1);
    if (!c->name) {
        free(c);
        return NULL;
    }
    strcpy(c->name, name);
    c->type = type;
    c->cb = *functions;
    c->logging = loggingOn;
    c->mode = INSTANTIATED;
    fmu_set_start_values(c);
    return c;
}

void fmi2FreeInstance(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!c) return;
    fmu_free_solver(c);
    free(c->name);
    free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_SETUP_EXPERIMENT)) return fmi2Error;
    if (toleranceDefined) {
        if (!(tolerance > 0.0 && tolerance < 1.0)) return fmu_fail(c, "%s", "the tolerance must lie in (0, 1)");
        c->rtol = tolerance;
    }
    if (!isfinite(startTime)) return fmu_fail(c, "%s", "fmi2SetupExperiment: the start time must be a finite number");
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime)) {
        return fmu_fail(c, "%s", "fmi2SetupExperiment: the stop time must be a finite number >= the start time");
    }
    c->t = c->t_done = c->start_time = startTime;
    c->stop_time = stopTimeDefined ? stopTime : FAR_FUTURE;
    fmu_start_changed(c);
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_ENTER_INITIALIZATION)) return fmi2Error;
    c->mode = INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_EXIT_INITIALIZATION)) return fmi2Error;
    const char *range = "";
    const int bad = fmu_prepare(c, &range);
    if (bad != MODEL_PARAMS_OK) return fmu_refuse_input(c, bad, range);
    if (fmu_check_start(c) != fmi2OK) return fmi2Error;
    c->nominals_changed = 0;
#ifdef FMU_CO_SIMULATION
    if (c->type == fmi2CoSimulation) return fmu_start_stepping(c);
#endif
    c->mode = EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_TERMINATE)) return fmi2Error;
    c->mode = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp)
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_RESET)) return fmi2Error;
    fmu_free_solver(c);
    fmu_set_start_values(c);
    memset(&c->m, 0, sizeof c->m);
    c->mode = INSTANTIATED;
    return fmi2OK;
}

/* ---- not provided: FMU states, directional derivatives ---- */
fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *state)
{
    (void)state;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2GetFMUstate is not supported (canGetAndSetFMUstate is false)");
}
fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate state)
{
    (void)state;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2SetFMUstate is not supported (canGetAndSetFMUstate is false)");
}
fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *state)
{
    (void)state;
    return fmu_fail((fmu_instance *)comp, "%s", "fmi2FreeFMUstate is not supported (canGetAndSetFMUstate is false)");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate state, size_t *size)
{
    (void)state; (void)size;
    return fmu_fail((fmu_instance *)comp, "%s", "FMU states cannot be serialized");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate state, fmi2Byte bytes[], size_t size)
{
    (void)state; (void)bytes; (void)size;
    return fmu_fail((fmu_instance *)comp, "%s", "FMU states cannot be serialized");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state)
{
    (void)bytes; (void)size; (void)state;
    return fmu_fail((fmu_instance *)comp, "%s", "FMU states cannot be serialized");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference unknown[], size_t nu,
                                        const fmi2ValueReference known[], size_t nk, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[])
{
    (void)unknown; (void)nu; (void)known; (void)nk; (void)dv_known; (void)dv_unknown;
    return fmu_fail((fmu_instance *)comp, "%s", "directional derivatives are not provided");
}
