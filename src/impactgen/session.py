"""The CVODE integrator of a run, reused across runs of a warm process (stage 7, with phases.py).

`CvodeSession` owns one `ig_solver` from the C glue (cvode_glue.c): it integrates one phase
segment at a time, until an event, the end time or a failure, and hands back the samples
(and, for dense output, each step's interpolating polynomial). `likely_cause` turns a CVODE
message into one that says what to try.
"""
from __future__ import annotations

import numpy as np

from .build import CompiledModel
from .errors import SolverError
from .scene import METHODS, Scene

FIRST_BUFFER = 1024  # samples; doubled while a segment keeps filling it


class CvodeSession:
    """One CVODE integrator for a whole simulation. `open` reuses an idle one of the same
    model and method (a warm process then allocates nothing per run); `close` returns it."""

    _idle: dict[tuple, list["CvodeSession"]] = {}  # (model, method) -> sessions not in use

    @staticmethod
    def _pool_key(model: CompiledModel, scene: Scene) -> tuple:
        return model.spec, str(model.path), scene.solver.method

    @classmethod
    def open(cls, model: CompiledModel, scene: Scene, atol) -> "CvodeSession":
        try:
            session = cls._idle.get(cls._pool_key(model, scene), []).pop()
        except IndexError:
            return cls(model, scene, atol)
        lib = model.lib
        if lib.ig_solver_reset(session.solver, scene.solver.rtol, atol, scene.solver.max_steps) != 0:
            raise SolverError(f"cannot reset the CVODE solver: {session._message()}")
        return session

    def close(self, scene: Scene) -> None:
        """Hand the integrator back for the next run (only after a run that ended normally)."""
        self._idle.setdefault(self._pool_key(self.model, scene), []).append(self)

    def __init__(self, model: CompiledModel, scene: Scene, atol):
        self.model = model
        ffi, lib = model.ffi, model.lib
        err = ffi.new("char[]", 512)
        method = METHODS.index(scene.solver.method)  # IG_METHOD_BDF, _ADAMS, _ERK
        analytic = 1 if uses_jacobian(model, scene) else 0
        solver = lib.ig_solver_new(method, analytic, scene.solver.rtol, atol, scene.solver.max_steps, err, 512)
        if solver == ffi.NULL:
            raise SolverError(f"cannot create the CVODE solver: {ffi.string(err).decode()}")
        self.solver = ffi.gc(solver, lib.ig_solver_free)
        self.capacity = FIRST_BUFFER
        self.dense_terms = int(lib.ig_dense_terms(self.solver))
        self.dense = False  # keep each step's interpolating polynomial (dense output, t_eval)
        self._alloc()
        # per-segment arguments, allocated once
        nev = max(len(model.event_names), 1)
        self.event_idx = ffi.new("int[]", nev)
        self.event_dirs = ffi.new("int[]", nev)
        self.roots = ffi.new("int[]", nev)
        self.n_out = ffi.new("int *")
        self.y0 = np.empty(model.nstate)
        self.y0_c = ffi.from_buffer("double[]", self.y0)

    def _alloc(self) -> None:
        ffi = self.model.ffi
        self.t_samples = np.empty(self.capacity)  # CVODE writes its steps here
        self.y_samples = np.empty((self.capacity, self.model.nstate))
        self.t_buf = ffi.from_buffer("double[]", self.t_samples)
        self.y_buf = ffi.from_buffer("double[]", self.y_samples)
        self.d_samples = np.empty((self.capacity, self.dense_terms, self.model.nstate)) if self.dense else None
        self.d_buf = ffi.from_buffer("double[]", self.d_samples) if self.dense else ffi.NULL

    def keep_polynomials(self, dense: bool) -> None:
        """Ask for (or stop asking for) each step's Taylor coefficients from the next segment on."""
        if dense != self.dense:
            self.dense = dense
            self._alloc()

    def segment(self, params, phase: str, t0: float, y0: np.ndarray, t_stop: float,
                n_events: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, bool]:
        """Integrate from (t0, y0) until one of the first `n_events` events in `event_idx`
        and `event_dirs` (filled by the phase machine) or t_stop. Returns the samples, their
        step polynomials (None unless `keep_polynomials`) and whether an event fired, with
        its flags in `roots`. A failure raises SolverError carrying the samples reached as
        `partial`."""
        lib = self.model.lib
        self.y0[:] = y0
        flag = lib.ig_segment_start(self.solver, params, t0, self.y0_c, t_stop, self.event_idx,
                                    self.event_dirs, n_events)
        if flag < 0:
            raise SolverError(self._message(), phase, t0)
        ts, ys, ds = [], [], []
        n_out, roots = self.n_out, self.roots
        while True:
            flag = lib.ig_segment_advance(self.solver, self.t_buf, self.y_buf, self.d_buf, self.capacity,
                                          n_out, roots)
            k = n_out[0]
            ts.append(self.t_samples[:k].copy())
            ys.append(self.y_samples[:k].copy())
            if self.dense:
                ds.append(self.d_samples[:k].copy())
            if flag == lib.IG_BUFFER_FULL:
                self.capacity *= 2
                self._alloc()
                continue
            if flag < 0:
                t_fail = float(ts[-1][-1]) if k else (float(ts[-2][-1]) if len(ts) > 1 else t0)
                error = SolverError(self._message(), phase, t_fail)
                error.partial = (np.concatenate(ts), np.concatenate(ys), np.concatenate(ds) if ds else None)
                raise error
            break
        fired = flag == lib.IG_ROOT
        if len(ts) == 1:
            return ts[0], ys[0], (ds[0] if ds else None), fired
        return np.concatenate(ts), np.concatenate(ys), (np.concatenate(ds) if ds else None), fired

    def use_jacobian(self, analytic: bool) -> None:
        if self.model.lib.ig_solver_use_jacobian(self.solver, 1 if analytic else 0) != 0:
            raise SolverError(self._message())

    def set_atol(self, atol) -> None:
        """New absolute tolerances (a cffi double array of the state's length)."""
        if self.model.lib.ig_solver_set_atol(self.solver, atol) != 0:
            raise SolverError(self._message())

    def outputs(self, params, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        ffi, model = self.model.ffi, self.model
        t = np.ascontiguousarray(t, dtype=float)
        y = np.ascontiguousarray(y, dtype=float)
        out = np.empty((len(t), len(model.output_names)))
        model.lib.ig_outputs(params, len(t), ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", y),
                             ffi.from_buffer("double[]", out))
        return out

    def stats(self) -> dict[str, int]:
        st = self.model.ffi.new("ig_stats *")
        self.model.lib.ig_solver_stats(self.solver, st)
        return {k: int(getattr(st, k)) for k in ("nsteps", "nfev", "njev", "nlinsetups",
                                                   "netfails", "nnlsfails", "ngev")}

    def _message(self) -> str:
        text = self.model.ffi.string(self.model.lib.ig_solver_message(self.solver)).decode(errors="replace")
        return likely_cause(text or "CVODE failed without a message")


def uses_jacobian(model: CompiledModel, scene: Scene) -> bool:
    """Whether CVODE gets the model's analytic Jacobian: the model has one and the method is
    implicit (the explicit Runge-Kutta pair uses none)."""
    return bool(model.spec.jacobian) and scene.solver.method != "erk"


def likely_cause(message: str) -> str:
    """Add to a CVODE message what usually causes it and what to try."""
    lower = message.lower()
    if "max_steps" in lower:
        hint = ("the phase needs more steps than allowed: raise solver.max_steps, loosen solver.rtol, "
                "or use method = \"bdf\" if stiff friction (a small contact.friction_eps) is the cause")
    elif "error test failed" in lower or "convergence test failed" in lower or "convfail" in lower:
        hint = ("the problem is too stiff or not smooth enough here for these tolerances: use "
                "method = \"bdf\", a larger contact.friction_eps, or a looser solver.rtol")
    elif "right-hand side" in lower or "rhs" in lower or "repeated recoverable" in lower:
        hint = ("the right-hand side stopped being finite: check for extreme parameters "
                "(moduli, radii, masses) or speeds")
    elif "too much accuracy" in lower:
        hint = "the tolerances are below what double precision resolves: raise solver.rtol or solver.atol"
    else:
        return message
    return f"{message}; likely cause: {hint}"
