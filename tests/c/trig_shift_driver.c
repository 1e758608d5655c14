/*
 * trig_shift_driver.c: the explicit pair's shifted sines and cosines (dopri5.c, included here
 * for its static helpers) against long-double libm at the exact shifted angle, and the
 * model's trig entry points against the plain ones. Prints "trig shift: ok" or what failed.
 * Build: cc -I<model folder> -I<native> trig_shift_driver.c <model folder>/model.c -lm
 */
#include <stdio.h>
#include <stdlib.h>

#include "dopri5.c"

#define SAMPLES 2000000L
#define ABS_LIMIT 0x1p-52  /* the shift's absolute error at most this (2.2e-16): an ulp of 1 */
#define CHAIN_LIMIT 0x1p-50 /* TRIG_CHAIN_MAX shifts in a row from libm's values: at most 4 ulps of 1, what libm
                             * gives at an angle rounded to a double */
#define CHAINS 200000L

/* sin and cos of q + d into out from those of q, as the pair's stages take them (stage_trig, here
 * for the first angle; y, the angle q + d, is what libm would be given beyond TRIG_SHIFT_MAX) */
static void shifted_trig(double s, double c, double d, double *out)
{
    double trig0[MODEL_NTRIG] = {0}, dy[MODEL_NSTATE] = {0}, y[MODEL_NSTATE] = {0}, trig[MODEL_NTRIG];
    trig0[0] = s;
    trig0[1] = c;
    dy[0] = d;
    stage_trig(trig0, dy, y, trig);
    out[0] = trig[0];
    out[1] = trig[1];
}

/* A deterministic pseudo-random number in [0, 1) (a 64-bit linear congruential generator). */
static double next_uniform(unsigned long long *state)
{
    *state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*state >> 11) * 0x1p-53;
}

int main(void)
{
    unsigned long long state = 1;
    double worst = 0.0, worst_libm = 0.0;
    for (long n = 0; n < SAMPLES; ++n) {
        const double q = (next_uniform(&state) - 0.5) * 20.0;
        /* |d| from TRIG_SHIFT_MAX down over 12 decades, both series and their boundary */
        const double d = (next_uniform(&state) - 0.5) * 2.0 * TRIG_SHIFT_MAX * pow(10.0, -12.0 * next_uniform(&state));
        double out[2];
        shifted_trig(sin(q), cos(q), d, out);
        const long double exact = (long double)q + (long double)d;  /* exact: the 64-bit mantissa holds it */
        const double err = fmax(fabsl(out[0] - sinl(exact)), fabsl(out[1] - cosl(exact)));
        const double y = q + d;  /* libm at the angle rounded to a double, as the stage state holds it */
        const double err_libm = fmax(fabsl(sin(y) - sinl(exact)), fabsl(cos(y) - cosl(exact)));
        worst = fmax(worst, err);
        worst_libm = fmax(worst_libm, err_libm);
    }
    printf("shift %.3f, libm at the rounded angle %.3f (units of 2^-52, worst of %ld)\n", worst / 0x1p-52,
           worst_libm / 0x1p-52, SAMPLES);
    if (!(worst <= ABS_LIMIT)) {
        printf("trig shift: error %.3g beyond %.3g\n", worst, ABS_LIMIT);
        return 1;
    }
    /* a step's end shifted from its start's, TRIG_CHAIN_MAX steps in a row (dopri5.c, attempt) */
    double worst_chain = 0.0;
    for (long n = 0; n < CHAINS; ++n) {
        double q = (next_uniform(&state) - 0.5) * 20.0, sc[2] = {sin(q), cos(q)};
        long double exact = q;
        for (int j = 0; j < TRIG_CHAIN_MAX; ++j) {
            const double d = (next_uniform(&state) - 0.5) * 2.0 * TRIG_SHIFT_MAX * pow(10.0, -6.0 * next_uniform(&state));
            const double q1 = q + d, dq = q1 - q;  /* as attempt() takes it: the end point's angle less the start's */
            shifted_trig(sc[0], sc[1], dq, sc);
            exact += dq;
            q = q1;
        }
        worst_chain = fmax(worst_chain, fmax(fabsl(sc[0] - sinl(exact)), fabsl(sc[1] - cosl(exact))));
    }
    printf("chain of %d shifts %.3f (units of 2^-52, worst of %ld)\n", TRIG_CHAIN_MAX, worst_chain / 0x1p-52, CHAINS);
    if (!(worst_chain <= CHAIN_LIMIT)) {
        printf("trig shift: a chain's error %.3g beyond %.3g\n", worst_chain, CHAIN_LIMIT);
        return 1;
    }
    /* the trig entry points give the plain ones' results bit for bit */
    model_params p;
    memset(&p, 0, sizeof p);
    p.L1 = 0.3;
    p.L2 = 0.2;
    p.m1 = 1.0;
    p.m2 = 0.5;
    p.g = 9.81;
    p.y_s = -0.45;
    p.mu = 0.3;
    p.eps = 1e-6;
    p.E_star = 1e11;
    p.R = 0.01;
    p.phase = MODEL_PHASE_ELASTIC;  /* about half of the states below are in contact */
    for (long n = 0; n < 1000; ++n) {
        double y[MODEL_NSTATE], trig[MODEL_NTRIG], a[MODEL_NSTATE], b[MODEL_NSTATE], ea[MODEL_NEVENT], eb[MODEL_NEVENT];
        for (int i = 0; i < MODEL_NSTATE; ++i) y[i] = (next_uniform(&state) - 0.5) * 10.0;
        model_trig(y, trig);
        const int fa = model_rhs(0.0, y, a, &p), fb = model_rhs_trig(0.0, y, trig, b, &p);
        model_events(0.0, y, ea, &p);
        model_events_trig(0.0, y, trig, eb, &p);
        if (fa != fb || memcmp(a, b, sizeof a) != 0 || memcmp(ea, eb, sizeof ea) != 0) {
            printf("trig shift: model_rhs_trig or model_events_trig differs from the plain function\n");
            return 1;
        }
    }
    printf("trig shift: ok\n");
    return 0;
}
