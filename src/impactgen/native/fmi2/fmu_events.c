/*
 * fmu_events.c: the machine's switches, as the FMU makes and reports them.
 *
 * The event update (as the Reference-FMUs' eventUpdate): FMI has no crossing direction, so
 * the FMU keeps the side of each event function (model_machine_sides) and, at an event, lets
 * the machine judge which watched function crossed in its direction (model_machine_crossed,
 * by the one rule of roots.h); a crossing the wrong way is a no-op event. Model Exchange calls
 * it at fmi2NewDiscreteStates; in Co-Simulation the same machine switches inside ig_run
 * (run.c, the engine's own loop), which records each switch.
 *
 * The log of a switch is one function for both: "t = ...: from -> to" for the tip,
 * "t = ...: joint k: from -> to" for a joint, and the stick-slip labels of a change under
 * exact Coulomb friction (model_machine_slip_name).
 */
#include <stdio.h>
#include <string.h>

#include "fmu_instance.h"

void fmu_log_switch(const fmu_instance *c, double t, int point, int was, int now, double was_slip, double slip,
                    int act)
{
    char who[32] = "";
    if (point == 0) snprintf(who, sizeof who, "base: ");  /* a free chain's base point */
    else if (point != MODEL_NQ) snprintf(who, sizeof who, "joint %d: ", point);
    if (now != was) {
        fmu_say(c, fmi2OK, "logEvents", "t = %.17g: %s%s -> %s", t, who, model_machine_state_name(was),
                model_machine_state_name(now));
    }
    if (act & MODEL_ACT_SLIP) {
        fmu_say(c, fmi2OK, "logEvents", "t = %.17g: %s%s -> %s", t, who, model_machine_slip_name(was, was_slip),
                model_machine_slip_name(now, slip));
    }
}

/* Follow the switch just made at (t, y) in the tally, as ig_run does (run.c): a record of
 * each point whose switch acted, in point order, at the sample (t, y) with the outputs `out`
 * under the force laws before the switch; `event`: the first watched event that fired. */
static void tally_switch(fmu_instance *c, int event, const double *out)
{
    for (int k = 0; k < MODEL_NCONTACT; ++k) {
        if (!c->m.point[k].act) continue;
        ig_segment rec;
        ig_record_point(&rec, &c->m, k, c->t, 0, event);
        rec.params = c->p;
        ig_tally_segment(&c->tally, &rec, &c->t, c->y, out);
    }
    ig_read_point(&c->tally.last, c->t, c->y, out);
}

int fmu_event_update(fmu_instance *c)
{
    double ev[MODEL_NEVENT], out[MODEL_NOUT];
    int fired[MODEL_NEVENT] = {0}, events[MODEL_NEVENT], directions[MODEL_NEVENT];
    model_events(c->t, c->y, ev, &c->p);
    int act = 0;
    if (model_machine_crossed(&c->m, ev, fired) > 0) {
        const int watched = model_machine_events(&c->m, events, directions);
        int event = -1;
        for (int k = 0; k < watched && event < 0; ++k) {
            if (fired[k]) event = events[k];
        }
        memcpy(out, fmu_outputs(c), sizeof out);  /* the switch's sample, before the force law changes */
        act = model_machine_switch(&c->m, &c->p, c->t, c->y, fired);
        if (act) {
            for (int n = 0; n < MODEL_NCONTACT; ++n) {  /* the tip's first, as ig_run records them */
                const int k = (MODEL_TIP_POINT + n) % MODEL_NCONTACT;
                const model_point_machine *r = &c->m.point[k];
                if (r->act) fmu_log_switch(c, c->t, model_point_number(k), r->was, r->state, r->was_slip, r->slip, r->act);
            }
            tally_switch(c, event, out);
            fmu_invalidate(c);  /* the force law changed */
            model_events(c->t, c->y, ev, &c->p);
        }
    }
    model_machine_sides(&c->m, ev);
    return act;
}
