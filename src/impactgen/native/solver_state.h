/*
 * solver_state.h: the ig_solver behind solver.h, shared by solver.c (one segment at a time
 * over a stepper) and run.c (the phase machine's loop over the segments). Not for callers.
 */
#ifndef IMPACTGEN_SOLVER_STATE_H
#define IMPACTGEN_SOLVER_STATE_H

#include "solver.h"

#define IG_MESSAGE_SIZE 512
#define IG_STEPPED 100  /* ig_solver_step: an ordinary step, the segment goes on */

struct ig_solver {
    ig_problem problem;        /* the model as the stepper sees it (user: this solver) */
    ig_stepper *st;
    const model_params *params;
    int events[MODEL_NEVENT];  /* the model events watched in the segment under way */
    int dirs[MODEL_NEVENT];
    int nevents;
    double t_stop;
    long max_steps;
    long segment_steps;
    double rtol;
    double atol[MODEL_NSTATE];
    int analytic;              /* created with the analytic Jacobian */
    int active;                /* a segment is under way */
    int root_pending;          /* ig_run: the last step ended at a root beyond t_target, not yet switched */
    int pending_roots[MODEL_NEVENT];
    /* ig_run's floor net (run.c): the heights are computed again only once the points may
     * have moved as far as the margin the last computation left (0: compute at the next step) */
    double net_margin, net_travel, net_t, net_speed;
    char message[IG_MESSAGE_SIZE];
};

/* One step of the segment under way: IG_STEPPED, IG_ROOT (roots_found filled),
 * IG_REACHED_END, or < 0 with the message set; its time and state in *t and y. */
int ig_solver_step(ig_solver *s, double *t, double *y, int *roots_found);
/* The step just taken, ending at (t, y), as sample k of the buffers (and its polynomial,
 * if dense_buf). Returns 0 or IG_ERR_SOLVER. */
int ig_solver_write_sample(ig_solver *s, double t, const double *y, int k, double *t_buf, double *y_buf,
                           double *dense_buf);
void ig_solver_say(ig_solver *s, const char *text);

#endif /* IMPACTGEN_SOLVER_STATE_H */
