/*
 * step_erk.c: ARKODE's explicit Runge-Kutta method (ERKStep) with Dormand and Prince's 5(4)
 * pair as a stepper (stepper.h), re-initialised at each segment start. SUNDIALS 6.x and 7.x.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <arkode/arkode_erkstep.h>

#include "step_sundials.h"

/* the explicit Runge-Kutta pair: Dormand and Prince's 5(4), 7 stages with the last one reused
 * (ARKODE's table; in work-precision runs on the paper's impact it beat Verner's 6(5) and
 * Fehlberg's 7(8), which failed at rtol 1e-8) */
#define ERK_TABLE ARKODE_DORMAND_PRINCE_7_4_5
#define ERK_DENSE_DEGREE 5  /* Hermite interpolant of ERK steps (ARK_INTERP_MAX_DEGREE) */

typedef struct {
    ig_stepper base;
    SUNContext ctx;
    void *erk;
    N_Vector y, abstol, dky;
    double rtol;
    int tolerances_changed;
    double t_stop;
    int *dirs;
    int counting;   /* ARKODE's counters belong to a segment of this run: add them */
} erk_stepper;

static int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void *user_data)
{
    const ig_problem *pb = ((const erk_stepper *)user_data)->base.problem;
    return pb->rhs(t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot), pb->user);
}

static int roots(sunrealtype t, N_Vector y, sunrealtype *g, void *user_data)
{
    const ig_problem *pb = ((const erk_stepper *)user_data)->base.problem;
    pb->events(t, N_VGetArrayPointer(y), g, pb->user);
    return 0;
}

static void live(const ig_stepper *st, ig_stats *stats)
{
    const erk_stepper *e = (const erk_stepper *)st;
    long v;
    if (!e->counting) return;
    if (ERKStepGetNumSteps(e->erk, &v) == ARK_SUCCESS) stats->nsteps += v;
    if (ERKStepGetNumRhsEvals(e->erk, &v) == ARK_SUCCESS) stats->nfev += v;
    if (ERKStepGetNumErrTestFails(e->erk, &v) == ARK_SUCCESS) stats->netfails += v;
    if (ERKStepGetNumGEvals(e->erk, &v) == ARK_SUCCESS) stats->ngev += v;
}

static int tolerances(ig_stepper *st, double rtol, const double *atol, long max_steps)
{
    erk_stepper *e = (erk_stepper *)st;
    (void)max_steps;
    e->rtol = rtol;
    memcpy(N_VGetArrayPointer(e->abstol), atol, sizeof(double) * (size_t)st->problem->n);
    e->tolerances_changed = 1;
    return 0;
}

static void restart(ig_stepper *st)
{
    erk_stepper *e = (erk_stepper *)st;
    memset(&st->done, 0, sizeof st->done);
    e->counting = 0;
}

static int start(ig_stepper *st, double t0, const double *y0, double t_stop, const int *directions, int nevents)
{
    erk_stepper *e = (erk_stepper *)st;
    ig_stepper_bank(st);  /* ERKStepReInit clears ARKODE's counters */
    e->counting = 0;
    memcpy(N_VGetArrayPointer(e->y), y0, sizeof(double) * (size_t)st->problem->n);
    for (int k = 0; k < nevents; ++k) e->dirs[k] = directions[k];
    if (ERKStepReInit(e->erk, rhs, t0, e->y) != ARK_SUCCESS) return -1;
    e->counting = 1;
    if (e->tolerances_changed) {
        if (ERKStepSVtolerances(e->erk, e->rtol, e->abstol) != ARK_SUCCESS) return -1;
        e->tolerances_changed = 0;
    }
    if (ERKStepRootInit(e->erk, nevents, nevents > 0 ? roots : NULL) != ARK_SUCCESS) return -1;
    if (nevents > 0) {
        if (ERKStepSetRootDirection(e->erk, e->dirs) != ARK_SUCCESS) return -1;
        if (ERKStepSetNoInactiveRootWarn(e->erk) != ARK_SUCCESS) return -1;
    }
    if (ERKStepSetStopTime(e->erk, t_stop) != ARK_SUCCESS) return -1;
    e->t_stop = t_stop;
    return 0;
}

