/*
 * cvode_glue.c: one CVODE integrator per simulation, re-initialised at each phase switch
 * (the force law changes there, so the step history must not be carried across).
 * Supports SUNDIALS 6.x and 7.x.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_types.h>
#include <sundials/sundials_version.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "cvode_glue.h"
#include "dopri5.h"
#include "small_kernels.h"

#ifndef SUNDIALS_VERSION_MAJOR
#error "SUNDIALS_VERSION_MAJOR is not defined: impactgen needs SUNDIALS 6 or 7"
#endif
#if SUNDIALS_VERSION_MAJOR < 6
#error "impactgen needs SUNDIALS 6 or newer"
#endif

struct ig_solver {
    SUNContext ctx;
    void *cvode;
    void *erk;        /* ARKODE ERKStep instead of CVODE (method IG_METHOD_ERK): explicit Runge-Kutta */
    ig_dopri5 *rk;    /* the plain-C pair instead (IG_METHOD_DOPRI5), or first (IG_METHOD_AUTO) */
    int on_cvode;     /* CVODE integrates the segment under way (always for BDF and Adams) */
    int continued;    /* a segment of this run has begun: the next may start from its last step */
    int dirs[MODEL_NEVENT];
    N_Vector y;
    double *y_data;   /* y's array (a serial vector keeps it): read and written every step */
    N_Vector abstol;
    N_Vector dky;     /* one derivative of the interpolating polynomial (dense output) */
    SUNMatrix A;
    SUNLinearSolver LS;
    const model_params *params;
    int events[MODEL_NEVENT];
    int nevents;
    double t_stop;
    long max_steps;
    long segment_steps;
    ig_stats total;   /* counters of finished segments */
    double *jac;      /* row-major buffer for model_jacobian */
    double rtol;
    int atol_changed; /* ig_solver_set_atol was called: pass the tolerances to CVODE */
    int analytic_in_use; /* the analytic Jacobian is set (else CVODE's difference quotients) */
    int initialised;  /* CVodeInit has been called */
    int counted;      /* CVODE's counters belong to a run already reset: do not add them */
    int active;       /* a segment is under way */
    int dense_terms;  /* Taylor coefficients per sample of dense output: max order + 1 */
    char message[512];
};

static void set_message(ig_solver *s, const char *text)
{
    snprintf(s->message, sizeof s->message, "%s", text);
}

/* ---- error messages: keep CVODE's last message instead of printing it to stderr ---- */
#if SUNDIALS_VERSION_MAJOR >= 7
static void on_error(int line, const char *func, const char *file, const char *msg,
                     SUNErrCode code, void *data, SUNContext ctx)
{
    (void)line; (void)file; (void)code; (void)ctx;
    ig_solver *s = (ig_solver *)data;
    snprintf(s->message, sizeof s->message, "%s: %s", func ? func : "CVODE", msg ? msg : "");
}
#else
static void on_error(int code, const char *module, const char *func, char *msg, void *data)
{
    (void)module;
    ig_solver *s = (ig_solver *)data;
    if (code >= 0) return; /* a warning, not a failure */
    snprintf(s->message, sizeof s->message, "%s: %s", func ? func : "CVODE", msg ? msg : "");
}
#endif

static int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void *user_data)
{
    const ig_solver *s = (const ig_solver *)user_data;
    return model_rhs(t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot), s->params);
}

/* the explicit Runge-Kutta pair: Dormand and Prince's 5(4), 7 stages with the last one reused
 * (ARKODE's table; in work-precision runs on the paper's impact it beat Verner's 6(5) and
 * Fehlberg's 7(8), which failed at rtol 1e-8) */
#define IG_ERK_TABLE ARKODE_DORMAND_PRINCE_7_4_5
#define IG_ERK_DENSE_DEGREE 5  /* Hermite interpolant of ERK steps (ARK_INTERP_MAX_DEGREE) */

static int roots(sunrealtype t, N_Vector y, sunrealtype *g, void *user_data)
{
    const ig_solver *s = (const ig_solver *)user_data;
    double ev[MODEL_NEVENT];
    model_events(t, N_VGetArrayPointer(y), ev, s->params);
    for (int k = 0; k < s->nevents; ++k) g[k] = ev[s->events[k]];
    return 0;
}

#if MODEL_HAS_JACOBIAN
static int jacobian(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *user_data,
                    N_Vector tmp1, N_Vector tmp2, N_Vector tmp3)
{
    (void)fy; (void)tmp1; (void)tmp2; (void)tmp3;
    const ig_solver *s = (const ig_solver *)user_data;
    const int flag = model_jacobian(t, N_VGetArrayPointer(y), s->jac, s->params);
    if (flag != 0) return flag;
    for (int j = 0; j < MODEL_NSTATE; ++j) {
        sunrealtype *column = SUNDenseMatrix_Column(J, j);
        for (int i = 0; i < MODEL_NSTATE; ++i) column[i] = s->jac[i * MODEL_NSTATE + j];
    }
    return 0;
}
#endif

