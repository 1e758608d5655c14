/*
 * dopri5.h: Dormand and Prince's explicit Runge-Kutta 5(4) pair with its dense output and
 * directional root finding, for any system y' = f(t, y) of n equations given as callbacks, in
 * plain C99 (no SUNDIALS; one allocation, in ig_dopri5_init).
 *
 * Written after Hairer, Norsett and Wanner's DOPRI5 (Solving Ordinary Differential Equations
 * I, 2nd ed., sections II.5 and II.6): the same tableau, error estimate and norm, PI step-size
 * controller and fourth-order continuous extension. The event functions are watched after
 * every step and their first crossing in the watched direction is located on the continuous
 * extension (Illinois), the step ending just past it, as CVODE's root finder does.
 *
 * The state after a root (IG_DOPRI5_ROOT): r->t and r->y are the point just past the root
 * (r->y from the continuous extension); the continuous extension still describes the whole
 * accepted step, so ig_dopri5_interpolate and ig_dopri5_taylor hold on [r->t_old, r->t]; r->h
 * is the step the controller proposed next. Nothing else is brought to the root (the stored
 * right-hand side, the events' sides): the segment is over, and ig_dopri5_step refuses to go
 * on (IG_DOPRI5_NOT_STARTED) until ig_dopri5_start begins the next one, at the root or
 * anywhere else, with r->h as its h_hint if the same time scale carries over.
 */
#ifndef IMPACTGEN_DOPRI5_H
#define IMPACTGEN_DOPRI5_H

#define IG_DOPRI5_STAGES 7
#define IG_DOPRI5_DENSE_TERMS 5  /* Taylor coefficients of the continuous extension (degree 4) */
#define IG_DOPRI5_STABILITY 3.25 /* h |lambda| beyond this: the step is limited by stability */
#define IG_DOPRI5_STIFF_STEPS 15 /* ... (or after a rejection) for this many steps: stiff (Hairer) */
#define IG_DOPRI5_SMOOTH_STEPS 6 /* ... within it this many in a row: the count starts again */
/* A state whose atol is at least this is a quadrature out of the error test (as CVODES leaves
 * quadratures out by default). Its term in the error norm, (e / (atol + ...))^2, is 0 in double
 * for any error under 1e38, so it is left out of the sum (n still divides it) and only its
 * error's finiteness is checked: summing it went through subnormal numbers, about 70 ns each on
 * this CPU (4 us of the 63 us of the paper's impact at rtol 1e-8, whose two impulses are such
 * states). */
#define IG_DOPRI5_QUADRATURE_ATOL 1e200

enum {
    IG_DOPRI5_STEPPED = 0,      /* an accepted step; the segment goes on */
    IG_DOPRI5_ROOT = 1,         /* a watched event crossed: the step ends just past it */
    IG_DOPRI5_STOP = 2,         /* t_stop reached */
    IG_DOPRI5_TOO_SMALL = -1,   /* the step size fell below what double precision resolves */
    IG_DOPRI5_RHS_FAILED = -2,  /* the right-hand side failed on every smaller step tried */
    IG_DOPRI5_NOT_STARTED = -3  /* no segment under way (none begun, or it ended at a root or t_stop) */
};

/* f = y'(t): returns 0, or nonzero where it cannot be evaluated (the step is then retried
 * smaller). user is ig_dopri5_init's. */
typedef int (*ig_dopri5_rhs_fn)(double t, const double *y, double *f, void *user);
/* g[k], k < nevents: the watched event functions at (t, y), in the order of ig_dopri5_start's
 * directions. */
typedef void (*ig_dopri5_events_fn)(double t, const double *y, double *g, void *user);

