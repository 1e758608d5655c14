/*
 * fmi2_glue.c: the FMI 2.0 interface of a generated impact model, written once for every
 * model (as the Reference-FMUs split a model from its FMI glue). The model-specific parts
 * are generated: model.c (right-hand side, events, outputs), model_machine.c (the phase
 * machine), model_scene.h (the start values) and model_fmu.h (the variables by value
 * reference).
 *
 * Model Exchange (FMU_MODEL_EXCHANGE): the importer integrates q, u and the works; the event
 * indicators are the machine's event functions. FMI has no crossing direction, so the glue
 * keeps the side of each function and lets the machine decide in fmi2NewDiscreteStates;
 * a crossing the wrong way is a no-op event. Unwatched indicators read 1.
 *
 * Co-Simulation (FMU_CO_SIMULATION): the phase machine runs in ig_run (run.c, SUNDIALS linked
 * statically), the same driver as impactgen's engine, at the tolerance of
 * fmi2SetupExperiment. The integrator steps on its own across communication points (states
 * there are interpolated), so the step size a master chooses does not change the events.
 *
 * Contact at the joints (a model generated with MODEL_NJOINT): each joint that can reach the
 * surface has its own machine state, events (after the tip's), outputs and impact record; the
 * glue logs each point's switches and gives each point's discrete outputs. The joints the
 * model was pruned of must stay out of reach: fmi2ExitInitializationMode refuses values that
 * would let one reach the surface (model_pruned_reach), naming it.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_machine.h"
#include "model_scene.h"
#include "model_fmu.h"
#ifdef FMU_CO_SIMULATION
#include "solver.h"
#endif

#if !defined(FMU_MODEL_EXCHANGE) && !defined(FMU_CO_SIMULATION)
#error "define FMU_MODEL_EXCHANGE, FMU_CO_SIMULATION or both"
#endif

enum mode { INSTANTIATED, INITIALIZATION, EVENT, CONTINUOUS, STEPPING, TERMINATED, FAILED };
/* the analytic Jacobian, when the model has one and the method is implicit */
#define USE_JACOBIAN (MODEL_HAS_JACOBIAN && IG_METHOD_USES_JACOBIAN(MODEL_SCENE_METHOD))
#define FAR_FUTURE 1e30  /* the end of a run with no stop time */
#define STOP_SLACK 1e-9  /* a last step may pass the stop time by this much (relative): rounding of t + h */
#ifdef MODEL_NJOINT
#define FMU_NJOINT MODEL_NJOINT           /* the joints with contact code */
#define FMU_NTIP_EVENT MODEL_NTIP_EVENT   /* the tip's events; each joint's follow */
#else
#define FMU_NJOINT 0
#define FMU_NTIP_EVENT MODEL_NEVENT
#endif
#define RUN_CAPACITY 8   /* samples per ig_run call of fmi2DoStep */
/* segment records per ig_run call: a switch writes one for the tip and one per joint that
 * switched (run.c, SWITCH_RECORDS) */
#define RUN_SEGMENTS (RUN_CAPACITY * (1 + FMU_NJOINT))
#define MAX_SEGMENTS 100000  /* phase segments within one fmi2DoStep (chattering impacts beyond) */

typedef struct {
    char *name;
    fmi2Type type;
    fmi2CallbackFunctions cb;
    int logging;
    int mode;
    model_params p;              /* inputs as set; derived and machine fields after initialization */
    double q0[MODEL_NQ], u0[MODEL_NQ];
    double t;
    double t_done;               /* Model Exchange: the last completed step or event; time never goes before it */
    double y[MODEL_NSTATE];
    model_machine m;
    double start_time, stop_time, rtol;
    int nominals_changed;
#ifdef FMU_CO_SIMULATION
    ig_solver *solver;
    double t_int;                /* where the integrator is (>= t) */
    double y_int[MODEL_NSTATE];
#endif
} instance;

/* ---- logging: the FMI 2 logger is printf-like, so a message has its % doubled ---- */
static void say(const instance *c, fmi2Status status, const char *category, const char *fmt, ...)
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

static fmi2Status fail(instance *c, const char *fmt, const char *what)
{
    say(c, fmi2Error, "logStatusError", fmt, what);
    return fmi2Error;
}

