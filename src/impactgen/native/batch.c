/*
 * batch.c: ig_batch_run (batch.h), many cases of one model run in C through the one driver
 * (ig_run_begin, ig_run): what a sweep's worker and impactgen.run_batch call once per chunk.
 */
#define _POSIX_C_SOURCE 199309L  /* clock_gettime under -std=c99 */

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "batch.h"

#define BATCH_SAMPLES 64  /* samples per ig_run call: the start and each switch (summary only) */
#define BATCH_RECORDS 64  /* switch records per ig_run call (at least MODEL_NCONTACT) */

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The indices of the links' lengths L1 ... L(MODEL_NQ) in the parameter table (-1: none). */
static void length_slots(int *slot)
{
    char name[16];
    for (int j = 0; j < MODEL_NQ; ++j) {
        slot[j] = -1;
        snprintf(name, sizeof name, "L%d", j + 1);
        for (int k = 0; k < MODEL_NPARAM; ++k) {
            if (strcmp(model_param_name(k), name) == 0) slot[j] = k;
        }
    }
}

/* 0 when this model's contact points are those the values in p need at the start y: no
 * pruned joint can reach the surface (model_pruned_reach) and every joint it has can (as
 * engines.reachable_joints decides the model's joints); else the first joint that differs.
 * A free chain's model has every point, whatever the values: always 0. */
static int other_model(model_params *p, const double *y, const int *slot)
{
#ifdef MODEL_FREE
    (void)p;
    (void)y;
    (void)slot;
    return 0;
#else
    const int pruned = model_pruned_reach(p, y);
    if (pruned != 0) return pruned;
    const double y_s = model_surface_at_start(p, y);
    const double depth = -y_s - MODEL_TOUCH_TOLERANCE * fmax(1.0, model_chain_length(p));
    for (int k = 0; k < MODEL_NCONTACT; ++k) {
        const int joint = model_point_number(k);
        if (joint == MODEL_NQ) continue;  /* the tip */
        double reach = 0.0;
        for (int j = 0; j < joint; ++j) reach += *model_param_slot(p, slot[j]);
        if (!(reach >= depth)) return joint;
    }
    return 0;
#endif
}

/* The contact constants the validity warnings read of point `number` of case p, R and delta_c
 * (the three-phase law's; NAN for the others, whose impacts the warnings do not judge so). */
static void constants_of(const model_params *p, int number, double *R, double *delta_c)
{
#if MODEL_PLASTIC && !MODEL_THORNTON
    const int k = ig_point_index(number);
    *R = p->point[k].R;
    *delta_c = p->point[k].delta_c;
#else
    (void)p;
    (void)number;
    *R = *delta_c = NAN;
#endif
}

/* The contact constants of case p in contact[]: the point of its first impact's, and B. */
static void contact_of(const model_params *p, int first_point, double *out)
{
    constants_of(p, first_point, &out[0], &out[1]);
#if MODEL_PLASTIC && !MODEL_THORNTON
    out[2] = p->B;
#else
    out[2] = NAN;
#endif
}

/* A case's impacts as its switch records make them (phases._impacts): each begun one's point,
 * start, end, delta_max and constants, the first IG_BATCH_IMPACTS of them. */
typedef struct {
    int begun;                       /* impacts begun */
    int latest[MODEL_NQ + 1];        /* by point number: the row of its latest impact (-1: none yet) */
    double *rows;                    /* IG_BATCH_IMPACTS rows of IG_BATCH_IMPACT_FIELDS */
} impact_table;

static void impacts_begin(impact_table *table, double *rows)
{
    table->begun = 0;
    for (int k = 0; k <= MODEL_NQ; ++k) table->latest[k] = -1;
    table->rows = rows;
    for (int k = 0; k < IG_BATCH_IMPACTS * IG_BATCH_IMPACT_FIELDS; ++k) rows[k] = NAN;
}

/* An impact of point `number` begins at t: the table's next row. */
static void impact_begins(impact_table *table, int number, double t, const model_params *p)
{
    const int j = table->latest[number] = table->begun++;
    if (j >= IG_BATCH_IMPACTS) return;
    double *row = table->rows + (size_t)j * IG_BATCH_IMPACT_FIELDS;
    row[0] = number;
    row[1] = t;
    row[3] = 0.0;
    constants_of(p, number, &row[4], &row[5]);
}

/* The points in contact from the start (machine m as ig_run_begin left it), in point order:
 * impacts begun at t = 0, without a switch record. */
static void impacts_at_start(impact_table *table, const model_machine *m, const model_params *p)
{
    for (int k = 0; k < MODEL_NCONTACT; ++k) {
        if (m->point[k].state != MODEL_MACHINE_FREE) impact_begins(table, model_point_number(k), 0.0, p);
    }
}

