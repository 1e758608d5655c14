"""Cross-check the compiled C engine against the independent pure-Python reference.

Two levels: the right-hand sides at random states in every phase, and whole simulations of
the repository's scenes, steel chains and random scenes, compared quantity by quantity.
"""
from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from .codegen.spec import PHASES
from .errors import SolverError
from .results import Impact, SimulationResult
from .scene import Scene, scene_from_dict, load_scene, steel_chain_scene

QUANTITIES = ("u_final", "q_final", "delta_max", "delta_r", "delta_T", "t_contact", "switch_times",
              "trajectory_q")


# ----------------------------------------------------------------------------- scenes

def random_scene(rng: np.random.Generator, n: int, name: str, rtol: float) -> Scene:
    """A random chain approaching the surface: lengths, masses, materials, mu (regularized or
    exact Coulomb), angles, speeds; half of them start in free flight a little above the
    surface."""
    L = rng.uniform(0.3, 1.5, n)
    for _ in range(1000):  # angles and speeds with a clear approach (a link near -90 deg has none)
        q = np.radians(rng.uniform(-150.0, -30.0, n))
        u = rng.uniform(-1.0, 1.0, n)
        v_By = float(np.sum(L * u * np.cos(q)))
        if abs(v_By) > 0.02:
            break
    else:  # pragma: no cover - probability ~0
        raise RuntimeError("could not draw an approaching state")
    if v_By > 0:  # approach the surface
        u = -u
    y_B = float(np.sum(L * np.sin(q)))
    free_flight = rng.random() < 0.5
    E = [float(10 ** rng.uniform(10.8, 11.6)) for _ in range(2)]
    raw = {
        "name": name,
        "chain": {"links": n, "length": L.tolist(), "mass": rng.uniform(0.2, 3.0, n).tolist(),
                  "gravity": 9.81},
        "rod": {"E": E[0], "nu": float(rng.uniform(0.2, 0.35)),
                "yield_strength": float(rng.uniform(0.4e9, 2.0e9)),
                "tip_radius": float(10 ** rng.uniform(-3, -1.7))},
        "surface": {"E": E[1], "nu": float(rng.uniform(0.2, 0.35)),
                    "yield_strength": float(rng.uniform(0.4e9, 2.0e9)),
                    "height": y_B - float(10 ** rng.uniform(-4, -2.5)) if free_flight else "initial"},
        "contact": {"model": "three-phase" if rng.random() < 0.8 else "hertz",
                    "friction": 0.0 if rng.random() < 0.25 else float(rng.uniform(0.05, 0.5)),
                    "friction_mode": "coulomb" if rng.random() < 0.3 else "regularized",
                    "friction_eps": float(10 ** rng.uniform(-5, -3))},
        "initial": {"q": q.tolist(), "u": u.tolist()},
        # a tip that comes to rest without separating ends the comparison at t_max
        "solver": {"rtol": rtol, "atol": rtol * 1e-2, "t_max": 0.05},
    }
    return scene_from_dict(raw, source=f"<random scene {name}>")