static int allowed(instance *c, const char *function, int modes)
{
    if (!c) return 0;
    if (modes & (1 << c->mode)) return 1;
    say(c, fmi2Error, "logStatusError", "%s is not allowed in this state of the FMU", function);
    return 0;
}
/* An array argument that is NULL while its count is not 0 (outside the FMI contract) is an
 * fmi2Error, not a crash, as in the Reference-FMUs. */
static int null_array(instance *c, const char *function, size_t n, const void *a, const void *b)
{
    if (n == 0 || (a && b)) return 0;
    say(c, fmi2Error, "logStatusError", "%s: an array argument is NULL", function);
    return 1;
}
#define IN(m) (1 << (m))
#define SETUP (IN(INSTANTIATED) | IN(INITIALIZATION))
#define RUNNING (IN(EVENT) | IN(CONTINUOUS) | IN(STEPPING))
#define ANY (SETUP | RUNNING | IN(TERMINATED) | IN(FAILED))

static void set_start_values(instance *c)
{
    double y0[MODEL_NSTATE];
    memset(&c->p, 0, sizeof c->p);
    model_scene_inputs(&c->p, y0);
    for (int i = 0; i < MODEL_NQ; ++i) {
        c->q0[i] = y0[i];
        c->u0[i] = y0[MODEL_NQ + i];
    }
    c->t = c->t_done = c->start_time = 0.0;
    c->stop_time = FAR_FUTURE;
    c->rtol = MODEL_SCENE_RTOL;
}

/* The initial state and, with the parameters derived, the machine at it. Returns 0, or the
 * index of the first parameter out of its range. */
static int prepare(instance *c, const char **range)
{
    for (int i = 0; i < MODEL_NQ; ++i) {
        c->y[i] = c->q0[i];
        c->y[MODEL_NQ + i] = c->u0[i];
    }
    for (int k = 2 * MODEL_NQ; k < MODEL_NSTATE; ++k) c->y[k] = 0.0;
    const int bad = model_derive(&c->p, range);
    if (bad != MODEL_PARAMS_OK) return bad;
    model_machine_start(&c->m, &c->p, c->t, c->y, 1);
    double ev[MODEL_NEVENT];
    model_events(c->t, c->y, ev, &c->p);
    model_machine_sides(&c->m, ev);
    return MODEL_PARAMS_OK;
}

static fmi2Status bad_parameter(instance *c, int k, const char *range)
{
    char what[256];
    snprintf(what, sizeof what, "%s = %g is outside its physical range %s", model_param_key(k),
             *model_param_slot(&c->p, k), range);
    c->mode = FAILED;
    return fail(c, "%s", what);
}

static const fmu_variable *variable(instance *c, fmi2ValueReference vr, char type)
{
    if (vr >= FMU_NVARS) {
        say(c, fmi2Error, "logStatusError", "no variable has value reference %u", (unsigned)vr);
        return NULL;
    }
    const fmu_variable *v = &fmu_variables[vr];
    if (v->type != type) {
        say(c, fmi2Error, "logStatusError", "variable %s (value reference %u) is not of this type",
            v->name, (unsigned)vr);
        return NULL;
    }
    return v;
}

/* ---- FMI functions common to both kinds ---- */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n, const fmi2String categories[])
{
    instance *c = (instance *)comp;
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
    instance probe = {0};
    probe.cb = *functions;
    probe.name = (char *)name;
#ifndef FMU_MODEL_EXCHANGE
    if (type == fmi2ModelExchange) {
        say(&probe, fmi2Error, "logStatusError", "this FMU was built for Co-Simulation only");
        return NULL;
    }
#endif
#ifndef FMU_CO_SIMULATION
    if (type == fmi2CoSimulation) {
        say(&probe, fmi2Error, "logStatusError", "this FMU was built for Model Exchange only");
        return NULL;
    }
#endif
    if (guid && strcmp(guid, FMU_GUID) != 0) {
        say(&probe, fmi2Error, "logStatusError", "GUID %s does not match this FMU (%s): rebuild it", guid, FMU_GUID);
        return NULL;
    }
    instance *c = (instance *)calloc(1, sizeof *c);
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
    set_start_values(c);
    return c;
}

static void free_solver(instance *c)
{
#ifdef FMU_CO_SIMULATION
    ig_solver_free(c->solver);
    c->solver = NULL;
#else
    (void)c;
#endif
}

