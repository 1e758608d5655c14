"""Many cases of one scene in one C call (native/batch.c, ig_batch_run): the sweep's chunks and
`run_batch` run their cases so, with no Python between them.

A case the batch can take changes only scene inputs that are model parameters (by their
parameter-table key, e.g. ``rod.yield_strength``, ``chain.length[1]``) and the initial state
(``initial.q[i]``, ``initial.q_deg[i]``, ``initial.u[i]``, and a free chain's
``initial.base[i]``, ``initial.base_velocity[i]``), by real numbers. The C loop fills
each case's parameters from the base scene's, checks and derives them (model_derive), runs it
through the one driver (ig_run_begin, ig_run) and writes its summary. Every case whose row the
batch cannot give exactly as `simulate` would is run again on the per-case path (chunk.run_case):
values the C checks refuse (the scene's message is the row's), a start the scene checks may
refuse, values that need another model's contact points, a failure (its message), a run that
ends without separating, and a case whose validity warnings may not be empty. Those are rare in
a study; the rows are then the same, bit for bit, as the per-case path's.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..laws import YIELD_ONSET
from ..scene import TOUCH_TOLERANCE, Scene, split_key
from ..validity import CHATTER_RATIO, ENERGY_FLOOR, ENERGY_MARGIN, JACKSON_GREEN_MAX_W, RESOLUTION_MARGIN

INITIAL_KEYS = ("q", "q_deg", "u")  # [initial] keys the batch takes element by element
BASE_KEYS = ("base", "base_velocity")  # and a free chain's base point's (x, y) and (vx, vy)
NOT_BATCHED = ("surface.height",)  # a parameter whose value also decides another ("initial")
FRICTION = "contact.friction"  # 0 or not chooses the model: a case on the other side runs per case
ANGLE = "surface.angle_deg"  # so does a level surface or an inclined one
# The warning screen: a case within this factor of a validity threshold runs on the per-case
# path, which words the warnings (validity.py).
SCREEN_MARGIN = 2.0
MAX_PLANS = 8  # plans kept per process (a sweep has one)
PLAIN_NUMBERS = {float, int}  # a column of these goes into an array at once
NUMBER = (float, int, np.floating, np.integer)


@dataclass(frozen=True)
class Plan:
    """How the cases of one scene with these varied keys run in C: the compiled model, each
    key's place (a parameter's index, or an initial state's element), the base parameters."""

    scene: Scene
    keys: tuple[str, ...]
    model: Any  # build.CompiledModel
    params: Any  # the base scene's model_params (cffi), never run
    param_keys: tuple[int, ...]  # positions in `keys` of the parameters
    param_index: tuple[int, ...]  # their indices in the parameter table
    settings: Any  # ig_batch_settings (cffi)
    heights_change: bool  # a length or an angle varies: the start's heights are screened


def plan_for(scene: Scene, keys: tuple[str, ...]) -> Plan | None:
    """The plan for cases of `scene` varying `keys`, or None when the batch cannot take them
    (a key that is no parameter nor initial element, or a scene whose warnings need the
    samples)."""
    if scene.contact.friction_mode == "frozen" and scene.contact.friction > 0:
        return None  # its warning reads the samples
    return _plan(scene, keys)


_plans: dict[tuple[str, tuple[str, ...]], Plan | None] = {}  # by the scene's text and the keys, per process


def _plan(scene: Scene, keys: tuple[str, ...]) -> Plan | None:
    key = (scene.to_toml(), keys)
    if key not in _plans:
        if len(_plans) >= MAX_PLANS:
            _plans.clear()
        _plans[key] = _new_plan(scene, keys)
    return _plans[key]


def _new_plan(scene: Scene, keys: tuple[str, ...]) -> Plan | None:
    from ..build import compile_model
    from ..engines import model_spec
    from ..model_params import fill_params
    model = compile_model(model_spec(scene))
    ffi, lib = model.ffi, model.lib
    inputs = {ffi.string(lib.model_param_key(k)).decode(): k for k in range(lib.MODEL_NPARAM)
              if lib.model_param_kind(k) == 0}
    param_keys, param_index = [], []
    initial = INITIAL_KEYS + (BASE_KEYS if scene.free else ())  # a pinned chain refuses the base's (per case)
    for position, key in enumerate(keys):
        section, name, index = split_key(key)
        if section == "initial" and name in initial and index is not None:
            continue
        if key in NOT_BATCHED or key not in inputs:
            return None
        param_keys.append(position)
        param_index.append(inputs[key])
    base_params = fill_params(model, scene)
    inputs_at = tuple(inputs.values())
    if not all(_sets_its_input_alone(scene, keys[p], k, model, base_params, inputs_at)
               for p, k in zip(param_keys, param_index)):
        return None
    settings = ffi.new("ig_batch_settings *")
    solver = scene.solver
    settings.run_to_time = solver.t_end is not None
    settings.rtol, settings.atol, settings.max_steps = solver.rtol, solver.atol, solver.max_steps
    settings.t_stop = solver.t_max if solver.t_end is None else solver.t_end
    from ..phases import MAX_SEGMENTS
    settings.max_records = MAX_SEGMENTS
    heights = any(_moves_the_start(key) for key in keys)
    return Plan(scene, keys, model, base_params, tuple(param_keys), tuple(param_index), settings, heights)