def random_free_scene(rng: np.random.Generator, n: int, name: str, rtol: float) -> Scene:
    """A random free chain (`chain.base = "free"`) falling onto a level or inclined surface:
    lengths, masses, materials, mu (regularized or exact Coulomb), angles, rates, the base
    point's velocity, the surface's angle; its lowest contact point starts 0.1 to 3 mm above
    the surface and moves towards it. Runs to its first separation."""
    L = rng.uniform(0.2, 1.0, n)
    for _ in range(1000):  # angles, rates and a base velocity whose lowest point approaches
        q = np.radians(rng.uniform(-180.0, 180.0, n))
        u = rng.uniform(-2.0, 2.0, n)
        v_base = np.array([rng.uniform(-0.5, 0.5), -rng.uniform(0.3, 2.0)])
        # the contact points (base, joints, tip) relative to the base, and their velocities
        heights = np.concatenate([[0.0], np.cumsum(L * np.sin(q))])
        v_y = v_base[1] + np.concatenate([[0.0], np.cumsum(L * u * np.cos(q))])
        lowest = int(np.argmin(heights))
        if v_y[lowest] < -0.05 and np.sort(heights)[1] - heights[lowest] > 0.01:
            break  # (the next lowest point clear of the surface: one point strikes first)
    else:  # pragma: no cover - probability ~0
        raise RuntimeError("could not draw an approaching state")
    E = [float(10 ** rng.uniform(10.8, 11.6)) for _ in range(2)]
    gap = float(10 ** rng.uniform(-4, -2.5))
    raw = {
        "name": name,
        "chain": {"links": n, "length": L.tolist(), "mass": rng.uniform(0.2, 3.0, n).tolist(),
                  "gravity": 9.81, "base": "free"},
        "rod": {"E": E[0], "nu": float(rng.uniform(0.2, 0.35)),
                "yield_strength": float(rng.uniform(0.4e9, 2.0e9)),
                "tip_radius": float(10 ** rng.uniform(-3, -1.7))},
        "surface": {"E": E[1], "nu": float(rng.uniform(0.2, 0.35)),
                    "yield_strength": float(rng.uniform(0.4e9, 2.0e9)), "height": 0.0,
                    "angle_deg": 0.0 if rng.random() < 0.5 else float(rng.uniform(-25.0, 25.0))},
        "contact": {"model": "three-phase" if rng.random() < 0.8 else "hertz",
                    "friction": 0.0 if rng.random() < 0.25 else float(rng.uniform(0.05, 0.5)),
                    "friction_mode": "coulomb" if rng.random() < 0.3 else "regularized",
                    "friction_eps": float(10 ** rng.uniform(-5, -3))},
        "initial": {"q": q.tolist(), "u": u.tolist(), "base": [0.0, gap - float(heights[lowest])],
                    "base_velocity": v_base.tolist()},
        "solver": {"rtol": rtol, "atol": rtol * 1e-2, "t_max": 0.05},
    }
    return scene_from_dict(raw, source=f"<random scene {name}>")


FREE_SHARE = 1 / 3  # of the random scenes, the share that are free chains (1 to 3 links)


def random_scenes(rng: np.random.Generator, count: int, label: str, rtol: float) -> list[Scene]:
    """`count` random scenes named "random-<label>-<i>": pinned chains of 1 to 6 links
    (`random_scene`) and, a third of them, free chains of 1 to 3 links (`random_free_scene`)."""
    scenes = []
    for i in range(count):
        name = f"random-{label}-{i}"
        if rng.random() < FREE_SHARE:
            scenes.append(random_free_scene(rng, int(rng.integers(1, 4)), name, rtol))
        else:
            scenes.append(random_scene(rng, int(rng.integers(1, 7)), name, rtol))
    return scenes


def with_tolerance(scene: Scene, rtol: float) -> Scene:
    return scene.replace(solver=dataclasses.replace(scene.solver, rtol=rtol, atol=rtol * 1e-2))


def standard_scenes(links: Iterable[int], rtol: float) -> list[Scene]:
    """The shipped example scenes that stop at their first separation (runs to a time are
    compared in tests/test_crosscheck_free.py and by POINT_SCENES), and the paper's steel
    chain with each number of links."""
    from .examples import example_names
    shipped = [load_scene(name) for name in example_names()]
    scenes = [with_tolerance(s, rtol) for s in shipped if s.solver.t_end is None]
    return scenes + [with_tolerance(steel_chain_scene(n), rtol) for n in links]


# Several contact points: scenes where joints strike the surface (issue 38), every impact
# simulated (no sustained contact: each rebound in both engines).
POINT_SCENES = {
    "two-points-at-once": {"initial.q_deg": [-30, 0], "initial.u": [-1, 0], "surface.height": "initial"},
    "joint-2-and-tip": {"chain.links": 3, "chain.length": [1, 1, 0.2], "initial.q_deg": [-30, -80, -20],
                        "initial.u": [0, 0, -3], "solver.t_end": 0.3},
    "joint-2-lands-coulomb": {"chain.links": 3, "chain.length": [1, 1, 0.2], "initial.q_deg": [-30, -80, 60],
                              "initial.u": [0, 0, 0], "surface.height": -1.5, "solver.t_end": 0.2,
                              "contact.friction_mode": "coulomb", "contact.friction": 0.5},
}