void fmi2FreeInstance(fmi2Component comp)
{
    instance *c = (instance *)comp;
    if (!c) return;
    free_solver(c);
    free(c->name);
    free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2SetupExperiment", IN(INSTANTIATED))) return fmi2Error;
    if (toleranceDefined) {
        if (!(tolerance > 0.0 && tolerance < 1.0)) return fail(c, "%s", "the tolerance must lie in (0, 1)");
        c->rtol = tolerance;
    }
    if (!isfinite(startTime)) return fail(c, "%s", "fmi2SetupExperiment: the start time must be a finite number");
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime)) {
        return fail(c, "%s", "fmi2SetupExperiment: the stop time must be a finite number >= the start time");
    }
    c->t = c->t_done = c->start_time = startTime;
    c->stop_time = stopTimeDefined ? stopTime : FAR_FUTURE;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2EnterInitializationMode", IN(INSTANTIATED))) return fmi2Error;
    c->mode = INITIALIZATION;
    return fmi2OK;
}

/* The length of link i (from 1), chain.length[i], m. */
static double link_length(instance *c, int i)
{
    char key[32];
    snprintf(key, sizeof key, "chain.length[%d]", i);
    for (int k = 0; k < MODEL_NPARAM; ++k) {
        if (strcmp(model_param_key(k), key) == 0) return *model_param_slot(&c->p, k);
    }
    return NAN;
}

/* The start load_scene refuses (scene.py, _check_physics), by the same rule: a tip inside the
 * surface, or a pivot or joint below it, by more than the touch tolerance. Logs the variable
 * and the link and returns 1; 0 for a start on or above the surface. After prepare (p.point[MODEL_TIP_POINT].y_s). */
static int start_below_surface(instance *c)
{
    double length[MODEL_NQ] = {0}, height[MODEL_NQ + 1] = {0}, total = 0.0;
    for (int i = 0; i < MODEL_NQ; ++i) {
        length[i] = link_length(c, i + 1);
        total += length[i];
        height[i + 1] = height[i] + length[i] * sin(c->q0[i]);
    }
    const double slack = MODEL_TOUCH_TOLERANCE * fmax(1.0, total), y_s = c->p.point[MODEL_TIP_POINT].y_s, y_tip = height[MODEL_NQ];
    if (y_s - y_tip > slack) {
        say(c, fmi2Error, "logStatusError", "surface.height: the tip of link %d starts %.3g m inside the "
            "surface (tip at y = %.6g m, surface at %.6g m); lower the surface or change initial.q",
            MODEL_NQ, y_s - y_tip, y_tip, y_s);
        return 1;
    }
    for (int link = 1; link <= MODEL_NQ; ++link) {
        const double upper = height[link - 1], lower = link < MODEL_NQ ? height[link] : upper;
        const double low = fmin(upper, lower);  /* the tip itself may touch */
        if (y_s - low > slack) {
            say(c, fmi2Error, "logStatusError", "initial.q: link %d starts below the surface: %s is at y = "
                "%.6g m, the surface at y = %.6g m; every point of the chain must start on or above the "
                "surface, the tip at most touching it", link, low == upper ? "its pivot end" : "its lower end",
                low, y_s);
            return 1;
        }
    }
    return 0;
}

/* A joint this model was pruned of (it could not reach the surface at the values the FMU was
 * built from) that could reach it with the values set now: the FMU has no contact law for it,
 * so it would pass through the surface unseen. Logs the joint and the values and returns 1;
 * 0 when the model fits the values. After prepare (p.point[MODEL_TIP_POINT].y_s: the surface at the start). */
