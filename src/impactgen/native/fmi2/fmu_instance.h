/*
 * fmu_instance.h: what the files of the FMI 2.0 interface share, as the Reference-FMUs split
 * theirs (model.h): the instance of a generated impact model and the few functions one file
 * offers the others. Written once for every model; the model-specific parts are generated:
 * model.c (right-hand side, events, outputs), model_params.c (the parameter table, its
 * checks), model_scene.h (the start values) and model_fmu.h (the variables by value
 * reference). The files, each with one job:
 *
 *   fmu_api.c           the FMI functions common to both kinds, and which one is allowed in
 *                       which mode (one table); the logger
 *   fmu_start.c         the start: start values, the derived parameters, the machine at the
 *                       start, and the checks that refuse a start (from the model's own)
 *   fmu_variables.c     get and set by value reference; outputs computed once per change
 *   fmu_events.c        the one event update (the machine's switch) and its log
 *   fmu_model_exchange.c  Model Exchange: states, derivatives, event indicators, steps
 *   fmu_cosimulation.c  Co-Simulation: ig_run (run.c) steps across communication points
 */
#ifndef FMU_INSTANCE_H
#define FMU_INSTANCE_H

#include <stddef.h>

#include "fmi2Functions.h"
#include "model_machine.h"
#include "tally.h"
#ifdef FMU_CO_SIMULATION
#include "solver.h"
#endif

#if !defined(FMU_MODEL_EXCHANGE) && !defined(FMU_CO_SIMULATION)
#error "define FMU_MODEL_EXCHANGE, FMU_CO_SIMULATION or both"
#endif

/* The instance's mode. FAILED: an error ended the run; only fmi2Terminate, fmi2Reset and
 * fmi2FreeInstance are left. */
enum fmu_mode { INSTANTIATED, INITIALIZATION, EVENT, CONTINUOUS, STEPPING, TERMINATED, FAILED };

/* The FMI functions whose mode the table of fmu_api.c checks (fmu_allowed). */
enum fmu_call {
    CALL_SETUP_EXPERIMENT, CALL_ENTER_INITIALIZATION, CALL_EXIT_INITIALIZATION, CALL_TERMINATE, CALL_RESET,
    CALL_GET_REAL, CALL_GET_INTEGER, CALL_GET_BOOLEAN, CALL_SET_REAL, CALL_SET_BOOLEAN,
    CALL_ENTER_EVENT_MODE, CALL_NEW_DISCRETE_STATES, CALL_ENTER_CONTINUOUS_TIME_MODE,
    CALL_COMPLETED_INTEGRATOR_STEP, CALL_SET_TIME, CALL_SET_CONTINUOUS_STATES, CALL_GET_DERIVATIVES,
    CALL_GET_EVENT_INDICATORS, CALL_GET_CONTINUOUS_STATES, CALL_GET_NOMINALS, CALL_DO_STEP,
    FMU_NCALL
};

/* What is computed from (t, y, p) once per change of any of them (fmu_variables.c). */
typedef struct {
    int have_outputs, have_derivatives, have_summaries;
    int rhs_flag;                   /* model_rhs's return at (t, y) */
    double out[MODEL_NOUT];
    double ydot[MODEL_NSTATE];
    ig_summary run, first_impact;   /* the summaries of the run from its start to t (fmu_summaries) */
} fmu_values;

