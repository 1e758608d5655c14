/*
 * fmu_variables.c: the model's variables by value reference (model_fmu.h: the same list as
 * modelDescription.xml). Parameters and start values are set before initialization, each
 * checked against its physical range (model_check); the continuous outputs and the
 * derivatives are computed once per change of t, the state or a parameter (fmu_invalidate)
 * however many variables an importer asks for; the machine's discrete outputs are read from
 * it, and the summaries of the run so far (run.*, first_impact.*) from its tally.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmu_instance.h"
#include "model_fmu.h"

void fmu_invalidate(fmu_instance *c)
{
    c->values.have_outputs = 0;
    c->values.have_derivatives = 0;
    c->values.have_summaries = 0;
}

const double *fmu_derivatives(fmu_instance *c, int *flag)
{
    fmu_values *v = &c->values;
    if (!v->have_derivatives) {
        v->rhs_flag = model_rhs(c->t, c->y, v->ydot, &c->p);
        v->have_derivatives = 1;
    }
    *flag = v->rhs_flag;
    return v->ydot;
}

const double *fmu_outputs(fmu_instance *c)
{
    fmu_values *v = &c->values;
    if (!v->have_outputs) {
        model_outputs(c->t, c->y, v->out, &c->p);
        v->have_outputs = 1;
    }
    return v->out;
}

/* The summaries of the run from its start to (t, y), as impactgen run's of a run that ends at
 * t: the tally with (t, y) as its latest sample. The first impact's is final once it ended. */
static const fmu_values *summaries(fmu_instance *c)
{
    fmu_values *v = &c->values;
    if (!v->have_summaries) {
        ig_tally now = c->tally;
        ig_read_point(&now.last, c->t, c->y, fmu_outputs(c));
        ig_summarize(&now, &v->run, &v->first_impact);
        v->have_summaries = 1;
    }
    return v;
}

/* A field of a summary (VAR_RUN, VAR_FIRST_IMPACT): its byte offset in ig_summary is the
 * variable's index; an Integer variable reads an int there. */
static double summary_value(fmu_instance *c, const fmu_variable *v)
{
    const fmu_values *values = summaries(c);
    const char *field = (const char *)(v->kind == VAR_RUN ? &values->run : &values->first_impact) + v->index;
    if (v->type == 'I') {
        int n;
        memcpy(&n, field, sizeof n);
        return n;
    }
    double x;
    memcpy(&x, field, sizeof x);
    return x;
}

static const fmu_variable *variable(const fmu_instance *c, fmi2ValueReference vr, char type)
{
    if (vr >= FMU_NVARS) {
        fmu_say(c, fmi2Error, "logStatusError", "no variable has value reference %u", (unsigned)vr);
        return NULL;
    }
    const fmu_variable *v = &fmu_variables[vr];
    if (v->type != type) {
        fmu_say(c, fmi2Error, "logStatusError", "variable %s (value reference %u) is not of this type",
                v->name, (unsigned)vr);
        return NULL;
    }
    return v;
}

/* A discrete output of the machine (VAR_PHASE, VAR_IMPACTS, VAR_DELTA_MAX, ...) of point
 * `point`: 0 the tip, k + 1 the joint in the machine's slot k. */
static double machine_value(const fmu_instance *c, int kind, int point)
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

static double real_value(fmu_instance *c, const fmu_variable *v)
{
    switch (v->kind) {
    case VAR_PARAM: return *model_param_slot(&c->p, v->index);
    case VAR_Q0: return c->q0[v->index];
    case VAR_U0: return c->u0[v->index];
    default: break;
    }
    /* before initialization ends: the state and outputs the start values give */
    const char *range = "";
    if ((c->mode == INSTANTIATED || c->mode == INITIALIZATION) && fmu_prepare(c, &range) != MODEL_PARAMS_OK) {
        return NAN;
    }
    int flag = 0;
    switch (v->kind) {
    case VAR_STATE: return c->y[v->index];
    case VAR_DER: {
        const double *ydot = fmu_derivatives(c, &flag);
        return flag != 0 ? NAN : ydot[v->index];
    }
    case VAR_OUTPUT: return fmu_outputs(c)[v->index];
    case VAR_PHASE:
    case VAR_IMPACTS:
    case VAR_DELTA_MAX:
    case VAR_DELTA_R:
    case VAR_P_MAX: return machine_value(c, v->kind, v->index);
    case VAR_RUN:
    case VAR_FIRST_IMPACT: return summary_value(c, v);
    default: return NAN;
    }
}

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_REAL)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetReal", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'R');
        if (!v) return fmi2Error;
        value[k] = real_value(c, v);
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_INTEGER)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetInteger", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'I');
        if (!v) return fmi2Error;
        const double x = real_value(c, v);
        value[k] = isfinite(x) ? (fmi2Integer)x : 0;  /* (not finite: the start values are refused) */
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_GET_BOOLEAN)) return fmi2Error;
    if (fmu_null_array(c, "fmi2GetBoolean", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'B');
        if (!v) return fmi2Error;
        value[k] = *model_param_slot(&c->p, v->index) != 0.0;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    return fmu_fail((fmu_instance *)comp, "%s", "this FMU has no String variables");
}

/* Set one parameter (or start value) after checking it against its physical range. */
static fmi2Status set_parameter(fmu_instance *c, const fmu_variable *v, double value)
{
    if (v->kind == VAR_Q0 || v->kind == VAR_U0) {
        if (!isfinite(value)) return fmu_fail(c, "%s must be a finite number", v->name);
        (v->kind == VAR_Q0 ? c->q0 : c->u0)[v->index] = value;
        fmu_start_changed(c);
        return fmi2OK;
    }
    if (v->kind != VAR_PARAM) return fmu_fail(c, "%s is not a parameter: it cannot be set", v->name);
    model_params trial = c->p;
    *model_param_slot(&trial, v->index) = value;
    const char *range = "";
    const int bad = model_check(&trial, &range);
    if (bad == v->index) {
        char what[256];
        snprintf(what, sizeof what, "%s = %g is outside its physical range %s; the value is not set",
                 v->name, value, range);
        return fmu_fail(c, "%s", what);
    }
    *model_param_slot(&c->p, v->index) = value;
    fmu_start_changed(c);
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_SET_REAL)) return fmi2Error;
    if (fmu_null_array(c, "fmi2SetReal", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'R');
        if (!v || set_parameter(c, v, value[k]) != fmi2OK) return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    return fmu_fail((fmu_instance *)comp, "%s",
                    "the Integer variables of this FMU (phase, impacts) are outputs: they cannot be set");
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    fmu_instance *c = (fmu_instance *)comp;
    if (!fmu_allowed(c, CALL_SET_BOOLEAN)) return fmi2Error;
    if (fmu_null_array(c, "fmi2SetBoolean", nvr, vr, value)) return fmi2Error;
    for (size_t k = 0; k < nvr; ++k) {
        const fmu_variable *v = variable(c, vr[k], 'B');
        if (!v || set_parameter(c, v, value[k] ? 1.0 : 0.0) != fmi2OK) return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    (void)vr; (void)value;
    if (nvr == 0) return fmi2OK;
    return fmu_fail((fmu_instance *)comp, "%s", "this FMU has no String variables");
}
