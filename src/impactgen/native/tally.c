/*
 * tally.c: the tallies of a run's summaries (tally.h), followed by ig_run segment by segment.
 */
#include <math.h>
#include <string.h>

#include "tally.h"

/* ---- impact coefficients (MODEL section 9): the tip's own works, impulses and normal speed at
 * a sample, the first impact's maximum compression, and the coefficients from the three
 * samples ---- */
static void read_tip(ig_point *point, const double *y, const double *out)
{
    model_tip_works(y, &point->W_normal_tip, &point->W_friction_tip);
    point->P_normal = y[MODEL_Y_P_normal];
#ifdef MODEL_Y_P_friction
    point->P_friction = y[MODEL_Y_P_friction];
#else
    point->P_friction = 0.0;
#endif
    point->v_n = out[MODEL_OUT_v_By];
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
    read_tip(point, y, out);
}

/* Follow the first impact's maximum compression (the latest, after a reloading). */
static void tally_coefficients(ig_tally *a, const ig_segment *seg, double t, const double *y, const double *out)
{
    if (a->impacts == 1 && a->ended == 0 && (seg->act & MODEL_ACT_MAX_COMPRESSION)) {
        ig_read_point(&a->first_max, t, y, out);
        a->first_compressed = 1;
    }
}

/* The first impact's impulses and coefficients, from its start, maximum compression and end;
 * NAN while it has not ended (or never reached maximum compression). */
static void summarize_coefficients(const ig_tally *a, ig_summary *out)
{
    const ig_point *b = &a->first_begin, *m = &a->first_max, *e = &a->first_end;
    out->v_n0 = a->impacts ? b->v_n : NAN;
    out->P_c = out->P_r = out->P_t = out->e_N = out->e_P = out->e_E = out->friction_share = NAN;
    if (a->ended == 0 || !a->first_compressed) return;
    const double W_c = m->W_normal_tip - b->W_normal_tip, W_r = e->W_normal_tip - m->W_normal_tip;
    const double W_f = e->W_friction_tip - b->W_friction_tip;
    out->P_c = m->P_normal - b->P_normal;
    out->P_r = e->P_normal - m->P_normal;
    out->P_t = e->P_friction - b->P_friction;
    out->e_N = -e->v_n / b->v_n;
    out->e_P = out->P_r / out->P_c;
    out->e_E = sqrt(W_r / -W_c);
    out->friction_share = W_f / (W_c + W_r + W_f) + 0.0;  /* + 0.0: no -0 without friction */
}

void ig_tally_begin(ig_tally *tally, double t0, const double *y0, const double *out0, int in_contact)
{
    memset(tally, 0, sizeof *tally);
    tally->first_point = IG_NO_POINT;
    ig_read_point(&tally->start, t0, y0, out0);
    tally->last = tally->start;
    tally->t_sustained = NAN;
    if (in_contact) {
        tally->first_point = MODEL_NQ;
        tally->impacts = 1;
        tally->first_begin = tally->start;
        tally->now_start = t0;
    }
}

