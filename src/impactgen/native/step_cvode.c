/*
 * step_cvode.c: CVODES's BDF or Adams method as a stepper (stepper.h), re-initialised at each
 * segment start (the force law changes at a phase switch, so the step history must not be
 * carried across). Supports SUNDIALS 6.x and 7.x.
 *
 * The problem's quadratures (the works and impulses), when there are many, are CVODES
 * quadratures: integrated after each step's corrector has converged, outside the Newton
 * iteration, whose matrix is then of the motion only (12 x 12 instead of 36 x 36 for the
 * six-link falling chain, where the dense LU of the whole state took a third of the run; see
 * IG_QUADRATURES_APART). CVODES, not CVODE: the two define the same symbols, and CVODE has no
 * quadratures.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_types.h>
#include <sundials/sundials_version.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "small_kernels.h"
#include "stepper.h"
#include "step_sundials.h"

/* CVODE's default maximum orders: dense output keeps max order + 1 coefficients a step. */
#define BDF_MAX_ORDER 5
#define ADAMS_MAX_ORDER 12
#define MAX_FAILS 50  /* error test and nonlinear convergence failures allowed in one step */
/* The quadratures leave the Newton system when there are at least this many: CVODES's
 * quadratures cost about 3000 instructions a step of their own (vector operations, the
 * quadratures' right-hand side, CVodeGetQuad), and the error test then takes the max of the
 * motion's and the quadratures' norms, which took up to 13 % more steps. Callgrind, BDF, whole
 * runs: the six-link falling chain (24 quadratures, 36 states) 1.14e9 instructions apart
 * against 1.62e9 on main with them in (1.42x; the dense LU of 36 x 36 was a third); three
 * links with both joints (12 of 18) 30.8e6 either way; two links with a joint (8 of 12)
 * 13.8e6 apart, 11.3e6 in; the paper's case (4 of 8) 6.1e6 apart, 4.7e6 in. */
#define IG_QUADRATURES_APART 16

typedef struct {
    ig_stepper base;
    SUNContext ctx;
    void *cvode;
    int m, nquad;         /* the motion's states y[0..m) in the Newton system, the quadratures after */
    N_Vector y, abstol, dky;     /* the motion's */
    N_Vector yQ, abstolQ, dkyQ;  /* the quadratures' (NULL when nquad is 0) */
    N_Vector full;               /* all n states, for the dense output */
    SUNMatrix A;
    SUNLinearSolver LS;
    double *jac;          /* row-major buffer for the problem's Jacobian (NULL: none) */
    int analytic_in_use;  /* the analytic Jacobian is set (else CVODE's difference quotients) */
    double rtol;
    int tolerances_changed;
    double t_stop;        /* the segment's end (CVODE's stop time, and its tout) */
    int *dirs;            /* max_events root directions */
    int counting;         /* CVODE's counters belong to a segment of this run: add them */
} cvode_stepper;

static int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void *user_data)
{
    const cvode_stepper *c = (const cvode_stepper *)user_data;
    const ig_problem *pb = c->base.problem;
    return (c->nquad ? pb->motion : pb->rhs)(t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot), pb->user);
}

static int quadrature_rhs(sunrealtype t, N_Vector y, N_Vector qdot, void *user_data)
{
    const ig_problem *pb = ((const cvode_stepper *)user_data)->base.problem;
    return pb->quadratures(t, N_VGetArrayPointer(y), N_VGetArrayPointer(qdot), pb->user);
}

static int roots(sunrealtype t, N_Vector y, sunrealtype *g, void *user_data)
{
    const ig_problem *pb = ((const cvode_stepper *)user_data)->base.problem;
    pb->events(t, N_VGetArrayPointer(y), g, pb->user);
    return 0;
}

static int jacobian(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *user_data, N_Vector tmp1,
                    N_Vector tmp2, N_Vector tmp3)
{
    (void)fy; (void)tmp1; (void)tmp2; (void)tmp3;
    const cvode_stepper *c = (const cvode_stepper *)user_data;
    const ig_problem *pb = c->base.problem;
    const int n = pb->n - pb->nquad;  /* the problem's Jacobian: of the states before the quadratures */
    const int flag = pb->jacobian(t, N_VGetArrayPointer(y), c->jac, pb->user);
    if (flag != 0) return flag;
    if (n < c->m) SUNMatZero(J);  /* the quadratures in the Newton system: their rows and columns 0 */
    for (int j = 0; j < n; ++j) {
        sunrealtype *column = SUNDenseMatrix_Column(J, j);
        for (int i = 0; i < n; ++i) column[i] = c->jac[i * n + j];
    }
    return 0;
}

