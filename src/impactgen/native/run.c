/*
 * run.c: the generated phase machine's run, segment after segment (ig_run_begin, ig_run in
 * solver.h): the one driver of the machine, for the Python engine, the C driver and the
 * FMU's Co-Simulation step.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "solver_state.h"

/* Begin the machine's next segment at (t, y): its events, its Jacobian, its tolerances. */
static int begin_segment(ig_solver *s, const model_machine *m, const model_params *p, double t,
                         const double *y, double t_stop)
{
    int events[MODEL_NEVENT], directions[MODEL_NEVENT];
    const int watched = model_machine_events(m, events, directions);
    if (s->analytic && ig_solver_use_jacobian(s, !model_machine_constrained(m)) != 0) return IG_ERR_SOLVER;
    return ig_segment_start(s, p, t, y, t_stop, events, directions, watched);
}

/* Write the step just taken, ending at (t, y), as the next sample with its outputs. */
static int write_sample(ig_solver *s, const model_params *p, double t, const double *y, double *t_buf,
                        double *y_buf, double *out_buf, double *dense_buf, int *n_written)
{
    const int k = *n_written;
    if (ig_solver_write_sample(s, t, y, k, t_buf, y_buf, dense_buf) != 0) return IG_ERR_SOLVER;
    model_outputs(t, y, out_buf + (size_t)k * MODEL_NOUT, p);
    (*n_written)++;
    return 0;
}

/* The floor net (model_machine_below): 1, with the message naming the point, when a joint or the
 * tip is below the surface at (t, y) by more than the contact-scale depth; else 0. Checked
 * after every accepted step: a sine per link, against a step's dozen. */
static int under_floor(ig_solver *s, const model_params *p, double t, const double *y)
{
    double depth = 0.0;
    const int point = model_machine_below(p, y, &depth);
    if (point == 0) return 0;
    char name[32];
    if (point < MODEL_NQ) snprintf(name, sizeof name, "joint %d", point);
    else if (point > MODEL_NQ) snprintf(name, sizeof name, "the base point");  /* a free chain's, after the tip */
    else snprintf(name, sizeof name, "the tip");
    snprintf(s->message, sizeof s->message,
             "%s is %.3g m below the surface at t = %.6g s (deeper than %g %% of the shortest link, "
             "beyond any contact's depth): the chain went through the surface",
             name, depth, t, 100.0 * MODEL_FLOOR_DEPTH);
    return 1;
}

/* The most switch records one switch writes: one per contact point. */
#define SWITCH_RECORDS MODEL_NCONTACT


/* After a switch at (t, sample) that `event` began (the first watched one that fired): a
 * record of each point whose switch acted, in point order, followed in the tally. `params`:
 * those the ended segment ran under. Returns 1 when the records do not fit. */
static int record_switch(const model_machine *m, const model_params *params, double t, long sample, int event,
                         ig_segment *segments, int segment_capacity, int *n_segments, ig_tally *tally,
                         const double *t_buf, const double *y_buf, const double *out_buf)
{
    for (int k = 0; k < MODEL_NCONTACT; ++k) {
        if (!m->point[k].act) continue;
        if (*n_segments >= segment_capacity) return 1;
        ig_segment *rec = &segments[(*n_segments)++];
        ig_record_point(rec, m, k, t, sample, event);
        rec->params = *params;
        if (tally) ig_tally_segment(tally, rec, t_buf, y_buf, out_buf);
    }
    return 0;
}

/* ig_run's loop over the segments (solver.h); ig_run then notes its last sample in the
 * tally, whichever way the loop returned. */
