/*
 * stepper.h: what the run loop asks of an integrator, as one small table of functions, with
 * one implementation per file: CVODE's BDF and Adams (step_cvode.c), ARKODE's explicit
 * Runge-Kutta pair (step_erk.c), the plain-C Dormand-Prince pair (step_pair.c over
 * dopri5.c), and "auto", a stepper made of two others (step_auto.c); what they share is in
 * stepper.c.
 *
 * A stepper knows no model: it integrates y' = f(t, y) of n equations and watches the event
 * functions it is given (ig_problem), from a start to a stop time or the first root. The
 * glue (solver.c) gives it the generated model's functions.
 */
#ifndef IMPACTGEN_STEPPER_H
#define IMPACTGEN_STEPPER_H

/* cdef-begin: the declarations below are read by cffi as they stand. */
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
/* cdef-end */

/* What a step did (ig_stepper_ops.step). */
enum {
    IG_STEP_ON = 0,     /* an accepted step; the segment goes on */
    IG_STEP_ROOT = 1,   /* a watched event fired: the step ends at the root (roots_found) */
    IG_STEP_END = 2,    /* the stop time is reached */
    IG_STEP_FAILED = -1 /* the message says why; the segment is over */
};

/* y' = f(t, y): returns 0, or nonzero where f cannot be evaluated. */
typedef int (*ig_rhs_fn)(double t, const double *y, double *ydot, void *user);
/* The watched event functions at (t, y), in the order of the start's directions. */
typedef void (*ig_events_fn)(double t, const double *y, double *g, void *user);
/* J[i * m + j] = d f_i / d y_j over the first m = n - nquad states (row-major); returns as
 * ig_rhs_fn does. */
typedef int (*ig_jacobian_fn)(double t, const double *y, double *J, void *user);

/* The system a stepper integrates; it keeps a pointer to it, which must outlive it. Its last
 * nquad states are quadratures: their derivatives read the other states only, and nothing
 * reads them, so an implicit method can leave them out of its Newton iteration. */
typedef struct {
    int n;                   /* equations */
    int max_events;          /* the most event functions watched at once (they read no quadrature) */
    ig_rhs_fn rhs;           /* all n derivatives */
    ig_events_fn events;
    ig_jacobian_fn jacobian; /* NULL: none (difference quotients where a method needs one) */
    int nquad;               /* the quadratures, y[n - nquad ..) */
    ig_rhs_fn motion;        /* the derivatives of the first n - nquad states */
    ig_rhs_fn quadratures;   /* the quadratures' nquad derivatives (from the first n - nquad states) */
    void *user;              /* passed to the functions */
    char *message;           /* where a stepper writes why it failed */
    int message_size;
} ig_problem;

typedef struct ig_stepper ig_stepper;

typedef struct {
    /* Tolerances (atol: n entries, copied) and the step limit of a segment, from the next
     * start on. Returns 0, or -1 (message set). */
    int (*tolerances)(ig_stepper *st, double rtol, const double *atol, long max_steps);
    /* The analytic Jacobian (1) or difference quotients (0) from now on; an explicit method
     * accepts 0 only. Returns 0 or -1. */
    int (*use_jacobian)(ig_stepper *st, int analytic);
    /* A new run: counters cleared, nothing carried over from the last step taken. */
    void (*restart)(ig_stepper *st);
    /* Begin a segment at (t0, y0) to t_stop, watching nevents event functions in their
     * directions (+1 rising, -1 falling, 0 both). Returns 0 or -1. */
    int (*start)(ig_stepper *st, double t0, const double *y0, double t_stop, const int *directions, int nevents);
    /* One step: IG_STEP_* with the time and state reached in *t and y (n entries); on
     * IG_STEP_ROOT, roots_found flags the events that fired. After IG_STEP_ROOT or
     * IG_STEP_END the segment is over: the next step needs a start. */
    int (*step)(ig_stepper *st, double *t, double *y, int *roots_found);
    /* y at t within the last step taken. Returns 0, or -1 when t lies outside it. */
    int (*interpolate)(ig_stepper *st, double t, double *y);
    /* The last step's polynomial as Taylor coefficients at t, its end: rows[j * n + i] =
     * y_i^(j)(t) / j!, terms rows (those past the method's order are 0). Returns 0 or -1. */
    int (*dense)(ig_stepper *st, double t, double *rows, int terms);
    /* Add the counters of the segment under way (not yet in done) to *stats. */
    void (*live)(const ig_stepper *st, ig_stats *stats);
    void (*free)(ig_stepper *st);
} ig_stepper_ops;

/* Every stepper begins with this. */
struct ig_stepper {
    const ig_stepper_ops *ops;
    const ig_problem *problem;
    int dense_terms; /* Taylor coefficients per step of dense output: the method's max order + 1 */
    ig_stats done;   /* counters of the segments finished since the last restart */
};

/* The steppers; NULL on failure with a message in err (errlen bytes). */
ig_stepper *ig_cvode_new(const ig_problem *problem, int adams, char *err, int errlen);
ig_stepper *ig_erk_new(const ig_problem *problem, char *err, int errlen);
ig_stepper *ig_pair_new(const ig_problem *problem, char *err, int errlen);
/* Each segment begins with first (an explicit pair) and goes on with second (an implicit
 * method) from where first finds it stiff, or has taken too many steps. Owns both (freed
 * with it, and on failure). */
ig_stepper *ig_auto_new(ig_stepper *first, ig_stepper *second, char *err, int errlen);

/* The pair's view for "auto": whether its segment turned stiff, its accepted steps in it,
 * and to forget its last step (the next start takes no hint from it). */
int ig_pair_stiff(const ig_stepper *st);
long ig_pair_steps(const ig_stepper *st);
void ig_pair_forget_step(ig_stepper *st);

/* The counters since the last restart, added to *stats (done and the live segment's). */
void ig_stepper_counters(const ig_stepper *st, ig_stats *stats);

/* Shared by the steppers (stepper.c): write a message into problem->message (printf-like);
 * move the live segment's counters into done (before a start re-initialises them); the
 * use_jacobian of an explicit method (difference quotients only: 0). */
void ig_stepper_say(const ig_problem *problem, const char *fmt, ...);
void ig_stepper_bank(ig_stepper *st);
int ig_stepper_no_jacobian(ig_stepper *st, int analytic);

#endif /* IMPACTGEN_STEPPER_H */