static int pruned_joint_reaches(instance *c)
{
    const int joint = model_pruned_reach(&c->p, c->y);
    if (joint == 0) return 0;
    double reach = 0.0;
    for (int i = 1; i <= joint; ++i) reach += link_length(c, i);
    char lengths[64];
    if (joint == 1) snprintf(lengths, sizeof lengths, "chain.length[1]");
    else snprintf(lengths, sizeof lengths, "chain.length[1] + ... + chain.length[%d]", joint);
    say(c, fmi2Error, "logStatusError", "joint %d (the end of link %d) can reach the surface with these values, "
        "but this FMU has no contact at joint %d: it was built from values at which the joint cannot reach, and "
        "was pruned. %s = %.6g m reaches the surface %.6g m below the pivot (%s). Build the FMU from a scene "
        "with these values (impactgen fmu SCENE --set KEY=VALUE) to have joint %d's contact, or keep the "
        "surface out of its reach", joint, joint, joint, lengths, reach, -c->p.point[MODEL_TIP_POINT].y_s,
        c->p.surface_initial != 0.0 ? "at the tip's initial height: surface.height_initial, initial.q"
                                    : "surface.height", joint);
    return 1;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2ExitInitializationMode", IN(INITIALIZATION))) return fmi2Error;
    const char *range = "";
    const int bad = prepare(c, &range);
    if (bad != MODEL_PARAMS_OK) return bad_parameter(c, bad, range);
    if (start_below_surface(c) || pruned_joint_reaches(c)) {
        c->mode = FAILED;
        return fmi2Error;
    }
    c->nominals_changed = 0;
#ifdef FMU_CO_SIMULATION
    if (c->type == fmi2CoSimulation) {
        double atol[MODEL_NSTATE];
        char err[256];
        model_machine_atol(&c->m, &c->p, c->rtol, MODEL_SCENE_ATOL, atol);
        c->solver = ig_solver_new(MODEL_SCENE_METHOD, USE_JACOBIAN, c->rtol, atol, MODEL_SCENE_MAX_STEPS,
                                  err, (int)sizeof err);
        if (!c->solver) {
            c->mode = FAILED;
            return fail(c, "cannot create CVODE: %s", err);
        }
        c->t_int = c->t;
        memcpy(c->y_int, c->y, sizeof c->y);
        c->mode = STEPPING;
        return fmi2OK;
    }
#endif
    c->mode = EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2Terminate", RUNNING | IN(FAILED))) return fmi2Error;
    c->mode = TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2Reset", ANY)) return fmi2Error;
    free_solver(c);
    set_start_values(c);
    memset(&c->m, 0, sizeof c->m);
    c->mode = INSTANTIATED;
    return fmi2OK;
}

/* ---- variables ---- */
/* A discrete output of the machine (VAR_PHASE, VAR_IMPACTS, VAR_DELTA_MAX, ...) of point
 * `point`: 0 the tip, k + 1 the joint in the machine's slot k. */
static double machine_value(const instance *c, int kind, int point)
{
#ifdef MODEL_NJOINT
    const model_point_machine *r = point > 0 ? &c->m.point[point - 1] : &c->m.point[MODEL_TIP_POINT];
#else
    const model_point_machine *r = &c->m.point[MODEL_TIP_POINT];
    (void)point;
#endif
    switch (kind) {
    case VAR_PHASE: return r->state;
    case VAR_IMPACTS: return r->impacts;
    case VAR_DELTA_MAX: return r->delta_max;
    case VAR_DELTA_R: return r->delta_r;
    case VAR_P_MAX: return r->P_max;
    default: return NAN;
    }
}

