"""Stage 8 of the pipeline: what a simulation returns, shaped like scipy's solve_ivp result.

`SimulationResult` holds the sampled trajectories (t, q, u, delta, F, F_f, v_B, phase, T per
link, T, V, and the works of the contact forces), the phase spans, the impacts with what
was recorded at their switches, and the summary with the energy budget of MODEL section 6.
Both engines fill the same types, so their results compare key by key.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .scene import Scene


@dataclass
class PhaseSpan:
    phase: str  # "free", "elastic", "elastoplastic", "restitution", "reloading", "sustained"
    t0: float
    t1: float
    ended_by: str  # the event that ended it, or "t_end"
    friction: str = ""  # exact Coulomb friction: "slip+", "slip-" or "stick" during the span

    def to_dict(self) -> dict[str, Any]:
        out = {"phase": self.phase, "t0": self.t0, "t1": self.t1, "ended_by": self.ended_by}
        if self.friction:
            out["friction"] = self.friction
        return out


@dataclass
class Impact:
    """One impact: from first contact to separation, with the values fixed at its switches."""

    t_start: float
    i_start: int  # sample index at first contact
    t_end: float | None = None  # separation; None if the run ended in contact
    i_end: int | None = None
    delta_m: float = 0.0
    P_m: float = 0.0
    delta_r: float = 0.0
    R_res: float = 0.0
    switches: list[tuple[float, str, str]] = field(default_factory=list)  # (t, from, to)
    stick_slip: list[tuple[float, str, str]] = field(default_factory=list)  # exact Coulomb: (t, from, to)


@dataclass
class Trajectory:
    """Samples at every accepted integrator step and at every switch."""

    t: np.ndarray  # (N,)
    y: np.ndarray  # (N, nstate): q, u, then the works W_normal[, W_friction]
    phase: np.ndarray  # (N,) phase name of the step that ended at each sample
    outputs: dict[str, np.ndarray]  # x_B, y_B, v_Bx, v_By, delta, delta_rate, F, F_f, T1.., T, V


@dataclass
class SimulationResult:
    scene: Scene
    engine: str
    status: str  # "ok" | "no-impact"
    message: str
    trajectory: Trajectory
    phases: list[PhaseSpan]
    impacts: list[Impact]
    stats: dict[str, Any]

    # -- solve_ivp-like views -------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.scene.n

    @property
    def success(self) -> bool:
        return self.status in ("ok", "no-impact")

    @property
    def t(self) -> np.ndarray:
        return self.trajectory.t

    @property
    def y(self) -> np.ndarray:
        return self.trajectory.y

    @property
    def q(self) -> np.ndarray:
        return self.trajectory.y[:, : self.n]

    @property
    def u(self) -> np.ndarray:
        return self.trajectory.y[:, self.n: 2 * self.n]

    @property
    def phase(self) -> np.ndarray:
        return self.trajectory.phase

    @property
    def warnings(self) -> list[str]:
        """Where this result leaves the model's range of validity (see validity.py)."""
        from .validity import validity_warnings
        return validity_warnings(self.scene, self.impacts)

    def __getattr__(self, name: str) -> np.ndarray:
        outputs = self.__dict__.get("trajectory")
        if outputs is not None and name in outputs.outputs:
            return outputs.outputs[name]
        raise AttributeError(name)

    @property
    def F_f(self) -> np.ndarray:
        return self.trajectory.outputs.get("F_f", np.zeros_like(self.t))

    @property
    def v_B(self) -> np.ndarray:
        o = self.trajectory.outputs
        return np.column_stack([o["v_Bx"], o["v_By"]])

    @property
    def T_links(self) -> np.ndarray:
        o = self.trajectory.outputs
        return np.column_stack([o[f"T{i + 1}"] for i in range(self.n)])

    @property
    def W_normal(self) -> np.ndarray:
        return self.trajectory.y[:, 2 * self.n]

    @property
    def W_friction(self) -> np.ndarray:
        y = self.trajectory.y
        return y[:, 2 * self.n + 1] if y.shape[1] > 2 * self.n + 1 else np.zeros(len(y))

    # -- summary --------------------------------------------------------------------------
    @property
    def summary(self) -> dict[str, Any]:
        """The first impact, as MODEL section 6 lists it, with its energy budget."""
        if not self.impacts:
            i0, i1 = 0, len(self.t) - 1
            impact = None
        else:
            impact = self.impacts[0]
            i0 = impact.i_start
            i1 = impact.i_end if impact.i_end is not None else len(self.t) - 1
        T, V = self.trajectory.outputs["T"], self.trajectory.outputs["V"]
        T0, Tf = float(T[i0]), float(T[i1])
        W_n = float(self.W_normal[i1] - self.W_normal[i0])
        W_f = float(self.W_friction[i1] - self.W_friction[i0])
        W_g = float(V[i0] - V[i1])
        return {
            "T0": T0,
            "Tf": Tf,
            "delta_T": T0 - Tf,
            "delta_max": impact.delta_m if impact else 0.0,
            "delta_r": impact.delta_r if impact else 0.0,
            "P_max": impact.P_m if impact else 0.0,
            "R_res": impact.R_res if impact else 0.0,
            "t_contact": (self.t[i1] - self.t[i0]) if impact and impact.t_end is not None else 0.0,
            "t_impact": impact.t_start if impact else None,
            "switches": [{"t": t, "from": a, "to": b} for t, a, b in impact.switches] if impact else [],
            "stick_slip": [{"t": t, "from": a, "to": b} for t, a, b in impact.stick_slip] if impact else [],
            "u_final": [float(v) for v in self.u[i1]],
            "q_final": [float(v) for v in self.q[i1]],
            "impacts": len(self.impacts),
            "energy": {
                "W_normal": W_n,
                "W_friction": W_f,
                "W_gravity": W_g,
                "residual": (Tf - T0) - (W_n + W_f + W_g),
            },
        }

    def to_json_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene.name,
            "engine": self.engine,
            "status": self.status,
            "message": self.message,
            "warnings": self.warnings,
            "summary": _finite(self.summary),
            "phases": [p.to_dict() for p in self.phases],
            "stats": self.stats,
        }


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: write them as null."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
