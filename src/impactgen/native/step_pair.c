/*
 * step_pair.c: the plain-C Dormand-Prince pair (dopri5.c) as a stepper (stepper.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dopri5.h"
#include "stepper.h"

typedef struct {
    ig_stepper base;
    ig_dopri5 r;
    double rtol;
    double *atol;
    int continued;    /* a segment of this run has begun: the next may start from its last step */
    int live_counted; /* the pair's counters belong to a run already restarted: do not add them */
} pair_stepper;

static void live(const ig_stepper *st, ig_stats *stats)
{
    const pair_stepper *p = (const pair_stepper *)st;
    if (p->live_counted) return;
    stats->nsteps += p->r.nsteps;
    stats->nfev += p->r.nfev;
    stats->netfails += p->r.netfails;
    stats->ngev += p->r.ngev;
}

static int tolerances(ig_stepper *st, double rtol, const double *atol, long max_steps)
{
    pair_stepper *p = (pair_stepper *)st;
    (void)max_steps;
    p->rtol = rtol;
    memcpy(p->atol, atol, sizeof(double) * (size_t)st->problem->n);
    return 0;
}

static void restart(ig_stepper *st)
{
    pair_stepper *p = (pair_stepper *)st;
    memset(&st->done, 0, sizeof st->done);
    p->live_counted = 1;
    p->continued = 0;
}

static int start(ig_stepper *st, double t0, const double *y0, double t_stop, const int *directions, int nevents)
{
    pair_stepper *p = (pair_stepper *)st;
    ig_stepper_bank(st);
    p->live_counted = 0;
    /* the step the pair proposed at the end of the segment before in this run */
    const double hint = p->continued ? p->r.h : 0.0;
    p->continued = 1;
    if (ig_dopri5_start(&p->r, t0, y0, t_stop, p->rtol, p->atol, directions, nevents, hint) != 0) {
        ig_stepper_say(st->problem, "the right-hand side is not finite at the start of the phase");
        return -1;
    }
    return 0;
}

static int step(ig_stepper *st, double *t, double *y, int *roots_found)
{
    pair_stepper *p = (pair_stepper *)st;
    const int flag = ig_dopri5_step(&p->r, roots_found);
    if (flag < 0) {
        ig_stepper_say(st->problem, flag == IG_DOPRI5_TOO_SMALL
                       ? "DOPRI5: the step size fell below what double precision resolves at t = %.9g (too much "
                         "accuracy asked, or a stiff phase)"
                       : flag == IG_DOPRI5_RHS_FAILED
                       ? "DOPRI5: the right-hand side stopped being finite at t = %.9g on every smaller step tried"
                       : "DOPRI5: no segment under way at t = %.9g", p->r.t);
        return IG_STEP_FAILED;
    }
    *t = p->r.t;
    memcpy(y, p->r.y, sizeof(double) * (size_t)st->problem->n);
    if (flag == IG_DOPRI5_ROOT) return IG_STEP_ROOT;
    if (flag == IG_DOPRI5_STOP) return IG_STEP_END;
    return IG_STEP_ON;
}

static int interpolate(ig_stepper *st, double t, double *y)
{
    pair_stepper *p = (pair_stepper *)st;
    if (t < p->r.t_old - 1e-12 * fabs(t) || t > p->r.t + 1e-12 * fabs(t)) return -1;
    ig_dopri5_interpolate(&p->r, t, y);
    return 0;
}

static int dense(ig_stepper *st, double t, double *rows, int terms)
{
    pair_stepper *p = (pair_stepper *)st;
    const int n = st->problem->n;
    (void)t;  /* the pair's polynomial is expanded at the step's end, r.t */
    if (terms < IG_DOPRI5_DENSE_TERMS) return -1;
    ig_dopri5_taylor(&p->r, rows);
    memset(rows + (size_t)IG_DOPRI5_DENSE_TERMS * n, 0, sizeof(double) * (size_t)n * (size_t)(terms - IG_DOPRI5_DENSE_TERMS));
    return 0;
}

static void free_pair(ig_stepper *st)
{
    pair_stepper *p = (pair_stepper *)st;
    if (!p) return;
    ig_dopri5_free(&p->r);
    free(p->atol);
    free(p);
}

static const ig_stepper_ops pair_ops = {tolerances, ig_stepper_no_jacobian, restart, start, step, interpolate, dense,
                                        live, free_pair};

ig_stepper *ig_pair_new(const ig_problem *problem, char *err, int errlen)
{
    pair_stepper *p = (pair_stepper *)calloc(1, sizeof *p);
    if (p) p->atol = (double *)calloc((size_t)problem->n, sizeof(double));
    if (!p || !p->atol || ig_dopri5_init(&p->r, problem->n, problem->max_events, problem->rhs, problem->events,
                                         problem->user) != 0) {
        snprintf(err, (size_t)errlen, "allocating the explicit pair failed");
        if (p) free_pair(&p->base);
        return NULL;
    }
    p->base.ops = &pair_ops;
    p->base.problem = problem;
    p->base.dense_terms = IG_DOPRI5_DENSE_TERMS;
    p->live_counted = 1;
    return &p->base;
}

int ig_pair_stiff(const ig_stepper *st)
{
    return ((const pair_stepper *)st)->r.stiff;
}

long ig_pair_steps(const ig_stepper *st)
{
    return ((const pair_stepper *)st)->r.nsteps;
}

void ig_pair_forget_step(ig_stepper *st)
{
    ((pair_stepper *)st)->continued = 0;
}
