/*
 * impact_driver.c: run a generated impact model with SUNDIALS CVODE and its phase machine,
 * in plain C: no Python. The loop every embedder writes: start the machine, integrate until
 * a watched event (CVODE's root finder keeps the directions), ask the machine what the event
 * does, restart. The scene's numbers come from the generated <prefix>_scene.h.
 *
 * Build (from the repository root; see examples/c/Makefile and docs/embedding.md):
 *     make -C examples/c MODEL=../../generated/paper-double-pendulum
 * Run:
 *     examples/c/impact_driver
 * It prints the run's summary as "name value" lines, in the units of `impactgen run`.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cvode_glue.h"
#include "model_scene.h"

#define CAPACITY 256  /* samples per call; the driver keeps only the last one */

typedef struct {
    double t_start, t_end, delta_max, P_max, delta_r, R_res, T_before, T_after;
} impact_record;

static double output(const model_params *p, double t, const double *y, int which)
{
    double out[MODEL_NOUT];
    model_outputs(t, y, out, p);
    return out[which];
}

int main(void)
{
    model_params p = {0};
    double y[MODEL_NSTATE], atol[MODEL_NSTATE], y_start[MODEL_NSTATE] = {0};
    const char *range = "";
    model_scene_inputs(&p, y);
    const int bad = model_derive(&p, &range);
    if (bad != MODEL_PARAMS_OK) {
        fprintf(stderr, "%s = %g is outside %s\n", model_param_key(bad), *model_param_slot(&p, bad), range);
        return 2;
    }
    model_machine m;
    double t = 0.0;
    const int start = model_machine_start(&m, &p, t, y, MODEL_SCENE_RUN_TO_TIME);
    if (start == MODEL_START_ALONG || start == MODEL_START_AWAY) {
        printf("status no-impact\n");
        return 0;
    }
    model_machine_atol(&m, &p, MODEL_SCENE_RTOL, MODEL_SCENE_ATOL, atol);
    char err[512];
    ig_solver *s = ig_solver_new(MODEL_SCENE_METHOD, MODEL_HAS_JACOBIAN, MODEL_SCENE_RTOL, atol,
                                 MODEL_SCENE_MAX_STEPS, err, (int)sizeof err);
    if (!s) {
        fprintf(stderr, "cannot create CVODE: %s\n", err);
        return 4;
    }
    static double t_buf[CAPACITY], y_buf[CAPACITY * MODEL_NSTATE];
    impact_record first = {0};
    int n_impacts = 0;
    if (start == MODEL_START_CONTACT) {
        first.t_start = t;
        first.T_before = output(&p, t, y, MODEL_OUT_T);
        for (int k = 0; k < MODEL_NSTATE; ++k) y_start[k] = y[k];
        n_impacts = 1;
    }
    const char *status = "ok";
    for (;;) {
        int events[MODEL_NEVENT], directions[MODEL_NEVENT], fired[MODEL_NEVENT];
        const int watched = model_machine_events(&m, events, directions);
        if (MODEL_HAS_JACOBIAN) ig_solver_use_jacobian(s, !model_machine_constrained(&m));
        if (ig_segment_start(s, &p, t, y, MODEL_SCENE_T_END, events, directions, watched) < 0) {
            status = "failed";
            break;
        }
        int flag, n = 0;
        do {
            flag = ig_segment_advance(s, t_buf, y_buf, NULL, CAPACITY, &n, fired);
            if (n > 0) {
                t = t_buf[n - 1];
                for (int k = 0; k < MODEL_NSTATE; ++k) y[k] = y_buf[(n - 1) * MODEL_NSTATE + k];
            }
        } while (flag == IG_BUFFER_FULL);
        if (flag < 0) {
            fprintf(stderr, "CVODE failed in %s at t = %g: %s\n", model_machine_state_name(m.state), t,
                    ig_solver_message(s));
            status = "failed";
            break;
        }
        if (flag != IG_ROOT) break;  /* the end time */
        const int act = model_machine_switch(&m, &p, t, y, fired);
        if (act & MODEL_ACT_IMPACT_BEGIN) {
            if (++n_impacts == 1) {
                first.t_start = t;
                first.T_before = output(&p, t, y, MODEL_OUT_T);
                for (int k = 0; k < MODEL_NSTATE; ++k) y_start[k] = y[k];
            }
        }
        if ((act & MODEL_ACT_MAX_COMPRESSION) && n_impacts == 1) {
            first.delta_max = m.delta_max;
            first.P_max = m.P_max;
            first.delta_r = m.delta_r;
            first.R_res = m.R_res;
        }
        if ((act & MODEL_ACT_IMPACT_END) && n_impacts == 1) {
            first.t_end = t;
            first.T_after = output(&p, t, y, MODEL_OUT_T);
        }
        if (act & MODEL_ACT_END) break;
        if (act & MODEL_ACT_TOLERANCES) {
            model_machine_atol(&m, &p, MODEL_SCENE_RTOL, MODEL_SCENE_ATOL, atol);
            ig_solver_set_atol(s, atol);
        }
    }
    ig_stats stats;
    ig_solver_stats(s, &stats);
    printf("scene %s\n", MODEL_SCENE_NAME);
    printf("status %s\n", status);
    printf("impacts %d\n", n_impacts);
    printf("t_final %.17g\n", t);
    printf("T0 %.17g\n", first.T_before);
    printf("Tf %.17g\n", first.T_after);
    printf("delta_max %.17g\n", first.delta_max);
    printf("delta_r %.17g\n", first.delta_r);
    printf("P_max %.17g\n", first.P_max);
    printf("R_res %.17g\n", first.R_res);
    printf("t_contact %.17g\n", first.t_end - first.t_start);
    for (int i = 0; i < MODEL_NQ; ++i) printf("q_final[%d] %.17g\n", i + 1, y[i]);
    for (int i = 0; i < MODEL_NQ; ++i) printf("u_final[%d] %.17g\n", i + 1, y[MODEL_NQ + i]);
    printf("W_normal %.17g\n", y[2 * MODEL_NQ] - y_start[2 * MODEL_NQ]);
    if (MODEL_NSTATE > 2 * MODEL_NQ + 1) printf("W_friction %.17g\n", y[MODEL_NSTATE - 1] - y_start[MODEL_NSTATE - 1]);
    printf("steps %ld\n", stats.nsteps);
    ig_solver_free(s);
    return strcmp(status, "ok") == 0 ? 0 : 4;
}
