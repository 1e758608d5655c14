/*
 * step_auto.c: method "auto" as a stepper (stepper.h) made of two others: each segment begins
 * with an explicit pair (step_pair.c) and goes on with an implicit method (CVODE's BDF) from
 * where the pair finds it stiff, or has taken too many steps.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "stepper.h"

/* The pair hands a segment to BDF after this many steps in it (or half of the step limit,
 * if less), whether or not Hairer's test has called it stiff. That test estimates h |lambda|
 * from two stages and can stay below its boundary while the steps are held by stability: a
 * stuck tip under steep regularized friction (mu 1 to 3, eps 1e-10 to 1e-9) kept the pair in
 * a cycle of steps of 3e-12 to 6e-12 s, its estimate between 1.1 and 3.0, for 500000 steps.
 * The catalogue's longest segment for the pair that ended well took 745 steps at rtol 1e-12
 * (139 at 1e-8). */
#define PAIR_STEPS 2000

typedef struct {
    ig_stepper base;
    ig_stepper *first, *second;
    int on_second;   /* the second integrates the segment under way */
    int to_second;   /* the second takes the segment over at the next step, once the caller
                      * has read this step's polynomial (the first's) for dense output */
    double t_hand;   /* ... from this point: the end of the first's last step */
    double *y_hand;
    long budget;     /* the first's steps in a segment before the second takes over */
    double t_stop;   /* the segment's, for a handover */
    int nevents;
    int *dirs;
    long nstiff;     /* segments handed over since the last restart */
} auto_stepper;

static ig_stepper *now(const auto_stepper *a)
{
    return a->on_second ? a->second : a->first;
}

static int tolerances(ig_stepper *st, double rtol, const double *atol, long max_steps)
{
    auto_stepper *a = (auto_stepper *)st;
    a->budget = max_steps / 2 < PAIR_STEPS ? max_steps / 2 : PAIR_STEPS;
    if (a->first->ops->tolerances(a->first, rtol, atol, max_steps) != 0) return -1;
    return a->second->ops->tolerances(a->second, rtol, atol, max_steps);
}

static int use_jacobian(ig_stepper *st, int analytic)
{
    auto_stepper *a = (auto_stepper *)st;
    return a->second->ops->use_jacobian(a->second, analytic);
}

static void restart(ig_stepper *st)
{
    auto_stepper *a = (auto_stepper *)st;
    a->first->ops->restart(a->first);
    a->second->ops->restart(a->second);
    a->on_second = 0;
    a->to_second = 0;
    a->nstiff = 0;
}

static int start(ig_stepper *st, double t0, const double *y0, double t_stop, const int *directions, int nevents)
{
    auto_stepper *a = (auto_stepper *)st;
    if (a->to_second) ig_pair_forget_step(a->first);  /* as if the handover had happened */
    a->on_second = 0;
    a->to_second = 0;
    a->t_stop = t_stop;
    a->nevents = nevents;
    for (int k = 0; k < nevents; ++k) a->dirs[k] = directions[k];
    return a->first->ops->start(a->first, t0, y0, t_stop, directions, nevents);
}

static int step(ig_stepper *st, double *t, double *y, int *roots_found)
{
    auto_stepper *a = (auto_stepper *)st;
    if (a->to_second) {
        /* The second finishes the segment from here; the next segment takes no step from the
         * first's. Not at the end of the first's last step: the caller then reads that step's
         * polynomial, which a freshly started second does not have (CVODE's gave NaN: dense
         * output and t_eval were NaN over that step). */
        a->to_second = 0;
        if (a->second->ops->start(a->second, a->t_hand, a->y_hand, a->t_stop, a->dirs, a->nevents) != 0) {
            return IG_STEP_FAILED;
        }
        ig_pair_forget_step(a->first);
        a->on_second = 1;
        a->nstiff++;
    }
    if (a->on_second) return a->second->ops->step(a->second, t, y, roots_found);
    const int flag = a->first->ops->step(a->first, t, y, roots_found);
    a->to_second = flag == IG_STEP_ON && (ig_pair_stiff(a->first) || ig_pair_steps(a->first) >= a->budget);
    if (a->to_second) {
        a->t_hand = *t;
        memcpy(a->y_hand, y, sizeof(double) * (size_t)st->problem->n);
    }
    return flag;
}

static int interpolate(ig_stepper *st, double t, double *y)
{
    ig_stepper *s = now((auto_stepper *)st);
    return s->ops->interpolate(s, t, y);
}

static int dense(ig_stepper *st, double t, double *rows, int terms)
{
    ig_stepper *s = now((auto_stepper *)st);
    return s->ops->dense(s, t, rows, terms);
}

/* Auto's own done stays empty: its counters are the two steppers' whole, and its handovers. */
static void live(const ig_stepper *st, ig_stats *stats)
{
    const auto_stepper *a = (const auto_stepper *)st;
    ig_stepper_counters(a->first, stats);
    ig_stepper_counters(a->second, stats);
    stats->nstiff += a->nstiff;
}

static void free_auto(ig_stepper *st)
{
    auto_stepper *a = (auto_stepper *)st;
    if (a->first) a->first->ops->free(a->first);
    if (a->second) a->second->ops->free(a->second);
    free(a->dirs);
    free(a->y_hand);
    free(a);
}

static const ig_stepper_ops auto_ops = {tolerances, use_jacobian, restart, start, step, interpolate, dense,
                                        live, free_auto};

ig_stepper *ig_auto_new(ig_stepper *first, ig_stepper *second, char *err, int errlen)
{
    auto_stepper *a = NULL;
    if (first && second) {  /* (a failed constructor wrote its message into err) */
        a = (auto_stepper *)calloc(1, sizeof *a);
        if (a) a->dirs = (int *)calloc((size_t)first->problem->max_events + 1, sizeof(int));
        if (a) a->y_hand = (double *)calloc((size_t)first->problem->n, sizeof(double));
        if (!a || !a->dirs || !a->y_hand) snprintf(err, (size_t)errlen, "out of memory");
    }
    if (!a || !a->dirs || !a->y_hand) {
        if (first) first->ops->free(first);
        if (second) second->ops->free(second);
        if (a) free(a->dirs);
        if (a) free(a->y_hand);
        free(a);
        return NULL;
    }
    a->base.ops = &auto_ops;
    a->base.problem = first->problem;
    a->base.dense_terms = first->dense_terms > second->dense_terms ? first->dense_terms : second->dense_terms;
    a->first = first;
    a->second = second;
    a->budget = PAIR_STEPS;
    return &a->base;
}