PROBE_STEP = 1e-3  # relative change of a key's value in the probe of _sets_its_input_alone


def _sets_its_input_alone(scene: Scene, key: str, slot: int, model, base_params, inputs: tuple[int, ...]) -> bool:
    """Whether `key`, changed in `scene`, changes the model's input `slot` and no other, so that
    the batch may set that slot alone: a link's length also sets its mass where the masses come
    from a cross-section, and the tip's radius sets the joints' where they have none of their
    own. Probed once per plan: the scene with the key's value moved by PROBE_STEP, made as the
    per-case path makes it (scene_with), against the base's inputs."""
    from ..model_params import fill_params
    from ..scene import scene_with
    from ..errors import SceneError
    try:
        value = float(scene[key])
        probed = fill_params(model, scene_with(scene, {key: value * (1 + PROBE_STEP) if value else PROBE_STEP}))
    except (SceneError, TypeError, ValueError):
        return False
    lib = model.lib
    return all((lib.model_param_slot(probed, k)[0] != lib.model_param_slot(base_params, k)[0]) == (k == slot)
               for k in inputs)


def _moves_the_start(key: str) -> bool:
    """Whether `key` moves the chain's points at the start (an angle, a length, a free
    chain's base point)."""
    section, name, _ = split_key(key)
    return section == "initial" and name not in ("u", "base_velocity") or section == "chain" and name == "length"


@dataclass
class BatchRows:
    """What the batch gives for some cases: per case its summary record (ig_summary's dtype) and
    its time, of status "ok" (no message, no warning), unless it must run on the per-case path
    instead (`again`)."""

    records: np.ndarray
    links: int  # the model's: y_final begins with its angles, then its speeds
    dof: int  # its coordinates: the angles, and a free chain's base point's two (the speeds start here)
    wall_s: np.ndarray
    again: np.ndarray  # bool per case


def run_plan(plan: Plan, values: np.ndarray, usable: np.ndarray) -> BatchRows:
    """Run the cases (rows of `values`, the keys' values, float) in C; `usable`: the cases
    whose values the batch may take (real numbers); the others are marked `again`."""
    from ..records import record_dtype
    from ..session import EngineSession
    model, scene = plan.model, plan.scene
    ffi, lib = model.ffi, model.lib
    n = len(values)
    y0 = _initial_states(plan, values, model.nstate)
    again = ~usable | ~np.isfinite(values).all(axis=1)
    if plan.heights_change:
        again |= _may_start_inside(plan, values, y0)
    if FRICTION in plan.keys:  # friction on or off is the model's structure (engines.model_spec)
        again |= (values[:, plan.keys.index(FRICTION)] > 0) != (scene.contact.friction > 0)
    if ANGLE in plan.keys:  # and so is a level surface or an inclined one
        again |= (values[:, plan.keys.index(ANGLE)] != 0) != (scene.surface_angle_deg != 0)
    todo = np.flatnonzero(~again)
    m = len(todo)
    dtype = record_dtype(ffi, "ig_summary")
    records = np.zeros(n, dtype)
    wall = np.zeros(n)
    if m:
        params = np.ascontiguousarray(values[todo][:, list(plan.param_keys)], dtype=float)
        starts = np.ascontiguousarray(y0[todo])
        summaries = np.zeros(m, dtype)
        code, flag = np.zeros(m, np.intc), np.zeros(m, np.intc)
        contact, times = np.zeros((m, lib.IG_BATCH_CONTACT)), np.zeros(m)
        begun, impacts = np.zeros(m, np.intc), np.zeros((m, lib.IG_BATCH_IMPACTS, lib.IG_BATCH_IMPACT_FIELDS))
        index = np.array(plan.param_index, np.intc)
        session = EngineSession.open(model, scene.solver)
        done = lib.ig_batch_run(session.solver, session.machine, plan.params, plan.settings, m, len(index),
                                _c(ffi, "int *", index), _c(ffi, "double *", params), _c(ffi, "double *", starts),
                                _c(ffi, "ig_summary *", summaries), _c(ffi, "int *", code), _c(ffi, "int *", flag),
                                _c(ffi, "double *", contact), _c(ffi, "double *", times), _c(ffi, "int *", begun),
                                _c(ffi, "double *", impacts))
        if done != 0:
            raise AssertionError("ig_batch_run refused its arguments")
        ran = code == lib.IG_CASE_RAN
        if not (ran & (flag < 0)).any():  # a failed solver is not handed to the next run
            session.close()
        ok = ran & (flag == lib.IG_RUN_DONE)
        if scene.solver.t_end is not None:  # a run to a time is ok at its end (phases._end_without_event)
            ok |= ran & (flag == lib.IG_REACHED_END)
        ok &= ~_may_warn(plan, summaries, contact, begun, impacts, _lengths(plan, values[todo]).sum(axis=1))
        records[todo] = summaries
        wall[todo] = times
        again[todo[~ok]] = True
    return BatchRows(records, scene.n, scene.dof, wall, again)


