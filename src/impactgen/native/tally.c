/*
 * tally.c: the tallies of a run's summaries (tally.h), followed by ig_run segment by segment.
 * Every contact point's impacts make them: the first impact is the run's first at whichever
 * point, with that point's own values; the run's record is over every point's impacts.
 */
#include <math.h>
#include <string.h>

#include "tally.h"

/* (tally.h) */
int ig_point_index(int number)
{
    for (int k = 0; k < MODEL_NCONTACT; ++k) {
        if (model_point_number(k) == number) return k;
    }
    return MODEL_TIP_POINT;  /* (every record names a point of the machine) */
}

/* ---- impact coefficients (MODEL section 9): a point's own works, impulses and normal speed
 * at a sample, the first impact's maximum compression, and the coefficients from the three
 * samples ---- */
static void read_own(ig_point *point, int k, double t, const double *y, const double *out)
{
    ig_read_point(point, t, y, out);
    model_point_integrals(k, y, point->own);
    point->v_n = out[model_point_output(k, MODEL_POINT_V_Y)];
}

/* The values a summary reads at sample k of the buffers. */
void ig_read_point(ig_point *point, double t, const double *y, const double *out)
{
    point->t = t;
    point->T = out[MODEL_OUT_T];
    point->V = out[MODEL_OUT_V];
    point->W_normal = y[MODEL_Y_W_normal];
#ifdef MODEL_Y_W_friction
    point->W_friction = y[MODEL_Y_W_friction];
#else
    point->W_friction = 0.0;
#endif
    memcpy(point->y, y, sizeof point->y);
}

/* The first impact's impulses and coefficients, from its start, maximum compression and end
 * (its point's own values); NAN while it has not ended (or never reached maximum compression). */
static void summarize_coefficients(const ig_tally *a, ig_summary *out)
{
    enum { W_N, W_F, P_N, P_F };
    const double *b = a->first_begin.own, *m = a->first_max.own, *e = a->first_end.own;
    out->v_n0 = a->impacts ? a->first_begin.v_n : NAN;
    out->P_c = out->P_r = out->P_t = out->e_N = out->e_P = out->e_E = out->friction_share = NAN;
    if (!a->first_ended || !a->first_compressed) return;
    const double W_c = m[W_N] - b[W_N], W_r = e[W_N] - m[W_N];
    const double W_f = e[W_F] - b[W_F];
    out->P_c = m[P_N] - b[P_N];
    out->P_r = e[P_N] - m[P_N];
    out->P_t = e[P_F] - b[P_F];
    out->e_N = -a->first_end.v_n / a->first_begin.v_n;
    out->e_P = out->P_r / out->P_c;
    out->e_E = sqrt(W_r / -W_c);
    out->friction_share = W_f / (W_c + W_r + W_f) + 0.0;  /* + 0.0: no -0 without friction */
}

/* An impact of point k begins at `start`, at the sample (t, y, out): counted; the run's first
 * if none was. */
static void begin_impact(ig_tally *a, int k, double start, double t, const double *y, const double *out)
{
    const int number = model_point_number(k);
    a->impacts++;
    a->point_impacts[number]++;
    a->now[k] = (ig_impact_now){.start = start, .open = 1};
    if (a->first_k < 0) {
        a->first_k = k;
        a->first_point = number;
        read_own(&a->first_begin, k, t, y, out);
    }
}

void ig_tally_begin(ig_tally *tally, double t0, const double *y0, const double *out0)
{
    memset(tally, 0, sizeof *tally);
    tally->first_point = IG_NO_POINT;
    tally->first_k = -1;
    ig_read_point(&tally->start, t0, y0, out0);
    tally->last = tally->start;
    tally->t_sustained = NAN;
}

void ig_tally_start(ig_tally *tally, const model_machine *m, double t0, const double *y0, const double *out0)
{
    ig_tally_begin(tally, t0, y0, out0);
    for (int k = 0; k < MODEL_NCONTACT; ++k) {  /* the points in contact from the start, in point order */
        if (m->point[k].state != MODEL_MACHINE_FREE) begin_impact(tally, k, t0, t0, y0, out0);
    }
}

void ig_record_point(ig_segment *rec, const model_machine *m, int k, double t, long sample, int event)
{
    const model_point_machine *r = &m->point[k];
    rec->t = t;
    rec->sample = sample;
    rec->point = model_point_number(k);  /* its number in the chain */
    rec->event = event;
    rec->act = r->act;
    rec->state = r->was;
    rec->slip = r->was_slip;
    rec->next_state = r->state;
    rec->next_slip = r->slip;
    rec->delta_max = r->delta_max;
    rec->P_max = r->P_max;
    rec->delta_r = r->delta_r;
    rec->R_res = r->R_res;
}

/* Add an impact's record (`now`, of point `number`) to the run's: the largest delta_max and
 * P_max, the deepest dent (of equals, the one that began first, then in point order), its
 * contact time. */
static void fold_impact(ig_tally *a, const ig_impact_now *now, int number, double contact)
{
    if (now->delta_max > a->delta_max) a->delta_max = now->delta_max;
    if (now->P_max > a->P_max) a->P_max = now->P_max;
    const int deeper = now->delta_r > a->deepest_delta_r ||
        (now->delta_r == a->deepest_delta_r && (now->start < a->deepest_start ||
                                                (now->start == a->deepest_start && number < a->deepest_point)));
    if (a->ended++ == 0 || deeper) {
        a->deepest_delta_r = now->delta_r;
        a->deepest_R_res = now->R_res;
        a->deepest_start = now->start;
        a->deepest_point = number;
    }
    a->t_contact += contact;
}