static void live(const ig_stepper *st, ig_stats *stats)
{
    const cvode_stepper *c = (const cvode_stepper *)st;
    long v;
    if (!c->counting) return;
    if (CVodeGetNumSteps(c->cvode, &v) == CV_SUCCESS) stats->nsteps += v;
    if (CVodeGetNumRhsEvals(c->cvode, &v) == CV_SUCCESS) stats->nfev += v;
    if (CVodeGetNumJacEvals(c->cvode, &v) == CV_SUCCESS) stats->njev += v;
    if (CVodeGetNumLinSolvSetups(c->cvode, &v) == CV_SUCCESS) stats->nlinsetups += v;
    if (CVodeGetNumErrTestFails(c->cvode, &v) == CV_SUCCESS) stats->netfails += v;
    if (c->nquad && CVodeGetQuadNumErrTestFails(c->cvode, &v) == CV_SUCCESS) stats->netfails += v;
    if (CVodeGetNumNonlinSolvConvFails(c->cvode, &v) == CV_SUCCESS) stats->nnlsfails += v;
    if (CVodeGetNumGEvals(c->cvode, &v) == CV_SUCCESS) stats->ngev += v;
}

static int tolerances(ig_stepper *st, double rtol, const double *atol, long max_steps)
{
    cvode_stepper *c = (cvode_stepper *)st;
    (void)max_steps;
    c->rtol = rtol;
    memcpy(N_VGetArrayPointer(c->abstol), atol, sizeof(double) * (size_t)c->m);
    if (c->nquad) memcpy(N_VGetArrayPointer(c->abstolQ), atol + c->m, sizeof(double) * (size_t)c->nquad);
    c->tolerances_changed = 1;
    return 0;
}

static int use_jacobian(ig_stepper *st, int analytic)
{
    cvode_stepper *c = (cvode_stepper *)st;
    if (analytic == c->analytic_in_use) return 0;
    if (analytic && !c->jac) {
        ig_stepper_say(st->problem, "the solver was created without the analytic Jacobian");
        return -1;
    }
    if (CVodeSetJacFn(c->cvode, analytic ? jacobian : NULL) != CV_SUCCESS) return -1;
    c->analytic_in_use = analytic;
    return 0;
}

static void restart(ig_stepper *st)
{
    cvode_stepper *c = (cvode_stepper *)st;
    memset(&st->done, 0, sizeof st->done);
    c->counting = 0;
}

static int start(ig_stepper *st, double t0, const double *y0, double t_stop, const int *directions, int nevents)
{
    cvode_stepper *c = (cvode_stepper *)st;
    ig_stepper_bank(st);  /* CVodeReInit clears CVODE's counters */
    c->counting = 0;
    memcpy(N_VGetArrayPointer(c->y), y0, sizeof(double) * (size_t)c->m);
    for (int k = 0; k < nevents; ++k) c->dirs[k] = directions[k];
    if (CVodeReInit(c->cvode, t0, c->y) != CV_SUCCESS) return -1;
    if (c->nquad) {
        memcpy(N_VGetArrayPointer(c->yQ), y0 + c->m, sizeof(double) * (size_t)c->nquad);
        if (CVodeQuadReInit(c->cvode, c->yQ) != CV_SUCCESS) return -1;
    }
    c->counting = 1;
    if (c->tolerances_changed) {
        if (CVodeSVtolerances(c->cvode, c->rtol, c->abstol) != CV_SUCCESS) return -1;
        if (c->nquad && CVodeQuadSVtolerances(c->cvode, c->rtol, c->abstolQ) != CV_SUCCESS) return -1;
        c->tolerances_changed = 0;
    }
    if (CVodeRootInit(c->cvode, nevents, nevents > 0 ? roots : NULL) != CV_SUCCESS) return -1;
    if (nevents > 0 && CVodeSetRootDirection(c->cvode, c->dirs) != CV_SUCCESS) return -1;
    if (CVodeSetStopTime(c->cvode, t_stop) != CV_SUCCESS) return -1;
    c->t_stop = t_stop;
    return 0;
}

