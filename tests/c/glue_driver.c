/*
 * glue_driver.c: exercise every path of the runtime (solver.h) with the paper's model, for
 * AddressSanitizer, UndefinedBehaviorSanitizer and LeakSanitizer (tests/test_memory.py,
 * scripts/sanitize.sh). Exits 0 when every path behaves as documented.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "solver.h"

#define COMMUNICATION_STEP 5e-5  /* s: where a Co-Simulation master would wake ig_run */

static int failures = 0;
#define EXPECT(cond, what) do { if (!(cond)) { printf("FAILED: %s\n", what); failures++; } } while (0)

static model_params paper_params(void)
{
    const double E = 210e9, nu = 0.29, S_y = 1.12e9, R = 0.005;
    const double E_star = E / (2.0 * (1.0 - nu * nu));
    const double C_j = 1.295 * exp(0.736 * nu);
    const double p0 = 3.14159265358979323846 * C_j * S_y / 2.0;
    model_params p;
    memset(&p, 0, sizeof p);
    p.L1 = 1.0; p.L2 = 1.0; p.m1 = 1.0; p.m2 = 1.0; p.g = 9.81;
    model_point_contact *tip = &p.point[MODEL_TIP_POINT];
    tip->y_s = sin(-70.0 * 3.14159265358979323846 / 180.0) + sin(-60.0 * 3.14159265358979323846 / 180.0);
    p.E_star = E_star; tip->R = R; p.C_j = C_j;
    tip->delta_c = R * (p0 / E_star) * (p0 / E_star);
    tip->P_c = 4.0 / 3.0 * (R / E_star) * (R / E_star) * p0 * p0 * p0;
    p.B = 0.14 * exp(23.0 * S_y / E_star);
    tip->inv_delta_c = 1.0 / tip->delta_c;
    tip->theta_c = 3.14159265358979323846 * sqrt(tip->delta_c / R) * exp(-p.B / 2.0 * log(1.9));
    tip->R_res = R; p.mu = 0.2; p.eps = 1e-6;
    tip->phase = MODEL_PHASE_ELASTIC;
    return p;
}

static void initial_state(double *y)
{
    memset(y, 0, sizeof(double) * MODEL_NSTATE);
    y[0] = -70.0 * 3.14159265358979323846 / 180.0;
    y[1] = -60.0 * 3.14159265358979323846 / 180.0;
    y[2] = -0.1;
    y[3] = -0.2;
}

/* A run of the paper's impact ready for ig_run: its parameters and machine started at t = 0,
 * and a solver of `method` (with the analytic Jacobian where the method uses one). */
static ig_solver *paper_run(int method, model_params *q, model_machine *m, double *y, const double *atol)
{
    char err[256];
    *q = paper_params();
    q->surface_height = q->point[MODEL_TIP_POINT].y_s;
    initial_state(y);
    model_machine_start(m, q, 0.0, y, 0);
    const int analytic = IG_METHOD_USES_JACOBIAN(method) ? MODEL_HAS_JACOBIAN : 0;
    return ig_solver_new(method, analytic, 1e-8, atol, 100000, err, sizeof err);
}

