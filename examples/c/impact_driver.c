/*
 * impact_driver.c: run a generated impact model with SUNDIALS CVODE and its phase machine,
 * in plain C: no Python. The machine's loop (integrate until a watched event, CVODE's root
 * finder keeping the directions; ask the machine what the event does; restart) is ig_run in
 * the CVODE glue, the same loop impactgen's Python wrapper calls. The scene's numbers come
 * from the generated <prefix>_scene.h.
 *
 * Build (from the repository root; see examples/c/Makefile and docs/embedding.md):
 *     make -C examples/c MODEL=../../generated/paper-double-pendulum
 * Run:
 *     examples/c/impact_driver              # the run's summary as "name value" lines
 *     examples/c/impact_driver --repeat 500 # and the wall time per run, warm (impactgen bench)
 * The summary is in the units of `impactgen run`.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "solver.h"
#include "model_scene.h"

/* the analytic Jacobian, when the model has one and the method is implicit */
#define USE_JACOBIAN (MODEL_HAS_JACOBIAN && IG_METHOD_USES_JACOBIAN(MODEL_SCENE_METHOD))
#define CAPACITY 64  /* segments (and their end samples) per call of ig_run */
#define MAX_SEGMENTS 100000L  /* phase switches in one run: beyond this, stop rather than hang */

typedef struct {
    const char *status;
    double t;
    double y[MODEL_NSTATE];
    ig_summary summary;  /* the run's (to a time) or its first impact's (to separation) */
} run_result;

/* One run of the scene from its start on solver s: begun (ig_run_begin: the machine started,
 * the solver reset with the scene's tolerances), then the phase machine's loop in one call
 * (ig_run), its summary tallied on the way (ig_summarize), as impactgen's Python wrapper
 * does. Only segment ends are sampled. */
static void run_scene(ig_solver *s, const model_params *inputs, const double *y0, run_result *r)
{
    double t_buf[CAPACITY], y_buf[CAPACITY * MODEL_NSTATE], out_buf[CAPACITY * MODEL_NOUT];
    ig_segment segments[CAPACITY];
    ig_tally tally;
    ig_summary run, first;
    model_params p = *inputs;
    double atol[MODEL_NSTATE];
    model_machine m;
    r->status = "ok";
    r->t = 0.0;
    memcpy(r->y, y0, sizeof r->y);
    const int start = ig_run_begin(s, &m, &p, r->t, r->y, MODEL_SCENE_RUN_TO_TIME, MODEL_SCENE_RTOL, MODEL_SCENE_ATOL,
                                   MODEL_SCENE_MAX_STEPS, atol, t_buf, y_buf, out_buf, &tally);
    if (start < 0) fprintf(stderr, "cannot begin the run: %s\n", ig_solver_message(s));
    if (start == MODEL_START_ALONG || start == MODEL_START_AWAY || start < 0) {
        r->status = start < 0 ? "failed" : "no-impact";
        ig_summarize(&tally, &r->summary, &first);
        return;
    }
    long begun = 0;
    int n = 1;  /* ig_run_begin wrote the start as sample 0 */
    for (;;) {
        int n_segments = 0;
        const int flag = ig_run(s, &m, &p, &r->t, r->y, MODEL_SCENE_T_END, MODEL_SCENE_T_END, MODEL_SCENE_ATOL, MAX_SEGMENTS - begun,
                                0, t_buf, y_buf, out_buf, NULL, CAPACITY, &n, segments, CAPACITY, &n_segments, &tally);
        begun += n_segments;
        n = 0;  /* the next call writes into emptied buffers */
        if (flag == IG_BUFFER_FULL || flag == IG_SEGMENTS_FULL) continue;
        if (flag < 0) {
            fprintf(stderr, "the integrator failed in %s at t = %g: %s\n", model_machine_state_name(m.state), r->t,
                    ig_solver_message(s));
            r->status = "failed";
        }
        ig_summarize(&tally, &run, &first);
        r->summary = MODEL_SCENE_RUN_TO_TIME || flag < 0 ? run : first;
        return;
    }
}

int main(int argc, char **argv)
{
    model_params p = {0};
    double y0[MODEL_NSTATE], atol[MODEL_NSTATE];
    const char *range = "";
    const long repeat = argc == 3 && strcmp(argv[1], "--repeat") == 0 ? strtol(argv[2], NULL, 10) : 0;
    model_scene_inputs(&p, y0);
    const int bad = model_derive(&p, &range);
    if (bad != MODEL_PARAMS_OK) {
        fprintf(stderr, "%s = %g is outside %s\n", model_param_key(bad), *model_param_slot(&p, bad), range);
        return 2;
    }
    for (int k = 0; k < MODEL_NSTATE; ++k) atol[k] = MODEL_SCENE_ATOL;
    char err[512];
    ig_solver *s = ig_solver_new(MODEL_SCENE_METHOD, USE_JACOBIAN, MODEL_SCENE_RTOL, atol,
                                 MODEL_SCENE_MAX_STEPS, err, (int)sizeof err);
    if (!s) {
        fprintf(stderr, "cannot create CVODE: %s\n", err);
        return 4;
    }
    run_result r;
    run_scene(s, &p, y0, &r);
    ig_stats stats;
    ig_solver_stats(s, &stats);
    if (repeat > 0) {  /* warm runs on the same solver, each reset by ig_run_begin (as a warm Python process reuses one) */
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        for (long k = 0; k < repeat; ++k) run_scene(s, &p, y0, &r);
        clock_gettime(CLOCK_MONOTONIC, &b);
        printf("ms_per_run %.6f\n", ((b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) * 1e-6) / (double)repeat);
    }
    const ig_summary *sum = &r.summary;
    printf("scene %s\n", MODEL_SCENE_NAME);
    printf("status %s\n", r.status);
    printf("impacts %d\n", sum->impacts);
    printf("t_final %.17g\n", sum->t_final);
    printf("T0 %.17g\n", sum->T0);
    printf("Tf %.17g\n", sum->Tf);
    printf("delta_max %.17g\n", sum->delta_max);
    printf("delta_r %.17g\n", sum->delta_r);
    printf("P_max %.17g\n", sum->P_max);
    printf("R_res %.17g\n", sum->R_res);
    printf("t_contact %.17g\n", sum->t_contact);
    for (int i = 0; i < MODEL_NQ; ++i) printf("q_final[%d] %.17g\n", i + 1, sum->y_final[i]);
    for (int i = 0; i < MODEL_NQ; ++i) printf("u_final[%d] %.17g\n", i + 1, sum->y_final[MODEL_NQ + i]);
    printf("W_normal %.17g\n", sum->W_normal);
#ifdef MODEL_Y_W_friction
    printf("W_friction %.17g\n", sum->W_friction);
#endif
    printf("W_gravity %.17g\n", sum->W_gravity);
    printf("steps %ld\n", stats.nsteps);
    ig_solver_free(s);
    return strcmp(r.status, "ok") == 0 || strcmp(r.status, "no-impact") == 0 ? 0 : 4;
}
