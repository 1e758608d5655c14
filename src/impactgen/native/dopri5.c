/*
 * dopri5.c: Dormand and Prince's 5(4) pair with dense output and root finding (dopri5.h).
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "dopri5.h"

#define N MODEL_NSTATE
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
#define TRIG_SHIFT_MAX 0.0625 /* a stage's angle within this of the step start's (rad): its sine and cosine
                               * come from the start's (stage_trig), beyond it from libm */
#define TRIG_SHIFT_SHORT 0x1p-10 /* ... within this, by shorter series (contact steps move the angles by 1e-5) */
#define TRIG_CHAIN_MAX 6  /* an accepted step's end takes its sines and cosines from its start's this many times
                           * in a row at most, then from libm: each shift adds at most 0.51 units of 2^-52, so
                           * the chain stays within 3.6 units, under libm's 4 at an angle rounded to a double */

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

/* model_rhs returns nonzero where it fails, and for any derivative that is not finite. */
static int rhs(ig_dopri5 *r, double t, const double *y, double *f)
{
    r->nfev++;
    return model_rhs(t, y, f, r->params) != 0 ? -1 : 0;
}

/* The same, given the sines and cosines of y's angles (model_trig's layout). */
static int rhs_trig(ig_dopri5 *r, double t, const double *y, const double *trig, double *f)
{
    r->nfev++;
    return model_rhs_trig(t, y, trig, f, r->params) != 0 ? -1 : 0;
}

static void watched_trig(ig_dopri5 *r, double t, const double *y, const double *trig, double *g)
{
    double ev[MODEL_NEVENT];
    r->ngev++;
    model_events_trig(t, y, trig, ev, r->params);
    for (int k = 0; k < r->nevents; ++k) g[k] = ev[r->events[k]];
}

static void watched(ig_dopri5 *r, double t, const double *y, double *g)
{
    double trig[MODEL_NTRIG];
    model_trig(y, trig);
    watched_trig(r, t, y, trig, g);
}

/* cos d - 1 and sin d by their Taylor series: to d^8 and d^9 for |d| <= TRIG_SHIFT_MAX, where
 * the first terms left out, d^10 / 10! and d^11 / 11!, are below 3e-19 and 3e-21; to d^4 and
 * d^5 for |d| <= TRIG_SHIFT_SHORT, where d^6 / 6! and d^7 / 7! are below 3e-21 and 3e-25. */
static inline void shift_series_long(double d, double *cm1, double *sd)
{
    const double z = d * d;
    *cm1 = z * (-1.0 / 2 + z * (1.0 / 24 + z * (-1.0 / 720 + z * (1.0 / 40320))));
    *sd = d + d * z * (-1.0 / 6 + z * (1.0 / 120 + z * (-1.0 / 5040 + z * (1.0 / 362880))));
}

static inline void shift_series_short(double d, double *cm1, double *sd)
{
    const double z = d * d;
    *cm1 = z * (-1.0 / 2 + z * (1.0 / 24));
    *sd = d + d * z * (-1.0 / 6 + z * (1.0 / 120));
}

/* sin(q + d) and cos(q + d) into out[0], out[1] from s = sin q, c = cos q and the series of d, as
 * s + (s (cos d - 1) + c sin d) and c + (c (cos d - 1) - s sin d). Either series is far under an
 * ulp of the result: it is libm's to about an ulp (the start's own rounding and the sum's), at a
 * fraction of the cost. */
static inline void rotate(double s, double c, double cm1, double sd, double *out)
{
    out[0] = s + (s * cm1 + c * sd);
    out[1] = c + (c * cm1 - s * sd);
}

/* The sines and cosines of the angles of y = y0 + dy (the angles are y[0 .. MODEL_NQ)), from
 * y0's in trig0: by the short series for |dy| <= TRIG_SHIFT_SHORT, the long one up to
 * TRIG_SHIFT_MAX, libm beyond. */
static inline void stage_trig(const double *trig0, const double *dy, const double *y, double *trig)
{
    for (int i = 0; i < MODEL_NQ; ++i) {
        const double d = dy[i], a = fabs(d);
        double cm1, sd;
        if (a <= TRIG_SHIFT_SHORT) {
            shift_series_short(d, &cm1, &sd);
        } else if (a <= TRIG_SHIFT_MAX) {
            shift_series_long(d, &cm1, &sd);
        } else {
            trig[2 * i] = sin(y[i]);
            trig[2 * i + 1] = cos(y[i]);
            continue;
        }
        rotate(trig0[2 * i], trig0[2 * i + 1], cm1, sd, trig + 2 * i);
    }
}