static void add_counters(const ig_solver *s, ig_stats *st)
{
    long v;
    if (!s->initialised || s->counted) return;
    if (s->rk) {
        st->nsteps += s->rk->nsteps;
        st->nfev += s->rk->nfev;
        st->netfails += s->rk->netfails;
        st->ngev += s->rk->ngev;
    }
    if (!s->on_cvode && !s->erk) return;  /* CVODE's counters belong to a segment already counted */
    if (s->erk) {
        long nfe = 0;
        if (ERKStepGetNumSteps(s->erk, &v) == ARK_SUCCESS) st->nsteps += v;
        if (ERKStepGetNumRhsEvals(s->erk, &nfe) == ARK_SUCCESS) st->nfev += nfe;
        if (ERKStepGetNumErrTestFails(s->erk, &v) == ARK_SUCCESS) st->netfails += v;
        if (ERKStepGetNumGEvals(s->erk, &v) == ARK_SUCCESS) st->ngev += v;
        return;
    }
    if (CVodeGetNumSteps(s->cvode, &v) == CV_SUCCESS) st->nsteps += v;
    if (CVodeGetNumRhsEvals(s->cvode, &v) == CV_SUCCESS) st->nfev += v;
    if (CVodeGetNumJacEvals(s->cvode, &v) == CV_SUCCESS) st->njev += v;
    if (CVodeGetNumLinSolvSetups(s->cvode, &v) == CV_SUCCESS) st->nlinsetups += v;
    if (CVodeGetNumErrTestFails(s->cvode, &v) == CV_SUCCESS) st->netfails += v;
    if (CVodeGetNumNonlinSolvConvFails(s->cvode, &v) == CV_SUCCESS) st->nnlsfails += v;
    if (CVodeGetNumGEvals(s->cvode, &v) == CV_SUCCESS) st->ngev += v;
}

void ig_solver_free(ig_solver *s)
{
    if (!s) return;
    if (s->cvode) CVodeFree(&s->cvode);
    if (s->erk) ERKStepFree(&s->erk);
    free(s->rk);
    if (s->LS) SUNLinSolFree(s->LS);
    if (s->A) SUNMatDestroy(s->A);
    if (s->y) N_VDestroy(s->y);
    if (s->abstol) N_VDestroy(s->abstol);
    if (s->dky) N_VDestroy(s->dky);
    if (s->ctx) SUNContext_Free(&s->ctx);
    free(s->jac);
    free(s);
}