/* Follow the switch records of one ig_run call in the table. */
static void impacts_follow(impact_table *table, const ig_segment *records, int n_records, const model_params *p)
{
    for (int r = 0; r < n_records; ++r) {
        const ig_segment *rec = &records[r];
        if (rec->act & MODEL_ACT_IMPACT_BEGIN) impact_begins(table, rec->point, rec->t, p);
        const int j = table->latest[rec->point];
        if (j < 0 || j >= IG_BATCH_IMPACTS) continue;  /* a flight before the point's first impact, or beyond the rows */
        double *row = table->rows + (size_t)j * IG_BATCH_IMPACT_FIELDS;
        if (rec->act & MODEL_ACT_MAX_COMPRESSION) row[3] = rec->delta_max;
        if (rec->act & MODEL_ACT_IMPACT_END) row[2] = rec->t;
    }
}

/* One case, from its start to its end, as phases.run runs it summary only: ig_run called
 * again with emptied buffers while they fill, its impacts followed in `impacts`. Returns
 * ig_run's last flag. */
static int run_case(ig_solver *s, model_machine *m, model_params *p, const ig_batch_settings *c, double *y,
                    double *t_buf, double *y_buf, double *out_buf, ig_segment *records, ig_tally *tally,
                    impact_table *impacts)
{
    double t = 0.0;
    long recorded = 0;
    int n_written = 1;  /* the start, written by ig_run_begin */
    int n_records = 0;
    int flag;
    do {
        flag = ig_run(s, m, p, &t, y, c->t_stop, c->t_stop, c->atol, c->max_records - recorded, 0, t_buf, y_buf,
                      out_buf, NULL, BATCH_SAMPLES, &n_written, records, BATCH_RECORDS, &n_records, tally);
        recorded += n_records;
        impacts_follow(impacts, records, n_records, p);
        n_written = 0;
    } while (flag == IG_BUFFER_FULL || flag == IG_SEGMENTS_FULL);
    return flag;
}

int ig_batch_run(ig_solver *s, model_machine *m, const model_params *base, const ig_batch_settings *settings,
                 int n, int n_vary, const int *vary_index, const double *values, const double *y0,
                 ig_summary *summaries, int *code, int *flag, double *contact, double *wall_s, int *n_impacts,
                 double *impacts)
{
    for (int j = 0; j < n_vary; ++j) {
        if (model_param_kind(vary_index[j]) != 0) return IG_ERR_USAGE;  /* only the scene's inputs */
    }
    int slot[MODEL_NQ];
    length_slots(slot);
    for (int j = 0; j < MODEL_NQ; ++j) {
        if (slot[j] < 0) return IG_ERR_USAGE;
    }
    ig_segment records[BATCH_RECORDS];  /* a call's switch records: the tally has read them on return */
    double t_buf[BATCH_SAMPLES], y_buf[BATCH_SAMPLES * MODEL_NSTATE], out_buf[BATCH_SAMPLES * MODEL_NOUT];
    double y[MODEL_NSTATE], atol_now[MODEL_NSTATE];
    impact_table table;
    ig_tally tally;
    ig_summary run, first;
    for (int i = 0; i < n; ++i) {
        const double started = now_s();
        const double *y_case = y0 + (size_t)i * MODEL_NSTATE;
        model_params p = *base;
        for (int j = 0; j < n_vary; ++j) *model_param_slot(&p, vary_index[j]) = values[(size_t)i * n_vary + j];
        const char *range = NULL;
        const int bad = model_derive(&p, &range);
        code[i] = IG_CASE_RAN;
        flag[i] = 0;
        memset(&summaries[i], 0, sizeof summaries[i]);
        for (int k = 0; k < IG_BATCH_CONTACT; ++k) contact[(size_t)i * IG_BATCH_CONTACT + k] = NAN;
        impacts_begin(&table, impacts + (size_t)i * IG_BATCH_IMPACTS * IG_BATCH_IMPACT_FIELDS);
        int joint = 0;
        if (bad != MODEL_PARAMS_OK) {
            code[i] = IG_CASE_BAD_PARAMS;
            flag[i] = bad;
        } else if ((joint = other_model(&p, y_case, slot)) != 0) {
            code[i] = IG_CASE_OTHER_MODEL;
            flag[i] = joint;
        } else {
            const int start = ig_run_begin(s, m, &p, 0.0, y_case, settings->run_to_time, settings->rtol,
                                           settings->atol, settings->max_steps, atol_now, t_buf, y_buf, out_buf,
                                           &tally);
            if (start < 0) {
                code[i] = IG_CASE_NOT_BEGUN;
                flag[i] = start;
            } else if (start == MODEL_START_ALONG || start == MODEL_START_AWAY) {
                code[i] = IG_CASE_NO_RUN;
                flag[i] = start;
            } else {
                memcpy(y, y_case, sizeof y);
                impacts_at_start(&table, m, &p);
                flag[i] = run_case(s, m, &p, settings, y, t_buf, y_buf, out_buf, records, &tally, &table);
                ig_summarize(&tally, &run, &first);
                summaries[i] = (settings->run_to_time || flag[i] < 0) ? run : first;
                contact_of(&p, summaries[i].first_point, contact + (size_t)i * IG_BATCH_CONTACT);
            }
        }
        n_impacts[i] = table.begun;
        wall_s[i] = now_s() - started;
    }
    return 0;
}