static int step(ig_stepper *st, double *t_now, double *y, int *roots_found)
{
    cvode_stepper *c = (cvode_stepper *)st;
    sunrealtype t;
    const int flag = CVode(c->cvode, c->t_stop, c->y, &t, CV_ONE_STEP);
    if (flag < 0) {
        if (!st->problem->message[0]) ig_stepper_say(st->problem, "CVode returned %d", flag);
        return IG_STEP_FAILED;
    }
    *t_now = t;
    memcpy(y, N_VGetArrayPointer(c->y), sizeof(double) * (size_t)c->m);
    if (c->nquad) {  /* the quadratures at the time CVode returned (a root's, the stop time) */
        sunrealtype t_quad;
        if (CVodeGetQuad(c->cvode, &t_quad, c->yQ) != CV_SUCCESS) {
            ig_stepper_say(st->problem, "CVodeGetQuad failed at t = %g", t);
            return IG_STEP_FAILED;
        }
        memcpy(y + c->m, N_VGetArrayPointer(c->yQ), sizeof(double) * (size_t)c->nquad);
    }
    if (flag == CV_ROOT_RETURN) {
        CVodeGetRootInfo(c->cvode, roots_found);
        return IG_STEP_ROOT;
    }
    if (flag == CV_TSTOP_RETURN || t >= c->t_stop) return IG_STEP_END;
    return IG_STEP_ON;
}

/* The k-th derivative of the last step's polynomial at t, of every state: the motion's and
 * the quadratures'. (mem: the stepper, as ig_sundials_taylor passes it.) */
static int every_dky(void *mem, sunrealtype t, int k, N_Vector out)
{
    cvode_stepper *c = (cvode_stepper *)mem;
    double *d = N_VGetArrayPointer(out);
    if (CVodeGetDky(c->cvode, t, k, c->dky) != CV_SUCCESS) return -1;
    memcpy(d, N_VGetArrayPointer(c->dky), sizeof(double) * (size_t)c->m);
    if (c->nquad) {
        if (CVodeGetQuadDky(c->cvode, t, k, c->dkyQ) != CV_SUCCESS) return -1;
        memcpy(d + c->m, N_VGetArrayPointer(c->dkyQ), sizeof(double) * (size_t)c->nquad);
    }
    return 0;
}

static int interpolate(ig_stepper *st, double t, double *y)
{
    cvode_stepper *c = (cvode_stepper *)st;
    if (every_dky(c, t, 0, c->full) != 0) return -1;
    memcpy(y, N_VGetArrayPointer(c->full), sizeof(double) * (size_t)st->problem->n);
    return 0;
}

/* The Taylor coefficients y^(k)(t) / k! of CVODE's interpolating polynomial of the last step
 * (zero past the order the step used). The polynomial has that order, so the expansion
 * reproduces it exactly over the step [t_n - h_u, t_n]. */
static int dense(ig_stepper *st, double t, double *rows, int terms)
{
    cvode_stepper *c = (cvode_stepper *)st;
    int order;
    if (CVodeGetLastOrder(c->cvode, &order) != CV_SUCCESS) return -1;
    return ig_sundials_taylor(st->problem->n, every_dky, c, c->full, order, t, rows, terms);
}

static void free_cvode(ig_stepper *st)
{
    cvode_stepper *c = (cvode_stepper *)st;
    if (c->cvode) CVodeFree(&c->cvode);
    if (c->LS) SUNLinSolFree(c->LS);
    if (c->A) SUNMatDestroy(c->A);
    if (c->y) N_VDestroy(c->y);
    if (c->abstol) N_VDestroy(c->abstol);
    if (c->dky) N_VDestroy(c->dky);
    if (c->yQ) N_VDestroy(c->yQ);
    if (c->abstolQ) N_VDestroy(c->abstolQ);
    if (c->dkyQ) N_VDestroy(c->dkyQ);
    if (c->full) N_VDestroy(c->full);
    if (c->ctx) SUNContext_Free(&c->ctx);
    free(c->jac);
    free(c->dirs);
    free(c);
}

static const ig_stepper_ops cvode_ops = {tolerances, use_jacobian, restart, start, step, interpolate, dense,
                                         live, free_cvode};