ig_solver *ig_solver_new(int method, int analytic_jacobian, double rtol, const double *atol,
                         long max_steps, char *err, int errlen)
{
    ig_solver *s = (ig_solver *)calloc(1, sizeof *s);
    const char *failed = NULL;
    if (!s) {
        snprintf(err, (size_t)errlen, "out of memory");
        return NULL;
    }
    if (method < IG_METHOD_BDF || method > IG_METHOD_AUTO) {
        failed = "method must be 0 (BDF), 1 (Adams), 2 (ERK), 3 (DOPRI5) or 4 (auto)";
    } else if (!IG_METHOD_USES_JACOBIAN(method) && analytic_jacobian) {
        failed = "an explicit method uses no Jacobian";
    }
    else if (!(rtol > 0.0) || max_steps <= 0) failed = "rtol and max_steps must be positive";
    else if (analytic_jacobian && !MODEL_HAS_JACOBIAN) failed = "this model was generated without its Jacobian";
#if SUNDIALS_VERSION_MAJOR >= 7
    else if (SUNContext_Create(SUN_COMM_NULL, &s->ctx) != 0) failed = "SUNContext_Create failed";
#else
    else if (SUNContext_Create(NULL, &s->ctx) != 0) failed = "SUNContext_Create failed";
#endif
    if (!failed) {
#if SUNDIALS_VERSION_MAJOR >= 7
        SUNContext_ClearErrHandlers(s->ctx);
        SUNContext_PushErrHandler(s->ctx, on_error, s);
#endif
        s->y = N_VNew_Serial(MODEL_NSTATE, s->ctx);
        if (s->y) s->y_data = N_VGetArrayPointer(s->y);
        s->abstol = N_VNew_Serial(MODEL_NSTATE, s->ctx);
        s->dky = N_VNew_Serial(MODEL_NSTATE, s->ctx);
        /* fused vector operations: fewer calls per step for CVODE's vectors, cloned from y */
        if (s->y) N_VEnableFusedOps_Serial(s->y, SUNTRUE);
        if (s->y) s->A = SUNDenseMatrix(MODEL_NSTATE, MODEL_NSTATE, s->ctx);
        if (s->A) s->LS = SUNLinSol_Dense(s->y, s->A, s->ctx);
        if (s->LS) ig_use_small_kernels(s->y, s->A, s->LS);
        if (method == IG_METHOD_DOPRI5 || method == IG_METHOD_AUTO) s->rk = (ig_dopri5 *)calloc(1, sizeof *s->rk);
        if (method == IG_METHOD_DOPRI5) {
            s->dense_terms = IG_DOPRI5_DENSE_TERMS;
            if (!s->y || !s->abstol || !s->dky || !s->rk) failed = "allocating the explicit pair failed";
        } else if (method == IG_METHOD_ERK) {
            if (s->y) N_VConst(0.0, s->y);
            if (s->y) s->erk = ERKStepCreate(rhs, 0.0, s->y, s->ctx);
            s->dense_terms = IG_ERK_DENSE_DEGREE + 1;
            if (!s->y || !s->abstol || !s->dky || !s->erk) failed = "allocating ARKODE failed";
        } else {
            s->cvode = CVodeCreate(method == IG_METHOD_ADAMS ? CV_ADAMS : CV_BDF, s->ctx);
            s->dense_terms = (method == IG_METHOD_ADAMS ? IG_ADAMS_MAX_ORDER : IG_BDF_MAX_ORDER) + 1;
            if (!s->y || !s->abstol || !s->dky || !s->A || !s->LS || !s->cvode) failed = "allocating CVODE failed";
            if (method == IG_METHOD_AUTO && !s->rk) failed = "allocating the explicit pair failed";
            s->on_cvode = method != IG_METHOD_AUTO;
        }
    }
    if (!failed) {
        double *a = N_VGetArrayPointer(s->abstol);
        for (int k = 0; k < MODEL_NSTATE; ++k) {
            if (!(atol[k] > 0.0)) failed = "every atol entry must be positive";
            a[k] = atol[k];
        }
    }
    if (!failed && s->rk && !s->cvode) {
        /* nothing to set up: tolerances and events come with each segment */
    } else if (!failed && s->erk) {
#if SUNDIALS_VERSION_MAJOR < 7
        ERKStepSetErrHandlerFn(s->erk, on_error, s);
#endif
        if (ERKStepSVtolerances(s->erk, rtol, s->abstol) != ARK_SUCCESS) failed = "ERKStepSVtolerances failed";
        else if (ERKStepSetUserData(s->erk, s) != ARK_SUCCESS) failed = "ERKStepSetUserData failed";
        else if (ERKStepSetTableNum(s->erk, IG_ERK_TABLE) != ARK_SUCCESS) failed = "ERKStepSetTableNum failed";
        else if (ERKStepSetInterpolantDegree(s->erk, IG_ERK_DENSE_DEGREE) != ARK_SUCCESS) failed = "ERKStepSetInterpolantDegree failed";
        else if (ERKStepSetMaxNumSteps(s->erk, -1) != ARK_SUCCESS) failed = "ERKStepSetMaxNumSteps failed";
    } else if (!failed) {
#if SUNDIALS_VERSION_MAJOR < 7
        CVodeSetErrHandlerFn(s->cvode, on_error, s);
#endif
        /* CVodeInit once here; every segment re-initialises with CVodeReInit. */
        N_VConst(0.0, s->y);
        if (CVodeInit(s->cvode, rhs, 0.0, s->y) != CV_SUCCESS) failed = "CVodeInit failed";
        else if (CVodeSVtolerances(s->cvode, rtol, s->abstol) != CV_SUCCESS) failed = "CVodeSVtolerances failed";
        else if (CVodeSetUserData(s->cvode, s) != CV_SUCCESS) failed = "CVodeSetUserData failed";
        else if (CVodeSetLinearSolver(s->cvode, s->LS, s->A) != CV_SUCCESS) failed = "CVodeSetLinearSolver failed";
        else if (CVodeSetNoInactiveRootWarn(s->cvode) != CV_SUCCESS) failed = "CVodeSetNoInactiveRootWarn failed";
        else if (CVodeSetMaxConvFails(s->cvode, 50) != CV_SUCCESS) failed = "CVodeSetMaxConvFails failed";
        else if (CVodeSetMaxErrTestFails(s->cvode, 50) != CV_SUCCESS) failed = "CVodeSetMaxErrTestFails failed";
    }
#if MODEL_HAS_JACOBIAN
    if (!failed && analytic_jacobian) {
        s->jac = (double *)malloc(sizeof(double) * MODEL_NSTATE * MODEL_NSTATE);
        if (!s->jac) failed = "out of memory";
        else if (CVodeSetJacFn(s->cvode, jacobian) != CV_SUCCESS) failed = "CVodeSetJacFn failed";
        else s->analytic_in_use = 1;
    }
#endif
    if (failed) {
        snprintf(err, (size_t)errlen, "%s%s%s", failed, s->message[0] ? ": " : "", s->message);
        ig_solver_free(s);
        return NULL;
    }
    s->max_steps = max_steps;
    s->rtol = rtol;
    s->initialised = 1;
    /* Counters restart at every CVodeReInit: keep the totals in s->total. */
    memset(&s->total, 0, sizeof s->total);
    return s;
}

int ig_solver_reset(ig_solver *s, double rtol, const double *atol, long max_steps)
{
    if (!(rtol > 0.0) || max_steps <= 0) {
        set_message(s, "ig_solver_reset: rtol and max_steps must be positive");
        return IG_ERR_USAGE;
    }
    const int flag = ig_solver_set_atol(s, atol);
    if (flag != 0) return flag;
    if (s->jac && ig_solver_use_jacobian(s, 1) != 0) return IG_ERR_SOLVER;
    s->rtol = rtol;
    s->max_steps = max_steps;
    s->active = 0;
    s->continued = 0;
    s->counted = 1;
    memset(&s->total, 0, sizeof s->total);
    s->message[0] = '\0';
    return 0;
}

int ig_solver_set_atol(ig_solver *s, const double *atol)
{
    double *a = N_VGetArrayPointer(s->abstol);
    for (int k = 0; k < MODEL_NSTATE; ++k) {
        if (!(atol[k] > 0.0)) {
            set_message(s, "ig_solver_set_atol: every entry must be positive");
            return IG_ERR_USAGE;
        }
    }
    for (int k = 0; k < MODEL_NSTATE; ++k) a[k] = atol[k];
    s->atol_changed = 1;
    return 0;
}

