/*
 * dopri5_driver.c: the plain-C Dormand-Prince pair (src/impactgen/native/dopri5.c) on textbook
 * problems with known answers, built alone (no model, no SUNDIALS) by tests/test_integrator.py,
 * which reads the printed "name value" lines and checks them.
 *
 *   harmonic_fixed_<N>: the error at t = 2 pi of y'' = -y (y = cos t) in N equal steps
 *   kepler_fixed_<N>: the error after one period of Kepler's problem (eccentricity 0.5) in N steps
 *   kepler_rtol_<r>: the same with the step-size control at rtol r, and its steps
 *   dense_mid_<h>: the continuous extension's error at the middle of one step of size h of y'' = -y
 *   taylor_vs_interpolate: the largest difference of the Taylor rows from the extension in a step
 *   ball_*: a ball dropped from 1 m: the root found, its tolerance, and the state after the root
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "dopri5.h"

#define PI 3.14159265358979323846
#define G 9.81
#define DROP 1.0  /* m */

static int harmonic(double t, const double *y, double *f, void *user)
{
    (void)t; (void)user;
    f[0] = y[1];
    f[1] = -y[0];
    return 0;
}

static int kepler(double t, const double *y, double *f, void *user)
{
    (void)t; (void)user;
    const double r2 = y[0] * y[0] + y[1] * y[1], r3 = r2 * sqrt(r2);
    f[0] = y[2];
    f[1] = y[3];
    f[2] = -y[0] / r3;
    f[3] = -y[1] / r3;
    return 0;
}

static int ball(double t, const double *y, double *f, void *user)
{
    (void)t; (void)user;
    f[0] = y[1];
    f[1] = -G;
    return 0;
}

static void height(double t, const double *y, double *g, void *user)
{
    (void)t; (void)user;
    g[0] = y[0];
}

/* n equal steps of size span / n from (0, y): each a segment of one step (t_stop one step
 * ahead, the first step capped there by h_hint, tolerances loose enough to accept it). */
static void fixed_steps(ig_dopri5 *r, double *y, double span, int n)
{
    const double atol[4] = {1.0, 1.0, 1.0, 1.0}, h = span / n;
    double t = 0.0;
    int roots[1];
    for (int k = 0; k < n; ++k) {
        const double t_next = (k + 1 == n) ? span : (k + 1) * h;
        ig_dopri5_start(r, t, y, t_next, 1.0, atol, NULL, 0, t_next - t);
        if (ig_dopri5_step(r, roots) != IG_DOPRI5_STOP) printf("fixed_step_failed 1\n");
        t = r->t;
        memcpy(y, r->y, sizeof(double) * (size_t)r->n);
    }
}

static void kepler_start(double *y)
{
    const double e = 0.5;  /* perihelion on the x axis, unit semi-major axis: period 2 pi */
    y[0] = 1.0 - e;
    y[1] = 0.0;
    y[2] = 0.0;
    y[3] = sqrt((1.0 + e) / (1.0 - e));
}

static double kepler_error(const double *y)
{
    double y0[4], e = 0.0;
    kepler_start(y0);
    for (int i = 0; i < 4; ++i) e = fmax(e, fabs(y[i] - y0[i]));
    return e;
}