static double real_value(instance *c, const fmu_variable *v)
{
    double out[MODEL_NOUT], ydot[MODEL_NSTATE];
    if (c->mode == INSTANTIATED || c->mode == INITIALIZATION) {
        if (v->kind == VAR_PARAM) return *model_param_slot(&c->p, v->index);
        if (v->kind == VAR_Q0) return c->q0[v->index];
        if (v->kind == VAR_U0) return c->u0[v->index];
        const char *range = "";  /* the state and outputs the start values give */
        if (prepare(c, &range) != MODEL_PARAMS_OK) return NAN;
    }
    switch (v->kind) {
    case VAR_PARAM: return *model_param_slot(&c->p, v->index);
    case VAR_Q0: return c->q0[v->index];
    case VAR_U0: return c->u0[v->index];
    case VAR_STATE: return c->y[v->index];
    case VAR_DER:
        if (model_rhs(c->t, c->y, ydot, &c->p) != 0) return NAN;
        return ydot[v->index];
    case VAR_OUTPUT:
        model_outputs(c->t, c->y, out, &c->p);
        return out[v->index];
    case VAR_DELTA_MAX:
    case VAR_DELTA_R:
    case VAR_P_MAX: return machine_value(c, v->kind, v->index);
    default: return NAN;
    }
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2GetReal", ANY & ~IN(FAILED))) return fmi2Error;
    if (null_array(c, "fmi2GetReal", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'R');
        if (!v) return fmi2Error;
        value[k] = real_value(c, v);
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2GetInteger", ANY & ~IN(FAILED))) return fmi2Error;
    if (null_array(c, "fmi2GetInteger", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'I');
        if (!v) return fmi2Error;
        value[k] = (fmi2Integer)machine_value(c, v->kind, v->index);
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2GetBoolean", ANY & ~IN(FAILED))) return fmi2Error;
    if (null_array(c, "fmi2GetBoolean", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'B');
        if (!v) return fmi2Error;
        value[k] = *model_param_slot(&c->p, v->index) != 0.0;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    instance *c = (instance *)comp;
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    return fail(c, "%s", "this FMU has no String variables");
}

/* Set one parameter (or start value) after checking it against its physical range. */
static fmi2Status set_parameter(instance *c, const fmu_variable *v, double value)
{
    if (v->kind == VAR_Q0 || v->kind == VAR_U0) {
        if (!isfinite(value)) return fail(c, "%s must be a finite number", v->name);
        (v->kind == VAR_Q0 ? c->q0 : c->u0)[v->index] = value;
        return fmi2OK;
    }
    if (v->kind != VAR_PARAM) return fail(c, "%s is not a parameter: it cannot be set", v->name);
    model_params trial = c->p;
    *model_param_slot(&trial, v->index) = value;
    const char *range = "";
    const int bad = model_check(&trial, &range);
    if (bad == v->index) {
        char what[256];
        snprintf(what, sizeof what, "%s = %g is outside its physical range %s; the value is not set",
                 v->name, value, range);
        return fail(c, "%s", what);
    }
    *model_param_slot(&c->p, v->index) = value;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2SetReal", SETUP)) return fmi2Error;
    if (null_array(c, "fmi2SetReal", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'R');
        if (!v || set_parameter(c, v, value[k]) != fmi2OK) return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    instance *c = (instance *)comp;
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    return fail(c, "%s", "the Integer variables of this FMU (phase, impacts) are outputs: they cannot be set");
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2SetBoolean", SETUP)) return fmi2Error;
    if (null_array(c, "fmi2SetBoolean", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'B');
        if (!v || set_parameter(c, v, value[k] ? 1.0 : 0.0) != fmi2OK) return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    instance *c = (instance *)comp;
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    return fail(c, "%s", "this FMU has no String variables");
}

/* ---- not supported: FMU state, directional derivatives ---- */
fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *state)
{
    (void)state;
    return fail((instance *)comp, "%s", "fmi2GetFMUstate is not supported (canGetAndSetFMUstate is false)");
}
fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate state)
{
    (void)state;
    return fail((instance *)comp, "%s", "fmi2SetFMUstate is not supported (canGetAndSetFMUstate is false)");
}
fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *state)
{
    (void)state;
    return fail((instance *)comp, "%s", "fmi2FreeFMUstate is not supported (canGetAndSetFMUstate is false)");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate state, size_t *size)
{
    (void)state; (void)size;
    return fail((instance *)comp, "%s", "FMU states cannot be serialized");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate state, fmi2Byte bytes[], size_t size)
{
    (void)state; (void)bytes; (void)size;
    return fail((instance *)comp, "%s", "FMU states cannot be serialized");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state)
{
    (void)bytes; (void)size; (void)state;
    return fail((instance *)comp, "%s", "FMU states cannot be serialized");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference unknown[], size_t nu,
                                        const fmi2ValueReference known[], size_t nk, const fmi2Real dv_known[],
                                        fmi2Real dv_unknown[])
{
    (void)unknown; (void)nu; (void)known; (void)nk; (void)dv_known; (void)dv_unknown;
    return fail((instance *)comp, "%s", "directional derivatives are not provided");
}

#ifdef FMU_MODEL_EXCHANGE
/* ---- Model Exchange ---- */
/* What an event does: the machine decides, from the sides it kept, whether a watched event
 * crossed in its direction. Returns the machine's act bits (0: a no-op event). */
static int handle_events(instance *c, const int *fired_by_integrator)
{
    double ev[MODEL_NEVENT];
    int fired[MODEL_NEVENT] = {0};
    model_events(c->t, c->y, ev, &c->p);
    int act = 0;
    const int crossed = fired_by_integrator ? 1 : model_machine_crossed(&c->m, ev, fired);
    if (crossed) {
        const int *flags = fired_by_integrator ? fired_by_integrator : fired;
        int events[MODEL_NEVENT], directions[MODEL_NEVENT], tip_fired = 0;
        const int watched = model_machine_events(&c->m, events, directions);
        for (int k = 0; k < watched; ++k) tip_fired |= flags[k] && events[k] < FMU_NTIP_EVENT;
        const int before = c->m.point[MODEL_TIP_POINT].state;
        act = model_machine_switch(&c->m, &c->p, c->t, c->y, flags);
        if (act) {
            if (tip_fired) {
                say(c, fmi2OK, "logEvents", "t = %.17g: %s -> %s", c->t, model_machine_state_name(before),
                    model_machine_state_name(c->m.point[MODEL_TIP_POINT].state));
            }
#ifdef MODEL_NJOINT
            for (int k = 0; k < MODEL_NJOINT; ++k) {  /* each joint that switched, by name */
                const model_point_machine *j = &c->m.point[k];
                if (!j->act) continue;
                say(c, fmi2OK, "logEvents", "t = %.17g: joint %d: %s -> %s", c->t, model_joint_number(k),
                    model_machine_state_name(j->was), model_machine_state_name(j->state));
            }
#endif
            model_events(c->t, c->y, ev, &c->p);
        }
    }
    model_machine_sides(&c->m, ev);
    return act;
}

fmi2Status fmi2EnterEventMode(fmi2Component comp)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2EnterEventMode", IN(EVENT) | IN(CONTINUOUS))) return fmi2Error;
    c->mode = EVENT;
    c->t_done = c->t;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo *info)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2NewDiscreteStates", IN(EVENT))) return fmi2Error;
    if (null_array(c, "fmi2NewDiscreteStates", 1, info, info)) return fmi2Error;
    const int act = handle_events(c, NULL);
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
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2EnterContinuousTimeMode", IN(EVENT))) return fmi2Error;
    c->mode = CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    instance *c = (instance *)comp;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2CompletedIntegratorStep", IN(CONTINUOUS))) return fmi2Error;
    if (null_array(c, "fmi2CompletedIntegratorStep", 1, enterEventMode, terminateSimulation)) return fmi2Error;
    /* an importer that does not locate roots still gets its events at the next step */
    double ev[MODEL_NEVENT];
    int fired[MODEL_NEVENT];
    double depth = 0.0;
    const int point = model_machine_below(&c->p, c->y, &depth);  /* the floor net, as ig_run's */
    if (point != 0) {
        char name[32];
        if (point < MODEL_NPOINT) snprintf(name, sizeof name, "joint %d", point);
        else snprintf(name, sizeof name, "the tip");
        c->mode = FAILED;
        *enterEventMode = fmi2False;
        *terminateSimulation = fmi2True;
        say(c, fmi2Error, "logStatusError", "%s is %.3g m below the surface at t = %.6g s (deeper than %g %% of "
            "the shortest link, beyond any contact's depth): the chain went through the surface", name, depth, c->t,
            100.0 * MODEL_FLOOR_DEPTH);
        return fmi2Error;
    }
    model_events(c->t, c->y, ev, &c->p);
    c->t_done = c->t;
    *enterEventMode = model_machine_crossed(&c->m, ev, fired) > 0;
    if (!*enterEventMode) model_machine_sides(&c->m, ev);
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2SetTime", IN(EVENT) | IN(CONTINUOUS))) return fmi2Error;
    /* an integrator may go back within its step (a retried step, a root search), never before
     * the last completed step or event: this FMU keeps no earlier state to go back to */
    if (!isfinite(time)) return fail(c, "%s", "fmi2SetTime: the time must be a finite number");
    if (time < c->t_done) {
        say(c, fmi2Error, "logStatusError", "fmi2SetTime: t = %.17g s is before the last completed step or event "
            "at t = %.17g s: time cannot go backwards", time, c->t_done);
        return fmi2Error;
    }
    c->t = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2SetContinuousStates", IN(EVENT) | IN(CONTINUOUS))) return fmi2Error;
    if (null_array(c, "fmi2SetContinuousStates", nx, x, x)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fail(c, "%s", "fmi2SetContinuousStates: wrong number of states");
    memcpy(c->y, x, sizeof(double) * MODEL_NSTATE);
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2GetDerivatives", RUNNING | IN(INITIALIZATION))) return fmi2Error;
    if (null_array(c, "fmi2GetDerivatives", nx, derivatives, derivatives)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fail(c, "%s", "fmi2GetDerivatives: wrong number of states");
    if (c->mode == INITIALIZATION) {
        const char *range = "";
        const int bad = prepare(c, &range);
        if (bad != MODEL_PARAMS_OK) return bad_parameter(c, bad, range);
    }
    const int flag = model_rhs(c->t, c->y, derivatives, &c->p);
    if (flag != 0) {
        say(c, fmi2Error, "logStatusError", "the right-hand side is not finite at t = %g in phase %s%s", c->t,
            model_machine_state_name(c->m.point[MODEL_TIP_POINT].state),
            flag < 0 ? ": the mass matrix is not positive definite (check chain.mass and chain.length)" : "");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real indicators[], size_t ni)
{
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2GetEventIndicators", RUNNING | IN(INITIALIZATION))) return fmi2Error;
    if (null_array(c, "fmi2GetEventIndicators", ni, indicators, indicators)) return fmi2Error;
    if (ni != MODEL_NEVENT) return fail(c, "%s", "fmi2GetEventIndicators: wrong number of indicators");
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
    instance *c = (instance *)comp;
    if (!allowed(c, "fmi2GetContinuousStates", RUNNING | IN(INITIALIZATION) | IN(TERMINATED))) return fmi2Error;
    if (null_array(c, "fmi2GetContinuousStates", nx, x, x)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fail(c, "%s", "fmi2GetContinuousStates: wrong number of states");
    if (c->mode == INITIALIZATION) {
        const char *range = "";
        const int bad = prepare(c, &range);
        if (bad != MODEL_PARAMS_OK) return bad_parameter(c, bad, range);
    }
    memcpy(x, c->y, sizeof(double) * MODEL_NSTATE);
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[], size_t nx)
{
    instance *c = (instance *)comp;
    if (!c) return fmi2Error;
    if (null_array(c, "fmi2GetNominalsOfContinuousStates", nx, x_nominal, x_nominal)) return fmi2Error;
    if (nx != MODEL_NSTATE) return fail(c, "%s", "fmi2GetNominalsOfContinuousStates: wrong number of states");
    /* the machine's tolerance scales: 1 for angles and speeds in flight, the impact's own
     * scales inside it (an importer's absolute tolerance is rtol times the nominal) */
    model_machine_atol(&c->m, &c->p, 1.0, 1.0, x_nominal);
    /* the impulses (N s) are left out of the machine's error test (MODEL_QUADRATURE_ATOL),
     * which is no scale: their nominal is 1 */
    for (size_t i = MODEL_Y_P_normal; i < nx; ++i) x_nominal[i] = 1.0;
    return fmi2OK;
}
#else
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *i) { (void)i; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean a, fmi2Boolean *b, fmi2Boolean *d) { (void)a; (void)b; (void)d; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { (void)t; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) { (void)x; (void)n; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) { (void)x; (void)n; return fail((instance *)c, "%s", "Model Exchange is not built in"); }
#endif

#ifdef FMU_CO_SIMULATION
/* ---- Co-Simulation: ig_run steps on its own; communication points are interpolated ---- */
/* The stick-slip label of a contact state under exact Coulomb friction (as impactgen's results). */
static const char *slip_label(int state, double slip)
{
    if (state == MODEL_MACHINE_FREE) return "";
    return slip > 0.0 ? "slip+" : (slip < 0.0 ? "slip-" : "stick");
}

/* Log the switches of the segments ig_run recorded: "t = ...: from -> to" for a change of
 * the tip's contact phase, "t = ...: joint k: from -> to" for a joint's (a record of its own,
 * seg->point), and for a stick-slip change (its labels). */
static void log_switches(const instance *c, const ig_segment *segments, int n)
{
    for (int k = 0; k < n; ++k) {
        const ig_segment *seg = &segments[k];
        if (seg->point != MODEL_NQ) {
            if (seg->next_state != seg->state) {
                say(c, fmi2OK, "logEvents", "t = %.17g: joint %d: %s -> %s", seg->t, seg->point,
                    model_machine_state_name(seg->state), model_machine_state_name(seg->next_state));
            }
            continue;
        }
        if (seg->next_state != seg->state) {
            say(c, fmi2OK, "logEvents", "t = %.17g: %s -> %s", seg->t, model_machine_state_name(seg->state),
                model_machine_state_name(seg->next_state));
        }
        if (seg->act & MODEL_ACT_SLIP) {
            say(c, fmi2OK, "logEvents", "t = %.17g: %s -> %s", seg->t, slip_label(seg->state, seg->slip),
                slip_label(seg->next_state, seg->next_slip));
        }
    }
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    instance *c = (instance *)comp;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2DoStep", IN(STEPPING))) return fmi2Error;
    if (!isfinite(t) || !isfinite(h)) {
        return fail(c, "%s", "fmi2DoStep: the communication point and the step size must be finite numbers");
    }
    if (!(h >= 0.0) || !(fabs(t - c->t) <= 1e-9 * fmax(1.0, fabs(t)))) {
        say(c, fmi2Error, "logStatusError", "fmi2DoStep: the step must start where the last one ended (t = %.17g s), "
            "with h >= 0; got t = %.17g s, h = %g s", c->t, t, h);
        return fmi2Error;
    }
    const double target = t + h;
    const double t_stop = c->stop_time + STOP_SLACK * fmax(1.0, fabs(c->stop_time));
    if (c->t_int >= t_stop && target > c->t_int) {
        return fail(c, "%s", "fmi2DoStep: the step goes beyond the stop time of fmi2SetupExperiment");
    }
    double t_buf[RUN_CAPACITY], y_buf[RUN_CAPACITY * MODEL_NSTATE], out_buf[RUN_CAPACITY * MODEL_NOUT];
    ig_segment segments[RUN_SEGMENTS];
    int flag = IG_TARGET;
    long begun = 0;
    while (c->t_int <= target) {  /* (at target only to switch at a root left there) */
        int n = 0, n_segments = 0;
        flag = ig_run(c->solver, &c->m, &c->p, &c->t_int, c->y_int, t_stop, target, MODEL_SCENE_ATOL,
                      MAX_SEGMENTS - begun, 0, t_buf, y_buf, out_buf, NULL, RUN_CAPACITY, &n, segments,
                      RUN_SEGMENTS, &n_segments, NULL);
        begun += n_segments;
        log_switches(c, segments, n_segments);
        if (flag != IG_BUFFER_FULL && flag != IG_SEGMENTS_FULL) break;
    }
    if (flag < 0) {
        c->mode = FAILED;
        say(c, fmi2Error, "logStatusError", "the integrator failed in phase %s near t = %g: %s",
            model_machine_state_name(c->m.point[MODEL_TIP_POINT].state), c->t_int, ig_solver_message(c->solver));
        return fmi2Error;
    }
    if (c->t_int < target) {  /* the run ended before the communication point */
        return fail(c, "%s", "fmi2DoStep: the step goes beyond the stop time of fmi2SetupExperiment");
    }
    if (c->t_int == target || h == 0.0) {
        if (c->t_int == target) memcpy(c->y, c->y_int, sizeof c->y);
    } else if (ig_interpolate(c->solver, target, c->y) != 0) {
        c->mode = FAILED;
        return fail(c, "cannot interpolate the state at the communication point: %s", ig_solver_message(c->solver));
    }
    c->t = target;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp) { return fail((instance *)comp, "%s", "fmi2DoStep never runs asynchronously"); }
fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status *value) { (void)s; (void)value; return fail((instance *)comp, "%s", "fmi2GetStatus: no asynchronous steps"); }
fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real *value)
{
    instance *c = (instance *)comp;
    if (s == fmi2LastSuccessfulTime && c) {
        *value = c->t;
        return fmi2OK;
    }
    return fail(c, "%s", "fmi2GetRealStatus: only fmi2LastSuccessfulTime is provided");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer *value) { (void)s; (void)value; return fail((instance *)comp, "%s", "fmi2GetIntegerStatus: not provided"); }
fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean *value) { (void)s; (void)value; return fail((instance *)comp, "%s", "fmi2GetBooleanStatus: not provided"); }
fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String *value) { (void)s; (void)value; return fail((instance *)comp, "%s", "fmi2GetStringStatus: not provided"); }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[], const fmi2Real value[]) { (void)vr; (void)nvr; (void)order; (void)value; return fail((instance *)comp, "%s", "this FMU has no inputs"); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[], fmi2Real value[]) { (void)vr; (void)nvr; (void)order; (void)value; return fail((instance *)comp, "%s", "output derivatives are not provided"); }
#else
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean b) { (void)t; (void)h; (void)b; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2CancelStep(fmi2Component c) { return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { (void)s; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) { (void)s; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { (void)s; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) { (void)s; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { (void)s; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]) { (void)vr; (void)n; (void)o; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]) { (void)vr; (void)n; (void)o; (void)v; return fail((instance *)c, "%s", "Co-Simulation is not built in"); }
#endif
