/*
 * tally.h: what a run keeps for its summaries while ig_run goes from segment to segment
 * (tally.c): the records a summary reads, begun at the run's first sample, followed switch
 * record by switch record, summarized at the end; and the switch record itself (ig_segment).
 */
#ifndef IMPACTGEN_TALLY_H
#define IMPACTGEN_TALLY_H

#include "model.h"
#include "model_machine.h"

/* first_point before any impact: 0, but for a free chain, whose base point is point 0 */
#ifdef MODEL_FREE
#define IG_NO_POINT (-1)
#else
#define IG_NO_POINT 0
#endif

/* cdef-begin: the declarations below are read by cffi as they stand. */
/* One switch record of ig_run: contact point `point`'s segment (the time it spent in one
 * machine state and stick-slip state) ended at t, at the switch that event `event` began, and
 * its switch did `act`, from (state, slip) to (next_state, next_slip). A switch writes one
 * record per point whose switch acted, in point order (the joints by number, then the tip),
 * each once; the records of one switch share t, sample, event and params. A point that did not
 * switch has no record: it stays in the state its last record went to. Reaching t_stop is no
 * switch: a run's last segment has no record (its points are as the machine is at the end). */
typedef struct {
    double t;            /* the switch's time, s */
    long sample;         /* index of the sample at t in the buffers of the ig_run call */
    int state;           /* MODEL_MACHINE_* of the point before the switch (model_point_machine.was) */
    double slip;         /* its stick-slip state before it (was_slip: +1, -1 slipping, 0 stuck) */
    int event;           /* the model event that began the switch (the first watched one that fired) */
    int act;             /* MODEL_ACT_* bits of the point's switch (model_point_machine.act, never 0) */
    int next_state;      /* the point's machine state after the switch */
    double next_slip;
    double delta_max, P_max, delta_r, R_res;  /* the point's impact record after the switch */
    int point;           /* the point: 0 a free chain's base, 1 to MODEL_NQ - 1 joint k (the end of link k), MODEL_NQ the tip */
    model_params params; /* the parameters the run's segment ending at t ran under (the switch changes some) */
} ig_segment;

/* The values at one sample that a summary reads: time, kinetic and potential energy, the
 * works of the contact forces (W_friction 0 without friction) and the state. */
typedef struct {
    double t, T, V, W_normal, W_friction;
    double y[MODEL_NSTATE];
    /* one contact point's own (the impact coefficients' terms; read for the first impact's
     * point): its works and impulses (model_point_integrals: W_normal, W_friction, J, P_normal,
     * P_friction, N s) and its normal speed (its v_y, negative approaching), m/s */
    double own[MODEL_NINTEGRAL], v_n;
} ig_point;

/* One contact point's impact going on (or its latest), as the tally follows it. */
typedef struct {
    double start;                            /* its start, s */
    double delta_max, P_max, delta_r, R_res; /* its record at maximum compression */
    int open;                                /* it is going on */
} ig_impact_now;

/* What a run keeps for its summaries while ig_run goes from segment to segment (over all
 * its calls): begun by ig_tally_begin at the run's first sample, read by ig_summarize. Every
 * contact point's impacts make them (MODEL section 6): the first impact is the run's first, at
 * whichever point; the run's are over every point's. */
typedef struct {
    ig_point start, last;             /* the run's first sample and its latest */
    ig_point first_begin, first_end;  /* the first impact's first and last samples (its point's own values) */
    ig_point first_max;               /* the first impact's (latest) maximum compression */
    int impacts;                      /* impacts begun, at every point */
    int point_impacts[MODEL_NQ + 1];  /* impacts begun at each point, by its number (ig_segment.point) */
    int first_point;                  /* the point of the run's first impact (ig_segment.point); IG_NO_POINT: none yet */
    int first_k;                      /* its index in the machine (model_machine.point[k]); -1: none yet */
    int first_ended;                  /* whether the first impact ended */
    int first_compressed;             /* whether it reached maximum compression */
    int first_switches;               /* phase switches within the first impact */
    int first_stick_slip;             /* stick-slip changes within it (exact Coulomb) */
    int ended;                        /* impacts ended (folded into the run's record) */
    ig_impact_now now[MODEL_NCONTACT];  /* each point's latest impact, by machine index */
    double first_delta_max, first_P_max, first_delta_r, first_R_res;  /* the first impact's, once ended */
    double delta_max, P_max, deepest_delta_r, deepest_R_res;  /* over the ended impacts: the
                                                                 largest, and the deepest dent's */
    double deepest_start;             /* the deepest dent's impact's start, s, and its point: */
    int deepest_point;                /* of equal dents, the one that began first (then in point order) */
    double t_contact;                 /* contact time of the ended impacts, every point's, s */
    double t_sustained;               /* when sustained contact first began (any point switched into it), s; NAN if never */
} ig_tally;