static int step(ig_stepper *st, double *t_now, double *y, int *roots_found)
{
    erk_stepper *e = (erk_stepper *)st;
    sunrealtype t;
    const int flag = ERKStepEvolve(e->erk, e->t_stop, e->y, &t, ARK_ONE_STEP);
    if (flag < 0) {
        if (!st->problem->message[0]) ig_stepper_say(st->problem, "ERKStepEvolve returned %d", flag);
        return IG_STEP_FAILED;
    }
    *t_now = t;
    memcpy(y, N_VGetArrayPointer(e->y), sizeof(double) * (size_t)st->problem->n);
    if (flag == ARK_ROOT_RETURN) {
        ERKStepGetRootInfo(e->erk, roots_found);
        return IG_STEP_ROOT;
    }
    if (flag == ARK_TSTOP_RETURN || t >= e->t_stop) return IG_STEP_END;
    return IG_STEP_ON;
}

static int interpolate(ig_stepper *st, double t, double *y)
{
    erk_stepper *e = (erk_stepper *)st;
    if (ERKStepGetDky(e->erk, t, 0, e->dky) != ARK_SUCCESS) return -1;
    memcpy(y, N_VGetArrayPointer(e->dky), sizeof(double) * (size_t)st->problem->n);
    return 0;
}

static int dense(ig_stepper *st, double t, double *rows, int terms)
{
    erk_stepper *e = (erk_stepper *)st;
    return ig_sundials_taylor(st->problem->n, ERKStepGetDky, e->erk, e->dky, ERK_DENSE_DEGREE, t, rows, terms);
}

static void free_erk(ig_stepper *st)
{
    erk_stepper *e = (erk_stepper *)st;
    if (e->erk) ERKStepFree(&e->erk);
    if (e->y) N_VDestroy(e->y);
    if (e->abstol) N_VDestroy(e->abstol);
    if (e->dky) N_VDestroy(e->dky);
    if (e->ctx) SUNContext_Free(&e->ctx);
    free(e->dirs);
    free(e);
}

static const ig_stepper_ops erk_ops = {tolerances, ig_stepper_no_jacobian, restart, start, step, interpolate, dense,
                                       live, free_erk};

ig_stepper *ig_erk_new(const ig_problem *problem, char *err, int errlen)
{
    erk_stepper *e = (erk_stepper *)calloc(1, sizeof *e);
    const char *failed = NULL;
    const int n = problem->n;
    if (!e) {
        snprintf(err, (size_t)errlen, "out of memory");
        return NULL;
    }
    e->base.ops = &erk_ops;
    e->base.problem = problem;
    e->base.dense_terms = ERK_DENSE_DEGREE + 1;
    e->dirs = (int *)calloc((size_t)problem->max_events + 1, sizeof(int));
    if (!e->dirs || ig_sundials_context(&e->ctx, problem) != 0) failed = "SUNContext_Create failed";
    if (!failed) {
        e->y = N_VNew_Serial(n, e->ctx);
        e->abstol = N_VNew_Serial(n, e->ctx);
        e->dky = N_VNew_Serial(n, e->ctx);
        if (e->y) N_VConst(0.0, e->y);
        if (e->y) e->erk = ERKStepCreate(rhs, 0.0, e->y, e->ctx);
        if (!e->y || !e->abstol || !e->dky || !e->erk) failed = "allocating ARKODE failed";
    }
    if (!failed) {
#if SUNDIALS_VERSION_MAJOR < 7
        ERKStepSetErrHandlerFn(e->erk, ig_sundials_on_error, (void *)problem);
#endif
        N_VConst(1.0, e->abstol);
        e->rtol = 1e-6;  /* until the solver sets its tolerances, before the first start */
        e->tolerances_changed = 1;
        if (ERKStepSVtolerances(e->erk, e->rtol, e->abstol) != ARK_SUCCESS) failed = "ERKStepSVtolerances failed";
        else if (ERKStepSetUserData(e->erk, e) != ARK_SUCCESS) failed = "ERKStepSetUserData failed";
        else if (ERKStepSetTableNum(e->erk, ERK_TABLE) != ARK_SUCCESS) failed = "ERKStepSetTableNum failed";
        else if (ERKStepSetInterpolantDegree(e->erk, ERK_DENSE_DEGREE) != ARK_SUCCESS) failed = "ERKStepSetInterpolantDegree failed";
        else if (ERKStepSetMaxNumSteps(e->erk, -1) != ARK_SUCCESS) failed = "ERKStepSetMaxNumSteps failed";
    }
    if (failed) {
        snprintf(err, (size_t)errlen, "%s%s%s", failed, problem->message[0] ? ": " : "", problem->message);
        free_erk(&e->base);
        return NULL;
    }
    return &e->base;
}