void ig_tally_start(ig_tally *tally, const model_machine *m, int start, double t0, const double *y0,
                    const double *out0)
{
    ig_tally_begin(tally, t0, y0, out0, start == MODEL_START_CONTACT);
    for (int k = 0; k < MODEL_NCONTACT; ++k) {  /* the joints in contact from the start (the tip: above) */
        if (model_point_number(k) == MODEL_NQ || m->point[k].state == MODEL_MACHINE_FREE) continue;
        tally->joint_impacts++;
        if (tally->first_point == IG_NO_POINT) tally->first_point = model_point_number(k);
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

/* Add the latest impact's record (a->now_...) to the run's: the largest delta_max and P_max,
 * the deepest dent (the first of equals), its contact time. */
static void fold_impact(ig_tally *a, double contact, int first_folded)
{
    if (a->now_delta_max > a->delta_max) a->delta_max = a->now_delta_max;
    if (a->now_P_max > a->P_max) a->P_max = a->now_P_max;
    if (first_folded || a->now_delta_r > a->deepest_delta_r) {
        a->deepest_delta_r = a->now_delta_r;
        a->deepest_R_res = a->now_R_res;
    }
    a->t_contact += contact;
}

/* Follow one switch record (at sample seg->sample of the buffers) in the tally: the tip's make
 * the summaries, the joints' are counted. */
void ig_tally_segment(ig_tally *a, const ig_segment *seg, const double *t_buf, const double *y_buf,
                          const double *out_buf)
{
    if ((seg->act & MODEL_ACT_IMPACT_BEGIN) && a->first_point == IG_NO_POINT) a->first_point = seg->point;
    if (seg->point != MODEL_NQ) {  /* a joint's: counted; the summaries are the tip's (the chain's end) */
        if (seg->act & MODEL_ACT_IMPACT_BEGIN) a->joint_impacts++;
        return;
    }
    const long k = seg->sample;
    const double *y = y_buf + (size_t)k * MODEL_NSTATE, *out = out_buf + (size_t)k * MODEL_NOUT;
    if (seg->next_state == MODEL_MACHINE_SUSTAINED && seg->state != MODEL_MACHINE_SUSTAINED &&
        isnan(a->t_sustained)) {
        a->t_sustained = seg->t;
    }
    if (seg->act & MODEL_ACT_IMPACT_BEGIN) {
        if (++a->impacts == 1) ig_read_point(&a->first_begin, t_buf[k], y, out);
        a->now_start = seg->t;
        a->now_delta_max = a->now_P_max = a->now_delta_r = a->now_R_res = 0.0;
    }
    if (a->impacts == 0) return;
    if (seg->act & MODEL_ACT_MAX_COMPRESSION) {
        a->now_delta_max = seg->delta_max;
        a->now_P_max = seg->P_max;
        a->now_delta_r = seg->delta_r;
        a->now_R_res = seg->R_res;
    }
    if (a->impacts == 1) {
        if (seg->act & MODEL_ACT_SLIP) a->first_stick_slip++;
        if (seg->state != MODEL_MACHINE_FREE && seg->next_state != seg->state) a->first_switches++;
    }
    if (seg->act & MODEL_ACT_IMPACT_END) {
#if MODEL_RATE_LAW
        a->now_delta_r = seg->delta_r;  /* a damped law lets go while penetrating: that depth */
#endif
        fold_impact(a, seg->t - a->now_start, a->ended++ == 0);
        if (a->impacts == 1) {
            ig_read_point(&a->first_end, t_buf[k], y, out);
            a->first_delta_max = a->now_delta_max;
            a->first_P_max = a->now_P_max;
            a->first_delta_r = a->now_delta_r;
            a->first_R_res = a->now_R_res;
        }
    }
    tally_coefficients(a, seg, t_buf[k], y, out);
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
    out->joint_impacts = a->joint_impacts;
    out->first_point = a->first_point;
    out->t_sustained = a->t_sustained;
    summarize_coefficients(a, out);
}

void ig_summarize(const ig_tally *a, ig_summary *run, ig_summary *first)
{
    const int open = a->impacts > a->ended;  /* the latest impact is still in contact */
    ig_tally all = *a;
    if (open) fold_impact(&all, a->last.t - a->now_start, a->ended == 0);
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
    const int first_open = a->ended == 0;
    summarize_between(&a->first_begin, first_open ? &a->last : &a->first_end, first);
    first->delta_max = first_open ? a->now_delta_max : a->first_delta_max;
    first->P_max = first_open ? a->now_P_max : a->first_P_max;
    first->delta_r = first_open ? a->now_delta_r : a->first_delta_r;
    first->R_res = first_open ? a->now_R_res : a->first_R_res;
    first->t_contact = first_open ? 0.0 : a->first_end.t - a->first_begin.t;
    summarize_first(a, first);
}
