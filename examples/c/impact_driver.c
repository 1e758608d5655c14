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
 * The summary is in the units of `impactgen run`. After it, each impact by the point that
 * struck (the tip, or a joint when the model has contact at the joints), in order of its start:
 *     impact[3].point joint 2
 *     impact[3].t_start 0.12628647...    (and t_end, delta_max, delta_r, P_max)
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
#define MAX_LISTED 256  /* impacts listed by point (the summary counts them all) */

/* One impact of one point, from the segment records of its switches. */
typedef struct {
    int point;  /* MODEL_NQ: the tip; 1 to MODEL_NQ - 1: that joint (ig_segment.point) */
    double t_start, t_end, delta_max, delta_r, P_max;
} impact_line;

typedef struct {
    int n;                    /* impacts begun (the first MAX_LISTED are kept) */
    int open[MODEL_NQ + 1];   /* each point's impact going on: its index, or -1 */
    impact_line line[MAX_LISTED];
} impact_list;

typedef struct {
    const char *status;
    double t;
    double y[MODEL_NSTATE];
    ig_summary summary;  /* the run's (to a time) or its first impact's (to separation) */
} run_result;

/* A new impact of `point` at t. */
static void impact_begins(impact_list *list, int point, double t)
{
    list->open[point] = list->n < MAX_LISTED ? list->n : -1;
    if (list->n < MAX_LISTED) list->line[list->n] = (impact_line){point, t, NAN, NAN, NAN, NAN};
    list->n += 1;
}

/* Follow the impacts of every point through the switch records of one call of ig_run: one
 * record per point whose switch acted (seg->point). */
static void follow_impacts(impact_list *list, const ig_segment *segments, int n)
{
    for (int k = 0; k < n; ++k) {
        const ig_segment *seg = &segments[k];
        if (seg->act & MODEL_ACT_IMPACT_BEGIN) impact_begins(list, seg->point, seg->t);
        const int i = list->open[seg->point];
        if (i < 0) continue;
        if (seg->act & MODEL_ACT_MAX_COMPRESSION) {
            list->line[i].delta_max = seg->delta_max;
            list->line[i].delta_r = seg->delta_r;
            list->line[i].P_max = seg->P_max;
        }
        if (seg->act & MODEL_ACT_IMPACT_END) {
            list->line[i].t_end = seg->t;
            list->open[seg->point] = -1;
        }
    }
}

/* One run of the scene from its start on solver s: begun (ig_run_begin: the machine started,
 * the solver reset with the scene's tolerances), then the phase machine's loop in one call
 * (ig_run), its summary tallied on the way (ig_summarize), as impactgen's Python wrapper
 * does. Only segment ends are sampled. With `list`, the impacts by point go there. */
