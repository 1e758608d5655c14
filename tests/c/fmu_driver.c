/*
 * fmu_driver.c: drive the FMI 2.0 glue directly, as an importer would, under the sanitizers
 * (scripts/sanitize.sh): Model Exchange with a fixed-step Euler loop that leaves the events
 * to fmi2CompletedIntegratorStep (the values read follow each new state and time),
 * Co-Simulation with two interleaved instances, a reset, and bad input (a non-physical
 * parameter, a wrong value reference, a call out of order).
 * Prints "fmu ok (N failures)" and returns the count of failures.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_machine.h"
#include "model_fmu.h"

static int failures = 0;
static char last_message[1024];

#define CHECK(cond) do { if (!(cond)) { ++failures; printf("FAILED line %d: %s\n", __LINE__, #cond); } } while (0)

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    (void)env; (void)name; (void)status; (void)category;
    snprintf(last_message, sizeof last_message, "%s", message);
}

static int vr_of(const char *name)
{
    for (int k = 0; k < FMU_NVARS; ++k) {
        if (strcmp(fmu_variables[k].name, name) == 0) return k;
    }
    return -1;
}

static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static double real(fmi2Component c, const char *name)
{
    const fmi2ValueReference vr = (fmi2ValueReference)vr_of(name);
    double value = NAN;
    CHECK(fmi2GetReal(c, &vr, 1, &value) == fmi2OK);
    return value;
}

/* The values an importer reads are those of the state and time it set last, however often
 * it reads them (the FMU computes them once per change). */
static void values_follow_the_state(fmi2Component c, double *x, size_t nx, double t)
{
    char der_q[32], u[32];
    snprintf(der_q, sizeof der_q, "der(q[%d])", MODEL_NQ);
    snprintf(u, sizeof u, "u[%d]", MODEL_NQ);
    CHECK(real(c, der_q) == x[2 * MODEL_NQ - 1] && real(c, der_q) == real(c, u));
    const double T = real(c, "T"), kept = x[2 * MODEL_NQ - 1];
    x[2 * MODEL_NQ - 1] = 2.0 * kept + 1.0;  /* the last link turns faster */
    CHECK(fmi2SetContinuousStates(c, x, nx) == fmi2OK);
    CHECK(real(c, der_q) == x[2 * MODEL_NQ - 1] && real(c, "T") != T);
    x[2 * MODEL_NQ - 1] = kept;
    CHECK(fmi2SetContinuousStates(c, x, nx) == fmi2OK);
    CHECK(real(c, der_q) == kept && real(c, "T") == T);
    CHECK(fmi2SetTime(c, t) == fmi2OK);
}

/* Every variable reads, the summaries' included (each read at its offset in ig_summary). */
static void every_variable_reads(fmi2Component c)
{
    for (int k = 0; k < FMU_NVARS; ++k) {
        const fmi2ValueReference vr = (fmi2ValueReference)k;
        double r;
        fmi2Integer i;
        fmi2Boolean b;
        if (fmu_variables[k].type == 'R') CHECK(fmi2GetReal(c, &vr, 1, &r) == fmi2OK);
        else if (fmu_variables[k].type == 'I') CHECK(fmi2GetInteger(c, &vr, 1, &i) == fmi2OK);
        else CHECK(fmi2GetBoolean(c, &vr, 1, &b) == fmi2OK);
    }
}