int ig_solver_use_jacobian(ig_solver *s, int analytic)
{
    if (!s->cvode) return analytic ? IG_ERR_USAGE : 0;
    if (analytic == s->analytic_in_use) return 0;
    if (analytic && !s->jac) {
        set_message(s, "ig_solver_use_jacobian: the solver was created without the analytic Jacobian");
        return IG_ERR_USAGE;
    }
#if MODEL_HAS_JACOBIAN
    if (CVodeSetJacFn(s->cvode, analytic ? jacobian : NULL) != CV_SUCCESS) return IG_ERR_SOLVER;
#else
    if (CVodeSetJacFn(s->cvode, NULL) != CV_SUCCESS) return IG_ERR_SOLVER;
#endif
    s->analytic_in_use = analytic;
    return 0;
}

/* CVODE from (t0, s->y) to the segment's end, with its events and their directions. */
static int start_cvode(ig_solver *s, double t0)
{
    if (CVodeReInit(s->cvode, t0, s->y) != CV_SUCCESS) return IG_ERR_SOLVER;
    if (s->atol_changed) {
        if (CVodeSVtolerances(s->cvode, s->rtol, s->abstol) != CV_SUCCESS) return IG_ERR_SOLVER;
        s->atol_changed = 0;
    }
    if (CVodeRootInit(s->cvode, s->nevents, s->nevents > 0 ? roots : NULL) != CV_SUCCESS) return IG_ERR_SOLVER;
    if (s->nevents > 0 && CVodeSetRootDirection(s->cvode, s->dirs) != CV_SUCCESS) return IG_ERR_SOLVER;
    if (CVodeSetStopTime(s->cvode, s->t_stop) != CV_SUCCESS) return IG_ERR_SOLVER;
    s->on_cvode = 1;
    return 0;
}

int ig_segment_start(ig_solver *s, const model_params *params, double t0, const double *y0,
                     double t_stop, const int *events, const int *directions, int nevents)
{
    if (!s || !params || !y0 || nevents < 0 || nevents > MODEL_NEVENT || !(t_stop > t0)) {
        if (s) set_message(s, "ig_segment_start: bad arguments (t_stop must exceed t0)");
        return IG_ERR_USAGE;
    }
    for (int k = 0; k < nevents; ++k) {
        if (events[k] < 0 || events[k] >= MODEL_NEVENT) {
            set_message(s, "ig_segment_start: event index out of range");
            return IG_ERR_USAGE;
        }
    }
    add_counters(s, &s->total);
    s->counted = 0;
    s->params = params;
    s->nevents = nevents;
    for (int k = 0; k < nevents; ++k) {
        s->events[k] = events[k];
        s->dirs[k] = directions[k];
    }
    s->t_stop = t_stop;
    s->segment_steps = 0;
    s->message[0] = '\0';

    memcpy(s->y_data, y0, sizeof(double) * MODEL_NSTATE);
    if (s->rk) {
        /* the step the pair proposed at the end of the segment before in this run (not after
         * CVODE took over) */
        const double hint = s->continued && !s->on_cvode ? s->rk->h : 0.0;
        s->continued = 1;
        if (ig_dopri5_start(s->rk, params, t0, y0, t_stop, s->rtol, N_VGetArrayPointer(s->abstol), events,
                            directions, nevents, hint) != 0) {
            set_message(s, "the right-hand side is not finite at the start of the phase");
            return IG_ERR_SOLVER;
        }
        if (!s->cvode) s->atol_changed = 0;  /* auto: CVODE takes them if it takes over */
        s->on_cvode = 0;
        s->active = 1;
        return 0;
    }
    if (s->erk) {
        if (ERKStepReInit(s->erk, rhs, t0, s->y) != ARK_SUCCESS) return IG_ERR_SOLVER;
        if (s->atol_changed) {
            if (ERKStepSVtolerances(s->erk, s->rtol, s->abstol) != ARK_SUCCESS) return IG_ERR_SOLVER;
            s->atol_changed = 0;
        }
        if (ERKStepRootInit(s->erk, nevents, nevents > 0 ? roots : NULL) != ARK_SUCCESS) return IG_ERR_SOLVER;
        if (nevents > 0) {
            if (ERKStepSetRootDirection(s->erk, s->dirs) != ARK_SUCCESS) return IG_ERR_SOLVER;
            if (ERKStepSetNoInactiveRootWarn(s->erk) != ARK_SUCCESS) return IG_ERR_SOLVER;
        }
        if (ERKStepSetStopTime(s->erk, t_stop) != ARK_SUCCESS) return IG_ERR_SOLVER;
        s->active = 1;
        return 0;
    }
    const int flag = start_cvode(s, t0);
    if (flag == 0) s->active = 1;
    return flag;
}

/* The Taylor coefficients y^(k)(t) / k!, k = 0 .. dense_terms - 1, of CVODE's interpolating
 * polynomial of the last step, at t (zero past the order the step used). The polynomial has
 * that order, so the expansion reproduces it exactly over the step [t_n - h_u, t_n]. */
static int get_dky(ig_solver *s, double t, int k)
{
    if (s->rk && !s->on_cvode) {  /* only the state itself (k = 0) is asked for; write_dense has its own path */
        if (k != 0 || t < s->rk->t_old - 1e-12 * fabs(t) || t > s->rk->t + 1e-12 * fabs(t)) return -1;
        ig_dopri5_interpolate(s->rk, t, N_VGetArrayPointer(s->dky));
        return 0;
    }
    if (s->erk) return ERKStepGetDky(s->erk, t, k, s->dky) == ARK_SUCCESS ? 0 : -1;
    return CVodeGetDky(s->cvode, t, k, s->dky) == CV_SUCCESS ? 0 : -1;
}

