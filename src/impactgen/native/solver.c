/*
 * solver.c: one integrator per simulation (solver.h), a stepper (stepper.h) chosen by method,
 * re-started at each phase switch (the force law changes there, so the step history must not
 * be carried across). Gives the steppers the generated model's functions.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sundials/sundials_version.h>

#include "solver_state.h"

void ig_solver_say(ig_solver *s, const char *text)
{
    snprintf(s->message, sizeof s->message, "%s", text);
}

/* ---- the model as a stepper sees it (user: the solver) ---- */
static int rhs(double t, const double *y, double *ydot, void *user)
{
    return model_rhs(t, y, ydot, ((const ig_solver *)user)->params);
}

static int motion(double t, const double *y, double *ydot, void *user)
{
    return model_motion_rhs(t, y, ydot, ((const ig_solver *)user)->params);
}

static int quadratures(double t, const double *y, double *qdot, void *user)
{
    return model_quadratures(t, y, qdot, ((const ig_solver *)user)->params);
}

static void watched(double t, const double *y, double *g, void *user)
{
    const ig_solver *s = (const ig_solver *)user;
    double ev[MODEL_NEVENT];
    model_events(t, y, ev, s->params);
    for (int k = 0; k < s->nevents; ++k) g[k] = ev[s->events[k]];
}

#if MODEL_HAS_JACOBIAN
static int jacobian(double t, const double *y, double *J, void *user)
{
    return model_jacobian(t, y, J, ((const ig_solver *)user)->params);
}
#endif

/* The stepper of a method, or NULL with a message in err. */
static ig_stepper *new_stepper(int method, const ig_problem *problem, char *err, int errlen)
{
    switch (method) {
    case IG_METHOD_BDF: return ig_cvode_new(problem, 0, err, errlen);
    case IG_METHOD_ADAMS: return ig_cvode_new(problem, 1, err, errlen);
    case IG_METHOD_ERK: return ig_erk_new(problem, err, errlen);
    case IG_METHOD_DOPRI5: return ig_pair_new(problem, err, errlen);
    default: {
        ig_stepper *pair = ig_pair_new(problem, err, errlen);
        ig_stepper *bdf = pair ? ig_cvode_new(problem, 0, err, errlen) : NULL;
        return pair ? ig_auto_new(pair, bdf, err, errlen) : NULL;
    }
    }
}

void ig_solver_free(ig_solver *s)
{
    if (!s) return;
    if (s->st) s->st->ops->free(s->st);
    free(s);
}

static int atol_valid(const double *atol)
{
    for (int k = 0; k < MODEL_NSTATE; ++k) {
        if (!(atol[k] > 0.0)) return 0;
    }
    return 1;
}

ig_solver *ig_solver_new(int method, int analytic_jacobian, double rtol, const double *atol,
                         long max_steps, char *err, int errlen)
{
    ig_solver *s = (ig_solver *)calloc(1, sizeof *s);
    const char *failed = NULL;
    if (!s) {
        snprintf(err, (size_t)errlen, "out of memory");
        return NULL;
    }
    if (method < IG_METHOD_BDF || method > IG_METHOD_AUTO) {
        failed = "method must be 0 (BDF), 1 (Adams), 2 (ERK), 3 (DOPRI5) or 4 (auto)";
    } else if (!IG_METHOD_USES_JACOBIAN(method) && analytic_jacobian) {
        failed = "an explicit method uses no Jacobian";
    }
    else if (!(rtol > 0.0) || max_steps <= 0) failed = "rtol and max_steps must be positive";
    else if (analytic_jacobian && !MODEL_HAS_JACOBIAN) failed = "this model was generated without its Jacobian";
    else if (!atol_valid(atol)) failed = "every atol entry must be positive";
    if (failed) {
        snprintf(err, (size_t)errlen, "%s", failed);
        free(s);
        return NULL;
    }
    s->problem.n = MODEL_NSTATE;
    s->problem.max_events = MODEL_NEVENT;
    s->problem.rhs = rhs;
    s->problem.events = watched;
    s->problem.nquad = MODEL_NQUAD;
    s->problem.motion = motion;
    s->problem.quadratures = quadratures;
#if MODEL_HAS_JACOBIAN
    s->problem.jacobian = analytic_jacobian ? jacobian : NULL;
#endif
    s->problem.user = s;
    s->problem.message = s->message;
    s->problem.message_size = (int)sizeof s->message;
    s->analytic = analytic_jacobian != 0;
    s->st = new_stepper(method, &s->problem, err, errlen);
    if (!s->st) {
        free(s);
        return NULL;
    }
    s->rtol = rtol;
    s->max_steps = max_steps;
    memcpy(s->atol, atol, sizeof s->atol);
    s->st->ops->tolerances(s->st, rtol, atol, max_steps);
    s->st->ops->restart(s->st);
    return s;
}

int ig_solver_reset(ig_solver *s, double rtol, const double *atol, long max_steps)
{
    if (!(rtol > 0.0) || max_steps <= 0) {
        ig_solver_say(s, "ig_solver_reset: rtol and max_steps must be positive");
        return IG_ERR_USAGE;
    }
    if (!atol_valid(atol)) {
        ig_solver_say(s, "ig_solver_set_atol: every entry must be positive");
        return IG_ERR_USAGE;
    }
    s->rtol = rtol;
    s->max_steps = max_steps;
    ig_solver_set_atol(s, atol);
    if (s->analytic && ig_solver_use_jacobian(s, 1) != 0) return IG_ERR_SOLVER;
    s->st->ops->restart(s->st);
    s->active = 0;
    s->root_pending = 0;
    s->message[0] = '\0';
    return 0;
}

