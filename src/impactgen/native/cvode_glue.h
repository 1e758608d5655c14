/*
 * cvode_glue.h: integrate one phase segment of a generated model with SUNDIALS CVODE.
 *
 * Written once for every model: it includes the generated "model.h" and calls model_rhs
 * and model_events. ig_segment_start sets up one phase segment (its force law via
 * params->phase, its active events and their directions), and ig_segment_advance steps until
 * a root, the stop time or a full sample buffer: the loop an embedder with its own phase
 * logic writes. ig_run is the whole loop of the generated phase machine in one call, from
 * segment to segment: what impactgen's Python wrapper and the C driver call.
 */
#ifndef IMPACTGEN_CVODE_GLUE_H
#define IMPACTGEN_CVODE_GLUE_H

#include "model.h"
#include "model_machine.h"

/* cdef-begin: the declarations below are read by cffi as they stand. */
/* Return codes of ig_segment_advance (>= 0: the segment may continue or is done). */
#define IG_REACHED_END 0     /* t_stop reached */
#define IG_ROOT 1            /* an active event fired: see roots_found */
#define IG_BUFFER_FULL 2     /* the sample buffers are full: call again to continue */
#define IG_ERR_SOLVER -1     /* CVODE failed: ig_solver_message says why */
#define IG_ERR_TOO_MUCH_WORK -2  /* more than max_steps steps in this segment */
#define IG_ERR_USAGE -3      /* bad arguments (a bug in the caller) */
#define IG_RUN_DONE 3        /* ig_run: the phase machine ended the run (separation) */
#define IG_SEGMENTS_FULL 4   /* ig_run: the segment records are full: call again to continue */
#define IG_ERR_STICK -4      /* ig_run: a stuck tip needed more than mu F: a slip event was missed */
#define IG_ERR_SEGMENTS -5   /* ig_run: more segments than allowed (chattering impacts?) */
/* Methods of ig_solver_new: CVODE's BDF and Adams, ARKODE's explicit Runge-Kutta pair, or
 * the same pair written out in C for a 6- to 60-state model (dopri5.c). */
#define IG_METHOD_BDF 0
#define IG_METHOD_ADAMS 1
#define IG_METHOD_ERK 2
#define IG_METHOD_DOPRI5 3  /* Dormand and Prince's 5(4) pair in plain C (dopri5.c), without SUNDIALS */
#define IG_METHOD_AUTO 4    /* each segment begins with the plain-C pair, and goes on with CVODE's BDF
                               from where the pair finds it stiff */
/* CVODE's default maximum orders: dense output keeps max order + 1 coefficients a sample. */
#define IG_BDF_MAX_ORDER 5
#define IG_ADAMS_MAX_ORDER 12

typedef struct ig_solver ig_solver;

