/*
 * fmu_start.c: the start of a run. The scene's start values (model_scene.h) as set by the
 * importer become the start state, the derived parameters (model_derive, which checks every
 * input against its physical range) and the machine at the start (model_machine_start), once
 * per change of the start values, where the tally of the run's summaries begins. A start the model cannot hold is refused by the model's own
 * checks, as load_scene refuses it: a point of the chain inside the surface
 * (model_machine_start_inside) or a joint the model was pruned of that could reach the surface
 * (model_pruned_reach: the FMU has no contact law for it). Each refusal names the scene key
 * and what to do.
 */
#include <stdio.h>
#include <string.h>

#include "fmu_instance.h"
#include "model_fmu.h"
#include "model_scene.h"

#define FAR_FUTURE 1e30  /* the end of a run with no stop time */

void fmu_set_start_values(fmu_instance *c)
{
    double y0[MODEL_NSTATE];
    memset(&c->p, 0, sizeof c->p);
    model_scene_inputs(&c->p, y0);
    for (int i = 0; i < MODEL_NDOF; ++i) {  /* the angles (and a free chain's base point) */
        c->q0[i] = y0[i];
        c->u0[i] = y0[MODEL_NDOF + i];
    }
    c->t = c->t_done = c->start_time = 0.0;
    c->stop_time = FAR_FUTURE;
    c->rtol = MODEL_SCENE_RTOL;
    fmu_start_changed(c);
}

void fmu_start_changed(fmu_instance *c)
{
    c->start_ready = 0;
    fmu_invalidate(c);
}

int fmu_prepare(fmu_instance *c, const char **range)
{
    *range = "";
    if (c->start_ready) return MODEL_PARAMS_OK;
    for (int i = 0; i < MODEL_NDOF; ++i) {
        c->y[i] = c->q0[i];
        c->y[MODEL_NDOF + i] = c->u0[i];
    }
    for (int k = MODEL_NMOTION; k < MODEL_NSTATE; ++k) c->y[k] = 0.0;
    fmu_invalidate(c);
    const int bad = model_derive(&c->p, range);
    if (bad != MODEL_PARAMS_OK) return bad;
    model_machine_start(&c->m, &c->p, c->t, c->y, 1);  /* (its points in contact: the tally reads them) */
    ig_tally_start(&c->tally, &c->m, c->t, c->y, fmu_outputs(c));
    double ev[MODEL_NEVENT];
    model_events(c->t, c->y, ev, &c->p);
    model_machine_sides(&c->m, ev);
    c->start_ready = 1;
    return MODEL_PARAMS_OK;
}

fmi2Status fmu_refuse_input(fmu_instance *c, int k, const char *range)
{
    char what[256];
    snprintf(what, sizeof what, "%s = %g is outside its physical range %s", model_param_key(k),
             *model_param_slot(&c->p, k), range);
    c->mode = FAILED;
    return fmu_fail(c, "%s", what);
}

/* A point of the chain inside the surface (model_machine_start_inside's), named as load_scene
 * names it (scene/physics.py): the tip names surface.height; the pivot (0) or joint k names
 * initial.q and the link it ends. */
static void log_start_inside(const fmu_instance *c, int point, double depth)
{
    const double y_s = c->p.point[MODEL_TIP_POINT].y_s;
    if (point == MODEL_NQ) {
        fmu_say(c, fmi2Error, "logStatusError", "surface.height: the tip of link %d starts %.3g m inside the "
                "surface (tip at y = %.6g m, surface at %.6g m); lower the surface or change initial.q",
                MODEL_NQ, depth, y_s - depth, y_s);
        return;
    }
    char where[64];
#ifdef MODEL_FREE
    if (point == 0) {
        fmu_say(c, fmi2Error, "logStatusError", "initial.base: the free chain's base point starts %.3g m inside "
                "the surface (at y = %.6g m, the surface at y = %.6g m)", depth, y_s - depth, y_s);
        return;
    }
#endif
    if (point == 0) snprintf(where, sizeof where, "its pivot end");
    else snprintf(where, sizeof where, "its lower end (joint %d)", point);
    fmu_say(c, fmi2Error, "logStatusError", "initial.q: link %d starts below the surface: %s is at y = %.6g m, "
            "the surface at y = %.6g m%s; every point of the chain must start on or above the surface (the "
            "joints and the tip may touch it)", point == 0 ? 1 : point, where, y_s - depth, y_s,
            c->p.surface_initial != 0.0 ? " (surface.height = \"initial\" puts the surface at the tip)" : "");
}

/* Joint `joint`, which this model was pruned of (it could not reach the surface at the values
 * the FMU was built from), could reach it with the values set now: the FMU has no contact law
 * for it, so it would pass through the surface unseen. Names the joint, its lengths' keys
 * (model_param_key) and their sum. */
static void log_pruned_reach(fmu_instance *c, int joint)
{
    double reach = 0.0;
    for (int i = 0; i < joint; ++i) reach += *model_param_slot(&c->p, fmu_link_length[i]);
    char lengths[160];
    if (joint == 1) snprintf(lengths, sizeof lengths, "%s", model_param_key(fmu_link_length[0]));
    else snprintf(lengths, sizeof lengths, "%s + ... + %s", model_param_key(fmu_link_length[0]),
                  model_param_key(fmu_link_length[joint - 1]));
    fmu_say(c, fmi2Error, "logStatusError", "joint %d (the end of link %d) can reach the surface with these values, "
            "but this FMU has no contact at joint %d: it was built from values at which the joint cannot reach, "
            "and was pruned. %s = %.6g m reaches the surface %.6g m below the pivot (%s). Build the FMU from a "
            "scene with these values (impactgen fmu SCENE --set KEY=VALUE) to have joint %d's contact, or keep "
            "the surface out of its reach", joint, joint, joint, lengths, reach, -c->p.point[MODEL_TIP_POINT].y_s,
            c->p.surface_initial != 0.0 ? "at the tip's initial height: surface.height_initial, initial.q"
                                        : "surface.height", joint);
}

fmi2Status fmu_check_start(fmu_instance *c)
{
    double depth = 0.0;
    const int point = model_machine_start_inside(&c->p, c->y, &depth);
    const int joint = point < 0 ? model_pruned_reach(&c->p, c->y) : 0;
    if (point >= 0) log_start_inside(c, point, depth);
    else if (joint != 0) log_pruned_reach(c, joint);
    else return fmi2OK;
    c->mode = FAILED;
    return fmi2Error;
}