def points_scenes(rtol: float) -> list[Scene]:
    """The paper's chain and materials in POINT_SCENES: joints and the tip strike the surface."""
    return [with_tolerance(load_scene("paper", {**overrides, "name": name, "solver.sustained_contact": False}), rtol)
            for name, overrides in POINT_SCENES.items()]


# ----------------------------------------------------------------------------- comparison

def _rel(a: np.ndarray | float, b: np.ndarray | float, floor: float = 1e-300) -> float:
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), floor))


# The floors of the final state's scales, for a run that barely moves (a chain resting or
# stuck from its start ends with speeds of rounding size in both engines): a milliradian for
# the pose, and a thousandth of the chain's pendulum speed sqrt(g L) for the speeds (so the
# kinetic energy of the chain at that speed for delta_T).
POSE_FLOOR = 1e-3
SPEED_FLOOR = 1e-3


def _energy_gap(c: SimulationResult, ref: SimulationResult) -> float:
    """delta_T's difference: a difference of energies of size T0 (and 0 for an elastic impact),
    measured against T0, or the run's largest T for a start at rest, or the floor's."""
    scene = ref.given_scene
    floor = 0.5 * sum(scene.chain.mass) * SPEED_FLOOR ** 2 * scene.chain.gravity * sum(scene.chain.length)
    a, b = c.summary["delta_T"], ref.summary["delta_T"]
    return abs(a - b) / max(abs(ref.summary["T0"]), float(np.max(ref.T)), floor)


def _final_state_gaps(c: SimulationResult, ref: SimulationResult) -> dict[str, float]:
    """u_final and q_final: the difference of the states the runs end in. The pose is the
    angles and a free chain's base position over the chain's length L (rad), against its
    largest entry; the motion is every speed as a speed of a point, the rates times L and the
    base's velocity (m/s), against the largest of the run's."""
    scene = ref.given_scene
    L = float(sum(scene.chain.length))

    def pose(result: SimulationResult) -> np.ndarray:
        base = () if result.base is None else result.base[:2, -1] / L
        return np.concatenate([result.summary["q_final"], base])

    def motion(result: SimulationResult) -> np.ndarray:
        base = () if result.base is None else result.base[2:, -1]
        return np.concatenate([np.asarray(result.summary["u_final"]) * L, base])

    speeds = np.abs(ref.u) * L if ref.base is None else np.abs(np.concatenate([ref.u * L, ref.base[2:]]))
    speed_scale = max(float(np.max(speeds)), SPEED_FLOOR * math.sqrt(scene.chain.gravity * L))
    return {"u_final": _rel(motion(c), motion(ref), speed_scale),
            "q_final": _rel(pose(c), pose(ref), POSE_FLOOR)}


def _hermite_q(result: SimulationResult, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """q of `result` at times t by cubic Hermite interpolation (q and dq/dt = u are known);
    returns the values and a mask of the times whose bracket lies inside one phase."""
    ts, q, u, ph = result.t, result.q.T, result.u.T, result.phase  # rows are samples
    k = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2)
    while np.any(ts[k + 1] == ts[k]):  # switch samples appear twice in time: step past them
        k = np.where(ts[k + 1] == ts[k], np.minimum(k + 1, len(ts) - 2), k)
    h = ts[k + 1] - ts[k]
    s = ((t - ts[k]) / np.where(h > 0, h, 1.0))[:, None]
    h = h[:, None]
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    values = h00 * q[k] + h10 * h * u[k] + h01 * q[k + 1] + h11 * h * u[k + 1]
    return values, (ph[k] == ph[k + 1]) & (s[:, 0] >= 0) & (s[:, 0] <= 1)


def _lasting(spans: list) -> list:
    """The phase spans without those of zero length: a stick-slip event that one integrator
    reports with a contact event, the other can report a rounding error later."""
    return [p for p in spans if p.t1 - p.t0 > 1e-12 * max(abs(p.t1), 1e-300)]


