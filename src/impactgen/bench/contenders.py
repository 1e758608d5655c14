"""The solvers a work-precision benchmark compares, each as `run(scene, rtol) -> result`.

- impactgen: the default "auto" (the plain-C pair, BDF where a segment turns stiff), CVODE
  BDF and Adams, ARKODE's explicit pair and the plain-C pair alone (dopri5), with the
  generated C, one C call per run (ig_run), the steps recorded; and auto and BDF summary
  only, as a sweep runs them;
- scipy + C: solve_ivp (RK45, DOP853, Radau, LSODA) calling the generated C right-hand
  side through cffi, under the reference engine's phase loop;
- reference: the pure-Python engine;
- scikit-sundae: SUNDIALS CVODE driven from Python callbacks (numpy right-hand side);
- PyDy: pydy.codegen's Cython ODE function of the same Kane system, with scipy's events.

The Python-driven contenders get a budget of right-hand-side calls, so that a stiff
problem handed to an explicit method stops instead of running for minutes.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import reference
from ..build import compile_model
from ..codegen.spec import PHASES
from ..codegen.spec import STATE_LAW
from ..engines import model_spec, simulate
from ..model_params import params_at_start
from ..reference import ReferenceModel, Segment
from ..results import SimulationResult
from ..scene import Scene

LAW_CODE = {state: PHASES.index(law) for state, law in STATE_LAW.items()}  # params.phase per state


class BudgetExceeded(RuntimeError):
    """A contender used more right-hand-side calls than the benchmark allows."""


def _as_given(scene: Scene, rtol: float, budget: int) -> Scene:
    return scene


@dataclass(frozen=True)
class Contender:
    name: str
    family: str
    run: Callable[[Scene, float, int], SimulationResult]  # scene, rtol, budget (RHS calls)
    # the scene `run` is given, made before the timing starts (a contender that takes its
    # settings from the scene does not time their parsing: the others take them as arguments)
    prepare: Callable[[Scene, float, int], Scene] = _as_given


def with_tolerance(scene: Scene, rtol: float, **solver) -> Scene:
    return scene.replace(solver=dataclasses.replace(scene.solver, rtol=rtol, atol=rtol * 1e-2, **solver))


def _budgeted(model: ReferenceModel, budget: int) -> ReferenceModel:
    rhs, calls = model.rhs, [0]

    def counted(t, y, phase):
        calls[0] += 1
        if calls[0] > budget:
            raise BudgetExceeded(f"more than {budget} right-hand-side calls")
        return rhs(t, y, phase)

    model.rhs = counted  # type: ignore[method-assign]
    return model


# ----------------------------------------------------------------------------- impactgen

def cvode(method: str, record_steps: bool = True) -> Contender:
    """impactgen's C engine; without `record_steps`, summary only (as a sweep runs it): the
    same steps, so the same error, with only the switches sampled."""
    def prepare(scene: Scene, rtol: float, budget: int) -> Scene:
        return with_tolerance(scene, rtol, method=method, max_steps=budget)

    def run(scene: Scene, rtol: float, budget: int) -> SimulationResult:
        return simulate(scene, engine="c", record_steps=record_steps, warn=False)  # the settings are the scene's
    name = {"erk": "ARKODE ERK 5(4)", "dopri5": "DOPRI5 plain C", "auto": "auto, DOPRI5 then BDF"}.get(
        method, f"CVODE {method.upper()}")
    return Contender(f"{name} (impactgen C{'' if record_steps else ', summary only'})", "impactgen", run,
                     prepare)


# ----------------------------------------------------------------------------- scipy + C

class CompiledRhsModel(ReferenceModel):
    """The reference's phase loop and events, with the generated C right-hand side."""

    @classmethod
    def for_scene(cls, scene: Scene) -> "CompiledRhsModel":
        base = ReferenceModel.from_scene(scene)
        model = cls(base.chain, base.contact, base.n, base.friction_state)
        model.compiled = compile_model(model_spec(scene))
        model.params = params_at_start(model.compiled, scene)
        model.ydot = np.empty(model.compiled.nstate)
        model.ydot_c = model.compiled.ffi.cast("double *", model.ydot.ctypes.data)
        return model

    def rhs(self, t: float, y: np.ndarray, phase: str) -> np.ndarray:
        c, ffi = self.contact, self.compiled.ffi
        tip = self.params.point[self.compiled.lib.MODEL_TIP_POINT]
        tip.phase = LAW_CODE[phase]
        tip.delta_m, tip.delta_r, tip.R_res = c.delta_m, c.delta_r, c.R_res
        y = np.ascontiguousarray(y, dtype=float)
        self.compiled.lib.model_rhs(t, ffi.cast("double *", y.ctypes.data), self.ydot_c, self.params)
        return self.ydot.copy()


def scipy_with_c(method: str) -> Contender:
    def run(scene: Scene, rtol: float, budget: int) -> SimulationResult:
        model = _budgeted(CompiledRhsModel.for_scene(scene), budget)
        return reference.simulate(scene, method, rtol, rtol * 1e-2, model=model, engine=f"scipy-{method}+C")
    return Contender(f"scipy {method} + C RHS", "scipy + C", run)


# ----------------------------------------------------------------------------- reference