static int write_dense(ig_solver *s, double t, double *out)
{
    if (s->rk && !s->on_cvode) {
        ig_dopri5_taylor(s->rk, out);
        memset(out + (size_t)IG_DOPRI5_DENSE_TERMS * MODEL_NSTATE, 0,
               sizeof(double) * MODEL_NSTATE * (size_t)(s->dense_terms - IG_DOPRI5_DENSE_TERMS));
        return 0;
    }
    int order = IG_ERK_DENSE_DEGREE;
    if (!s->erk && CVodeGetLastOrder(s->cvode, &order) != CV_SUCCESS) return -1;
    const double *dky = N_VGetArrayPointer(s->dky);
    double factorial = 1.0;
    int failed = 0;
    for (int k = 0; k < s->dense_terms; ++k) {
        double *row = out + (size_t)k * MODEL_NSTATE;
        if (k > order || failed) {
            memset(row, 0, sizeof(double) * MODEL_NSTATE);
            continue;
        }
        if (k > 0) factorial *= k;
        if (get_dky(s, t, k) != 0) {
            failed = 1;
            memset(row, 0, sizeof(double) * MODEL_NSTATE);
            continue;
        }
        for (int i = 0; i < MODEL_NSTATE; ++i) row[i] = dky[i] / factorial;
    }
    return failed ? -1 : 0;
}

int ig_interpolate(ig_solver *s, double t, double *y)
{
    if (get_dky(s, t, 0) != 0) {
        set_message(s, "ig_interpolate: t lies outside the last step");
        return IG_ERR_USAGE;
    }
    memcpy(y, N_VGetArrayPointer(s->dky), sizeof(double) * MODEL_NSTATE);
    return 0;
}

int ig_dense_terms(const ig_solver *s)
{
    return s->dense_terms;
}

#define IG_STEPPED 100  /* step_once: an ordinary step, the segment goes on */
/* Method auto: the explicit pair hands a segment to BDF after this many steps in it (or half
 * of solver.max_steps, if less), whether or not Hairer's test has called it stiff. That test
 * estimates h |lambda| from two stages and can stay below its boundary while the steps are
 * held by stability: a stuck tip under steep regularized friction (mu 1 to 3, eps 1e-10 to
 * 1e-9) kept the pair in a cycle of steps of 3e-12 to 6e-12 s, its estimate between 1.1
 * and 3.0, for 500000 steps. The catalogue's longest segment for the pair that ended well
 * took 745 steps at rtol 1e-12 (139 at 1e-8). */
#define IG_AUTO_PAIR_STEPS 2000

static int step_dopri5(ig_solver *s, double *t_now, int *roots_found)
{
    const int flag = ig_dopri5_step(s->rk, roots_found);
    if (flag < 0) {
        s->active = 0;
        snprintf(s->message, sizeof s->message, flag == IG_DOPRI5_TOO_SMALL
                 ? "DOPRI5: the step size fell below what double precision resolves at t = %.9g (too much "
                   "accuracy asked, or a stiff phase)"
                 : "DOPRI5: the right-hand side stopped being finite at t = %.9g on every smaller step tried",
                 s->rk->t);
        return IG_ERR_SOLVER;
    }
    s->segment_steps++;
    *t_now = s->rk->t;
    memcpy(s->y_data, s->rk->y, sizeof(double) * MODEL_NSTATE);
    if (flag == IG_DOPRI5_ROOT) {
        s->active = 0;
        return IG_ROOT;
    }
    if (flag == IG_DOPRI5_STOP) {
        s->active = 0;
        return IG_REACHED_END;
    }
    return IG_STEPPED;
}

/* One step of the segment under way: IG_STEPPED, IG_ROOT (roots_found filled),
 * IG_REACHED_END, or < 0 with the message set. The state is in s->y. */
static int step_once(ig_solver *s, double *t_now, int *roots_found)
{
    if (s->segment_steps >= s->max_steps) {
        s->active = 0;
        snprintf(s->message, sizeof s->message,
                 "more than %ld steps in one phase (solver.max_steps)", s->max_steps);
        return IG_ERR_TOO_MUCH_WORK;
    }
    if (s->rk && !s->on_cvode) {
        const int flag = step_dopri5(s, t_now, roots_found);
        const long budget = s->max_steps / 2 < IG_AUTO_PAIR_STEPS ? s->max_steps / 2 : IG_AUTO_PAIR_STEPS;
        if (flag == IG_STEPPED && s->cvode && (s->rk->stiff || s->segment_steps >= budget)) {
            /* auto: BDF finishes the segment */
            if (start_cvode(s, *t_now) != 0) {
                s->active = 0;
                return IG_ERR_SOLVER;
            }
            s->total.nstiff++;
        }
        return flag;
    }
    sunrealtype t;
    const int flag = s->erk ? ERKStepEvolve(s->erk, s->t_stop, s->y, &t, ARK_ONE_STEP)
                            : CVode(s->cvode, s->t_stop, s->y, &t, CV_ONE_STEP);
    if (flag < 0) {
        s->active = 0;
        if (!s->message[0]) snprintf(s->message, sizeof s->message, "CVode returned %d", flag);
        return IG_ERR_SOLVER;
    }
    s->segment_steps++;
    *t_now = t;
    if (flag == CV_ROOT_RETURN) {  /* ARK_ROOT_RETURN has the same value */
        if (s->erk) ERKStepGetRootInfo(s->erk, roots_found);
        else CVodeGetRootInfo(s->cvode, roots_found);
        s->active = 0;
        return IG_ROOT;
    }
    if (flag == CV_TSTOP_RETURN || t >= s->t_stop) {
        s->active = 0;
        return IG_REACHED_END;
    }
    return IG_STEPPED;
}

