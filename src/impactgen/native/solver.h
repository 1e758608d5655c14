/*
 * solver.h: the runtime of a generated model, written once for every model: it includes the
 * generated "model.h" and "model_machine.h".
 *
 * ig_solver integrates one phase segment at a time with one of the steppers of stepper.h
 * (solver.c): ig_segment_start sets up a segment (its force law via params->phase, its
 * active events and their directions), and ig_segment_advance steps until a root, the stop
 * time or a full sample buffer: the loop an embedder with its own phase logic writes.
 * ig_run (run.c) is the whole loop of the generated phase machine, from segment to segment,
 * resumable: what impactgen's Python engine, the C driver and the FMU's Co-Simulation call.
 * The tallies of a run's summaries are in tally.h.
 */
#ifndef IMPACTGEN_SOLVER_H
#define IMPACTGEN_SOLVER_H

#include "model.h"
#include "model_machine.h"
#include "stepper.h"
#include "tally.h"

/* cdef-begin: the declarations below are read by cffi as they stand. */
/* Return codes of ig_segment_advance (>= 0: the segment may continue or is done). */
#define IG_REACHED_END 0     /* t_stop reached */
#define IG_ROOT 1            /* an active event fired: see roots_found */
#define IG_BUFFER_FULL 2     /* the sample buffers are full: call again to continue */
#define IG_ERR_SOLVER -1     /* the integrator failed: ig_solver_message says why */
#define IG_ERR_TOO_MUCH_WORK -2  /* more than max_steps steps in this segment */
#define IG_ERR_USAGE -3      /* bad arguments (a bug in the caller) */
#define IG_RUN_DONE 3        /* ig_run: the phase machine ended the run (separation) */
#define IG_SEGMENTS_FULL 4   /* ig_run: the segment records are full: call again to continue */
#define IG_ERR_STICK -4      /* ig_run: a stuck tip needed more than mu F: a slip event was missed */
#define IG_ERR_SEGMENTS -5   /* ig_run: more segments than allowed (chattering impacts?) */
#define IG_ERR_UNDER_FLOOR -6  /* ig_run: a joint or the tip went below the surface (the floor net) */
#define IG_TARGET 5          /* ig_run: the step that reached t_target is taken (ig_interpolate there) */
/* Methods of ig_solver_new (callers name them: Python reads IG_METHOD_<NAME> from the
 * library): CVODE's BDF and Adams, ARKODE's explicit Runge-Kutta pair, or the same pair
 * written out in plain C (dopri5.c). */
#define IG_METHOD_BDF 0
#define IG_METHOD_ADAMS 1
#define IG_METHOD_ERK 2
#define IG_METHOD_DOPRI5 3  /* Dormand and Prince's 5(4) pair in plain C (dopri5.c), without SUNDIALS */
#define IG_METHOD_AUTO 4    /* each segment begins with the plain-C pair, and goes on with CVODE's BDF
                               from where the pair finds it stiff */
typedef struct ig_solver ig_solver;

/* method: IG_METHOD_BDF, IG_METHOD_ADAMS (CVODE), IG_METHOD_ERK (ARKODE ERKStep, Dormand and
 * Prince's 5(4) pair, for non-stiff problems), IG_METHOD_DOPRI5 (the same pair in plain C) or
 * IG_METHOD_AUTO (the plain-C pair, switching to BDF within a segment that turns stiff);
 * analytic_jacobian: 1 to give CVODE model_jacobian (the model must have one; not with the
 * explicit methods), 0 for CVODE's difference quotients. atol has MODEL_NSTATE entries.
 * Returns NULL on failure with a message in err (errlen bytes). */
ig_solver *ig_solver_new(int method, int analytic_jacobian, double rtol, const double *atol,
                         long max_steps, char *err, int errlen);
void ig_solver_free(ig_solver *s);

/* Make a used solver ready for a new simulation with the same method: new tolerances and
 * step limit, the counters cleared, the analytic Jacobian (if it was created with one) back
 * in use. Saves creating and freeing the integrator's memory for every run of a warm process.
 * Returns 0, or IG_ERR_USAGE for a bad argument (the solver is then unchanged). */
int ig_solver_reset(ig_solver *s, double rtol, const double *atol, long max_steps);

/* Replace the absolute tolerances (MODEL_NSTATE entries) from the next segment on: the phase
 * machine tightens them inside a contact, where the penetration is a small difference of
 * tip heights. Returns 0, or IG_ERR_USAGE for a non-positive entry. */
int ig_solver_set_atol(ig_solver *s, const double *atol);

/* Use the analytic Jacobian (1) or CVODE's difference quotients (0) from now on: the phase
 * machine switches to difference quotients where a constraint force (stick, sustained
 * contact) changes the equations that the analytic Jacobian was derived from. */
int ig_solver_use_jacobian(ig_solver *s, int analytic);

/* Begin a segment at (t0, y0) under params; the solver keeps a pointer to params, which
 * must stay alive and unchanged until the segment ends. events/directions: nevents indices
 * into the model's event functions and their crossing directions (+1 rising, -1 falling,
 * 0 both). */
int ig_segment_start(ig_solver *s, const model_params *params, double t0, const double *y0,
                     double t_stop, const int *events, const int *directions, int nevents);