/* A run's summary (MODEL section 6), over the whole run or over its first impact: energies
 * at its two ends and the works between them (the whole chain's), the impact record (the
 * largest values, and the deepest dent's delta_r and R_res, of every point), the contact time,
 * the state at its end. NAN where there is nothing to report: t_impact without an impact,
 * t_sustained without sustained contact. */
typedef struct {
    double T0, Tf, delta_T, delta_max, delta_r, P_max, R_res, t_contact, t_impact, t_sustained, t_final;
    double W_normal, W_friction, W_gravity, residual;
    int n_switches, n_stick_slip;     /* the first impact's phase switches and stick-slip changes */
    int impacts;                      /* in the whole run, at every point */
    int point_impacts[MODEL_NQ + 1];  /* in the whole run, at each point by its number: 0 a free chain's base
                                         (a pinned chain's pivot: always 0), k joint k, MODEL_NQ the tip */
    int first_point;                  /* where the run's first impact was: MODEL_NQ the tip, k joint k (0: a free
                                         chain's base); IG_NO_POINT: none */
    /* The first impact's impulses and coefficients of restitution (MODEL section 9), its
     * point's own, NAN while it has not ended: the point's normal speed at its start v_n0
     * (m/s), the normal impulse of compression P_c and of restitution P_r (split at maximum
     * compression), the tangential impulse P_t (N s); e_N = -v_n(end) / v_n0, e_P = P_r / P_c,
     * e_E = sqrt(W_r / -W_c) of the point's normal force's work in restitution and compression;
     * friction's share of the work the point's forces took, W_friction / (W_normal + W_friction). */
    double v_n0, P_c, P_r, P_t, e_N, e_P, e_E, friction_share;
    double y_final[MODEL_NSTATE];     /* the state at its end */
} ig_summary;

/* Begin the tally of a run at its first sample (t0, y0, with its outputs out0), no impact yet. */
void ig_tally_begin(ig_tally *tally, double t0, const double *y0, const double *out0);

/* The two summaries of a tallied run: over the whole run (an impact still in contact counted
 * to the run's last sample), and over its first impact (the whole run if it had none; an
 * impact still in contact has no contact time). A run to separation reports the second. */
void ig_summarize(const ig_tally *tally, ig_summary *run, ig_summary *first_impact);

/* cdef-end */

/* The machine index k (m->point[k]) of the contact point numbered `number` (ig_segment.point:
 * 0 a free chain's base, k joint k, MODEL_NQ the tip); the tip's for a number it lacks. */
int ig_point_index(int number);

/* The values a summary reads at one sample (t, y with its outputs out): the chain's (its
 * `own` and v_n are left for the first impact's samples). */
void ig_read_point(ig_point *point, double t, const double *y, const double *out);

/* Begin the tally of a run whose machine model_machine_start began at (t0, y0, with its
 * outputs out0): ig_tally_begin, and every point the machine started in contact counted as an
 * impact begun at t0, in point order (ig_run_begin's, and the FMU's). */
void ig_tally_start(ig_tally *tally, const model_machine *m, double t0, const double *y0, const double *out0);

/* The switch record of contact point k (m->point[k], whose switch acted) at a switch at t
 * (sample `sample`) that `event` began; its `params` are left for the caller. */
void ig_record_point(ig_segment *rec, const model_machine *m, int k, double t, long sample, int event);

/* Follow one switch record (at sample seg->sample of the buffers) in the tally. */
void ig_tally_segment(ig_tally *a, const ig_segment *seg, const double *t_buf, const double *y_buf,
                      const double *out_buf);

#endif /* IMPACTGEN_TALLY_H */