typedef struct {
    int n, max_events;
    ig_dopri5_rhs_fn rhs;
    ig_dopri5_events_fn events;
    void *user;
    double rtol;
    double *atol;                 /* n entries */
    int *tested;                  /* n entries: the ntested states in the error test (atol below
                                   * IG_DOPRI5_QUADRATURE_ATOL), then the quadratures */
    int ntested;
    double t, h, t_stop;          /* time reached, next step size, the end of the segment */
    double t_old, h_old;          /* the last step: [t_old, t_old + h_old] */
    double *y;                    /* n entries */
    double *k[IG_DOPRI5_STAGES];  /* stages; k[0] is f(t, y) (first same as last) */
    double *cont[5];              /* continuous extension of the last step, made when first asked for */
    int extension_made;           /* cont holds the last step's extension (else made from the inputs below) */
    double *y_old, *f_old;        /* the last step's start and f there ... */
    double *kept[IG_DOPRI5_STAGES]; /* ... and its stages 2 to 6 (kept[2..6]; the next attempts write k[2..6]) */
    double *y1, *y6, *tmp, *ymid; /* work vectors of a step and of root finding */
    double log_fac_old;           /* the PI controller's memory: the log of the last accepted error */
    int rejected;                 /* the step before was rejected */
    int started;                  /* a segment is under way (ig_dopri5_step may go on) */
    int nevents;
    int *directions;              /* max_events entries: +1 rising, -1 falling, 0 both */
    double *g;                    /* watched event functions at t */
    double *side;                 /* their last nonzero sign (0: none yet) */
    double *g_end, *g_lo, *g_hi, *g_now, *t_root;  /* work arrays of root finding */
    double h_lambda;              /* h times the stiffness estimate of the last accepted step (Hairer) */
    int stiff_count, smooth_count;/* consecutive steps beyond and within the stability boundary */
    int stiff;                    /* 1 once the steps are limited by stability, not accuracy */
    long nsteps, nfev, netfails, ngev;
    void *memory;                 /* the one allocation behind the arrays */
} ig_dopri5;

/* Make r ready for systems of n equations with at most max_events watched event functions
 * (events may be NULL when max_events is 0). Returns 0, or -1 when out of memory or for bad
 * sizes (r is then empty: ig_dopri5_free is still safe). */
int ig_dopri5_init(ig_dopri5 *r, int n, int max_events, ig_dopri5_rhs_fn rhs, ig_dopri5_events_fn events,
                   void *user);
void ig_dopri5_free(ig_dopri5 *r);

/* Begin a segment at (t0, y0) to t_stop, watching nevents event functions in their
 * directions (+1 rising, -1 falling, 0 both). rtol and atol (n entries, copied) are the
 * tolerances. The first step is Hairer's estimate, at most h_hint when h_hint > 0 (the step
 * the segment before proposed next, r->h: a continuous force law carries its time scale over
 * a switch). The counters start again from 0. Returns 0, or IG_DOPRI5_RHS_FAILED. */
int ig_dopri5_start(ig_dopri5 *r, double t0, const double *y0, double t_stop, double rtol, const double *atol,
                    const int *directions, int nevents, double h_hint);
/* One accepted step (after any rejected ones): IG_DOPRI5_STEPPED, _ROOT (roots_found flags
 * the watched events that crossed; see the state after a root above), _STOP, or < 0.
 * r->stiff turns 1 when IG_DOPRI5_STIFF_STEPS accepted steps had h |lambda| beyond the pair's
 * stability boundary (Hairer's test, from the last two stages) or came after a rejected
 * attempt, with never IG_DOPRI5_SMOOTH_STEPS ordinary steps in a row between them: the
 * steps are held by stability, not accuracy, and an implicit method takes far fewer. */
int ig_dopri5_step(ig_dopri5 *r, int *roots_found);
/* y at t within the last step, from its continuous extension. Not const: the extension is made
 * when first asked for after a step (most steps of an impact need none: only the event checks
 * inside a step, root finding and dense output read it). */
void ig_dopri5_interpolate(ig_dopri5 *r, double t, double *y);
/* The last step's continuous extension as Taylor coefficients at r->t:
 * rows[j * n + i] = y_i^(j)(r->t) / j!, j < IG_DOPRI5_DENSE_TERMS. */
void ig_dopri5_taylor(ig_dopri5 *r, double *rows);

#endif /* IMPACTGEN_DOPRI5_H */
