"""The front door: from a checked scene to a result, with the engine of one's choice.

Every option is checked against the engine before any work (no model is built for an
option that will be refused), and the solver settings override the scene's own.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from . import phases
from .build import compile_model
from .codegen.spec import RATE_LAWS, STATES, ModelSpec
from .dense import dropped_times_warning
from .errors import ImpactgenWarning, SceneError, excerpt
from .results import SimulationResult
from .scene import METHODS as C_METHODS
from .scene import TOUCH_TOLERANCE, Scene, Solver, joint_heights, load_scene, replace_solver, solver_with
from .validity import issue_warnings

ENGINES = ("c", "reference")
# simulate()'s solver settings, and the scene keys they override (both engines take them)
SOLVER_OPTIONS = ("rtol", "atol", "max_steps", "t_end")  # simulate()'s keys of the scene's [solver]
OPTIONS = ("engine", "method", *SOLVER_OPTIONS, "t_eval", "dense_output", "record_steps", "warn")


def model_spec(scene: Scene, solver: Solver | None = None) -> ModelSpec:
    """The structure of the generated C that `scene` needs (numbers stay parameters), run
    under `solver` (default: the scene's own)."""
    contact = scene.contact
    if solver is None:
        solver = scene.solver
    friction_law = contact.friction_mode if contact.friction > 0 else "none"
    sustained = solver.t_end is not None and solver.sustained_contact
    joints = reachable_joints(scene)
    # the analytic Jacobian is written for a rate-free law (pinned or free chain, level or
    # inclined surface): a rate-dependent law's runs on CVODE's difference quotients
    analytic = solver.jacobian == "analytic" and contact.model not in RATE_LAWS
    return ModelSpec(scene.n, contact.model, friction_law, analytic, sustained, joints,
                     scene.free, scene.surface_angle_deg != 0.0)


def reachable_joints(scene: Scene) -> tuple[int, ...]:
    """The contact points besides the tip that can touch the surface: the joints (1 to n - 1)
    whose distance from the pivot along the chain reaches the surface below it. The others get
    no contact code. Every point of a free chain can reach it: its base point (0) and its joints."""
    if scene.free:
        return tuple(range(scene.n))
    lengths = scene.chain.length
    y_s = joint_heights(scene)[-1] if scene.surface_height is None else scene.surface_height  # "initial": the tip's
    depth = -y_s - TOUCH_TOLERANCE * max(1.0, sum(lengths))  # of the surface below the pivot, less the rounding
    reach = 0.0
    joints = []
    for joint, length in enumerate(lengths[:-1], start=1):
        reach += length
        if reach >= depth:
            joints.append(joint)
    return tuple(joints)


def simulate(scene: Scene, engine: str = "c", *, method: str | None = None, rtol: float | None = None,
             atol: float | None = None, max_steps: int | None = None, t_end: float | str | None = None,
             t_eval: Any = None, dense_output: bool = False, record_steps: bool = True, warn: bool = True,
             **unknown: Any) -> SimulationResult:
    """Simulate `scene` to its first separation, or to `solver.t_end`, and return the result.

    Parameters
    ----------
    scene : Scene, str or Path
        A checked scene (`load_scene`, `scene_from_dict`), or a scene file or a shipped
        example's name, loaded as `load_scene` loads it.
    engine : {"c", "reference"}, default "c"
        "c": the generated C model on its C integrators (built on first use, then cached).
        "reference": the independent pure-Python engine on scipy's solve_ivp.
    method : str, optional
        The integrator. C engine: "auto" (the scene default: the plain-C explicit pair,
        handing a segment that turns stiff, or that takes it 2000 steps, to BDF), "bdf",
        "adams", "erk" or "dopri5"
        (default: the scene's solver.method).
        Reference engine: a solve_ivp method, "Radau" (default), "BDF", "LSODA", "DOP853"
        or "RK45".
    rtol, atol : float, optional
        Tolerances, overriding solver.rtol and solver.atol.
    max_steps : int, optional
        Steps allowed per phase, overriding solver.max_steps.
    t_end : float or "separation", optional
        Overrides solver.t_end: a time in s runs through every later impact.
    t_eval : array_like, optional
        Sorted real times in s at which to return the solution (read from the integrator's
        own interpolating polynomial, as solve_ivp does); bools, strings and complex numbers
        are refused, and so is a count whose samples would not fit in the memory available. Times after the run's end (the first
        separation) are left out, as solve_ivp does after a terminal event, and
        ``result.warnings`` says how many and when the run ended. Without it, the samples are every integrator step.
    dense_output : bool, default False
        Keep the interpolating polynomials, so that ``result.sol(t)`` gives y at any time
        of the run, across phase switches.
    record_steps : bool, default True
        Keep a sample at every integrator step. False keeps only the start, each phase
        switch and the end: every summary, impact and phase span is the same (bit for bit,
        the steps being the same), at less cost; what a sweep uses. The reference engine
        always keeps its steps.
    warn : bool, default True
        Issue each of ``result.warnings`` through Python's `warnings` module as well, with
        category `impactgen.errors.ValidityWarning` (the t_eval times left out:
        `ImpactgenWarning`), attributed to the line that called simulate(), so that a result
        outside the model's range is never silent. False keeps them in ``result.warnings``
        only: for a caller that reports them itself (the command line prints them; a sweep
        issues one warning with a count of its cases).

    Returns
    -------
    SimulationResult
        ``t`` (n_points,), ``y`` (n_states, n_points), the outputs, ``impacts``,
        ``summary``, ``status`` and ``success``. A solver failure does not raise: the
        result has ``success`` False, the reason in ``message`` and the samples reached.

    Raises
    ------
    SceneError
        An unknown option, or a value an engine cannot take, before any model is built.
    BuildError
        The C model could not be generated or compiled.

    Examples
    --------
    >>> import impactgen
    >>> scene = impactgen.load_scene("paper")
    >>> result = impactgen.simulate(scene, rtol=1e-8, t_eval=[0.0, 1e-4, 2e-4])
    >>> result.y.shape                     # q1, q2, u1, u2, W_normal, W_friction, P_normal, P_friction
    (8, 3)
    >>> round(result.summary["delta_r"] * 1e6, 2)       # permanent deformation in um
    5.57
    """
    if type(scene) is not Scene:
        scene = _scene_of(scene)
    if unknown:
        name = sorted(unknown)[0]
        raise SceneError(name, f"unknown option of simulate(); the options are {', '.join(OPTIONS)}")
    if engine not in ENGINES:
        raise SceneError("engine", f"{excerpt(engine)} is not one of {', '.join(ENGINES)}")
    solver = scene.solver
    if rtol is not None or atol is not None or max_steps is not None or t_end is not None or method is not None:
        given = {"rtol": rtol, "atol": atol, "max_steps": max_steps, "t_end": t_end}
        settings = {k: v for k, v in given.items() if v is not None}
        if method is not None and engine == "c":
            settings["method"] = _c_method(method)
        if settings:  # only the values given are checked: the rest of the scene was checked already
            solver = solver_with(scene, settings)
    times = _checked_times(t_eval, scene, solver) if t_eval is not None else None
    if type(dense_output) is not bool or type(record_steps) is not bool or type(warn) is not bool:  # (the common case)
        for name, flag in (("dense_output", dense_output), ("record_steps", record_steps), ("warn", warn)):
            if flag is not True and flag is not False and not isinstance(flag, np.bool_):
                raise SceneError(name, f"expected True or False, got {excerpt(flag)}")
    if engine == "c":
        result = phases.run(compile_model(model_spec(scene, solver)), scene, solver, t_eval=times,
                            dense_output=bool(dense_output), record_steps=bool(record_steps))
    else:
        from . import reference
        result = reference.simulate(replace_solver(scene, solver), _reference_method(method), t_eval=times,
                                    dense_output=bool(dense_output))
    dropped = []  # t_eval's times after the run's end: not done as asked, but no validity issue
    if times is not None and len(result.t) < len(times):  # warnings are made once, then kept
        dropped = dropped_times_warning(len(times), len(result.t), float(result.trajectory.t[-1]))
        result.warnings.extend(dropped)
    if warn:
        issue_warnings(result.warnings[:len(result.warnings) - len(dropped)], scene.name)
        issue_warnings(dropped, scene.name, ImpactgenWarning)
    return result


def _scene_of(scene: Any) -> Scene:
    """simulate()'s first argument as a Scene: a scene file or an example's name is loaded,
    as load_scene does; anything else is refused in one line."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise SceneError("scene", f"simulate() takes a Scene (load_scene, scene_from_dict), a scene file or an "
                              f"example's name such as 'paper'; got {type(scene).__name__} {excerpt(scene)}")


def _c_method(method: Any) -> str:
    name = method.lower() if isinstance(method, str) else method
    if name not in C_METHODS:
        raise SceneError("method", f"{excerpt(method)} is not a method of the C engine ({', '.join(C_METHODS)}); "
                                   "solve_ivp's methods (Radau, LSODA, ...) need engine='reference'")
    return name


def _reference_method(method: Any) -> str:
    from .reference import METHODS
    if method is None:
        return "Radau"
    names = {m.lower(): m for m in METHODS}
    if not isinstance(method, str) or method.lower() not in names:
        raise SceneError("method", f"{excerpt(method)} is not a method of the reference engine "
                                   f"({', '.join(METHODS)})")
    return names[method.lower()]


NOT_TIMES = (bool, np.bool_, str, bytes, complex, np.complexfloating)  # what np.asarray(dtype=float) took silently
SAMPLE_COPIES = 2  # the samples at t_eval exist twice at the end of a run: per segment, and joined
PHASE_LABEL_BYTES = 4 * max(len(name) for name in STATES)  # each sample's phase, a numpy str


def _checked_times(t_eval: Any, scene: Scene, solver: Solver) -> np.ndarray:
    """t_eval as a sorted 1-D array of finite real times within the run, of a size whose
    samples fit in memory. Numbers only: a bool, a string of digits or a complex number
    (whose imaginary part numpy drops) is refused, not read as a time."""
    if isinstance(t_eval, NOT_TIMES) or not hasattr(t_eval, "__len__") and not hasattr(t_eval, "__array__"):
        raise SceneError("t_eval", f"expected an array of times in s, got {type(t_eval).__name__} {excerpt(t_eval)}")
    try:
        count = len(t_eval)
    except TypeError:  # a numpy scalar, say
        count = 1
    _check_memory(count, scene)
    if np.ma.isMaskedArray(t_eval) and np.ma.getmaskarray(t_eval).any():  # np.asarray would drop the mask
        raise SceneError("t_eval", "expected times in s, got a masked array with masked times: give only the "
                                   "times wanted (t_eval.compressed())")
    try:
        given = np.asarray(t_eval)
    except (TypeError, ValueError):  # a ragged list
        raise SceneError("t_eval", f"expected an array of times in s (real numbers), got {excerpt(t_eval)}") from None
    # a list's elements, and an object array's, are looked at one by one: numpy makes
    # [0.5, True] an array of floats
    items = t_eval if isinstance(t_eval, (list, tuple)) else given.ravel() if given.dtype.kind == "O" else ()
    bad = next((x for x in items if x is None or isinstance(x, NOT_TIMES)), 0.0)
    if bad is None or isinstance(bad, NOT_TIMES):
        raise SceneError("t_eval", f"expected times in s (real numbers), got {type(bad).__name__} {excerpt(bad)}")
    try:
        if given.dtype.kind not in "iufO":  # bool, complex, str, bytes, datetime, ...
            raise TypeError(given.dtype)
        times = given.astype(float, copy=False)
    except (TypeError, ValueError):
        raise SceneError("t_eval", f"expected an array of times in s (real numbers), got {excerpt(t_eval)}") from None
    if times.ndim != 1 or not len(times):
        raise SceneError("t_eval", f"expected a non-empty 1-D array of times, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        raise SceneError("t_eval", "times must be finite")
    if np.any(np.diff(times) < 0):
        raise SceneError("t_eval", "times must be sorted in increasing order")
    end = solver.t_end if solver.t_end is not None else solver.t_max
    if times[0] < 0 or times[-1] > end * (1 + 4 * np.finfo(float).eps):
        what = "solver.t_end" if solver.t_end is not None else "solver.t_max"
        raise SceneError("t_eval", f"times must lie in [0, {what} = {end:g} s], got "
                                   f"[{times[0]:g}, {times[-1]:g}]")
    return times


def sample_bytes(scene: Scene) -> int:
    """Bytes a run of `scene` keeps per sample at a t_eval time: the time, the states (the
    angles, the speeds, and each contact point's works and impulses), the outputs (the tip's
    eight, a kinetic energy per link and the two totals, six per joint with contact) and the
    phase label, SAMPLE_COPIES times."""
    n, points = scene.n, 1 + len(reachable_joints(scene))
    states, outputs = 2 * n + 4 * points, 8 + n + 2 + 6 * (points - 1)
    return SAMPLE_COPIES * (8 * (1 + states + outputs) + PHASE_LABEL_BYTES)


def available_memory() -> int | None:
    """Bytes of memory this process could still take (Linux's MemAvailable; elsewhere the
    physical memory), or None where the system does not say."""
    try:
        with open("/proc/meminfo") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None


def _check_memory(count: int, scene: Scene) -> None:
    """Refuse, before any work, a t_eval whose samples will not fit in memory, naming the size
    (10^8 times had run 15 s and ended in numpy's MemoryError)."""
    need = count * sample_bytes(scene)
    have = available_memory()
    if have is not None and need > have:
        raise SceneError("t_eval", f"{count} times need about {_size(need)} for their samples, more than the "
                                   f"{_size(have)} of memory available; ask for fewer times, or for dense_output=True "
                                   "and read result.sol(t) a part at a time")


def _size(n_bytes: float) -> str:
    for unit in ("bytes", "kB", "MB", "GB"):
        if n_bytes < 1000:
            return f"{n_bytes:.3g} {unit}"
        n_bytes /= 1000
    return f"{n_bytes:.3g} TB"


__all__ = ["ENGINES", "OPTIONS", "model_spec", "simulate"]
