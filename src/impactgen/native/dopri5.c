/*
 * dopri5.c: Dormand and Prince's 5(4) pair with dense output and root finding (dopri5.h),
 * for any n: the right-hand side and the event functions are callbacks.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dopri5.h"
#include "roots.h"

#define SAFE 0.9          /* safety factor of the step-size controller */
#define FAC_MIN 0.2       /* the step shrinks at most 5x ... */
#define FAC_MAX 10.0      /* ... and grows at most 10x per step */
#define BETA 0.04         /* the PI controller's weight of the previous error (Hairer's choice) */
#define ERR_FLOOR 1e-4    /* the controller's memory never goes below this error */
#define RHS_RETRIES 10    /* a failing right-hand side is retried on this many smaller steps */
#define ROOT_TOLERANCE 100.0  /* a root is located to this many ulps of max(|t|, |h|) (as CVODE) */
#define ROOT_ITERATIONS 200
#define INSIDE_POINTS 4   /* points inside a step where not-yet-armed events are looked at */
#define FAC_MIN_START 1e-3 /* until a start's first step is accepted, a rejected step shrinks by the error's
                            * own h^5 law (at most this much): the starting guess can be far off where a
                            * force law begins at 0 (Hertz's delta^1.5 at first contact) */

/* Dormand and Prince's tableau, its error weights and its dense-output weights. */
static const double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
static const double a21 = 1.0 / 5;
static const double a31 = 3.0 / 40, a32 = 9.0 / 40;
static const double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
static const double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561, a54 = -212.0 / 729;
static const double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                    a65 = -5103.0 / 18656;
static const double a71 = 35.0 / 384, a73 = 500.0 / 1113, a74 = 125.0 / 192, a75 = -2187.0 / 6784,
                    a76 = 11.0 / 84;
static const double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920, e5 = -17253.0 / 339200,
                    e6 = 22.0 / 525, e7 = -1.0 / 40;
static const double d1 = -12715105075.0 / 11282082432.0, d3 = 87487479700.0 / 32700410799.0,
                    d4 = -10690763975.0 / 1880347072.0, d5 = 701980252875.0 / 199316789632.0,
                    d6 = -1453857185.0 / 822651844.0, d7 = 69997945.0 / 29380423.0;

/* The right-hand side, counted; nonzero where it fails. */
static int rhs(ig_dopri5 *r, double t, const double *y, double *f)
{
    r->nfev++;
    return r->rhs(t, y, f, r->user) != 0 ? -1 : 0;
}

/* The watched event functions, counted. */
static void watched(ig_dopri5 *r, double t, const double *y, double *g)
{
    r->ngev++;
    if (r->nevents > 0) r->events(t, y, g, r->user);
}

/* The smaller and larger of two numbers that are not NaN (infinities are fine): fmin and fmax
 * are calls into libm (their NaN rules keep GCC from inlining them), and the step-size
 * controller takes several per step. */
static inline double smaller(double a, double b)
{
    return a < b ? a : b;
}

static inline double larger(double a, double b)
{
    return a > b ? a : b;
}

/* Hairer's starting step: from the sizes of y0, f(y0) and an estimate of the second derivative
 * (the quadratures left out of the norms, as of the error test). */
static double first_step(ig_dopri5 *r, double *scratch, double *f1)
{
    const int n = r->n;
    const double *y = r->y, *f0 = r->k[0];
    double dnf = 0.0, dny = 0.0;
    for (int j = 0; j < r->ntested; ++j) {
        const int i = r->tested[j];
        const double sk = r->atol[i] + r->rtol * fabs(y[i]);
        dnf += (f0[i] / sk) * (f0[i] / sk);
        dny += (y[i] / sk) * (y[i] / sk);
    }
    const double span = r->t_stop - r->t;
    double h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
    h = fmin(h, span);
    for (int i = 0; i < n; ++i) scratch[i] = y[i] + h * f0[i];
    if (rhs(r, r->t + h, scratch, f1) != 0) return fmin(h * 1e-3, span);
    double der2 = 0.0;
    for (int j = 0; j < r->ntested; ++j) {
        const int i = r->tested[j];
        const double sk = r->atol[i] + r->rtol * fabs(y[i]);
        der2 += ((f1[i] - f0[i]) / sk) * ((f1[i] - f0[i]) / sk);
    }
    der2 = sqrt(der2) / h;
    const double der12 = fmax(fabs(der2), sqrt(dnf));
    const double h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 1.0 / 5.0);
    return fmin(fmin(100.0 * h, h1), span);
}