/* Follow one switch record (at sample seg->sample of the buffers) in the tally: every point's
 * make the run's summaries, the first impact's point's make the first impact's. */
void ig_tally_segment(ig_tally *a, const ig_segment *seg, const double *t_buf, const double *y_buf,
                      const double *out_buf)
{
    const long i = seg->sample;
    const int k = ig_point_index(seg->point);
    const double *y = y_buf + (size_t)i * MODEL_NSTATE, *out = out_buf + (size_t)i * MODEL_NOUT;
    ig_impact_now *now = &a->now[k];
    if (seg->next_state == MODEL_MACHINE_SUSTAINED && seg->state != MODEL_MACHINE_SUSTAINED &&
        isnan(a->t_sustained)) {
        a->t_sustained = seg->t;
    }
    if (seg->act & MODEL_ACT_IMPACT_BEGIN) begin_impact(a, k, seg->t, t_buf[i], y, out);
    if (!now->open) return;  /* a flight before the point's first impact */
    const int in_first = k == a->first_k && !a->first_ended;
    if (seg->act & MODEL_ACT_MAX_COMPRESSION) {
        now->delta_max = seg->delta_max;
        now->P_max = seg->P_max;
        now->delta_r = seg->delta_r;
        now->R_res = seg->R_res;
        if (in_first) {  /* the first impact's maximum compression (the latest, after a reloading) */
            read_own(&a->first_max, k, t_buf[i], y, out);
            a->first_compressed = 1;
        }
    }
    if (in_first) {
        if (seg->act & MODEL_ACT_SLIP) a->first_stick_slip++;
        if (seg->state != MODEL_MACHINE_FREE && seg->next_state != seg->state) a->first_switches++;
    }
    if (seg->act & MODEL_ACT_IMPACT_END) {
#if MODEL_RATE_LAW
        now->delta_r = seg->delta_r;  /* a damped law lets go while penetrating: that depth */
#endif
        now->open = 0;
        fold_impact(a, now, seg->point, seg->t - now->start);
        if (in_first) {
            read_own(&a->first_end, k, t_buf[i], y, out);
            a->first_ended = 1;
            a->first_delta_max = now->delta_max;
            a->first_P_max = now->P_max;
            a->first_delta_r = now->delta_r;
            a->first_R_res = now->R_res;
        }
    }
}

/* A summary from sample `from` to sample `to` (the energies, the works, the end state). */
static void summarize_between(const ig_point *from, const ig_point *to, ig_summary *out)
{
    out->T0 = from->T;
    out->Tf = to->T;
    out->delta_T = from->T - to->T;
    memcpy(out->y_final, to->y, sizeof out->y_final);
    out->t_final = to->t;
    out->W_normal = to->W_normal - from->W_normal;
    out->W_friction = to->W_friction - from->W_friction;
    out->W_gravity = from->V - to->V;
    out->residual = (to->T - from->T) - (out->W_normal + out->W_friction + out->W_gravity);
}

/* What both summaries share: the first impact's start, switches and coefficients of
 * restitution, and the run's counts of impacts. */
static void summarize_first(const ig_tally *a, ig_summary *out)
{
    out->t_impact = a->impacts ? a->first_begin.t : NAN;
    out->n_switches = a->first_switches;
    out->n_stick_slip = a->first_stick_slip;
    out->impacts = a->impacts;
    memcpy(out->point_impacts, a->point_impacts, sizeof out->point_impacts);
    out->first_point = a->first_point;
    out->t_sustained = a->t_sustained;
    summarize_coefficients(a, out);
}

void ig_summarize(const ig_tally *a, ig_summary *run, ig_summary *first)
{
    ig_tally all = *a;
    for (int k = 0; k < MODEL_NCONTACT; ++k) {  /* the impacts still in contact, counted to the last sample */
        if (a->now[k].open) fold_impact(&all, &a->now[k], model_point_number(k), a->last.t - a->now[k].start);
    }
    memset(run, 0, sizeof *run);
    summarize_between(&a->start, &a->last, run);
    run->delta_max = all.delta_max;
    run->P_max = all.P_max;
    run->delta_r = all.deepest_delta_r;
    run->R_res = all.deepest_R_res;
    run->t_contact = all.t_contact;
    summarize_first(a, run);  /* the first impact's switches and coefficients, the run's counts */
    if (a->impacts == 0) {
        *first = *run;
        return;
    }
    memset(first, 0, sizeof *first);
    const int first_open = !a->first_ended;
    const ig_impact_now *now = &a->now[a->first_k];
    summarize_between(&a->first_begin, first_open ? &a->last : &a->first_end, first);
    first->delta_max = first_open ? now->delta_max : a->first_delta_max;
    first->P_max = first_open ? now->P_max : a->first_P_max;
    first->delta_r = first_open ? now->delta_r : a->first_delta_r;
    first->R_res = first_open ? now->R_res : a->first_R_res;
    first->t_contact = first_open ? 0.0 : a->first_end.t - a->first_begin.t;
    summarize_first(a, first);
}