int main(void)
{
    ig_dopri5 r;
    int roots[1];

    ig_dopri5_init(&r, 2, 0, harmonic, NULL, NULL);
    for (int n = 20; n <= 160; n *= 2) {
        double y[2] = {1.0, 0.0};
        fixed_steps(&r, y, 2.0 * PI, n);
        printf("harmonic_fixed_%d %.17g\n", n, fmax(fabs(y[0] - 1.0), fabs(y[1])));
    }
    /* the continuous extension in the middle of one step from the exact start, y = cos t */
    for (double h = 0.4; h > 0.04; h /= 2.0) {
        const double y0[2] = {1.0, 0.0}, atol[2] = {1.0, 1.0};
        double mid[2];
        ig_dopri5_start(&r, 0.0, y0, h, 1.0, atol, NULL, 0, h);
        ig_dopri5_step(&r, roots);
        ig_dopri5_interpolate(&r, 0.5 * h, mid);
        printf("dense_mid_%.3f %.17g\n", h, fmax(fabs(mid[0] - cos(0.5 * h)), fabs(mid[1] + sin(0.5 * h))));
    }
    /* the Taylor rows at the step's end give the extension anywhere in the step */
    {
        const double y0[2] = {1.0, 0.0}, atol[2] = {1e-9, 1e-9};
        double rows[IG_DOPRI5_DENSE_TERMS * 2], worst = 0.0;
        ig_dopri5_start(&r, 0.0, y0, 10.0, 1e-9, atol, NULL, 0, 0.0);
        for (int k = 0; k < 5; ++k) ig_dopri5_step(&r, roots);
        ig_dopri5_taylor(&r, rows);
        for (int j = 0; j <= 8; ++j) {
            const double t = r.t_old + r.h_old * j / 8.0, d = t - r.t;
            double y[2];
            ig_dopri5_interpolate(&r, t, y);
            for (int i = 0; i < 2; ++i) {
                double p = 0.0;
                for (int m = IG_DOPRI5_DENSE_TERMS - 1; m >= 0; --m) p = p * d + rows[m * 2 + i];
                worst = fmax(worst, fabs(p - y[i]));
            }
        }
        printf("taylor_vs_interpolate %.17g\n", worst);
    }
    ig_dopri5_free(&r);

    ig_dopri5_init(&r, 4, 0, kepler, NULL, NULL);
    for (int n = 200; n <= 1600; n *= 2) {
        double y[4];
        kepler_start(y);
        fixed_steps(&r, y, 2.0 * PI, n);
        printf("kepler_fixed_%d %.17g\n", n, kepler_error(y));
    }
    for (int e = 6; e <= 12; e += 2) {
        const double rtol = pow(10.0, -e), atol[4] = {rtol, rtol, rtol, rtol};
        double y[4];
        kepler_start(y);
        ig_dopri5_start(&r, 0.0, y, 2.0 * PI, rtol, atol, NULL, 0, 0.0);
        int flag;
        while ((flag = ig_dopri5_step(&r, roots)) == IG_DOPRI5_STEPPED) {}
        printf("kepler_rtol_1e-%d %.17g\nkepler_steps_1e-%d %ld\n", e, flag == IG_DOPRI5_STOP ? kepler_error(r.y) : 1.0,
               e, r.nsteps);
    }
    ig_dopri5_free(&r);

    /* a ball dropped from DROP: the floor (height 0, falling) at sqrt(2 DROP / g) */
    ig_dopri5_init(&r, 2, 1, ball, height, NULL);
    {
        const double y0[2] = {DROP, 0.0}, atol[2] = {1e-10, 1e-10};
        const int falling = -1;
        ig_dopri5_start(&r, 0.0, y0, 10.0, 1e-10, atol, &falling, 1, 0.0);
        int flag;
        while ((flag = ig_dopri5_step(&r, roots)) == IG_DOPRI5_STEPPED) {}
        const double t_root = r.t, h_left = r.h;
        printf("ball_flag %d\nball_root_found %d\n", flag, roots[0]);
        printf("ball_t %.17g\nball_t_exact %.17g\n", t_root, sqrt(2.0 * DROP / G));
        printf("ball_tolerance %.17g\n", 100.0 * DBL_EPSILON * fmax(fabs(r.t), fabs(r.h_old)));
        printf("ball_height %.17g\nball_speed %.17g\n", r.y[0], r.y[1]);
        /* the rule after a root (dopri5.h): no step until a start; the extension holds up to the root */
        double y_at[2];
        ig_dopri5_interpolate(&r, t_root, y_at);
        printf("ball_after_root_step %d\n", ig_dopri5_step(&r, roots));
        printf("ball_interpolate_at_root %.17g\n", fmax(fabs(y_at[0] - r.y[0]), fabs(y_at[1] - r.y[1])));
        /* bounced (speed reversed) and started again at the root: back on the floor 2 v / g later */
        const double bounced[2] = {0.0, -r.y[1]};
        ig_dopri5_start(&r, t_root, bounced, 10.0, 1e-10, atol, &falling, 1, h_left);
        while ((flag = ig_dopri5_step(&r, roots)) == IG_DOPRI5_STEPPED) {}
        printf("ball_second_flag %d\nball_second_t %.17g\nball_second_exact %.17g\n", flag, r.t,
               t_root + 2.0 * bounced[1] / G);
    }
    ig_dopri5_free(&r);
    return 0;
}