/* r->trig from libm at r->y: the chain of shifted end points (TRIG_CHAIN_MAX) starts again. */
static void trig_from_libm(ig_dopri5 *r)
{
    model_trig(r->y, r->trig);
    r->trig_chain = 0;
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

static double sign_of(double v)
{
    return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

/* Hairer's starting step: from the sizes of y0, f(y0) and an estimate of the second derivative. */
static double first_step(ig_dopri5 *r, double *scratch, double *f1)
{
    const double *y = r->y, *f0 = r->k[0];
    double dnf = 0.0, dny = 0.0;
    for (int i = 0; i < N; ++i) {
        const double sk = r->atol[i] + r->rtol * fabs(y[i]);
        dnf += (f0[i] / sk) * (f0[i] / sk);
        dny += (y[i] / sk) * (y[i] / sk);
    }
    const double span = r->t_stop - r->t;
    double h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
    h = fmin(h, span);
    for (int i = 0; i < N; ++i) scratch[i] = y[i] + h * f0[i];
    if (rhs(r, r->t + h, scratch, f1) != 0) return fmin(h * 1e-3, span);
    double der2 = 0.0;
    for (int i = 0; i < N; ++i) {
        const double sk = r->atol[i] + r->rtol * fabs(y[i]);
        der2 += ((f1[i] - f0[i]) / sk) * ((f1[i] - f0[i]) / sk);
    }
    der2 = sqrt(der2) / h;
    const double der12 = fmax(fabs(der2), sqrt(dnf));
    const double h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 1.0 / 5.0);
    return fmin(fmin(100.0 * h, h1), span);
}

int ig_dopri5_start(ig_dopri5 *r, const model_params *params, double t0, const double *y0, double t_stop,
                    double rtol, const double *atol, const int *events, const int *directions, int nevents,
                    double h_hint)
{
    r->params = params;
    r->rtol = rtol;
    memcpy(r->atol, atol, sizeof r->atol);
    r->t = r->t_old = t0;
    r->t_stop = t_stop;
    memcpy(r->y, y0, sizeof r->y);
    r->log_fac_old = log(ERR_FLOOR);
    r->rejected = 0;
    r->nsteps = r->nfev = r->netfails = r->ngev = 0;
    r->stiff_count = r->smooth_count = r->stiff = 0;
    r->nevents = nevents;
    for (int k = 0; k < nevents; ++k) {
        r->events[k] = events[k];
        r->directions[k] = directions[k];
    }
    trig_from_libm(r);
    if (rhs_trig(r, t0, r->y, r->trig, r->k[0]) != 0) return IG_DOPRI5_RHS_FAILED;
    r->h = first_step(r, r->k[1], r->k[2]);
    if (h_hint > 0.0) r->h = fmin(r->h, h_hint);
    watched_trig(r, t0, r->y, r->trig, r->g);
    int at_zero = 0;
    for (int k = 0; k < nevents; ++k) {
        r->side[k] = sign_of(r->g[k]);
        at_zero |= r->side[k] == 0.0;
    }
    if (at_zero) {  /* an event function starting at 0: its side is where it goes (as CVODE decides) */
        const double dt = fmin(fmax(ROOT_TOLERANCE * DBL_EPSILON * (fabs(t0) + r->h), 1e-3 * r->h), 0.5 * r->h);
        double y_near[N], g_near[MODEL_NEVENT];
        for (int i = 0; i < N; ++i) y_near[i] = r->y[i] + dt * r->k[0][i];
        watched(r, t0 + dt, y_near, g_near);
        for (int k = 0; k < nevents; ++k) {
            if (r->side[k] == 0.0) r->side[k] = sign_of(g_near[k]);
        }
    }
    /* the polynomial of a zero-length step: constant y (for an interpolation before any step) */
    r->h_old = 0.0;
    memcpy(r->cont[0], r->y, sizeof r->y);
    memcpy(r->trig_old, r->trig, sizeof r->trig);
    memset(r->cont[1], 0, sizeof r->cont - sizeof r->cont[0]);
    return 0;
}

/* The stages of a step of size h from (t, y); the new state in y1 with its sines and cosines
 * in trig1, the sixth stage's state in y6 (for the stiffness estimate), and the error norm.
 * The stages take their angles' sines and cosines from the step start's (stage_trig); the
 * end point too while r->trig_chain < TRIG_CHAIN_MAX, else from libm (the chain of shifts
 * from the last libm values is kept short). */
static int attempt(ig_dopri5 *r, double h, double *y1, double *y6, double *trig1, double *err)
{
    double (*k)[N] = r->k, dy[N], tmp[N], trig[MODEL_NTRIG];
    const double t = r->t, *y = r->y;
    for (int i = 0; i < N; ++i) tmp[i] = y[i] + (dy[i] = h * a21 * k[0][i]);
    stage_trig(r->trig, dy, tmp, trig);
    if (rhs_trig(r, t + c2 * h, tmp, trig, k[1]) != 0) return -1;
    for (int i = 0; i < N; ++i) tmp[i] = y[i] + (dy[i] = h * (a31 * k[0][i] + a32 * k[1][i]));
    stage_trig(r->trig, dy, tmp, trig);
    if (rhs_trig(r, t + c3 * h, tmp, trig, k[2]) != 0) return -1;
    for (int i = 0; i < N; ++i) tmp[i] = y[i] + (dy[i] = h * (a41 * k[0][i] + a42 * k[1][i] + a43 * k[2][i]));
    stage_trig(r->trig, dy, tmp, trig);
    if (rhs_trig(r, t + c4 * h, tmp, trig, k[3]) != 0) return -1;
    for (int i = 0; i < N; ++i) {
        tmp[i] = y[i] + (dy[i] = h * (a51 * k[0][i] + a52 * k[1][i] + a53 * k[2][i] + a54 * k[3][i]));
    }
    stage_trig(r->trig, dy, tmp, trig);
    if (rhs_trig(r, t + c5 * h, tmp, trig, k[4]) != 0) return -1;
    for (int i = 0; i < N; ++i) {
        y6[i] = y[i] + (dy[i] = h * (a61 * k[0][i] + a62 * k[1][i] + a63 * k[2][i] + a64 * k[3][i] + a65 * k[4][i]));
    }
    stage_trig(r->trig, dy, y6, trig);
    if (rhs_trig(r, t + h, y6, trig, k[5]) != 0) return -1;
    for (int i = 0; i < N; ++i) {
        y1[i] = y[i] + h * (a71 * k[0][i] + a73 * k[2][i] + a74 * k[3][i] + a75 * k[4][i] + a76 * k[5][i]);
    }
    if (r->trig_chain < TRIG_CHAIN_MAX) {
        for (int i = 0; i < MODEL_NQ; ++i) dy[i] = y1[i] - y[i];  /* exact where y1 is within 2x of y */
        stage_trig(r->trig, dy, y1, trig1);
    } else {
        model_trig(y1, trig1);
    }
    if (rhs_trig(r, t + h, y1, trig1, k[6]) != 0) return -1;
    double sum = 0.0;
    for (int i = 0; i < N; ++i) {
        const double e = h * (e1 * k[0][i] + e3 * k[2][i] + e4 * k[3][i] + e5 * k[4][i] + e6 * k[5][i] + e7 * k[6][i]);
        const double sk = r->atol[i] + r->rtol * larger(fabs(y[i]), fabs(y1[i]));
        sum += (e / sk) * (e / sk);
    }
    *err = sqrt(sum / N);
    return isfinite(*err) ? 0 : -1;
}

/* Hairer's stiffness estimate of an accepted step, h |f(y1) - f(y6)| / |y1 - y6| (y6 the
 * sixth stage's state): made for accepted steps only, the only ones whose estimate counts. */
static double stiffness_estimate(const ig_dopri5 *r, double h, const double *y1, const double *y6)
{
    double num = 0.0, den = 0.0;
    for (int i = 0; i < N; ++i) {
        num += (r->k[6][i] - r->k[5][i]) * (r->k[6][i] - r->k[5][i]);
        den += (y1[i] - y6[i]) * (y1[i] - y6[i]);
    }
    return den > 0.0 ? h * sqrt(num / den) : 0.0;
}

/* The continuous extension of the step just accepted (y still the old state). */
static void keep_extension(ig_dopri5 *r, double h, const double *y1)
{
    const double (*k)[N] = (const double (*)[N])r->k;
    for (int i = 0; i < N; ++i) {
        const double ydiff = y1[i] - r->y[i];
        const double bspl = h * k[0][i] - ydiff;
        r->cont[0][i] = r->y[i];
        r->cont[1][i] = ydiff;
        r->cont[2][i] = bspl;
        r->cont[3][i] = ydiff - h * k[6][i] - bspl;
        r->cont[4][i] = h * (d1 * k[0][i] + d3 * k[2][i] + d4 * k[3][i] + d5 * k[4][i] + d6 * k[5][i] + d7 * k[6][i]);
    }
}

/* y at t within the last step, and dy = y - y(t_old) as the extension gives it. */
static inline void interpolate_with_increment(const ig_dopri5 *r, double t, double *y, double *dy)
{
    const double s = r->h_old != 0.0 ? (t - r->t_old) / r->h_old : 0.0, s1 = 1.0 - s;
    for (int i = 0; i < N; ++i) {
        y[i] = r->cont[0][i] + (dy[i] = s * (r->cont[1][i] + s1 * (r->cont[2][i] + s * (r->cont[3][i] + s1 * r->cont[4][i]))));
    }
}

void ig_dopri5_interpolate(const ig_dopri5 *r, double t, double *y)
{
    double dy[N];
    interpolate_with_increment(r, t, y, dy);
}

/* The same, with the sines and cosines of y's angles from the step start's. */
static void interpolate_trig(const ig_dopri5 *r, double t, double *y, double *trig)
{
    double dy[N];
    interpolate_with_increment(r, t, y, dy);
    stage_trig(r->trig_old, dy, y, trig);
}

void ig_dopri5_taylor(const ig_dopri5 *r, double *rows)
{
    /* the extension in powers of s = (t - t_old) / h_old, shifted to the s of r->t */
    const double s0 = r->h_old != 0.0 ? (r->t - r->t_old) / r->h_old : 0.0;
    static const double binomial[5][5] = {{1, 0, 0, 0, 0}, {1, 1, 0, 0, 0}, {1, 2, 1, 0, 0}, {1, 3, 3, 1, 0},
                                          {1, 4, 6, 4, 1}};
    for (int i = 0; i < N; ++i) {
        const double (*c)[N] = (const double (*)[N])r->cont;
        const double a[5] = {c[0][i], c[1][i] + c[2][i], -c[2][i] + c[3][i] + c[4][i], -c[3][i] - 2.0 * c[4][i],
                             c[4][i]};
        double scale = 1.0;
        for (int j = 0; j < IG_DOPRI5_DENSE_TERMS; ++j) {
            double b = 0.0, power = 1.0;
            for (int m = j; m < 5; ++m) {
                b += a[m] * binomial[m][j] * power;
                power *= s0;
            }
            rows[j * N + i] = r->h_old != 0.0 ? b / scale : (j == 0 ? b : 0.0);
            scale *= r->h_old;
        }
    }
}

/* Watched event k crossed in its direction between the stored side and the value g
 * (an exact 0 counts as crossed). */
static int crossed(const ig_dopri5 *r, int k, double g)
{
    const double side = r->side[k];
    if (side == 0.0 || sign_of(g) == side) return 0;
    return r->directions[k] == 0 || r->directions[k] == -side;
}

/* The first time in [t_lo, t_hi] where event k reaches the crossed side (Illinois on the
 * continuous extension of the last step): the right end of a bracket narrower than tol. */
static double locate(ig_dopri5 *r, int k, double t_lo, double g_lo, double t_hi, double g_hi, double tol)
{
    double y[N], trig[MODEL_NTRIG], g[MODEL_NEVENT];
    const double side = r->side[k];
    int kept = 0;  /* which end stayed the last time (Illinois halves its value) */
    for (int it = 0; it < ROOT_ITERATIONS && t_hi - t_lo > tol; ++it) {
        double t_mid = t_hi - g_hi * (t_hi - t_lo) / (g_hi - g_lo);
        if (!(t_mid > t_lo + tol / 2 && t_mid < t_hi - tol / 2)) t_mid = 0.5 * (t_lo + t_hi);
        interpolate_trig(r, t_mid, y, trig);
        watched_trig(r, t_mid, y, trig, g);
        if (sign_of(g[k]) == side) {  /* still on the old side */
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

int ig_dopri5_step(ig_dopri5 *r, int *roots_found)
{
    const double expo = 0.2 - BETA * 0.75;
    double y1[N], y6[N], trig1[MODEL_NTRIG], err = 0.0;
    int retries = 0;
    for (;;) {
        double h = r->h;
        if (0.1 * fabs(h) <= fabs(r->t) * DBL_EPSILON || !(h > 0.0)) return IG_DOPRI5_TOO_SMALL;
        const int last = r->t + 1.01 * h >= r->t_stop;
        if (last) h = r->t_stop - r->t;
        if (attempt(r, h, y1, y6, trig1, &err) != 0) {  /* the right-hand side failed: a smaller step */
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
        keep_extension(r, h, y1);
        r->t_old = r->t;
        r->h_old = h;
        r->t = last ? r->t_stop : r->t + h;
        memcpy(r->y, y1, sizeof r->y);
        memcpy(r->trig_old, r->trig, sizeof r->trig);
        memcpy(r->trig, trig1, sizeof r->trig);
        r->trig_chain = r->trig_chain < TRIG_CHAIN_MAX ? r->trig_chain + 1 : 0;
        memcpy(r->k[0], r->k[6], sizeof r->k[0]);  /* first same as last */
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
    double g_end[MODEL_NEVENT], g_lo[MODEL_NEVENT], g_hi[MODEL_NEVENT], t_lo = r->t_old;
    memcpy(g_lo, r->g, sizeof g_lo);
    watched_trig(r, r->t, r->y, r->trig, g_end);
    const int points = some_unarmed(r) ? INSIDE_POINTS : 0;
    const double tol = ROOT_TOLERANCE * DBL_EPSILON * larger(fabs(r->t), fabs(r->h_old));
    for (int j = 1; j <= points + 1; ++j) {
        const double t_hi = j > points ? r->t : r->t_old + r->h_old * j / (points + 1);
        if (j > points) {
            memcpy(g_hi, g_end, sizeof g_hi);
        } else {
            double y[N], trig[MODEL_NTRIG];
            interpolate_trig(r, t_hi, y, trig);
            watched_trig(r, t_hi, y, trig, g_hi);
        }
        int any = 0;
        for (int k = 0; k < r->nevents; ++k) any |= crossed(r, k, g_hi[k]);
        if (any) {  /* the first crossing: each crossed event located, the earliest kept with any as close */
            double t_root[MODEL_NEVENT], g_end_now[MODEL_NEVENT], first = t_hi;
            memcpy(g_end_now, g_hi, sizeof g_end_now);
            for (int k = 0; k < r->nevents; ++k) t_root[k] = INFINITY;
            /* each pass looks at the interval's end as the roots found so far have cut it: an
             * event back on its old side at t_hi may have crossed and come back before a root
             * (the yield of a grazing impact, crossed up and down about the maximum compression
             * that ends the step) */
            for (int located = 0;;) {
                const double end = first;
                const int before = located;
                for (int k = 0; k < r->nevents; ++k) {
                    if (t_root[k] < INFINITY || !crossed(r, k, g_end_now[k])) continue;
                    const double lo = g_lo[k] != 0.0 ? g_lo[k] : r->side[k] * DBL_MIN;  /* the old side's value */
                    t_root[k] = locate(r, k, t_lo, lo, end, g_end_now[k], tol);
                    first = smaller(first, t_root[k]);
                    ++located;
                }
                if (located == before || located == r->nevents || first == end) break;
                double y_first[N], trig[MODEL_NTRIG];
                interpolate_trig(r, first, y_first, trig);
                watched_trig(r, first, y_first, trig, g_end_now);
            }
            for (int k = 0; k < r->nevents; ++k) roots_found[k] = t_root[k] <= first + tol;
            if (first < r->t) {
                r->t = first;
                ig_dopri5_interpolate(r, first, r->y);
                trig_from_libm(r);
            }
            return IG_DOPRI5_ROOT;
        }
        for (int k = 0; k < r->nevents; ++k) {
            if (g_hi[k] != 0.0) r->side[k] = sign_of(g_hi[k]);
        }
        memcpy(g_lo, g_hi, sizeof g_lo);
        t_lo = t_hi;
    }
    memcpy(r->g, g_end, sizeof r->g);
    return r->t >= r->t_stop ? IG_DOPRI5_STOP : IG_DOPRI5_STEPPED;
}