static void run_scene(ig_solver *s, const model_params *inputs, const double *y0, run_result *r, impact_list *list)
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
    if (list) {  /* the points in contact from the start */
        list->n = 0;
        for (int i = 0; i <= MODEL_NQ; ++i) list->open[i] = -1;
        for (int k = 0; k < MODEL_NCONTACT; ++k) {
            if (m.point[k].state != MODEL_MACHINE_FREE) impact_begins(list, model_point_number(k), r->t);
        }
    }
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
        if (list) follow_impacts(list, segments, n_segments);
        n = 0;  /* the next call writes into emptied buffers */
        if (flag == IG_BUFFER_FULL || flag == IG_SEGMENTS_FULL) continue;
        if (flag < 0) {
            fprintf(stderr, "the integrator failed in %s at t = %g: %s\n", model_machine_state_name(m.point[MODEL_TIP_POINT].state), r->t,
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
    /* values other than the scene's (set above model_derive) must keep out of the surface's reach
     * the joints the model has no contact for */
    const int pruned = model_pruned_reach(&p, y0);
    if (pruned != 0) {
        fprintf(stderr, "joint %d can reach the surface with these values, but the model was generated without "
                "contact at it (pruned): generate it from a scene with these values\n", pruned);
        return 2;
    }
    /* and every point of the chain must start on or above the surface (the scene checks' rule) */
    double depth = 0.0;
    const int inside = model_machine_start_inside(&p, y0, &depth);
    if (inside >= 0) {
#ifdef MODEL_FREE
        const char *base = "the base point";
#else
        const char *base = "the pivot";
#endif
        const char *where = inside == 0 ? base : (inside == MODEL_NQ ? "the tip" : "a joint");
        fprintf(stderr, "%s (point %d of the chain) starts %.3g m inside the surface: lower the surface or change "
                "the initial angles\n", where, inside, depth);
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
    impact_list impacts;
    run_scene(s, &p, y0, &r, &impacts);
    ig_stats stats;
    ig_solver_stats(s, &stats);
    if (repeat > 0) {  /* warm runs on the same solver, each reset by ig_run_begin (as a warm Python process reuses one) */
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        for (long k = 0; k < repeat; ++k) run_scene(s, &p, y0, &r, NULL);
        clock_gettime(CLOCK_MONOTONIC, &b);
        printf("ms_per_run %.6f\n", ((b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) * 1e-6) / (double)repeat);
    }
    const ig_summary *sum = &r.summary;
    printf("scene %s\n", MODEL_SCENE_NAME);
    printf("status %s\n", r.status);
    printf("impacts %d\n", sum->impacts);  /* at every point; then per point, by its number */
#ifdef MODEL_FREE
    const int first_counted = 0;  /* the base point */
#else
    const int first_counted = 1;  /* (a pinned chain's pivot is no contact point) */
#endif
    for (int k = first_counted; k <= MODEL_NQ; ++k) printf("point_impacts[%d] %d\n", k, sum->point_impacts[k]);
    printf("first_point %d\n", sum->first_point);
    printf("t_final %.17g\n", sum->t_final);
    printf("T0 %.17g\n", sum->T0);
    printf("Tf %.17g\n", sum->Tf);
    printf("delta_max %.17g\n", sum->delta_max);
    printf("delta_r %.17g\n", sum->delta_r);
    printf("P_max %.17g\n", sum->P_max);
    printf("R_res %.17g\n", sum->R_res);
    printf("t_contact %.17g\n", sum->t_contact);
    for (int i = 0; i < MODEL_NQ; ++i) printf("q_final[%d] %.17g\n", i + 1, sum->y_final[i]);
    for (int i = 0; i < MODEL_NQ; ++i) printf("u_final[%d] %.17g\n", i + 1, sum->y_final[MODEL_NDOF + i]);
#ifdef MODEL_FREE
    for (int i = 0; i < 2; ++i) printf("base_final[%d] %.17g\n", i + 1, sum->y_final[MODEL_NQ + i]);
#endif
    printf("W_normal %.17g\n", sum->W_normal);
#ifdef MODEL_Y_W_friction
    printf("W_friction %.17g\n", sum->W_friction);
#endif
    printf("W_gravity %.17g\n", sum->W_gravity);
    printf("steps %ld\n", stats.nsteps);
    for (int i = 0; i < impacts.n && i < MAX_LISTED; ++i) {
        const impact_line *line = &impacts.line[i];
        if (line->point == MODEL_NQ) printf("impact[%d].point tip\n", i + 1);
        else if (line->point == 0) printf("impact[%d].point base\n", i + 1);  /* a free chain's base point */
        else printf("impact[%d].point joint %d\n", i + 1, line->point);
        printf("impact[%d].t_start %.17g\n", i + 1, line->t_start);
        printf("impact[%d].t_end %.17g\n", i + 1, line->t_end);
        printf("impact[%d].delta_max %.17g\n", i + 1, line->delta_max);
        printf("impact[%d].delta_r %.17g\n", i + 1, line->delta_r);
        printf("impact[%d].P_max %.17g\n", i + 1, line->P_max);
    }
    ig_solver_free(s);
    return strcmp(r.status, "ok") == 0 || strcmp(r.status, "no-impact") == 0 ? 0 : 4;
}