int main(void)
{
    char err[256];
    double atol[MODEL_NSTATE];
    for (int k = 0; k < MODEL_NSTATE; ++k) atol[k] = 1e-12;

    /* bad arguments: NULL with a message, nothing leaked */
    EXPECT(ig_solver_new(7, MODEL_HAS_JACOBIAN, 1e-8, atol, 1000, err, sizeof err) == NULL && err[0], "bad method refused");
    atol[0] = -1.0;
    EXPECT(ig_solver_new(0, MODEL_HAS_JACOBIAN, 1e-8, atol, 1000, err, sizeof err) == NULL && err[0], "bad atol refused");
    atol[0] = 1e-12;

    model_params p = paper_params();
    double y0[MODEL_NSTATE], t_buf[7], y_buf[7 * MODEL_NSTATE], out[7 * MODEL_NOUT];
    int n = 0, roots[MODEL_NEVENT];
    const int events[2] = {MODEL_EVENT_MAX_COMPRESSION, MODEL_EVENT_YIELD};
    const int dirs[2] = {-1, 1};
    initial_state(y0);

    /* a whole elastic phase through a 7-sample buffer: continuation, then the yield root */
    ig_solver *s = ig_solver_new(0, MODEL_HAS_JACOBIAN, 1e-10, atol, 100000, err, sizeof err);
    EXPECT(s != NULL, "solver created");
    EXPECT(ig_segment_advance(s, t_buf, y_buf, NULL, 7, &n, roots) == IG_ERR_USAGE, "advance before start refused");
    const int bad_event[1] = {99};
    EXPECT(ig_segment_start(s, &p, 0.0, y0, 1.0, bad_event, dirs, 1) == IG_ERR_USAGE, "bad event refused");
    EXPECT(ig_segment_start(s, &p, 0.0, y0, 0.0, events, dirs, 2) == IG_ERR_USAGE, "t_stop <= t0 refused");
    double contact_atol[MODEL_NSTATE];
    for (int k = 0; k < MODEL_NSTATE; ++k) contact_atol[k] = -1.0;
    EXPECT(ig_solver_set_atol(s, contact_atol) == IG_ERR_USAGE, "negative atol refused");
    for (int k = 0; k < MODEL_NSTATE; ++k) contact_atol[k] = 1e-14;
    EXPECT(ig_solver_set_atol(s, contact_atol) == 0, "contact atol accepted");
    EXPECT(ig_solver_use_jacobian(s, 0) == 0, "difference quotients selected");
    EXPECT(ig_solver_use_jacobian(s, 1) == (MODEL_HAS_JACOBIAN ? 0 : IG_ERR_USAGE),
           "analytic Jacobian selected only if the model has it");
    EXPECT(ig_segment_start(s, &p, 0.0, y0, 1.0, events, dirs, 2) == 0, "segment started");
    int flag, fills = 0;
    while ((flag = ig_segment_advance(s, t_buf, y_buf, NULL, 7, &n, roots)) == IG_BUFFER_FULL) {
        ig_outputs(&p, n, t_buf, y_buf, out);
        fills++;
    }
    EXPECT(fills > 0, "buffer filled and continued");
    EXPECT(flag == IG_ROOT && roots[1] != 0, "yield root found");
    ig_outputs(&p, n, t_buf, y_buf, out);
    EXPECT(fabs(out[(n - 1) * MODEL_NOUT + MODEL_OUT_delta] - 1.9 * p.point[MODEL_TIP_POINT].delta_c) < 1e-12, "root at 1.9 delta_c");
    ig_stats st;
    ig_solver_stats(s, &st);
    EXPECT(st.nsteps > 0 && st.nfev > 0, "statistics counted");

    /* reuse for a new run: the same segment again gives the same steps, counted afresh */
    const double t_root = t_buf[n - 1];
    EXPECT(ig_solver_reset(s, -1.0, atol, 100000) == IG_ERR_USAGE, "reset with rtol <= 0 refused");
    EXPECT(ig_solver_reset(s, 1e-10, contact_atol, 100000) == 0, "solver reset");
    ig_stats cleared;
    ig_solver_stats(s, &cleared);
    EXPECT(cleared.nsteps == 0 && cleared.nfev == 0, "reset clears the counters");
    EXPECT(ig_segment_start(s, &p, 0.0, y0, 1.0, events, dirs, 2) == 0, "segment started after reset");
    while ((flag = ig_segment_advance(s, t_buf, y_buf, NULL, 7, &n, roots)) == IG_BUFFER_FULL) {}
    ig_stats again;
    ig_solver_stats(s, &again);
    EXPECT(flag == IG_ROOT && t_buf[n - 1] == t_root, "same root after reset");
    EXPECT(again.nsteps == st.nsteps && again.nfev == st.nfev, "same work after reset");
    ig_solver_free(s);

    /* too much work */
    s = ig_solver_new(0, MODEL_HAS_JACOBIAN, 1e-10, atol, 5, err, sizeof err);
    EXPECT(ig_segment_start(s, &p, 0.0, y0, 1.0, events, dirs, 2) == 0, "segment started (max_steps 5)");
    flag = ig_segment_advance(s, t_buf, y_buf, NULL, 7, &n, roots);
    EXPECT(flag == IG_ERR_TOO_MUCH_WORK && strstr(ig_solver_message(s), "max_steps"), "too much work reported");
    ig_solver_free(s);

    /* a right-hand side that is never finite: CVODE gives up, the message says so */
    model_params bad = p;
    bad.E_star = NAN;
    y0[0] -= 0.001;  /* start inside the surface so that the force is evaluated */
    s = ig_solver_new(0, MODEL_HAS_JACOBIAN, 1e-10, atol, 100000, err, sizeof err);
    EXPECT(ig_segment_start(s, &bad, 0.0, y0, 1.0, events, dirs, 2) == 0, "segment started (NaN)");
    do { flag = ig_segment_advance(s, t_buf, y_buf, NULL, 7, &n, roots); } while (flag == IG_BUFFER_FULL);
    EXPECT(flag == IG_ERR_SOLVER && ig_solver_message(s)[0], "solver failure reported");
    ig_solver_free(s);
    ig_solver_free(NULL);

    /* the phase machine's loop in one call (ig_run): summary only and every step, with
     * buffers small enough that both resume many times, end in the same state */
    double t_end_of[2], y_end_of[2][MODEL_NSTATE];
    int segments_of[2] = {0, 0};
    ig_summary run_of[2], first_of[2];
    const int methods[3] = {IG_METHOD_BDF, IG_METHOD_DOPRI5, IG_METHOD_AUTO};
    for (int which = 0; which < 3; ++which)
    for (int every = 0; every <= 1; ++every) {
        model_params q;
        model_machine m;
        ig_segment segs[1];
        double t = 0.0, y[MODEL_NSTATE];
        int n_seg = 0;
        ig_tally tally;
        s = paper_run(methods[which], &q, &m, y, atol);
        EXPECT(s != NULL, "solver for ig_run created");
        n = 0;
        EXPECT(ig_run(s, &m, &q, &t, y, 1.0, 1.0, 1e-12, 100, every, t_buf, y_buf, out, NULL, 0, &n, segs, 1, &n_seg,
                      NULL) == IG_ERR_USAGE && ig_solver_message(s)[0], "ig_run without room for a sample refused");
        n = 7;
        EXPECT(ig_run(s, &m, &q, &t, y, 1.0, 1.0, 1e-12, 100, every, t_buf, y_buf, out, NULL, 7, &n, segs, 1, &n_seg,
                      NULL) == IG_ERR_USAGE, "ig_run into full buffers refused (not a loop that never ends)");
        ig_outputs(&q, 1, &t, y, out);
        ig_tally_start(&tally, &m, t, y, out);  /* the points the machine started in contact: impacts */
        do {
            n = 0;  /* the buffers emptied before each call */
            flag = ig_run(s, &m, &q, &t, y, 1.0, 1.0, 1e-12, 100, every, t_buf, y_buf, out, NULL, every ? 7 : 1, &n,
                          segs, 1, &n_seg, &tally);
            segments_of[every] += n_seg;
            EXPECT(n_seg == 0 || segs[0].t == t_buf[segs[0].sample], "a segment's end is its last sample");
        } while (flag == IG_BUFFER_FULL || flag == IG_SEGMENTS_FULL);
        EXPECT(flag == IG_RUN_DONE, "ig_run runs to separation");
        t_end_of[every] = t;
        memcpy(y_end_of[every], y, sizeof y);
        ig_summarize(&tally, &run_of[every], &first_of[every]);
        EXPECT(first_of[every].impacts == 1 && first_of[every].n_switches == 3 && first_of[every].delta_r > 0.0
               && first_of[every].t_final == t && first_of[every].t_contact > 0.0 && isnan(first_of[every].t_sustained),
               "the tally follows the impact across resumed calls");
        EXPECT(fabs(first_of[every].residual) < 1e-6 * first_of[every].T0, "the impact's energy budget closes");
        ig_solver_free(s);
        if (every == 1) {
            EXPECT(segments_of[0] == 3 && segments_of[1] == 3, "three phases: elastic, elasto-plastic, restitution");
            EXPECT(t_end_of[0] == t_end_of[1] && memcmp(y_end_of[0], y_end_of[1], sizeof y_end_of[0]) == 0,
                   "summary-only and every-step runs take the same steps");
            EXPECT(memcmp(&first_of[0], &first_of[1], sizeof first_of[0]) == 0
                   && memcmp(&run_of[0], &first_of[0], sizeof run_of[0]) == 0,
                   "both give the same summary, the run's that of its one impact");
            segments_of[0] = segments_of[1] = 0;
        }
    }
    /* a caller woken at communication points (t_target, as the FMU's Co-Simulation step):
     * the same steps as a run without them, each point within the step that reached it */
    for (int which = 0; which < 3; ++which) {
        double t_plain = 0.0, y_plain[MODEL_NSTATE];
        for (int woken = 0; woken <= 1; ++woken) {
            model_params q;
            model_machine m;
            ig_segment segs[4];
            double t = 0.0, y[MODEL_NSTATE], y_at[MODEL_NSTATE];
            double target = woken ? COMMUNICATION_STEP : 1.0;
            int n_seg = 0, within = 1, points = 0;
            s = paper_run(methods[which], &q, &m, y, atol);
            for (;;) {
                n = 0;
                flag = ig_run(s, &m, &q, &t, y, 1.0, target, 1e-12, 100, 0, t_buf, y_buf, out, NULL, 7, &n, segs, 4,
                              &n_seg, NULL);
                if (flag == IG_BUFFER_FULL || flag == IG_SEGMENTS_FULL) continue;
                if (flag != IG_TARGET) break;
                within &= t >= target && (t == target || ig_interpolate(s, target, y_at) == 0);
                target += COMMUNICATION_STEP;
                ++points;
            }
            EXPECT(flag == IG_RUN_DONE, "ig_run woken at communication points runs to separation");
            if (!woken) {
                t_plain = t;
                memcpy(y_plain, y, sizeof y);
            } else {
                EXPECT(points > 3 && within, "each communication point lies within the step that reached it");
                EXPECT(t == t_plain && memcmp(y, y_plain, sizeof y) == 0, "communication points change no step");
            }
            ig_solver_free(s);
        }
    }
    {
        model_params q;
        model_machine m;
        ig_segment segs[4];
        double t = 0.0, y[MODEL_NSTATE];
        int n_seg = 0;
        s = paper_run(IG_METHOD_BDF, &q, &m, y, atol);
        n = 0;
        EXPECT(ig_run(s, &m, &q, &t, y, 1.0, 1.0, 1e-12, 1, 0, t_buf, y_buf, out, NULL, 7, &n, segs, 4, &n_seg, NULL)
               == IG_ERR_SEGMENTS && n_seg == 1, "ig_run stops at max_segments");
        ig_solver_free(s);
    }

    printf("%s (%d failures)\n", failures ? "FAIL" : "ok", failures);
    return failures ? 1 : 0;
}