/* Write the step just taken as sample k (and its polynomial, if dense_buf). */
static int write_sample(ig_solver *s, double t, int k, double *t_buf, double *y_buf, double *dense_buf)
{
    t_buf[k] = t;
    memcpy(y_buf + (size_t)k * MODEL_NSTATE, s->y_data, sizeof(double) * MODEL_NSTATE);
    if (dense_buf != NULL && write_dense(s, t, dense_buf + (size_t)k * s->dense_terms * MODEL_NSTATE) != 0) {
        s->active = 0;
        set_message(s, "CVodeGetDky could not give the interpolating polynomial of the step");
        return IG_ERR_SOLVER;
    }
    return 0;
}

int ig_segment_advance(ig_solver *s, double *t_buf, double *y_buf, double *dense_buf,
                       int capacity, int *n_written, int *roots_found)
{
    *n_written = 0;
    if (!s->active) {
        set_message(s, "ig_segment_advance: no segment under way");
        return IG_ERR_USAGE;
    }
    while (*n_written < capacity) {
        double t;
        const int flag = step_once(s, &t, roots_found);
        if (flag < 0) return flag;
        if (write_sample(s, t, *n_written, t_buf, y_buf, dense_buf) != 0) return IG_ERR_SOLVER;
        (*n_written)++;
        if (flag != IG_STEPPED) return flag;
    }
    return IG_BUFFER_FULL;
}

/* Begin the machine's next segment at (t, y): its events, its Jacobian, its tolerances. */
static int begin_segment(ig_solver *s, const model_machine *m, const model_params *p, double t,
                         const double *y, double t_stop)
{
    int events[MODEL_NEVENT], directions[MODEL_NEVENT];
    const int watched = model_machine_events(m, events, directions);
    if (s->jac && ig_solver_use_jacobian(s, !model_machine_constrained(m)) != 0) return IG_ERR_SOLVER;
    return ig_segment_start(s, p, t, y, t_stop, events, directions, watched);
}

/* ---- impact coefficients (MODEL section 9): the impulses and the normal speed at a sample,
 * the first impact's maximum compression, and the coefficients from the three samples ---- */
static void read_impulses(ig_point *point, const double *y, const double *out)
{
    point->P_normal = y[MODEL_Y_P_normal];
#ifdef MODEL_Y_P_friction
    point->P_friction = y[MODEL_Y_P_friction];
#else
    point->P_friction = 0.0;
#endif
    point->v_n = out[MODEL_OUT_v_By];
}

/* The values a summary reads at sample k of the buffers. */
static void read_point(ig_point *point, double t, const double *y, const double *out)
{
    point->t = t;
    point->T = out[MODEL_OUT_T];
    point->V = out[MODEL_OUT_V];
    point->W_normal = y[2 * MODEL_NQ];
#ifdef MODEL_Y_W_friction
    point->W_friction = y[MODEL_Y_W_friction];
#else
    point->W_friction = 0.0;
#endif
    memcpy(point->y, y, sizeof point->y);
    read_impulses(point, y, out);
}

/* Follow the first impact's maximum compression (the latest, after a reloading). */
static void tally_coefficients(ig_tally *a, const ig_segment *seg, double t, const double *y, const double *out)
{
    if (a->impacts == 1 && a->ended == 0 && (seg->act & MODEL_ACT_MAX_COMPRESSION)) {
        read_point(&a->first_max, t, y, out);
        a->first_compressed = 1;
    }
}

/* The first impact's impulses and coefficients, from its start, maximum compression and end;
 * NAN while it has not ended (or never reached maximum compression). */
static void summarize_coefficients(const ig_tally *a, ig_summary *out)
{
    const ig_point *b = &a->first_begin, *m = &a->first_max, *e = &a->first_end;
    out->v_n0 = a->impacts ? b->v_n : NAN;
    out->P_c = out->P_r = out->P_t = out->e_N = out->e_P = out->e_E = out->friction_share = NAN;
    if (a->ended == 0 || !a->first_compressed) return;
    const double W_c = m->W_normal - b->W_normal, W_r = e->W_normal - m->W_normal;
    const double W_f = e->W_friction - b->W_friction;
    out->P_c = m->P_normal - b->P_normal;
    out->P_r = e->P_normal - m->P_normal;
    out->P_t = e->P_friction - b->P_friction;
    out->e_N = -e->v_n / b->v_n;
    out->e_P = out->P_r / out->P_c;
    out->e_E = sqrt(W_r / -W_c);
    out->friction_share = W_f / (W_c + W_r + W_f) + 0.0;  /* + 0.0: no -0 without friction */
}

void ig_tally_begin(ig_tally *tally, double t0, const double *y0, const double *out0, int in_contact)
{
    memset(tally, 0, sizeof *tally);
    read_point(&tally->start, t0, y0, out0);
    tally->last = tally->start;
    tally->segment_start = t0;
    tally->t_sustained = NAN;
    if (in_contact) {
        tally->impacts = 1;
        tally->first_begin = tally->start;
        tally->now_start = t0;
    }
}

/* Add the latest impact's record (a->now_...) to the run's: the largest delta_max and P_max,
 * the deepest dent (the first of equals), its contact time. */