static void model_exchange(void)
{
    fmi2Component c = fmi2Instantiate("me", fmi2ModelExchange, FMU_GUID, "", &callbacks, fmi2False, fmi2True);
    CHECK(c != NULL);
    if (!c) return;
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, 2e-3) == fmi2OK);
    CHECK(fmi2EnterInitializationMode(c) == fmi2OK);
    CHECK(fmi2ExitInitializationMode(c) == fmi2OK);
    fmi2EventInfo info;
    CHECK(fmi2NewDiscreteStates(c, &info) == fmi2OK);
    CHECK(fmi2EnterContinuousTimeMode(c) == fmi2OK);
    double x[64], dx[64], z[64], nominal[64];
    const size_t nx = MODEL_NSTATE, nz = MODEL_NEVENT;
    CHECK(fmi2GetContinuousStates(c, x, nx) == fmi2OK);
    CHECK(fmi2GetNominalsOfContinuousStates(c, nominal, nx) == fmi2OK);
    values_follow_the_state(c, x, nx, 0.0);
    const double h = 1e-7;
    int events = 0;
    for (double t = 0.0; t < 1e-3; t += h) {
        CHECK(fmi2GetDerivatives(c, dx, nx) == fmi2OK);
        for (size_t k = 0; k < nx; ++k) x[k] += h * dx[k];
        CHECK(fmi2SetTime(c, t + h) == fmi2OK);
        CHECK(fmi2SetContinuousStates(c, x, nx) == fmi2OK);
        CHECK(fmi2GetEventIndicators(c, z, nz) == fmi2OK);
        fmi2Boolean enter = fmi2False, stop = fmi2False;
        CHECK(fmi2CompletedIntegratorStep(c, fmi2True, &enter, &stop) == fmi2OK);
        if (enter) {
            ++events;
            CHECK(fmi2EnterEventMode(c) == fmi2OK);
            CHECK(fmi2NewDiscreteStates(c, &info) == fmi2OK);
            CHECK(fmi2EnterContinuousTimeMode(c) == fmi2OK);
            if (info.nominalsOfContinuousStatesChanged) fmi2GetNominalsOfContinuousStates(c, nominal, nx);
        }
    }
    CHECK(events >= 3);  /* yield, maximum compression, separation */
    fmi2Integer impacts = 0;
    const fmi2ValueReference vr_impacts = (fmi2ValueReference)vr_of("impacts");
    CHECK(fmi2GetInteger(c, &vr_impacts, 1, &impacts) == fmi2OK && impacts == 1);
    every_variable_reads(c);
    /* one impact: the first is the latest, and the run's tally saw it */
    CHECK(real(c, "first_impact.delta_max") == real(c, "delta_max"));
    CHECK(real(c, "first_impact.delta_r") == real(c, "delta_r") && real(c, "run.delta_r") == real(c, "delta_r"));
    const fmi2ValueReference vr_run_impacts = (fmi2ValueReference)vr_of("run.impacts");
    CHECK(fmi2GetInteger(c, &vr_run_impacts, 1, &impacts) == fmi2OK && impacts == 1);
    CHECK(fmi2Terminate(c) == fmi2OK);
    fmi2FreeInstance(c);
}

static double co_simulate(fmi2Component c, double stop, double h)
{
    CHECK(fmi2SetupExperiment(c, fmi2True, 1e-8, 0.0, fmi2True, stop) == fmi2OK);
    CHECK(fmi2EnterInitializationMode(c) == fmi2OK);
    CHECK(fmi2ExitInitializationMode(c) == fmi2OK);
    for (double t = 0.0; t < stop - 1e-12; t += h) CHECK(fmi2DoStep(c, t, h, fmi2True) == fmi2OK);
    const fmi2ValueReference vr = (fmi2ValueReference)vr_of("u[2]");
    double u = 0.0;
    CHECK(fmi2GetReal(c, &vr, 1, &u) == fmi2OK);
    return u;
}

static void co_simulation(void)
{
    fmi2Component a = fmi2Instantiate("a", fmi2CoSimulation, FMU_GUID, "", &callbacks, fmi2False, fmi2False);
    fmi2Component b = fmi2Instantiate("b", fmi2CoSimulation, FMU_GUID, "", &callbacks, fmi2False, fmi2False);
    CHECK(a && b);
    if (!a || !b) return;
    const double u = co_simulate(a, 1e-3, 1e-4);
    every_variable_reads(a);
    CHECK(real(a, "first_impact.delta_max") == real(a, "delta_max") && real(a, "first_impact.t_contact") > 0.0);
    CHECK(fmi2Reset(a) == fmi2OK);
    CHECK(co_simulate(a, 1e-3, 2.5e-4) == u);  /* reset, and a coarser step: the same answer */
    CHECK(co_simulate(b, 1e-3, 1e-4) == u);
    /* bad input: each refused with a message naming it, nothing crashes */
    CHECK(fmi2Reset(b) == fmi2OK);
    const fmi2ValueReference mass = (fmi2ValueReference)vr_of("chain.mass[1]");
    const double negative = -1.0;
    CHECK(fmi2SetReal(b, &mass, 1, &negative) == fmi2Error);
    CHECK(strstr(last_message, "chain.mass[1]") != NULL);
    const fmi2ValueReference nowhere = 100000;
    double value;
    CHECK(fmi2GetReal(b, &nowhere, 1, &value) == fmi2Error);
    CHECK(fmi2DoStep(b, 0.0, 1e-4, fmi2True) == fmi2Error);  /* not initialized */
    fmi2FreeInstance(a);
    fmi2FreeInstance(b);
}

int main(void)
{
    CHECK(fmi2Instantiate("wrong", fmi2CoSimulation, "{not-this-fmu}", "", &callbacks, fmi2False, fmi2False) == NULL);
    model_exchange();
    co_simulation();
    printf("fmu ok (%d failures)\n", failures);
    return failures;
}