int ig_dopri5_init(ig_dopri5 *r, int n, int max_events, ig_dopri5_rhs_fn rhs_fn, ig_dopri5_events_fn events,
                   void *user)
{
    memset(r, 0, sizeof *r);
    if (n < 1 || max_events < 0 || !rhs_fn || (max_events > 0 && !events)) return -1;
    /* k, kept (2..6), cont, atol, y, y1, y6, tmp, ymid, y_old, f_old, tested */
    const size_t n_vectors = IG_DOPRI5_STAGES + 5 + 5 + 9;
    const size_t n_event_arrays = 8;                      /* g, side, g_end, g_lo, g_hi, g_now, t_root, directions */
    double *memory = (double *)malloc(sizeof(double) * (n_vectors * (size_t)n + n_event_arrays * (size_t)(max_events + 1)));
    if (!memory) return -1;
    r->memory = memory;
    r->n = n;
    r->max_events = max_events;
    r->rhs = rhs_fn;
    r->events = events;
    r->user = user;
    double *next = memory;
    double **vectors[] = {&r->atol, &r->y, &r->y1, &r->y6, &r->tmp, &r->ymid, &r->y_old, &r->f_old};
    double **event_arrays[] = {&r->g, &r->side, &r->g_end, &r->g_lo, &r->g_hi, &r->g_now, &r->t_root};
    for (int s = 0; s < IG_DOPRI5_STAGES; ++s, next += n) r->k[s] = next;
    for (int s = 2; s < IG_DOPRI5_STAGES; ++s, next += n) r->kept[s] = next;
    for (int s = 0; s < 5; ++s, next += n) r->cont[s] = next;
    for (size_t v = 0; v < sizeof vectors / sizeof *vectors; ++v, next += n) *vectors[v] = next;
    r->tested = (int *)next;  /* n ints fit in n doubles */
    next += n;
    const int m = max_events + 1;  /* never an empty array */
    for (size_t v = 0; v < sizeof event_arrays / sizeof *event_arrays; ++v, next += m) *event_arrays[v] = next;
    r->directions = (int *)next;  /* m ints fit in m doubles */
    return 0;
}

void ig_dopri5_free(ig_dopri5 *r)
{
    free(r->memory);
    memset(r, 0, sizeof *r);
}

int ig_dopri5_start(ig_dopri5 *r, double t0, const double *y0, double t_stop, double rtol, const double *atol,
                    const int *directions, int nevents, double h_hint)
{
    const int n = r->n;
    r->started = 0;
    if (nevents < 0 || nevents > r->max_events) return IG_DOPRI5_NOT_STARTED;
    r->rtol = rtol;
    memcpy(r->atol, atol, sizeof(double) * (size_t)n);
    int quadratures = 0;
    r->ntested = 0;
    for (int i = 0; i < n; ++i) {
        if (atol[i] < IG_DOPRI5_QUADRATURE_ATOL) r->tested[r->ntested++] = i;
        else r->tested[n - 1 - quadratures++] = i;
    }
    r->t = r->t_old = t0;
    r->t_stop = t_stop;
    memcpy(r->y, y0, sizeof(double) * (size_t)n);
    r->log_fac_old = log(ERR_FLOOR);
    r->rejected = 0;
    r->nsteps = r->nfev = r->netfails = r->ngev = 0;
    r->stiff_count = r->smooth_count = r->stiff = 0;
    r->nevents = nevents;
    for (int k = 0; k < nevents; ++k) r->directions[k] = directions[k];
    if (rhs(r, t0, r->y, r->k[0]) != 0) return IG_DOPRI5_RHS_FAILED;
    r->h = first_step(r, r->k[1], r->k[2]);
    if (h_hint > 0.0) r->h = fmin(r->h, h_hint);
    watched(r, t0, r->y, r->g);
    int at_zero = 0;
    for (int k = 0; k < nevents; ++k) {
        r->side[k] = ig_side_of(r->g[k]);
        at_zero |= r->side[k] == 0.0;
    }
    if (at_zero) {  /* an event function starting at 0: its side is where it goes (as CVODE decides) */
        const double dt = fmin(fmax(ROOT_TOLERANCE * DBL_EPSILON * (fabs(t0) + r->h), 1e-3 * r->h), 0.5 * r->h);
        for (int i = 0; i < n; ++i) r->tmp[i] = r->y[i] + dt * r->k[0][i];
        watched(r, t0 + dt, r->tmp, r->g_hi);
        for (int k = 0; k < nevents; ++k) {
            if (r->side[k] == 0.0) r->side[k] = ig_side_of(r->g_hi[k]);
        }
    }
    /* the polynomial of a zero-length step: constant y (for an interpolation before any step) */
    r->h_old = 0.0;
    memcpy(r->cont[0], r->y, sizeof(double) * (size_t)n);
    for (int s = 1; s < 5; ++s) memset(r->cont[s], 0, sizeof(double) * (size_t)n);
    r->extension_made = 1;
    r->started = 1;
    return 0;
}