int ig_solver_set_atol(ig_solver *s, const double *atol)
{
    if (!atol_valid(atol)) {
        ig_solver_say(s, "ig_solver_set_atol: every entry must be positive");
        return IG_ERR_USAGE;
    }
    memcpy(s->atol, atol, sizeof s->atol);
    return s->st->ops->tolerances(s->st, s->rtol, s->atol, s->max_steps) == 0 ? 0 : IG_ERR_SOLVER;
}

int ig_solver_use_jacobian(ig_solver *s, int analytic)
{
    if (analytic && !s->analytic) {
        ig_solver_say(s, "ig_solver_use_jacobian: the solver was created without the analytic Jacobian");
        return IG_ERR_USAGE;
    }
    return s->st->ops->use_jacobian(s->st, analytic) == 0 ? 0 : IG_ERR_SOLVER;
}

int ig_segment_start(ig_solver *s, const model_params *params, double t0, const double *y0,
                     double t_stop, const int *events, const int *directions, int nevents)
{
    if (!s || !params || !y0 || nevents < 0 || nevents > MODEL_NEVENT || !(t_stop > t0)) {
        if (s) ig_solver_say(s, "ig_segment_start: bad arguments (t_stop must exceed t0)");
        return IG_ERR_USAGE;
    }
    for (int k = 0; k < nevents; ++k) {
        if (events[k] < 0 || events[k] >= MODEL_NEVENT) {
            ig_solver_say(s, "ig_segment_start: event index out of range");
            return IG_ERR_USAGE;
        }
    }
    s->params = params;
    s->nevents = nevents;
    for (int k = 0; k < nevents; ++k) {
        s->events[k] = events[k];
        s->dirs[k] = directions[k];
    }
    s->t_stop = t_stop;
    s->segment_steps = 0;
    s->root_pending = 0;
    s->message[0] = '\0';
    s->active = 0;
    if (s->st->ops->start(s->st, t0, y0, t_stop, s->dirs, nevents) != 0) return IG_ERR_SOLVER;
    s->active = 1;
    return 0;
}

int ig_solver_step(ig_solver *s, double *t, double *y, int *roots_found)
{
    if (s->segment_steps >= s->max_steps) {
        s->active = 0;
        snprintf(s->message, sizeof s->message, "more than %ld steps in one phase (solver.max_steps)", s->max_steps);
        return IG_ERR_TOO_MUCH_WORK;
    }
    const int flag = s->st->ops->step(s->st, t, y, roots_found);
    if (flag < 0) {
        s->active = 0;
        if (!s->message[0]) ig_solver_say(s, "the integrator failed without a message");
        return IG_ERR_SOLVER;
    }
    s->segment_steps++;
    if (flag == IG_STEP_ROOT) {
        s->active = 0;
        return IG_ROOT;
    }
    if (flag == IG_STEP_END) {
        s->active = 0;
        return IG_REACHED_END;
    }
    return IG_STEPPED;
}

int ig_solver_write_sample(ig_solver *s, double t, const double *y, int k, double *t_buf, double *y_buf,
                           double *dense_buf)
{
    const int terms = s->st->dense_terms;
    t_buf[k] = t;
    memcpy(y_buf + (size_t)k * MODEL_NSTATE, y, sizeof(double) * MODEL_NSTATE);
    if (dense_buf != NULL && s->st->ops->dense(s->st, t, dense_buf + (size_t)k * terms * MODEL_NSTATE, terms) != 0) {
        s->active = 0;
        ig_solver_say(s, "the integrator could not give the interpolating polynomial of the step");
        return IG_ERR_SOLVER;
    }
    return 0;
}

int ig_segment_advance(ig_solver *s, double *t_buf, double *y_buf, double *dense_buf,
                       int capacity, int *n_written, int *roots_found)
{
    *n_written = 0;
    if (!s->active) {
        ig_solver_say(s, "ig_segment_advance: no segment under way");
        return IG_ERR_USAGE;
    }
    while (*n_written < capacity) {
        double t, y[MODEL_NSTATE];
        const int flag = ig_solver_step(s, &t, y, roots_found);
        if (flag < 0) return flag;
        if (ig_solver_write_sample(s, t, y, *n_written, t_buf, y_buf, dense_buf) != 0) return IG_ERR_SOLVER;
        (*n_written)++;
        if (flag != IG_STEPPED) return flag;
    }
    return IG_BUFFER_FULL;
}

int ig_interpolate(ig_solver *s, double t, double *y)
{
    if (s->st->ops->interpolate(s->st, t, y) != 0) {
        ig_solver_say(s, "ig_interpolate: t lies outside the last step");
        return IG_ERR_USAGE;
    }
    return 0;
}

int ig_dense_terms(const ig_solver *s)
{
    return s->st->dense_terms;
}

void ig_solver_stats(const ig_solver *s, ig_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    ig_stepper_counters(s->st, stats);
}

const char *ig_solver_message(const ig_solver *s)
{
    return s->message;
}

void ig_outputs(const model_params *params, int n, const double *t, const double *y,
                double *out)
{
    for (int k = 0; k < n; ++k) {
        model_outputs(t[k], y + (size_t)k * MODEL_NSTATE, out + (size_t)k * MODEL_NOUT, params);
    }
}

int ig_sundials_version_major(void)
{
    return SUNDIALS_VERSION_MAJOR;
}