/* Step until a root, t_stop or capacity samples. Each internal step (and the root or stop
 * point) is written as t_buf[k], y_buf[k * MODEL_NSTATE ...]. roots_found (nevents ints)
 * flags the events that fired on IG_ROOT. dense_buf, if not NULL, receives per sample
 * ig_dense_terms(s) rows of MODEL_NSTATE Taylor coefficients c_j = y^(j)(t_k) / j! of
 * the method's interpolating polynomial of that step: y(t) = sum_j c_j (t - t_k)^j holds for
 * t_(k-1) <= t <= t_k (dense output, as solve_ivp's dense_output). */
int ig_segment_advance(ig_solver *s, double *t_buf, double *y_buf, double *dense_buf,
                       int capacity, int *n_written, int *roots_found);

/* The state at time t within the last step taken (the method's interpolating polynomial): for a
 * caller that must report the state at times the integrator stepped over (co-simulation
 * communication points). Returns 0, or IG_ERR_USAGE when t lies outside the last step. */
int ig_interpolate(ig_solver *s, double t, double *y);

/* Rows of Taylor coefficients per sample of dense output (the method's max order + 1). */
int ig_dense_terms(const ig_solver *s);

/* Counters accumulated over all segments of this solver. */
void ig_solver_stats(const ig_solver *s, ig_stats *stats);
const char *ig_solver_message(const ig_solver *s);

/* Evaluate model_outputs for n samples (one Python crossing for a whole segment). */
void ig_outputs(const model_params *params, int n, const double *t, const double *y,
                double *out);

/* Begin a run of the phase machine m under p at (t0, y0), as every caller of ig_run does:
 * start the machine (model_machine_start, run_to_time as there), write sample 0 (t_buf[0],
 * the rows y_buf and out_buf: the state and its outputs) and begin the tally there, and,
 * when an impact can follow, make the solver ready for the run (ig_solver_reset) with rtol,
 * max_steps and the absolute tolerances the machine asks for from the scene's atol (written
 * to atol_now). One call where a caller from Python would cross into C five times. Returns
 * model_machine_start's MODEL_START_* (with MODEL_START_ALONG or MODEL_START_AWAY the solver
 * is left as it was: there is no run), or IG_ERR_USAGE for tolerances the solver refuses. */
int ig_run_begin(ig_solver *s, model_machine *m, model_params *p, double t0, const double *y0, int run_to_time,
                 double rtol, double atol, long max_steps, double *atol_now,
                 double *t_buf, double *y_buf, double *out_buf, ig_tally *tally);

/* Advance the phase machine m (begun with ig_run_begin) under p from (*t, y) until
 * t_target, a buffer fills, or the run ends (at t_stop, or where the machine ends it): each
 * segment integrated until one of the events the machine watches, the switch there, the next
 * segment, with the tolerances the machine asks for (atol: the scene's absolute tolerance;
 * the relative one is the solver's) and the analytic Jacobian only where no constraint force
 * acts. The integrator's stop time is t_stop; t_target only ends the call: the step that
 * reaches it is taken whole (the integrator is not stopped there, so where a caller asks to
 * be woken does not change the steps), and ig_interpolate gives the state at t_target within
 * it. *t and y follow the run (the integrator's time and state, *t >= t_target on
 * IG_TARGET). A root beyond t_target in that step is left pending: the machine switches
 * there at the next call, so its state and p are those of t_target on return.
 * Samples, with their outputs under the segment's parameters: every step when every_step is
 * 1 (dense_buf, if not NULL, as ig_segment_advance), else only each segment's end (no dense
 * output). Returns IG_RUN_DONE when the machine ends the run, IG_REACHED_END at t_stop,
 * IG_TARGET past t_target, IG_BUFFER_FULL or IG_SEGMENTS_FULL when the buffers hold capacity
 * samples or segment_capacity switch records could not hold another switch's (call again with
 * emptied buffers to continue), or < 0 on a failure (ig_solver_message says why; the samples up to it are
 * written): IG_ERR_STICK when a stuck tip needed more than mu F (a slip event was missed),
 * IG_ERR_UNDER_FLOOR when a joint or the tip is found below the surface by more than
 * MODEL_FLOOR_DEPTH of the shortest link at the start of the call or after a step (the floor
 * net, model_machine_below: the message names the point, its depth and the time; the sample
 * there is written).
 * *n_written: the samples already in the buffers on entry (1 after ig_run_begin wrote the
 * start; 0 in emptied buffers), written after, and less than capacity (IG_ERR_USAGE
 * otherwise); on return, the samples in them (segments[k].sample indexes them).
 * segments: the switch records (tally.h's ig_segment: one per point whose switch acted, in
 * point order; none at t_stop), *n_segments of them on return; segment_capacity at least
 * MODEL_NCONTACT. At most max_segments segments begin in one call.
 * tally, if not NULL (begun with ig_tally_begin), follows the run for ig_summarize. */
int ig_run(ig_solver *s, model_machine *m, model_params *p, double *t, double *y, double t_stop, double t_target,
           double atol, long max_segments, int every_step,
           double *t_buf, double *y_buf, double *out_buf, double *dense_buf, int capacity, int *n_written,
           ig_segment *segments, int segment_capacity, int *n_segments, ig_tally *tally);

/* Read the SUNDIALS version the glue was compiled against. */
int ig_sundials_version_major(void);
/* cdef-end */

/* Whether a method uses a Jacobian (the explicit pairs do not; Python: scene.EXPLICIT_METHODS). */
#define IG_METHOD_USES_JACOBIAN(method) ((method) != IG_METHOD_ERK && (method) != IG_METHOD_DOPRI5)

#endif /* IMPACTGEN_SOLVER_H */