/* The stages of a step of size h from (t, y); the new state in y1, the sixth stage's state
 * in y6 (for the stiffness estimate), and the error norm (Hairer's: the root mean square of
 * the errors scaled by atol + rtol max(|y|, |y1|)). */
static int attempt(ig_dopri5 *r, double h, double *y1, double *y6, double *err)
{
    const int n = r->n;
    double *const *k = r->k, *tmp = r->tmp;
    const double t = r->t, *y = r->y;
    for (int i = 0; i < n; ++i) tmp[i] = y[i] + h * a21 * k[0][i];
    if (rhs(r, t + c2 * h, tmp, k[1]) != 0) return -1;
    for (int i = 0; i < n; ++i) tmp[i] = y[i] + h * (a31 * k[0][i] + a32 * k[1][i]);
    if (rhs(r, t + c3 * h, tmp, k[2]) != 0) return -1;
    for (int i = 0; i < n; ++i) tmp[i] = y[i] + h * (a41 * k[0][i] + a42 * k[1][i] + a43 * k[2][i]);
    if (rhs(r, t + c4 * h, tmp, k[3]) != 0) return -1;
    for (int i = 0; i < n; ++i) {
        tmp[i] = y[i] + h * (a51 * k[0][i] + a52 * k[1][i] + a53 * k[2][i] + a54 * k[3][i]);
    }
    if (rhs(r, t + c5 * h, tmp, k[4]) != 0) return -1;
    for (int i = 0; i < n; ++i) {
        y6[i] = y[i] + h * (a61 * k[0][i] + a62 * k[1][i] + a63 * k[2][i] + a64 * k[3][i] + a65 * k[4][i]);
    }
    if (rhs(r, t + h, y6, k[5]) != 0) return -1;
    for (int i = 0; i < n; ++i) {
        y1[i] = y[i] + h * (a71 * k[0][i] + a73 * k[2][i] + a74 * k[3][i] + a75 * k[4][i] + a76 * k[5][i]);
    }
    if (rhs(r, t + h, y1, k[6]) != 0) return -1;
    double sum = 0.0;
    for (int j = 0; j < r->ntested; ++j) {
        const int i = r->tested[j];
        const double e = h * (e1 * k[0][i] + e3 * k[2][i] + e4 * k[3][i] + e5 * k[4][i] + e6 * k[5][i] + e7 * k[6][i]);
        const double sk = r->atol[i] + r->rtol * larger(fabs(y[i]), fabs(y1[i]));
        sum += (e / sk) * (e / sk);
    }
    int finite = 1;  /* the quadratures' errors count as 0 in the norm (IG_DOPRI5_QUADRATURE_ATOL) */
    for (int j = r->ntested; j < n; ++j) {
        const int i = r->tested[j];
        const double e = h * (e1 * k[0][i] + e3 * k[2][i] + e4 * k[3][i] + e5 * k[4][i] + e6 * k[5][i] + e7 * k[6][i]);
        finite &= isfinite(e) != 0;
    }
    *err = sqrt(sum / n);
    return finite && isfinite(*err) ? 0 : -1;
}

