"""One phase segment, integrated with scipy.integrate.solve_ivp up to its first event."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate
from scipy.integrate import solve_ivp
from scipy.linalg.lapack import dgetrs, zgetrs

from ..errors import SolverError
from .events import Event
from .model import ReferenceModel

METHODS = ("Radau", "BDF", "LSODA", "DOP853", "RK45")  # solve_ivp's


class Radau(integrate.Radau):
    """scipy's Radau, its LU solves done by LAPACK's getrs directly: scipy.linalg.lu_solve, which
    Radau calls twice per Newton iteration, spends far longer checking and converting its
    arguments than solving a system of a few states. The same routine on the same factors,
    so the same steps; like lu_solve, a right-hand side that is not finite raises."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        if isinstance(self.J, np.ndarray):  # dense factors, from scipy.linalg.lu_factor
            self.solve_lu = _solve_lu


def _solve_lu(LU: tuple[np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
    lu, piv = LU
    if not np.isfinite(b).all():
        raise ValueError("array must not contain infs or NaNs")
    x, info = (zgetrs if np.iscomplexobj(lu) or np.iscomplexobj(b) else dgetrs)(lu, piv, b, overwrite_b=True)
    if info:
        raise ValueError(f"illegal value in argument {-info} of LAPACK's getrs")
    return x


SOLVERS = {"Radau": Radau}  # solve_ivp's methods run by a class of ours; the others by name


@dataclass
class Segment:
    """What an integrator returns for one phase: samples after t0 (the event point last when
    an event fired), the events that fired, and its counters."""

    t: np.ndarray
    y: np.ndarray
    fired: list[str]
    nsteps: int
    nfev: int
    njev: int
    sol: object = None  # solve_ivp's OdeSolution of the segment, when dense output was asked for


def solve_ivp_segment(model: ReferenceModel, phase: str, t0: float, y0: np.ndarray, t_final: float,
                      events: dict[str, Event], method: str, rtol: float, atol: np.ndarray,
                      dense: bool = False) -> Segment:
    """Integrate one phase with scipy.integrate.solve_ivp and its terminal events (`phase`:
    point n's, as `ReferenceModel.rhs` takes it)."""
    names = list(events)
    sol = solve_ivp(lambda t_, y_: model.rhs(t_, y_, phase), (t0, t_final), y0,
                    method=SOLVERS.get(method, method), rtol=rtol, atol=atol, events=list(events.values()),
                    dense_output=dense)
    if sol.status < 0:
        error = SolverError(f"solve_ivp ({method}): {sol.message}", phase, float(sol.t[-1]))
        error.partial = (sol.t[1:], sol.y.T[1:])
        raise error
    fired = [names[i] for i, te in enumerate(sol.t_events) if len(te)]
    seg_t, seg_y = sol.t[1:], sol.y.T[1:]
    if fired:  # the last sample is the event point
        seg_t = np.append(seg_t[:-1], sol.t_events[names.index(fired[0])][0])
        seg_y = np.vstack([seg_y[:-1], sol.y_events[names.index(fired[0])][0]])
    return Segment(seg_t, seg_y, fired, len(sol.t) - 1, sol.nfev, sol.njev, sol.sol)