static void fold_impact(ig_tally *a, double contact, int first_folded)
{
    if (a->now_delta_max > a->delta_max) a->delta_max = a->now_delta_max;
    if (a->now_P_max > a->P_max) a->P_max = a->now_P_max;
    if (first_folded || a->now_delta_r > a->deepest_delta_r) {
        a->deepest_delta_r = a->now_delta_r;
        a->deepest_R_res = a->now_R_res;
    }
    a->t_contact += contact;
}

/* Follow one finished segment (its end is sample k of the buffers) in the tally. */
static void tally_segment(ig_tally *a, const ig_segment *seg, const double *t_buf, const double *y_buf,
                          const double *out_buf)
{
    const long k = seg->sample;
    const double *y = y_buf + (size_t)k * MODEL_NSTATE, *out = out_buf + (size_t)k * MODEL_NOUT;
    if (seg->state == MODEL_MACHINE_SUSTAINED && isnan(a->t_sustained)) a->t_sustained = a->segment_start;
    a->segment_start = seg->t;
    if (seg->act & MODEL_ACT_IMPACT_BEGIN) {
        if (++a->impacts == 1) read_point(&a->first_begin, t_buf[k], y, out);
        a->now_start = seg->t;
        a->now_delta_max = a->now_P_max = a->now_delta_r = a->now_R_res = 0.0;
    }
    if (a->impacts == 0) return;
    if (seg->act & MODEL_ACT_MAX_COMPRESSION) {
        a->now_delta_max = seg->delta_max;
        a->now_P_max = seg->P_max;
        a->now_delta_r = seg->delta_r;
        a->now_R_res = seg->R_res;
    }
    if (a->impacts == 1) {
        if (seg->act & MODEL_ACT_SLIP) a->first_stick_slip++;
        if (seg->state != MODEL_MACHINE_FREE && seg->next_state != seg->state) a->first_switches++;
    }
    if (seg->act & MODEL_ACT_IMPACT_END) {
        fold_impact(a, seg->t - a->now_start, a->ended++ == 0);
        if (a->impacts == 1) {
            read_point(&a->first_end, t_buf[k], y, out);
            a->first_delta_max = a->now_delta_max;
            a->first_P_max = a->now_P_max;
            a->first_delta_r = a->now_delta_r;
            a->first_R_res = a->now_R_res;
        }
    }
    tally_coefficients(a, seg, t_buf[k], y, out);
}

/* A summary from sample `from` to sample `to` (the energies, the works, the end state). */
static void summarize_between(const ig_point *from, const ig_point *to, ig_summary *out)
{
    out->T0 = from->T;
    out->Tf = to->T;
    out->delta_T = from->T - to->T;
    memcpy(out->y_final, to->y, sizeof out->y_final);
    out->t_final = to->t;
    out->W_normal = to->W_normal - from->W_normal;
    out->W_friction = to->W_friction - from->W_friction;
    out->W_gravity = from->V - to->V;
    out->residual = (to->T - from->T) - (out->W_normal + out->W_friction + out->W_gravity);
}

void ig_summarize(const ig_tally *a, ig_summary *run, ig_summary *first)
{
    const int open = a->impacts > a->ended;  /* the latest impact is still in contact */
    ig_tally all = *a;
    if (open) fold_impact(&all, a->last.t - a->now_start, a->ended == 0);
    memset(run, 0, sizeof *run);
    summarize_between(&a->start, &a->last, run);
    run->delta_max = all.delta_max;
    run->P_max = all.P_max;
    run->delta_r = all.deepest_delta_r;
    run->R_res = all.deepest_R_res;
    run->t_contact = all.t_contact;
    run->t_impact = a->impacts ? a->first_begin.t : NAN;
    run->n_switches = a->first_switches;
    run->n_stick_slip = a->first_stick_slip;
    run->impacts = a->impacts;
    run->t_sustained = a->t_sustained;
    summarize_coefficients(a, run);  /* the first impact's, as the run's switches are */
    if (a->impacts == 0) {
        *first = *run;
        return;
    }
    memset(first, 0, sizeof *first);
    const int first_open = a->ended == 0;
    summarize_between(&a->first_begin, first_open ? &a->last : &a->first_end, first);
    first->delta_max = first_open ? a->now_delta_max : a->first_delta_max;
    first->P_max = first_open ? a->now_P_max : a->first_P_max;
    first->delta_r = first_open ? a->now_delta_r : a->first_delta_r;
    first->R_res = first_open ? a->now_R_res : a->first_R_res;
    first->t_contact = first_open ? 0.0 : a->first_end.t - a->first_begin.t;
    first->t_impact = a->first_begin.t;
    first->n_switches = a->first_switches;
    first->n_stick_slip = a->first_stick_slip;
    first->impacts = a->impacts;
    first->t_sustained = a->t_sustained;
    summarize_coefficients(a, first);
}

/* ig_run's loop over the segments (cvode_glue.h); ig_run then notes its last sample in the
 * tally, whichever way the loop returned. */