def pure_python(method: str = "Radau") -> Contender:
    def run(scene: Scene, rtol: float, budget: int) -> SimulationResult:
        model = _budgeted(ReferenceModel.from_scene(scene), budget)
        return reference.simulate(scene, method, rtol, rtol * 1e-2, model=model)
    return Contender(f"reference ({method}, numpy)", "reference", run)


# ----------------------------------------------------------------------------- scikit-sundae

def _sksundae_segment(model, phase, t0, y0, t_final, events, method, rtol, atol) -> Segment:
    from sksundae.cvode import CVODE
    names, functions = list(events), list(events.values())

    def rhsfn(t, y, yp):
        yp[:] = model.rhs(t, y, phase)

    def eventsfn(t, y, out):
        for k, fn in enumerate(functions):
            out[k] = fn(t, y)

    eventsfn.terminal = [True] * len(functions)
    eventsfn.direction = [int(fn.direction) for fn in functions]
    solver = CVODE(rhsfn, method="BDF", rtol=rtol, atol=atol, eventsfn=eventsfn,
                   num_events=len(functions), max_num_steps=10**7)
    sol = solver.solve(np.array([t0, t_final]), np.asarray(y0, float))
    if not sol.success:
        raise reference.SolverError(f"scikit-sundae: {sol.message}", phase, float(sol.t[-1]))
    fired = []
    if sol.i_events is not None and len(sol.i_events):
        fired = [names[k] for k, flag in enumerate(np.atleast_2d(sol.i_events)[-1]) if flag != 0]
    return Segment(np.asarray(sol.t[1:]), np.asarray(sol.y[1:]), fired, len(sol.t) - 1, sol.nfev, sol.njev)


def scikit_sundae() -> Contender:
    def run(scene: Scene, rtol: float, budget: int) -> SimulationResult:
        model = _budgeted(ReferenceModel.from_scene(scene), budget)
        return reference.simulate(scene, "BDF", rtol, rtol * 1e-2, model=model,
                                  integrate=_sksundae_segment, engine="scikit-sundae")
    return Contender("scikit-sundae CVODE (Python callbacks)", "scikit-sundae", run)


# ----------------------------------------------------------------------------- PyDy

class PyDyModel(ReferenceModel):
    """PyDy's generated ODE function of the same Kane system; the contact forces are its
    'specified' inputs, computed per call from the reference's contact laws."""

    @classmethod
    def for_scene(cls, scene: Scene, generator: str) -> "PyDyModel":
        from ..codegen.mechanics import kane_system
        base = ReferenceModel.from_scene(scene)
        model = cls(base.chain, base.contact, base.n, base.friction_state)
        model.f = _pydy_function(kane_system(scene.n), generator)
        model.p = np.array(list(scene.chain.length) + list(scene.chain.mass) + [scene.chain.gravity])
        return model

    def chain_rates(self, t: float, y: np.ndarray, F: np.ndarray, F_f: np.ndarray) -> np.ndarray:
        # the loads of the last link: the forces at the tip, the only point of this Kane system
        return self.f(y[:2 * self.n], t, np.array([F[-1], F_f[-1]]), self.p)


_pydy_cache: dict = {}


def _pydy_function(system, generator: str):
    import sympy
    from pydy.codegen.ode_function_generators import generate_ode_function
    key = (len(system.q), generator)
    if key not in _pydy_cache:
        s = system.symbols
        _pydy_cache[key] = generate_ode_function(
            system.kane.forcing, list(system.q), list(system.u), list(s.L) + list(s.m) + [s.g],
            mass_matrix=system.kane.mass_matrix, coordinate_derivatives=sympy.Matrix(system.u),
            specifieds=[s.F, s.F_f], generator=generator)
    return _pydy_cache[key]


def pydy_codegen(generator: str = "cython", method: str = "LSODA") -> Contender:
    def run(scene: Scene, rtol: float, budget: int) -> SimulationResult:
        model = _budgeted(PyDyModel.for_scene(scene, generator), budget)
        return reference.simulate(scene, method, rtol, rtol * 1e-2, model=model, engine=f"pydy-{generator}")
    return Contender(f"PyDy {generator} + scipy {method}", "PyDy", run)


def available_contenders() -> tuple[list[Contender], list[str]]:
    """Every contender whose packages import, and a note for each one left out."""
    contenders = [cvode("auto"), cvode("auto", record_steps=False), cvode("bdf"), cvode("bdf", record_steps=False),
                  cvode("adams"), cvode("erk"), cvode("dopri5")]
    contenders += [scipy_with_c(m) for m in ("LSODA", "Radau", "DOP853", "RK45")]
    contenders += [pure_python("Radau"), pure_python("LSODA")]  # the reference engine's fastest, whichever
    notes = []
    try:
        import sksundae  # noqa: F401
        contenders.append(scikit_sundae())
    except ImportError:
        notes.append("scikit-sundae is not installed (pip install scikit-sundae): left out")
    try:
        import pydy  # noqa: F401
        import Cython  # noqa: F401
        contenders.append(pydy_codegen("cython"))
    except ImportError:
        notes.append("PyDy with Cython is not installed (pip install pydy cython): left out")
    return contenders, notes