def _c(ffi, ctype: str, array: np.ndarray):
    return ffi.cast(ctype, ffi.from_buffer(array))


def _initial_states(plan: Plan, values: np.ndarray, nstate: int) -> np.ndarray:
    """Each case's initial state as `scene_with` makes it (Scene.motion_start): the base angles
    (and a free chain's base point) and their speeds with the varied elements set in the keys'
    order (an element of q_deg in degrees, taking the other angles through degrees and back, as
    the scene does), the works and impulses 0."""
    scene = plan.scene
    n, dof = scene.n, scene.dof
    q = np.tile(np.asarray(scene.q0, float), (len(values), 1))
    u = np.tile(np.asarray(scene.u0, float), (len(values), 1))
    base = {name: np.tile(np.asarray(start, float), (len(values), 1))
            for name, start in (("base", scene.base_start), ("base_velocity", scene.base_velocity))}
    for position, key in enumerate(plan.keys):
        section, name, index = split_key(key)
        if section != "initial":
            continue
        column = values[:, position]
        if name == "u":
            u[:, index - 1] = column
        elif name == "q":
            q[:, index - 1] = column
        elif name in base:
            base[name][:, index - 1] = column
        else:
            q[:] = np.radians(np.degrees(q))
            q[:, index - 1] = np.radians(column)
    y0 = np.zeros((len(values), nstate))
    y0[:, :n], y0[:, dof:dof + n] = q, u
    if scene.free:  # the base point after the angles, its velocity after their rates
        y0[:, n:dof], y0[:, dof + n:2 * dof] = base["base"], base["base_velocity"]
    return y0


def _lengths(plan: Plan, values: np.ndarray) -> np.ndarray:
    lengths = np.tile(np.asarray(plan.scene.chain.length, float), (len(values), 1))
    for position, key in enumerate(plan.keys):
        section, name, index = split_key(key)
        if section == "chain" and name == "length":
            lengths[:, index - 1] = values[:, position]
    return lengths


def _may_start_inside(plan: Plan, values: np.ndarray, y0: np.ndarray) -> np.ndarray:
    """The cases whose start the scene checks (physics.check_physics: no point of the chain
    inside the surface) may refuse: within half their slack of it. They run per case."""
    n = plan.scene.n
    lengths = _lengths(plan, values)
    base = y0[:, n + 1:n + 2] if plan.scene.free else np.zeros((len(values), 1))  # a free chain's y_0, or the pivot
    heights = base + np.concatenate([np.zeros((len(values), 1)), np.cumsum(lengths * np.sin(y0[:, :n]), axis=1)],
                                    axis=1)
    surface = plan.scene.surface_height
    slack = TOUCH_TOLERANCE * np.maximum(1.0, lengths.sum(axis=1))
    if plan.scene.free:  # every point, the base point's too, against the surface ("initial": the lowest's)
        if surface is None:
            return np.zeros(len(values), bool)
        return surface - heights.min(axis=1) > slack / SCREEN_MARGIN
    y_s = heights[:, -1] if surface is None else np.full(len(values), surface)
    low = np.minimum(heights[:, :-1], heights[:, 1:]).min(axis=1)
    inside = y_s - low > slack / SCREEN_MARGIN
    if surface is not None:
        inside |= surface - heights[:, -1] > slack / SCREEN_MARGIN
    return inside