static int run_machine(ig_solver *s, model_machine *m, model_params *p, double *t, double *y, double t_stop,
                       double atol, long max_segments, int every_step, double *t_buf, double *y_buf,
                       double *out_buf, double *dense_buf, int capacity, int *n_written, ig_segment *segments,
                       int segment_capacity, int *n_segments, ig_tally *tally)
{
    int roots_found[MODEL_NEVENT];
    double atol_now[MODEL_NSTATE];
    long begun = 0;
    *n_segments = 0;
    if (capacity < 1 || segment_capacity < 1 || *n_written < 0 || *n_written >= capacity) {
        set_message(s, "ig_run: the buffers must have room for a sample and a segment (*n_written: "
                       "the samples already in them, 0 for emptied buffers)");
        return IG_ERR_USAGE;
    }
    for (;;) {
        if (!s->active) {
            if (*n_segments >= segment_capacity) return IG_SEGMENTS_FULL;
            if (!every_step && *n_written >= capacity) return IG_BUFFER_FULL;
            if (begun++ >= max_segments) {
                set_message(s, "too many phase switches");
                return IG_ERR_SEGMENTS;
            }
            const int flag = begin_segment(s, m, p, *t, y, t_stop);
            if (flag < 0) return flag;
        }
        int flag;
        do {
            if (every_step && *n_written >= capacity) return IG_BUFFER_FULL;
            flag = step_once(s, t, roots_found);
            if (flag < 0) return flag;
            memcpy(y, s->y_data, sizeof(double) * MODEL_NSTATE);
            model_machine_observe(m, p, *t, y);
            if (every_step || flag != IG_STEPPED) {
                const int k = *n_written;
                if (write_sample(s, *t, k, t_buf, y_buf, every_step ? dense_buf : NULL) != 0) return IG_ERR_SOLVER;
                model_outputs(*t, y, out_buf + (size_t)k * MODEL_NOUT, p);
                (*n_written)++;
            }
        } while (flag == IG_STEPPED);
        if (model_machine_stick_missed(m, p)) {
            set_message(s, "the stuck tip needed a friction force beyond mu F and no slip event "
                           "fired; tighten solver.rtol");
            return IG_ERR_STICK;
        }
        ig_segment *seg = &segments[(*n_segments)++];
        seg->t = *t;
        seg->sample = *n_written - 1;
        seg->state = m->state;
        seg->slip = m->slip;
        seg->params = *p;
        seg->event = -1;
        seg->act = 0;
        if (flag == IG_ROOT) {
            for (int k = 0; k < s->nevents && seg->event < 0; ++k) {
                if (roots_found[k]) seg->event = s->events[k];
            }
            seg->act = model_machine_switch(m, p, *t, y, roots_found);
        }
        seg->next_state = m->state;  /* the machine after the switch (as it was, at t_stop) */
        seg->next_slip = m->slip;
        seg->delta_max = m->delta_max;
        seg->P_max = m->P_max;
        seg->delta_r = m->delta_r;
        seg->R_res = m->R_res;
        if (tally) tally_segment(tally, seg, t_buf, y_buf, out_buf);
        if (flag == IG_REACHED_END) return IG_REACHED_END;
        const int act = seg->act;
        if (act & MODEL_ACT_END) return IG_RUN_DONE;
        if (act & MODEL_ACT_TOLERANCES) {
            model_machine_atol(m, p, s->rtol, atol, atol_now);
            if (ig_solver_set_atol(s, atol_now) != 0) return IG_ERR_USAGE;
        }
    }
}

int ig_run_begin(ig_solver *s, model_machine *m, model_params *p, double t0, const double *y0, int run_to_time,
                 double rtol, double atol, long max_steps, double *atol_now,
                 double *t_buf, double *y_buf, double *out_buf, ig_tally *tally)
{
    memcpy(y_buf, y0, sizeof(double) * MODEL_NSTATE);
    t_buf[0] = t0;
    const int start = model_machine_start(m, p, t0, y_buf, run_to_time);
    model_outputs(t0, y_buf, out_buf, p);
    ig_tally_begin(tally, t0, y_buf, out_buf, start == MODEL_START_CONTACT);
    if (start == MODEL_START_ALONG || start == MODEL_START_AWAY) return start;
    model_machine_atol(m, p, rtol, atol, atol_now);
    const int flag = ig_solver_reset(s, rtol, atol_now, max_steps);
    return flag != 0 ? flag : start;
}

int ig_run(ig_solver *s, model_machine *m, model_params *p, double *t, double *y, double t_stop,
           double atol, long max_segments, int every_step,
           double *t_buf, double *y_buf, double *out_buf, double *dense_buf, int capacity, int *n_written,
           ig_segment *segments, int segment_capacity, int *n_segments, ig_tally *tally)
{
    const int flag = run_machine(s, m, p, t, y, t_stop, atol, max_segments, every_step, t_buf, y_buf, out_buf,
                                 dense_buf, capacity, n_written, segments, segment_capacity, n_segments, tally);
    if (tally && *n_written > 0) {
        const long k = *n_written - 1;
        read_point(&tally->last, t_buf[k], y_buf + (size_t)k * MODEL_NSTATE, out_buf + (size_t)k * MODEL_NOUT);
    }
    return flag;
}

void ig_solver_stats(const ig_solver *s, ig_stats *stats)
{
    *stats = s->total;
    add_counters(s, stats);
}

const char *ig_solver_message(const ig_solver *s)
{
    return s->message;
}

void ig_outputs(const model_params *params, int n, const double *t, const double *y,
                double *out)
{
    for (int k = 0; k < n; ++k) {
        model_outputs(t[k], y + (size_t)k * MODEL_NSTATE, out + (size_t)k * MODEL_NOUT, params);
    }
}

int ig_sundials_version_major(void)
{
    return SUNDIALS_VERSION_MAJOR;
}