/* Hairer's stiffness estimate of an accepted step, h |f(y1) - f(y6)| / |y1 - y6| (y6 the
 * sixth stage's state): made for accepted steps only, the only ones whose estimate counts. */
static double stiffness_estimate(const ig_dopri5 *r, double h, const double *y1, const double *y6)
{
    double num = 0.0, den = 0.0;
    for (int i = 0; i < r->n; ++i) {
        num += (r->k[6][i] - r->k[5][i]) * (r->k[6][i] - r->k[5][i]);
        den += (y1[i] - y6[i]) * (y1[i] - y6[i]);
    }
    return den > 0.0 ? h * sqrt(num / den) : 0.0;
}

/* The last step's continuous extension, if not made yet, from what the step kept: its start
 * y_old, f there, its stages and its end r->y. Made only when asked for: on the paper's impact
 * 3 of 59 steps need it (their roots), and making it at every step was 3 % of the run's C
 * instructions (16k of 485k, callgrind). */
static void make_extension(ig_dopri5 *r)
{
    if (r->extension_made) return;
    const double h = r->h_old, *y0 = r->y_old, *y1 = r->y, *f0 = r->f_old;
    double *const *k = r->kept, *const *cont = r->cont;
    for (int i = 0; i < r->n; ++i) {
        const double ydiff = y1[i] - y0[i];
        const double bspl = h * f0[i] - ydiff;
        cont[0][i] = y0[i];
        cont[1][i] = ydiff;
        cont[2][i] = bspl;
        cont[3][i] = ydiff - h * k[6][i] - bspl;
        cont[4][i] = h * (d1 * f0[i] + d3 * k[2][i] + d4 * k[3][i] + d5 * k[4][i] + d6 * k[5][i] + d7 * k[6][i]);
    }
    r->extension_made = 1;
}

static void swap_vectors(double **a, double **b)
{
    double *const kept = *a;
    *a = *b;
    *b = kept;
}

void ig_dopri5_interpolate(ig_dopri5 *r, double t, double *y)
{
    make_extension(r);
    const double s = r->h_old != 0.0 ? (t - r->t_old) / r->h_old : 0.0, s1 = 1.0 - s;
    double *const *cont = r->cont;
    for (int i = 0; i < r->n; ++i) {
        y[i] = cont[0][i] + s * (cont[1][i] + s1 * (cont[2][i] + s * (cont[3][i] + s1 * cont[4][i])));
    }
}

void ig_dopri5_taylor(ig_dopri5 *r, double *rows)
{
    make_extension(r);
    /* the extension in powers of s = (t - t_old) / h_old, shifted to the s of r->t */
    const int n = r->n;
    const double s0 = r->h_old != 0.0 ? (r->t - r->t_old) / r->h_old : 0.0;
    static const double binomial[5][5] = {{1, 0, 0, 0, 0}, {1, 1, 0, 0, 0}, {1, 2, 1, 0, 0}, {1, 3, 3, 1, 0},
                                          {1, 4, 6, 4, 1}};
    double *const *c = r->cont;
    for (int i = 0; i < n; ++i) {
        const double a[5] = {c[0][i], c[1][i] + c[2][i], -c[2][i] + c[3][i] + c[4][i], -c[3][i] - 2.0 * c[4][i],
                             c[4][i]};
        double scale = 1.0;
        for (int j = 0; j < IG_DOPRI5_DENSE_TERMS; ++j) {
            double b = 0.0, power = 1.0;
            for (int m = j; m < 5; ++m) {
                b += a[m] * binomial[m][j] * power;
                power *= s0;
            }
            rows[j * n + i] = r->h_old != 0.0 ? b / scale : (j == 0 ? b : 0.0);
            scale *= r->h_old;
        }
    }
}

/* The first time in [t_lo, t_hi] where event k reaches the crossed side (Illinois on the
 * continuous extension of the last step): the right end of a bracket narrower than tol.
 * Uses r->ymid and r->g_hi (free while locate runs). */
