/*
 * dopri5.h: Dormand and Prince's explicit Runge-Kutta 5(4) pair with its dense output and
 * directional root finding, for a generated model, in plain C99 (no SUNDIALS, no allocation).
 *
 * Written after Hairer, Norsett and Wanner's DOPRI5 (Solving Ordinary Differential Equations
 * I, 2nd ed., section II.5 and II.6): the same tableau, error estimate, PI step-size
 * controller and fourth-order continuous extension. For the non-stiff phases of an impact a
 * step costs its six right-hand sides and little else; the CVODE glue offers it as the method
 * IG_METHOD_DOPRI5. The event functions are watched after every step and their first
 * crossing in the watched direction is located on the continuous extension (Illinois), the
 * step ending just past it, as CVODE's root finder does.
 */
#ifndef IMPACTGEN_DOPRI5_H
#define IMPACTGEN_DOPRI5_H

#include "model.h"

#define IG_DOPRI5_STAGES 7
#define IG_DOPRI5_DENSE_TERMS 5  /* Taylor coefficients of the continuous extension (degree 4) */
#define IG_DOPRI5_STABILITY 3.25 /* h |lambda| beyond this: the step is limited by stability */
#define IG_DOPRI5_STIFF_STEPS 15 /* ... (or after a rejection) for this many steps: stiff (Hairer) */
#define IG_DOPRI5_SMOOTH_STEPS 6 /* ... within it this many in a row: the count starts again */

enum {
    IG_DOPRI5_STEPPED = 0,    /* an accepted step; the segment goes on */
    IG_DOPRI5_ROOT = 1,       /* a watched event crossed: the step ends just past it */
    IG_DOPRI5_STOP = 2,       /* t_stop reached */
    IG_DOPRI5_TOO_SMALL = -1, /* the step size fell below what double precision resolves */
    IG_DOPRI5_RHS_FAILED = -2 /* the right-hand side failed on every smaller step tried */
};

typedef struct {
    const model_params *params;
    double rtol, atol[MODEL_NSTATE];
    double t, h, t_stop;          /* time reached, next step size, the end of the segment */
    double t_old, h_old;          /* the last step: [t_old, t_old + h_old] */
    double y[MODEL_NSTATE];
    double trig[MODEL_NTRIG];     /* the sines and cosines of y's angles (model_trig) */
    double trig_old[MODEL_NTRIG]; /* ... and of the last step's start's, y(t_old) */
    int trig_chain;               /* accepted steps since trig last came from libm (dopri5.c) */
    double k[IG_DOPRI5_STAGES][MODEL_NSTATE];  /* stages; k[0] is f(t, y) (first same as last) */
    double cont[5][MODEL_NSTATE]; /* continuous extension of the last step */
    double log_fac_old;           /* the PI controller's memory: the log of the last accepted error */
    int rejected;                 /* the step before was rejected */
    int nevents, events[MODEL_NEVENT], directions[MODEL_NEVENT];
    double g[MODEL_NEVENT];       /* watched event functions at t */
    double side[MODEL_NEVENT];    /* their last nonzero sign (0: none yet) */
    double h_lambda;              /* h times the stiffness estimate of the last accepted step (Hairer) */
    int stiff_count, smooth_count;/* consecutive steps beyond and within the stability boundary */
    int stiff;                    /* 1 once the steps are limited by stability, not accuracy */
    long nsteps, nfev, netfails, ngev;
} ig_dopri5;

/* Begin a segment at (t0, y0) under params, to t_stop, watching events[0..nevents) in their
 * directions (+1 rising, -1 falling, 0 both). rtol and atol (MODEL_NSTATE entries) are the
 * tolerances. The first step is Hairer's estimate, at most h_hint when h_hint > 0 (the step
 * the segment before proposed next, r->h: a continuous force law carries its time scale over
 * a switch).
 * The counters start again from 0. Returns 0, or IG_DOPRI5_RHS_FAILED. */
int ig_dopri5_start(ig_dopri5 *r, const model_params *params, double t0, const double *y0, double t_stop,
                    double rtol, const double *atol, const int *events, const int *directions, int nevents,
                    double h_hint);
/* One accepted step (after any rejected ones): IG_DOPRI5_STEPPED, _ROOT (roots_found flags
 * the watched events that crossed; r->t, r->y are just past the root), _STOP, or < 0.
 * r->stiff turns 1 when IG_DOPRI5_STIFF_STEPS accepted steps had h |lambda| beyond the pair's
 * stability boundary (Hairer's test, from the last two stages) or came after a rejected
 * attempt, with never IG_DOPRI5_SMOOTH_STEPS ordinary steps in a row between them: the
 * steps are held by stability, not accuracy, and an implicit method takes far fewer. */
int ig_dopri5_step(ig_dopri5 *r, int *roots_found);
/* y at t within the last step, from its continuous extension. */
void ig_dopri5_interpolate(const ig_dopri5 *r, double t, double *y);
/* The last step's continuous extension as Taylor coefficients at its end r->t:
 * rows[j * MODEL_NSTATE + i] = y_i^(j)(t) / j!, j < IG_DOPRI5_DENSE_TERMS. */
void ig_dopri5_taylor(const ig_dopri5 *r, double *rows);

#endif /* IMPACTGEN_DOPRI5_H */