typedef struct {
    long nsteps;     /* internal steps */
    long nfev;       /* right-hand side calls */
    long njev;       /* Jacobian evaluations */
    long nlinsetups; /* linear solver setups */
    long netfails;   /* error test failures */
    long nnlsfails;  /* nonlinear convergence failures */
    long ngev;       /* root function calls */
    long nstiff;     /* method auto: segments the explicit pair handed to BDF (stiff, or too long) */
} ig_stats;

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
 * in use. Saves creating and freeing CVODE's memory for every run of a warm process.
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
 * CVODE's interpolating polynomial of that step: y(t) = sum_j c_j (t - t_k)^j holds for
 * t_(k-1) <= t <= t_k (dense output, as solve_ivp's dense_output). */
int ig_segment_advance(ig_solver *s, double *t_buf, double *y_buf, double *dense_buf,
                       int capacity, int *n_written, int *roots_found);

/* The state at time t within the last step taken (CVODE's interpolating polynomial): for a
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

/* One phase segment of ig_run: the machine state it ran in, how it ended, what the switch
 * at its end did, and the parameters it ran under (the machine changes some at a switch). */
typedef struct {
    double t;            /* its end, s */
    long sample;         /* index of its last sample in the buffers of the ig_run call */
    int state;           /* MODEL_MACHINE_* during the segment */
    double slip;         /* the stick-slip state during it (model_machine.slip) */
    int event;           /* the model event that ended it (the first watched one fired); -1: t_stop */
    int act;             /* MODEL_ACT_* bits of the switch at its end (0 at t_stop) */
    int next_state;      /* the machine state after the switch */
    double next_slip;
    double delta_max, P_max, delta_r, R_res;  /* the machine's impact record after the switch */
    model_params params; /* the parameters during the segment */
} ig_segment;

/* The values at one sample that a summary reads: time, kinetic and potential energy, the
 * works of the contact forces (W_friction 0 without friction) and the state. */
typedef struct {
    double t, T, V, W_normal, W_friction;
    double y[MODEL_NSTATE];
    double P_normal, P_friction;  /* the impulses of the contact forces (P_friction 0 without friction), N s */
    double v_n;                   /* the contact point's normal speed (v_By, negative approaching), m/s */
} ig_point;

/* What a run keeps for its summaries while ig_run goes from segment to segment (over all
 * its calls): begun by ig_tally_begin at the run's first sample, read by ig_summarize. */
typedef struct {
    ig_point start, last;             /* the run's first sample and its latest */
    ig_point first_begin, first_end;  /* the first impact's first and last samples */
    int impacts;                      /* impacts begun */
    int first_switches;               /* phase switches within the first impact */
    int first_stick_slip;             /* stick-slip changes within it (exact Coulomb) */
    int ended;                        /* impacts ended */
    double now_start;                 /* the latest impact's start, s */
    double now_delta_max, now_P_max, now_delta_r, now_R_res;      /* its record at maximum compression */
    double first_delta_max, first_P_max, first_delta_r, first_R_res;  /* the first impact's */
    double delta_max, P_max, deepest_delta_r, deepest_R_res;  /* over the ended impacts: the
                                                                 largest, and the deepest dent's */
    double t_contact;                 /* contact time of the ended impacts, s */
    double segment_start;             /* when the current segment began, s */
    double t_sustained;               /* when sustained contact first began, s; NAN if never */
    ig_point first_max;               /* the first impact's (latest) maximum compression */
    int first_compressed;             /* whether the first impact reached maximum compression */
} ig_tally;

/* A run's summary (MODEL section 6), over the whole run or over its first impact: energies
 * at its two ends and the works between them, the impact record (the largest values, and the
 * deepest dent's delta_r and R_res), the contact time, the state at its end. NAN where there
 * is nothing to report: t_impact without an impact, t_sustained without sustained contact. */
typedef struct {
    double T0, Tf, delta_T, delta_max, delta_r, P_max, R_res, t_contact, t_impact, t_sustained, t_final;
    double W_normal, W_friction, W_gravity, residual;
    int n_switches, n_stick_slip;     /* the first impact's phase switches and stick-slip changes */
    int impacts;                      /* in the whole run */
    /* The first impact's impulses and coefficients of restitution (MODEL section 9), NAN while
     * it has not ended: the normal speed at its start v_n0 (m/s), the normal impulse of
     * compression P_c and of restitution P_r (split at maximum compression), the tangential
     * impulse P_t (N s); e_N = -v_n(end) / v_n0, e_P = P_r / P_c, e_E = sqrt(W_r / -W_c) of the
     * normal force's work in restitution and compression; friction's share of the work the
     * contact forces took, W_friction / (W_normal + W_friction). */
    double v_n0, P_c, P_r, P_t, e_N, e_P, e_E, friction_share;
    double y_final[MODEL_NSTATE];     /* the state at its end */
} ig_summary;

/* Begin the tally of a run at its first sample (t0, y0, with its outputs out0); in_contact:
 * the run starts with an impact (model_machine_start returned MODEL_START_CONTACT). */
void ig_tally_begin(ig_tally *tally, double t0, const double *y0, const double *out0, int in_contact);

/* The two summaries of a tallied run: over the whole run (an impact still in contact counted
 * to the run's last sample), and over its first impact (the whole run if it had none; an
 * impact still in contact has no contact time). A run to separation reports the second. */
void ig_summarize(const ig_tally *tally, ig_summary *run, ig_summary *first_impact);

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

/* Run the phase machine m (begun with ig_run_begin) under p from (*t, y) to
 * t_stop: each segment integrated until one of the events the machine watches, the switch
 * there, the next segment, with the tolerances the machine asks for (atol: the scene's
 * absolute tolerance; the relative one is the solver's) and the analytic Jacobian only
 * where no constraint force acts. *t and y follow the run. Samples, with their outputs
 * under the segment's parameters: every step when every_step is 1 (dense_buf, if not NULL,
 * as ig_segment_advance), else only each segment's end (no dense output). Returns
 * IG_RUN_DONE when the machine ends the run, IG_REACHED_END at t_stop, IG_BUFFER_FULL or
 * IG_SEGMENTS_FULL when the buffers hold capacity samples or segment_capacity segments are
 * written (call again with emptied buffers to continue), or < 0 on a failure
 * (ig_solver_message says why; the samples up to it are written). *n_written: the samples
 * already in the buffers on entry (1 after ig_run_begin wrote the start; 0 in emptied
 * buffers), written after, and less than capacity (IG_ERR_USAGE otherwise); on return,
 * the samples in them (segments[k].sample indexes them). At most max_segments segments
 * begin in one call.
 * tally, if not NULL (begun with ig_tally_begin), follows the run for ig_summarize. */
int ig_run(ig_solver *s, model_machine *m, model_params *p, double *t, double *y, double t_stop,
           double atol, long max_segments, int every_step,
           double *t_buf, double *y_buf, double *out_buf, double *dense_buf, int capacity, int *n_written,
           ig_segment *segments, int segment_capacity, int *n_segments, ig_tally *tally);

/* Read the SUNDIALS version the glue was compiled against. */
int ig_sundials_version_major(void);
/* cdef-end */

/* Whether a method uses a Jacobian (the explicit pairs do not; Python: scene.EXPLICIT_METHODS). */
#define IG_METHOD_USES_JACOBIAN(method) ((method) != IG_METHOD_ERK && (method) != IG_METHOD_DOPRI5)

#endif /* IMPACTGEN_CVODE_GLUE_H */