def _may_warn(plan: Plan, summaries: np.ndarray, contact: np.ndarray, begun: np.ndarray, impacts: np.ndarray,
              chain_length: np.ndarray) -> np.ndarray:
    """A screen of validity.validity_warnings and energy_warning: the cases that may have a
    warning (an impact near or past a threshold, flights near chattering, an impact the table
    of `impacts` lacks) are True. Every impact is judged, at its own point (the summary holds
    only the first impact's and the largest values): `begun` and `impacts` are batch.c's table
    (IG_BATCH_IMPACT_FIELDS). The warnings' words and their exact rules stay in validity.py:
    these cases run per case."""
    scene = plan.scene
    rtol = scene.solver.rtol
    flagged = begun > impacts.shape[1]  # impacts beyond the table's rows
    listed = np.arange(impacts.shape[1]) < begun[:, None]
    point, t_start, t_end, dm, R, dc = np.moveaxis(impacts, 2, 0)
    resolution = (rtol * chain_length)[:, None]  # the angles carry rtol |q|
    near = (dm > 0) & (dm < SCREEN_MARGIN * RESOLUTION_MARGIN * resolution)
    if scene.contact.model == "three-phase":
        B = contact[:, 2:3]
        with np.errstate(all="ignore"):
            w = dm / dc
            a = np.sqrt(R * dm * (dm / (YIELD_ONSET * dc)) ** B)
        near |= ~(dc > 0) | (w > JACKSON_GREEN_MAX_W / SCREEN_MARGIN) | ((w > 0) & (w < SCREEN_MARGIN))
        near |= (dm >= YIELD_ONSET * dc / SCREEN_MARGIN) & ~(a < R / SCREEN_MARGIN)
        flagged |= ~(contact[:, 1] > 0)
    flagged |= (near & listed).any(axis=1)
    if not (scene.solver.t_end is not None and scene.solver.sustained_contact):  # (validity_warnings' rule)
        flagged |= _may_chatter(point, t_start, t_end, listed)
    budget = np.stack([summaries[name] for name in ("T0", "Tf", "W_normal", "W_friction", "W_gravity")])
    scale = np.abs(budget).max(axis=0)
    allowed = max(ENERGY_MARGIN * rtol, ENERGY_FLOOR) * scale
    flagged |= ~(np.abs(summaries["residual"]) <= allowed / SCREEN_MARGIN)
    return flagged


def _may_chatter(point: np.ndarray, t_start: np.ndarray, t_end: np.ndarray, listed: np.ndarray) -> np.ndarray:
    """A screen of validity.chattering over each case's impacts (rows; columns in the order
    they began): a point's flight to its next impact shorter than SCREEN_MARGIN times what
    chattering allows (CHATTER_RATIO contact times of the impact before)."""
    flagged = np.zeros(len(point), bool)
    for j in range(1, point.shape[1]):
        before = np.full(len(point), -1)
        for i in range(j):  # the latest impact of the same point before impact j
            before = np.where(point[:, i] == point[:, j], i, before)
        rows = np.flatnonzero((before >= 0) & listed[:, j])
        if not len(rows):
            continue
        b = before[rows]
        start, end = t_start[rows, b], t_end[rows, b]
        flagged[rows] |= ~(t_start[rows, j] - end >= SCREEN_MARGIN * CHATTER_RATIO * (end - start))
    return flagged


def case_values(keys: tuple[str, ...], cases: list[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray]:
    """The cases' values of `keys` as floats (rows), and which cases are all real numbers
    (a bool, a string or a list is not: such a case runs per case, which says what is wrong)."""
    values = np.full((len(cases), len(keys)), np.nan)
    usable = np.ones(len(cases), bool)
    for position, key in enumerate(keys):
        column = [case[key] for case in cases]
        if set(map(type, column)) <= PLAIN_NUMBERS:  # the common column: floats (ints) only, at C speed
            try:
                values[:, position] = column
                continue
            except OverflowError:  # an integer beyond a float: found below
                pass
        for i, v in enumerate(column):
            try:
                if isinstance(v, NUMBER) and not isinstance(v, (bool, np.bool_)):
                    values[i, position] = v
                    continue
            except OverflowError:
                pass
            usable[i] = False
    return values, usable


__all__ = ["BatchRows", "Plan", "case_values", "plan_for", "run_plan"]
