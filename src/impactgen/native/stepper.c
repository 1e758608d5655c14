/*
 * stepper.c: what every stepper (stepper.h) shares.
 */
#include <stdarg.h>
#include <stdio.h>

#include "stepper.h"

void ig_stepper_say(const ig_problem *problem, const char *fmt, ...)
{
    va_list args;
    va_start(args, fmt);
    vsnprintf(problem->message, (size_t)problem->message_size, fmt, args);
    va_end(args);
}

static void add(ig_stats *to, const ig_stats *from)
{
    to->nsteps += from->nsteps;
    to->nfev += from->nfev;
    to->njev += from->njev;
    to->nlinsetups += from->nlinsetups;
    to->netfails += from->netfails;
    to->nnlsfails += from->nnlsfails;
    to->ngev += from->ngev;
    to->nstiff += from->nstiff;
}

void ig_stepper_counters(const ig_stepper *st, ig_stats *stats)
{
    add(stats, &st->done);
    st->ops->live(st, stats);
}

void ig_stepper_bank(ig_stepper *st)
{
    st->ops->live(st, &st->done);
}

int ig_stepper_no_jacobian(ig_stepper *st, int analytic)
{
    (void)st;
    return analytic ? -1 : 0;
}