def compare(c: SimulationResult, ref: SimulationResult) -> dict[str, float]:
    """Largest relative difference per quantity (inf where the phase sequences differ).
    Vectors are compared in the max norm (the final state as `_final_state_gaps`);
    delta_r against delta_max when it is ~0; delta_T
    against T0 (or the run's largest kinetic energy, for a start at rest); switch times against the latest switch time. With several contact points,
    the impacts are compared one by one (`_compare_points`)."""
    if any(i.point != "tip" for i in (*c.impacts, *ref.impacts)):
        return _compare_points(c, ref)
    a, b = c.summary, ref.summary
    out = {
        **_final_state_gaps(c, ref),
        "delta_max": _rel(a["delta_max"], b["delta_max"], 1e-300),
        "delta_r": _rel(a["delta_r"], b["delta_r"], 1e-6 * max(b["delta_max"], 1e-300)),
        "delta_T": _energy_gap(c, ref),
        "t_contact": _rel(a["t_contact"], b["t_contact"], 1e-300),
    }
    sa = [(s["from"], s["to"]) for s in a["switches"]]
    sb = [(s["from"], s["to"]) for s in b["switches"]]
    phases_a, phases_b = _lasting(c.phases), _lasting(ref.phases)
    if sa != sb or [(p.phase, p.slip_state) for p in phases_a] != [(p.phase, p.slip_state) for p in phases_b]:
        out["switch_times"] = math.inf
    else:
        times_a = np.array([p.t1 for p in phases_a])
        times_b = np.array([p.t1 for p in phases_b])
        out["switch_times"] = _rel(times_a, times_b, 1e-300) if len(times_b) else 0.0
    q_c, inside = _hermite_q(c, ref.t)
    out["trajectory_q"] = _rel(q_c[inside], ref.q.T[inside]) if inside.any() else 0.0
    return out


def _compare_points(c: SimulationResult, ref: SimulationResult) -> dict[str, float]:
    """`compare` for several contact points: the final state, delta_T and the trajectory as
    there; the impacts one by one, in time order (inf where the engines list other points):
    delta_max, delta_r (against delta_max), each one's contact time, the times of every
    start and end (switch_times, against the latest), and each point's own coefficients of
    restitution."""
    out = {**_final_state_gaps(c, ref),
           "delta_T": _energy_gap(c, ref)}
    mine, theirs = c.impacts, ref.impacts
    if [i.point for i in mine] != [i.point for i in theirs]:
        out.update(delta_max=math.inf, delta_r=math.inf, t_contact=math.inf, switch_times=math.inf,
                   coefficients=math.inf)
    elif not theirs:
        out.update(delta_max=0.0, delta_r=0.0, t_contact=0.0, switch_times=0.0, coefficients=0.0)
    else:
        t_last = float(ref.t[-1])

        def ends(impacts) -> np.ndarray:
            return np.array([i.t_end if i.t_end is not None else t_last for i in impacts])

        out["delta_max"] = max(_rel(i.delta_max, j.delta_max, 1e-300) for i, j in zip(mine, theirs))
        out["delta_r"] = max(_rel(i.delta_r, j.delta_r, 1e-6 * max(j.delta_max, 1e-300)) for i, j in zip(mine, theirs))
        starts_c, starts_r = np.array([i.t_start for i in mine]), np.array([j.t_start for j in theirs])
        out["t_contact"] = _rel(ends(mine) - starts_c, ends(theirs) - starts_r, 1e-300)
        out["switch_times"] = _rel(np.concatenate([starts_c, ends(mine)]), np.concatenate([starts_r, ends(theirs)]),
                                   1e-300)
        out["coefficients"] = max(_coefficient_gap(i, j) for i, j in zip(mine, theirs))
    q_c, inside = _hermite_q(c, ref.t)
    out["trajectory_q"] = _rel(q_c[inside], ref.q.T[inside]) if inside.any() else 0.0
    return out