static double locate(ig_dopri5 *r, int k, double t_lo, double g_lo, double t_hi, double g_hi, double tol)
{
    double *y = r->ymid, *g = r->g_hi;
    const double side = r->side[k];
    int kept = 0;  /* which end stayed the last time (Illinois halves its value) */
    for (int it = 0; it < ROOT_ITERATIONS && t_hi - t_lo > tol; ++it) {
        double t_mid = t_hi - g_hi * (t_hi - t_lo) / (g_hi - g_lo);
        if (!(t_mid > t_lo + tol / 2 && t_mid < t_hi - tol / 2)) t_mid = 0.5 * (t_lo + t_hi);
        ig_dopri5_interpolate(r, t_mid, y);
        watched(r, t_mid, y, g);
        if (ig_side_of(g[k]) == side) {  /* still on the old side */
            t_lo = t_mid;
            g_lo = g[k];
            if (kept == 1) g_hi *= 0.5;
            kept = 1;
        } else {
            t_hi = t_mid;
            g_hi = g[k];
            if (kept == -1) g_lo *= 0.5;
            kept = -1;
        }
    }
    return t_hi;
}

/* Whether some watched event is not armed: on the side its watched crossing leads to (or at
 * 0), so that it must first cross back. Such a return can fit inside one step (a short
 * flight after a separation that leaves the tip in the dent): the step is then also looked
 * at inside. */
static int some_unarmed(const ig_dopri5 *r)
{
    for (int k = 0; k < r->nevents; ++k) {
        if (r->side[k] == 0.0 || (r->directions[k] != 0 && r->side[k] == r->directions[k])) return 1;
    }
    return 0;
}

/* The first crossing within [t_lo, t_hi] (the events at t_hi in g_hi, some crossed): each
 * crossed event located, the earliest kept with any as close; r->t and r->y moved to it. */
static void first_root(ig_dopri5 *r, double t_lo, double t_hi, int *roots_found, double tol)
{
    const int nevents = r->nevents;
    double *t_root = r->t_root, *g_end_now = r->g_now, *g_lo = r->g_lo, first = t_hi;
    memcpy(g_end_now, r->g_hi, sizeof(double) * (size_t)nevents);
    for (int k = 0; k < nevents; ++k) t_root[k] = INFINITY;
    /* each pass looks at the interval's end as the roots found so far have cut it: an event
     * back on its old side at t_hi may have crossed and come back before a root (the yield of
     * a grazing impact, crossed up and down about the maximum compression that ends the step) */
    for (int located = 0;;) {
        const double end = first;
        const int before = located;
        for (int k = 0; k < nevents; ++k) {
            if (t_root[k] < INFINITY || !ig_crossed(r->side[k], g_end_now[k], r->directions[k])) continue;
            const double lo = g_lo[k] != 0.0 ? g_lo[k] : r->side[k] * DBL_MIN;  /* the old side's value */
            t_root[k] = locate(r, k, t_lo, lo, end, g_end_now[k], tol);
            first = smaller(first, t_root[k]);
            ++located;
        }
        if (located == before || located == nevents || first == end) break;
        ig_dopri5_interpolate(r, first, r->ymid);
        watched(r, first, r->ymid, g_end_now);
    }
    for (int k = 0; k < nevents; ++k) roots_found[k] = t_root[k] <= first + tol;
    if (first < r->t) {
        r->t = first;
        ig_dopri5_interpolate(r, first, r->y);
    }
}

