"""Dense output of a whole run: y(t) at any time, across the phase switches.

Shaped like scipy's `OdeSolution`: one interpolant per integrator step, each valid between
the step's two ends. The C engine keeps CVODE's own interpolating polynomial of every step
(as Taylor coefficients at the step's end, from `CVodeGetDky`); the reference engine keeps
solve_ivp's dense output of every phase segment. The state is continuous across a switch
(only the force law changes), so one piece ending where the next begins is a valid join.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from .errors import SceneError, excerpt

Interpolant = Callable[[np.ndarray], np.ndarray]  # times (m,) -> states (n_states, m)


END_SLACK = 4 * np.finfo(float).eps  # relative rounding allowed at the run's two ends


class StepPolynomials:
    """The polynomials of consecutive steps: step k holds y(t) = sum_j c[k, j] (t - t_k)^j
    for t_(k-1) <= t <= t_k, where t_k is the step's end (its sample time)."""

    def __init__(self, t_ends: np.ndarray, coefficients: np.ndarray):
        self.t_ends = np.asarray(t_ends, dtype=float)  # (m,)
        self.coefficients = np.asarray(coefficients, dtype=float)  # (m, terms, n_states)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        k = np.clip(np.searchsorted(self.t_ends, t, side="left"), 0, len(self.t_ends) - 1)
        dt = (t - self.t_ends[k])[:, None]
        c = self.coefficients[k]  # (len(t), terms, n_states)
        y = c[:, -1, :].copy()
        for j in range(c.shape[1] - 2, -1, -1):  # Horner
            y = y * dt + c[:, j, :]
        return y.T


class DenseSolution:
    """y(t) of a run, pieced together from the interpolants of its steps or segments.

    Parameters
    ----------
    breaks : sequence of float
        The start of the first piece, then the end of every piece (increasing).
    pieces : sequence of callables
        Piece i maps times in [breaks[i], breaks[i + 1]] to states (n_states, m).
    n_states : int
        Number of states, for an empty solution.

    Calling it with a scalar time gives a state vector (n_states,); with an array of times,
    an array (n_states, len(t)), as `scipy.integrate.OdeSolution` does.

    Raises
    ------
    SceneError
        A time outside the run, [t_min, t_max] (or not a number). This differs from
        `scipy.integrate.OdeSolution`, which extrapolates its first or last polynomial:
        outside the run that is no solution at all (q1 = -2.3e10 at t = -1 s).
    """

    def __init__(self, breaks: Sequence[float], pieces: Sequence[Interpolant], n_states: int):
        if len(breaks) != len(pieces) + 1:
            raise ValueError("DenseSolution needs one more break than pieces")
        self.breaks = np.asarray(breaks, dtype=float)
        self.pieces = list(pieces)
        self.n_states = n_states
        self.t_min, self.t_max = float(self.breaks[0]), float(self.breaks[-1])

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        try:
            times = np.asarray(t, dtype=float)
        except (TypeError, ValueError):
            raise SceneError("t", f"expected a time or an array of times in s, got {excerpt(t)}") from None
        flat = np.atleast_1d(times).ravel()
        if not self.pieces:
            raise SceneError("t", "this run has no dense output: it ended at its first point")
        slack = END_SLACK * max(1.0, abs(self.t_max))
        outside = ~((flat >= self.t_min - slack) & (flat <= self.t_max + slack))  # NaN included
        if outside.any():
            raise SceneError("t", f"{excerpt(flat[outside][0])} s is outside the run [{self.t_min:.17g}, "
                                  f"{self.t_max:.17g}] s; dense output does not extrapolate")
        out = np.empty((self.n_states, len(flat)))
        which = np.clip(np.searchsorted(self.breaks, flat, side="left") - 1, 0, len(self.pieces) - 1)
        for i in np.unique(which):
            mask = which == i
            out[:, mask] = self.pieces[i](flat[mask])
        return out[:, 0] if times.ndim == 0 else out


class NoDenseOutput:
    """`result.sol` of a run that kept no dense output: false in a test, and calling it says
    how to ask for it (it was None, whose call said only "'NoneType' object is not callable")."""

    def __bool__(self) -> bool:
        return False

    def __call__(self, t: object = None) -> np.ndarray:
        raise SceneError("dense_output", "this run kept no dense output (it was not asked for): "
                                         "simulate(..., dense_output=True) keeps it, so that result.sol(t) "
                                         "gives y at any time of the run")

    def __repr__(self) -> str:
        return "NoDenseOutput()"


NO_DENSE_OUTPUT = NoDenseOutput()


OutputsAt = Callable[[np.ndarray, np.ndarray], dict[str, np.ndarray]]  # (t (m,), y (m, n_states))


class TimeSampler:
    """The samples at requested times (solve_ivp's t_eval), gathered one phase segment at a
    time: a time in (t0, t1] of a segment (the run's first time included) is read from that
    segment's interpolant, and its outputs use that segment's force law."""

    def __init__(self, t_eval: np.ndarray):
        self.t_eval = np.asarray(t_eval, dtype=float)
        self.taken = 0
        self.t: list[np.ndarray] = []
        self.y: list[np.ndarray] = []
        self.phase: list[np.ndarray] = []
        self.outputs: list[dict[str, np.ndarray]] = []

    def segment(self, t1: float, interpolant: Interpolant, outputs_at: OutputsAt, phase: str) -> None:
        stop = int(np.searchsorted(self.t_eval, t1, side="right"))
        if stop <= self.taken:
            return
        t = self.t_eval[self.taken:stop]
        y = np.ascontiguousarray(interpolant(t).T)
        self.t.append(t)
        self.y.append(y)
        self.phase.append(np.full(len(t), phase))
        self.outputs.append(outputs_at(t, y))
        self.taken = stop

    def gathered(self, n_states: int, output_names: Sequence[str]) -> tuple[np.ndarray, np.ndarray,
                                                                            np.ndarray, dict[str, np.ndarray]]:
        """(t, y rows, phase, outputs) of every time taken so far (a run's end drops the rest,
        as solve_ivp does after a terminal event)."""
        if not self.t:
            return (np.empty(0), np.empty((0, n_states)), np.empty(0, dtype=str),
                    {k: np.empty(0) for k in output_names})
        return (np.concatenate(self.t), np.concatenate(self.y), np.concatenate(self.phase),
                {k: np.concatenate([o[k] for o in self.outputs]) for k in self.outputs[0]})


def dropped_times_warning(requested: int, taken: int, t_end: float) -> list[str]:
    """The warning for t_eval times after the run's end: they are left out, as solve_ivp
    leaves them out after a terminal event, but not silently."""
    if taken >= requested:
        return []
    return [f"{requested - taken} of the {requested} t_eval times lie after the run's end at "
            f"t = {t_end:.6g} s and are left out (the run stops at the first separation unless "
            "solver.t_end is set)"]