def _coefficient_gap(mine: Impact, theirs: Impact) -> float:
    """The largest difference of two records' coefficients of restitution (numbers near 1);
    inf where one engine has one that the other has not (an impact that did not end)."""
    gap = 0.0
    for name in ("e_N", "e_P", "e_E"):
        a, b = getattr(mine, name), getattr(theirs, name)
        if math.isnan(a) != math.isnan(b):
            return math.inf
        if not math.isnan(a):
            gap = max(gap, abs(a - b))
    return gap


@dataclass
class CaseReport:
    scene: Scene
    differences: dict[str, float]
    wall_c: float
    wall_reference: float


def run_case(scene: Scene, method: str = "Radau") -> CaseReport:
    from .engines import simulate
    c = simulate(scene, engine="c", warn=False)  # (the differences are the report)
    ref = simulate(scene, engine="reference", method=method, warn=False)
    for result in (c, ref):
        if not result.success:  # nothing to compare: say which engine failed on which scene
            raise SolverError(f"{result.engine} engine on scene {scene.name}: {result.message}")
    return CaseReport(scene, compare(c, ref), c.stats["wall_s"], ref.stats["wall_s"])


def run(scenes: list[Scene], method: str = "Radau",
        progress: Callable[[int, int, Scene], None] | None = None) -> list[CaseReport]:
    reports = []
    for i, scene in enumerate(scenes):
        if progress:
            progress(i, len(scenes), scene)
        reports.append(run_case(scene, method))
    return reports


def worst(reports: list[CaseReport]) -> dict[str, tuple[float, str]]:
    out = {}
    for q in QUANTITIES:
        values = [(r.differences[q], r.scene.name) for r in reports]
        out[q] = max(values, key=lambda v: v[0]) if values else (0.0, "")
    return out


def stderr_progress(i: int, total: int, scene: Scene) -> None:
    end = "\r" if sys.stderr.isatty() else "\n"
    print(f"crosscheck [{i + 1}/{total}] {scene.name} ({scene.n} links)".ljust(60), end=end,
          file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- right-hand sides

PHASE_LAWS = PHASES  # the force laws of the generated C, in the order of params.phase


def rhs_pair(scene: Scene, phase: str, y: np.ndarray, delta_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The C right-hand side (through cffi) and the reference's, at state y in `phase`,
    with the restitution state set as at a maximum compression delta_m."""
    from .build import compile_model
    from .engines import model_spec
    from .laws import contact_constants, residual_deformation, unloading_radius
    from .model_params import params_at_start
    from .reference import ReferenceModel

    # the tip's laws, phase by phase: the tip-only model (a joint's contact is compared in whole runs)
    model = compile_model(dataclasses.replace(model_spec(scene), joints=()))
    ffi = model.ffi
    consts = contact_constants(scene)
    params = params_at_start(model, scene)
    ref = ReferenceModel.from_scene(scene)
    P_m = ref.contact.normal_force("elastoplastic" if ref.contact.plastic else "elastic", delta_m)
    ref.contact.at_maximum_compression(delta_m, P_m)
    delta_r = residual_deformation(delta_m, consts.delta_c)
    tip = params.point[model.lib.MODEL_TIP_POINT]
    tip.delta_m = delta_m
    if "R_res" in dict(ffi.typeof("model_point_contact").fields):
        tip.delta_r = delta_r
        tip.R_res = unloading_radius(P_m, delta_m, delta_r, consts.E_star)
    tip.phase = PHASE_LAWS.index(phase)
    names = ref.state_names  # y is laid out as the reference's state; the C model's may have more (each
    if len(y) != len(names):  # joint's own works), which start at 0 here and are not compared
        raise ValueError(f"the state has {len(y)} entries; the reference engine's has {len(names)}")
    given = dict(zip(names, (float(v) for v in y)))
    y_c = ffi.new("double[]", [given.get(name, 0.0) for name in model.state_names])
    ydot = ffi.new("double[]", model.nstate)
    flag = model.lib.model_rhs(0.0, y_c, ydot, params)
    if flag != 0:
        raise ArithmeticError(f"model_rhs returned {flag}")
    c = dict(zip(model.state_names, ydot))
    return np.array([c[name] for name in names]), ref.rhs(0.0, np.asarray(y, float), phase)