ig_stepper *ig_cvode_new(const ig_problem *problem, int adams, char *err, int errlen)
{
    cvode_stepper *c = (cvode_stepper *)calloc(1, sizeof *c);
    const char *failed = NULL;
    if (!c) {
        snprintf(err, (size_t)errlen, "out of memory");
        return NULL;
    }
    c->base.ops = &cvode_ops;
    c->base.problem = problem;
    c->base.dense_terms = (adams ? ADAMS_MAX_ORDER : BDF_MAX_ORDER) + 1;
    /* the quadratures apart when the problem gives its two parts and has enough of them */
    c->nquad = problem->nquad >= IG_QUADRATURES_APART && problem->motion && problem->quadratures ? problem->nquad : 0;
    c->m = problem->n - c->nquad;
    const int n = c->m;
    c->dirs = (int *)calloc((size_t)problem->max_events + 1, sizeof(int));
    if (!c->dirs || ig_sundials_context(&c->ctx, problem) != 0) failed = "SUNContext_Create failed";
    if (!failed) {
        c->y = N_VNew_Serial(n, c->ctx);
        c->abstol = N_VNew_Serial(n, c->ctx);
        c->dky = N_VNew_Serial(n, c->ctx);
        c->full = N_VNew_Serial(problem->n, c->ctx);
        if (c->nquad) {
            c->yQ = N_VNew_Serial(c->nquad, c->ctx);
            c->abstolQ = N_VNew_Serial(c->nquad, c->ctx);
            c->dkyQ = N_VNew_Serial(c->nquad, c->ctx);
            if (c->yQ) N_VEnableFusedOps_Serial(c->yQ, SUNTRUE);
            if (c->yQ) ig_use_small_vector_kernels(c->yQ);
            if (!c->yQ || !c->abstolQ || !c->dkyQ) failed = "allocating CVODES's quadratures failed";
        }
        /* fused vector operations: fewer calls per step for CVODE's vectors, cloned from y */
        if (c->y) N_VEnableFusedOps_Serial(c->y, SUNTRUE);
        if (c->y) c->A = SUNDenseMatrix(n, n, c->ctx);
        if (c->A) c->LS = SUNLinSol_Dense(c->y, c->A, c->ctx);
        if (c->LS) ig_use_small_kernels(c->y, c->A, c->LS);
        c->cvode = CVodeCreate(adams ? CV_ADAMS : CV_BDF, c->ctx);
        if (!c->y || !c->abstol || !c->dky || !c->full || !c->A || !c->LS || !c->cvode) failed = "allocating CVODE failed";
    }
    if (!failed) {
#if SUNDIALS_VERSION_MAJOR < 7
        CVodeSetErrHandlerFn(c->cvode, ig_sundials_on_error, (void *)problem);
#endif
        /* CVodeInit once here; every segment re-initialises with CVodeReInit. */
        N_VConst(0.0, c->y);
        N_VConst(1.0, c->abstol);
        c->rtol = 1e-6;  /* until the solver sets its tolerances, before the first start */
        c->tolerances_changed = 1;
        if (CVodeInit(c->cvode, rhs, 0.0, c->y) != CV_SUCCESS) failed = "CVodeInit failed";
        else if (CVodeSVtolerances(c->cvode, c->rtol, c->abstol) != CV_SUCCESS) failed = "CVodeSVtolerances failed";
        else if (CVodeSetUserData(c->cvode, c) != CV_SUCCESS) failed = "CVodeSetUserData failed";
        else if (CVodeSetLinearSolver(c->cvode, c->LS, c->A) != CV_SUCCESS) failed = "CVodeSetLinearSolver failed";
        else if (CVodeSetNoInactiveRootWarn(c->cvode) != CV_SUCCESS) failed = "CVodeSetNoInactiveRootWarn failed";
        else if (CVodeSetMaxConvFails(c->cvode, MAX_FAILS) != CV_SUCCESS) failed = "CVodeSetMaxConvFails failed";
        else if (CVodeSetMaxErrTestFails(c->cvode, MAX_FAILS) != CV_SUCCESS) failed = "CVodeSetMaxErrTestFails failed";
    }
    if (!failed && c->nquad) {
        /* the quadratures in the error test with their own tolerances (atol past the motion's):
         * an untested one (the impulses) has an atol so large that its weight is ~0 */
        N_VConst(0.0, c->yQ);
        N_VConst(1.0, c->abstolQ);
        if (CVodeQuadInit(c->cvode, quadrature_rhs, c->yQ) != CV_SUCCESS) failed = "CVodeQuadInit failed";
        else if (CVodeQuadSVtolerances(c->cvode, c->rtol, c->abstolQ) != CV_SUCCESS) failed = "CVodeQuadSVtolerances failed";
        else if (CVodeSetQuadErrCon(c->cvode, SUNTRUE) != CV_SUCCESS) failed = "CVodeSetQuadErrCon failed";
    }
    if (!failed && problem->jacobian) {
        const size_t m = (size_t)(problem->n - problem->nquad);
        c->jac = (double *)malloc(sizeof(double) * m * m);
        if (!c->jac) failed = "out of memory";
        else if (CVodeSetJacFn(c->cvode, jacobian) != CV_SUCCESS) failed = "CVodeSetJacFn failed";
        else c->analytic_in_use = 1;
    }
    if (failed) {
        snprintf(err, (size_t)errlen, "%s%s%s", failed, problem->message[0] ? ": " : "", problem->message);
        free_cvode(&c->base);
        return NULL;
    }
    return &c->base;
}