int ig_dopri5_step(ig_dopri5 *r, int *roots_found)
{
    const int n = r->n;
    const double expo = 0.2 - BETA * 0.75;
    double *y1 = r->y1, *y6 = r->y6, err = 0.0;
    int retries = 0;
    if (!r->started) return IG_DOPRI5_NOT_STARTED;
    for (;;) {
        double h = r->h;
        if (0.1 * fabs(h) <= fabs(r->t) * DBL_EPSILON || !(h > 0.0)) return IG_DOPRI5_TOO_SMALL;
        const int last = r->t + 1.01 * h >= r->t_stop;
        if (last) h = r->t_stop - r->t;
        if (attempt(r, h, y1, y6, &err) != 0) {  /* the right-hand side failed: a smaller step */
            if (++retries > RHS_RETRIES) return IG_DOPRI5_RHS_FAILED;
            r->netfails++;
            r->h = 0.25 * h;
            r->rejected = 1;
            continue;
        }
        /* the controller's powers of the error as exponentials of its logarithm: one log and
         * one exp per attempt where two pow calls cost twice that */
        const double log_err = log(err);
        if (err > 1.0) {  /* rejected: a smaller step */
            r->netfails++;
            r->h = r->nsteps == 0 ? h * larger(FAC_MIN_START, SAFE * exp(-0.2 * log_err))
                                  : h / smaller(1.0 / FAC_MIN, exp(expo * log_err) / SAFE);
            r->rejected = 1;
            continue;
        }
        /* accepted: the PI controller's next step */
        r->h_lambda = stiffness_estimate(r, h, y1, y6);
        const double fac = larger(1.0 / FAC_MAX, smaller(1.0 / FAC_MIN, exp(expo * log_err - BETA * r->log_fac_old) / SAFE));
        double h_new = h / fac;
        r->log_fac_old = larger(log_err, log(ERR_FLOOR));
        r->t_old = r->t;
        r->h_old = h;
        r->t = last ? r->t_stop : r->t + h;
        /* the step keeps what its extension is made from (make_extension): its start and f there
         * set aside, its stages swapped for the other bank, which the next attempts write */
        swap_vectors(&r->y_old, &r->y);
        memcpy(r->y, y1, sizeof(double) * (size_t)n);
        swap_vectors(&r->f_old, &r->k[0]);
        memcpy(r->k[0], r->k[6], sizeof(double) * (size_t)n);  /* first same as last */
        for (int s = 2; s < IG_DOPRI5_STAGES; ++s) swap_vectors(&r->kept[s], &r->k[s]);
        r->extension_made = 0;
        if (r->rejected) h_new = smaller(h_new, h);
        const int unstable = r->h_lambda > IG_DOPRI5_STABILITY || r->rejected;
        r->h = last ? larger(h_new, r->h) : h_new;  /* a step cut to t_stop proposes what it was cut from */
        r->nsteps++;
        r->rejected = 0;
        if (unstable) {
            r->smooth_count = 0;
            if (++r->stiff_count >= IG_DOPRI5_STIFF_STEPS) r->stiff = 1;
        } else if (++r->smooth_count >= IG_DOPRI5_SMOOTH_STEPS) {
            r->stiff_count = 0;
        }
        break;
    }
    /* the watched events over the step: at its end, and inside it while some is not armed */
    double *g_end = r->g_end, *g_lo = r->g_lo, *g_hi = r->g_hi, t_lo = r->t_old;
    const size_t event_bytes = sizeof(double) * (size_t)r->nevents;
    memcpy(g_lo, r->g, event_bytes);
    watched(r, r->t, r->y, g_end);
    const int points = some_unarmed(r) ? INSIDE_POINTS : 0;
    const double tol = ROOT_TOLERANCE * DBL_EPSILON * larger(fabs(r->t), fabs(r->h_old));
    for (int j = 1; j <= points + 1; ++j) {
        const double t_hi = j > points ? r->t : r->t_old + r->h_old * j / (points + 1);
        if (j > points) {
            memcpy(g_hi, g_end, event_bytes);
        } else {
            ig_dopri5_interpolate(r, t_hi, r->ymid);
            watched(r, t_hi, r->ymid, g_hi);
        }
        int any = 0;
        for (int k = 0; k < r->nevents; ++k) any |= ig_crossed(r->side[k], g_hi[k], r->directions[k]);
        if (any) {
            first_root(r, t_lo, t_hi, roots_found, tol);
            r->started = 0;  /* the segment ends at the root (dopri5.h) */
            return IG_DOPRI5_ROOT;
        }
        for (int k = 0; k < r->nevents; ++k) {
            r->side[k] = ig_side_after(r->side[k], g_hi[k]);
        }
        memcpy(g_lo, g_hi, event_bytes);
        t_lo = t_hi;
    }
    memcpy(r->g, g_end, event_bytes);
    if (r->t >= r->t_stop) {
        r->started = 0;
        return IG_DOPRI5_STOP;
    }
    return IG_DOPRI5_STEPPED;
}
