/*
 * batch.h: many runs of one compiled model, case after case in C (batch.c): an ensemble or a
 * sweep without a return to the caller between its cases. Each case is the base parameters
 * with a few inputs changed and its own initial state, run to its end through the one driver
 * (ig_run_begin, ig_run in run.c) on one solver, one machine and one tally, reused.
 */
#ifndef IMPACTGEN_BATCH_H
#define IMPACTGEN_BATCH_H

#include "solver.h"

/* cdef-begin: the declarations below are read by cffi as they stand. */
/* What became of a case of ig_batch_run (code[i]), with flag[i] saying more. */
#define IG_CASE_RAN 0          /* ran to its end: flag is ig_run's last return (< 0: it failed) */
#define IG_CASE_NO_RUN 1       /* the machine started without an impact: flag is MODEL_START_ALONG or _AWAY */
#define IG_CASE_BAD_PARAMS 2   /* model_derive refused the values: flag is the parameter's index */
#define IG_CASE_OTHER_MODEL 3  /* the values need another model's contact points: flag is the joint */
#define IG_CASE_NOT_BEGUN 4    /* ig_run_begin refused the tolerances: flag is its return */
#define IG_BATCH_CONTACT 3     /* values per case in contact[]: R and delta_c of the first impact's point
                                  (the tip's without one), and the Jackson-Green exponent B (NAN: none) */
#define IG_BATCH_IMPACTS 16    /* impacts per case in impacts[], the first ones (a case with more runs per case) */
#define IG_BATCH_IMPACT_FIELDS 6  /* values per impact in impacts[]: its point's number (ig_segment.point),
                                     its start and end (NAN: still in contact), s, its delta_max at its latest
                                     maximum compression (0: none), m, and its point's R and delta_c (NAN but
                                     for the three-phase law): what the validity warnings read of an impact */

/* How every case of a batch runs: as the scene's solver says, and as phases.run passes it to
 * ig_run_begin and ig_run (summary only: samples at the switches). */
typedef struct {
    int run_to_time;      /* 1: to t_stop (solver.t_end), 0: to the first separation */
    double rtol, atol;
    long max_steps;       /* steps per segment */
    double t_stop;        /* solver.t_end, or solver.t_max */
    long max_records;     /* switch records in one run, at most (phases.MAX_SEGMENTS) */
} ig_batch_settings;

/* Run n cases of the model on solver s with machine m, and write one row per case:
 * case i runs under *base with the n_vary inputs vary_index[j] (model_param_slot's indices)
 * set to values[i * n_vary + j], then checked and derived (model_derive), from the initial
 * state y0[i * MODEL_NSTATE ...] at t = 0. summaries[i] is the case's ig_summary: the first
 * impact's of a run to separation that did not fail, else the whole run's (ig_summarize);
 * code[i] and flag[i] say what became of it (IG_CASE_*); contact[i * IG_BATCH_CONTACT ...]
 * (see IG_BATCH_CONTACT) and wall_s[i], the case's own time in s; n_impacts[i], the impacts of its
 * run (those in contact from its start first, at t = 0), the first IG_BATCH_IMPACTS of them in
 * impacts[(i * IG_BATCH_IMPACTS + j) * IG_BATCH_IMPACT_FIELDS ...] (see IG_BATCH_IMPACT_FIELDS),
 * as phases._impacts reads them from the switch records. A case that fails is
 * recorded so and the next one runs. Returns 0, or IG_ERR_USAGE for bad arguments (an index
 * that is not an input), with nothing run. */
int ig_batch_run(ig_solver *s, model_machine *m, const model_params *base, const ig_batch_settings *settings,
                 int n, int n_vary, const int *vary_index, const double *values, const double *y0,
                 ig_summary *summaries, int *code, int *flag, double *contact, double *wall_s, int *n_impacts,
                 double *impacts);
/* cdef-end */

#endif /* IMPACTGEN_BATCH_H */