typedef struct {
    char *name;
    fmi2Type type;
    fmi2CallbackFunctions cb;
    int logging;
    int mode;                    /* enum fmu_mode */
    model_params p;              /* inputs as set; derived and machine fields after initialization */
    double q0[MODEL_NDOF], u0[MODEL_NDOF];  /* the angles (and a free chain's base point), their rates */
    double t;
    double t_done;               /* Model Exchange: the last completed step or event; time never goes before it */
    double y[MODEL_NSTATE];
    model_machine m;
    ig_tally tally;              /* the run's summaries (tally.c, as impactgen run's): begun at the start,
                                    followed switch by switch, read to t by fmu_summaries */
    double start_time, stop_time, rtol;
    int start_ready;             /* before initialization ends: y, p and m are those of the start values */
    int nominals_changed;
    fmu_values values;           /* valid while t, y and p stay as they were */
#ifdef FMU_CO_SIMULATION
    ig_solver *solver;
    double t_int;                /* where the integrator is (>= t) */
    double y_int[MODEL_NSTATE];
#endif
} fmu_instance;

/* ---- fmu_api.c: logging and the mode table ---- */
/* Log through the importer's printf-like logger (a message has its % doubled); fmi2OK
 * messages only while logging is on. */
void fmu_say(const fmu_instance *c, fmi2Status status, const char *category, const char *fmt, ...);
/* Log fmt with what as an error; returns fmi2Error. */
fmi2Status fmu_fail(const fmu_instance *c, const char *fmt, const char *what);
/* 1 when `call` is allowed in c's mode; else logs that it is not and returns 0 (0 for c NULL). */
int fmu_allowed(const fmu_instance *c, enum fmu_call call);
/* 1 (after logging it) when an array argument is NULL while its count n is not 0. */
int fmu_null_array(const fmu_instance *c, const char *function, size_t n, const void *a, const void *b);

/* ---- fmu_start.c ---- */
/* The scene's start values (model_scene.h), the start time 0 and no stop time. */
void fmu_set_start_values(fmu_instance *c);
/* The start state, the derived parameters and the machine at the start, once per change of
 * the start values. Returns MODEL_PARAMS_OK, or the index of the first input out of its
 * physical range (or breaking a rule across inputs: model_derive), with the range or rule
 * in *range (fmu_refuse_input logs it). */
int fmu_prepare(fmu_instance *c, const char **range);
/* Refuse input k with its range (fmu_prepare's answer), naming its key: FAILED, fmi2Error. */
fmi2Status fmu_refuse_input(fmu_instance *c, int k, const char *range);
/* The start values changed (a parameter, a start value, the start time). */
void fmu_start_changed(fmu_instance *c);
/* The checks that refuse a start the model does not hold (a point inside the surface, a
 * pruned joint that could reach it), as load_scene refuses it; fmi2Error (FAILED, logged). */
fmi2Status fmu_check_start(fmu_instance *c);

/* ---- fmu_variables.c ---- */
/* t, y or p changed: what was computed from them is stale. */
void fmu_invalidate(fmu_instance *c);
/* The derivatives at (t, y), computed once per change; *flag: model_rhs's return. */
const double *fmu_derivatives(fmu_instance *c, int *flag);
/* The outputs at (t, y), computed once per change. */
const double *fmu_outputs(fmu_instance *c);

/* ---- fmu_events.c ---- */
/* The event update: when a watched event crossed in its direction since the sides were
 * stored (roots.h, through the machine), the machine switches, each switch is logged and
 * followed in the tally, and the sides are stored again. Returns the machine's MODEL_ACT_*
 * bits (0: a no-op event). */
int fmu_event_update(fmu_instance *c);
/* Log a point's switch at t ("t = ...: from -> to", "t = ...: joint k: from -> to" for a
 * joint, and its stick-slip change under exact Coulomb friction). point: the chain's point
 * (1 .. MODEL_NQ - 1 a joint, MODEL_NQ the tip); act: its MODEL_ACT_* bits. */
void fmu_log_switch(const fmu_instance *c, double t, int point, int was, int now, double was_slip, double slip,
                    int act);

/* ---- fmu_cosimulation.c ---- */
/* Co-Simulation at the end of initialization: the integrator, at the tolerance set up. */
fmi2Status fmu_start_stepping(fmu_instance *c);
void fmu_free_solver(fmu_instance *c);

#endif /* FMU_INSTANCE_H */