static int run_machine(ig_solver *s, model_machine *m, model_params *p, double *t, double *y, double t_stop,
                       double t_target, double atol, long max_segments, int every_step, double *t_buf,
                       double *y_buf, double *out_buf, double *dense_buf, int capacity, int *n_written,
                       ig_segment *segments, int segment_capacity, int *n_segments, ig_tally *tally)
{
    int roots_found[MODEL_NEVENT];
    double atol_now[MODEL_NSTATE];
    long begun = 0;
    *n_segments = 0;
    if (capacity < 1 || segment_capacity < SWITCH_RECORDS || *n_written < 0 || *n_written >= capacity) {
        ig_solver_say(s, "ig_run: the buffers must have room for a sample and a segment (*n_written: "
                         "the samples already in them, 0 for emptied buffers)");
        return IG_ERR_USAGE;
    }
    if (under_floor(s, p, *t, y)) return IG_ERR_UNDER_FLOOR;
    if (!s->root_pending && *t >= t_target) return IG_TARGET;
    for (;;) {
        int flag;
        if (s->root_pending) {  /* the last call's last step ended at a root beyond its t_target */
            s->root_pending = 0;
            memcpy(roots_found, s->pending_roots, sizeof roots_found);
            flag = IG_ROOT;
            if (write_sample(s, p, *t, y, t_buf, y_buf, out_buf, every_step ? dense_buf : NULL, n_written) != 0) {
                return IG_ERR_SOLVER;
            }
        } else {
            if (!s->active) {
                if (*n_segments + SWITCH_RECORDS > segment_capacity) return IG_SEGMENTS_FULL;
                if (!every_step && *n_written >= capacity) return IG_BUFFER_FULL;
                if (begun++ >= max_segments) {
                    ig_solver_say(s, "too many phase switches");
                    return IG_ERR_SEGMENTS;
                }
                const int started = begin_segment(s, m, p, *t, y, t_stop);
                if (started < 0) return started;
            }
            do {
                if (every_step && *n_written >= capacity) return IG_BUFFER_FULL;
                flag = ig_solver_step(s, t, y, roots_found);
                if (flag < 0) return flag;
                model_machine_observe(m, p, *t, y);
                if (under_floor(s, p, *t, y)) {  /* the step is kept as the last sample */
                    s->active = 0;
                    if (write_sample(s, p, *t, y, t_buf, y_buf, out_buf, every_step ? dense_buf : NULL,
                                     n_written) != 0) {
                        return IG_ERR_SOLVER;
                    }
                    return IG_ERR_UNDER_FLOOR;
                }
                if (flag == IG_ROOT && *t > t_target) {  /* switched at the next call, after t_target */
                    memcpy(s->pending_roots, roots_found, sizeof roots_found);
                    s->root_pending = 1;
                    return IG_TARGET;
                }
                if (every_step || flag != IG_STEPPED) {
                    if (write_sample(s, p, *t, y, t_buf, y_buf, out_buf, every_step ? dense_buf : NULL,
                                     n_written) != 0) {
                        return IG_ERR_SOLVER;
                    }
                }
                if (flag == IG_STEPPED && *t >= t_target) return IG_TARGET;
            } while (flag == IG_STEPPED);
        }
        if (model_machine_stick_missed(m, p)) {
            ig_solver_say(s, "the stuck tip needed a friction force beyond mu F and no slip event "
                             "fired; tighten solver.rtol");
            return IG_ERR_STICK;
        }
        if (flag == IG_REACHED_END) return IG_REACHED_END;  /* t_stop: no switch, no record */
        int event = -1;
        for (int k = 0; k < s->nevents && event < 0; ++k) {
            if (roots_found[k]) event = s->events[k];
        }
        const model_params ran_under = *p;  /* the switch changes some */
        const int act = model_machine_switch(m, p, *t, y, roots_found);
        if (record_switch(m, &ran_under, *t, *n_written - 1, event, segments, segment_capacity, n_segments, tally,
                          t_buf, y_buf, out_buf) != 0) {
            ig_solver_say(s, "ig_run: no room for a switch's records (segment_capacity)");
            return IG_ERR_USAGE;
        }
        if (act & MODEL_ACT_END) return IG_RUN_DONE;
        if (act & MODEL_ACT_TOLERANCES) {
            model_machine_atol(m, p, s->rtol, atol, atol_now);
            if (ig_solver_set_atol(s, atol_now) != 0) return IG_ERR_USAGE;
        }
        if (*t >= t_target) return IG_TARGET;
    }
}

int ig_run_begin(ig_solver *s, model_machine *m, model_params *p, double t0, const double *y0, int run_to_time,
                 double rtol, double atol, long max_steps, double *atol_now,
                 double *t_buf, double *y_buf, double *out_buf, ig_tally *tally)
{
    memcpy(y_buf, y0, sizeof(double) * MODEL_NSTATE);
    t_buf[0] = t0;
    const int start = model_machine_start(m, p, t0, y_buf, run_to_time);
    model_outputs(t0, y_buf, out_buf, p);
    ig_tally_start(tally, m, t0, y_buf, out_buf);
    if (start == MODEL_START_ALONG || start == MODEL_START_AWAY) return start;
    model_machine_atol(m, p, rtol, atol, atol_now);
    const int flag = ig_solver_reset(s, rtol, atol_now, max_steps);
    return flag != 0 ? flag : start;
}

int ig_run(ig_solver *s, model_machine *m, model_params *p, double *t, double *y, double t_stop, double t_target,
           double atol, long max_segments, int every_step,
           double *t_buf, double *y_buf, double *out_buf, double *dense_buf, int capacity, int *n_written,
           ig_segment *segments, int segment_capacity, int *n_segments, ig_tally *tally)
{
    const int flag = run_machine(s, m, p, t, y, t_stop, t_target, atol, max_segments, every_step, t_buf, y_buf,
                                 out_buf, dense_buf, capacity, n_written, segments, segment_capacity, n_segments,
                                 tally);
    if (tally && *n_written > 0) {
        const long k = *n_written - 1;
        ig_read_point(&tally->last, t_buf[k], y_buf + (size_t)k * MODEL_NSTATE, out_buf + (size_t)k * MODEL_NOUT);
    }
    return flag;
}
