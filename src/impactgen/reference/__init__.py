"""The pure-Python reference engine: an independent implementation to check the C against.

It shares no code with codegen/ or the generated C: only the scene loader and the result
types. Clarity comes first; where the integrators call in at every evaluation (the
right-hand side, the events, Radau's linear solves) the code avoids per-call overhead that
changes no result, because the test suite runs this engine for minutes.

- `chain`: the chain's equations, derived by hand with Lagrange's equations (not Kane's
  method and sympy), pinned or free (the base's coordinates after the angles), under gravity
  in the frame of a level or inclined surface, and the kinematics of its points;
- `body`: what the scene says of the base (pinned or free, where a free one starts) and of
  the surface's angle;
- `contact`: the contact laws of one point, written again from docs/model.md;
- `model`: the chain with its contact points (a free chain's base as point 0, every joint
  that can reach the surface, and the tip as point n), the forces at the points in contact,
  the right-hand side, the outputs;
- `events`: each point's root functions in its phase;
- `machine`: the phase machine over points (transitions, switches, stick and slip, the
  sustained contact of a chattering or vibrating point);
- `segment`: one phase integrated with scipy.integrate.solve_ivp and its terminal events;
- `run`: the phase loop (`simulate`); `result`: each point's impacts and the result.

Every point follows the same rules; the tip differs only in what the scene says of it: it is
the end of the chain (its outputs are x_B, ..., F), and a run to separation ends when, after
the first contact, no point touches the surface.
"""
from __future__ import annotations

from ..errors import SceneError, SolverError
from .body import Body
from .chain import HOLD_RCOND, ChainModel
from .contact import Contact
from .model import ContactPoint, PointForce, ReferenceModel, reachable_joints
from .result import PointImpact, ReferenceResult
from .run import FLOOR_DEPTH, MAX_SEGMENTS, simulate
from .segment import METHODS, Segment, solve_ivp_segment

__all__ = ["Body", "ChainModel", "Contact", "ContactPoint", "FLOOR_DEPTH", "HOLD_RCOND", "MAX_SEGMENTS", "METHODS",
           "PointForce", "PointImpact", "ReferenceModel", "ReferenceResult", "SceneError", "Segment",
           "SolverError", "reachable_joints", "simulate", "solve_ivp_segment"]
