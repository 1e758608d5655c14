"""The named thresholds of the phase machine, in one place for the C and the Python.

The generated machine prints them as #defines (MODEL_TOUCH_TOLERANCE, ...); the scene checks,
the validity warnings and the Python wrapper read the same numbers from here. No sympy: the
scene module imports this at start-up.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Threshold:
    name: str
    value: float
    doc: str


THRESHOLDS = (
    Threshold("TOUCH_TOLERANCE", 1e-12,
              "a tip this far below the surface, relative to the chain's length (at least 1 m), "
              "still touches it at the start: the rounding of a height summed over the links"),
    Threshold("TANGENTIAL_TOLERANCE", 1e-12,
              "d(delta)/dt or v_Bx below this fraction of the tip speed is rounding: zero"),
    Threshold("STOPPED_TOLERANCE", 1e-9,
              "a slipping tip whose v_Bx has fallen below this fraction of its speed has stopped"),
    Threshold("CHATTER_RATIO", 2.0,
              "impacts chatter when a flight is shorter than this many contact times"),
    Threshold("ANGLE_RESOLUTION", 1e-2,
              "inside an impact the angles are resolved to this fraction of the expected "
              "penetration (over the chain's length)"),
    Threshold("STICK_EXCESS", 1e-6,
              "a stuck tip whose |F_f| exceeds mu F by this fraction of the largest F missed a slip event "
              "(judged at the end of each segment from every step: the machine's observer)"),
    Threshold("YIELD_ONSET", 1.9,
              "the Hertz law (phase I) holds up to this many critical deformations delta_c; the "
              "Jackson-Green law (phase II, Eq. 10) beyond"),
    Threshold("FLOOR_DEPTH", 1e-2,
              "a joint or the tip found deeper than this fraction of the chain's shortest link "
              "below the surface, after any step, ends the run as failed (the floor net)"),
    Threshold("HOLD_REGULARIZATION", 1e-12,
              "the constraint forces of several held points (stuck, resting) are solved with this "
              "fraction of the largest diagonal entry added to the diagonal: dependent rows (both ends "
              "of a link lying flat, stuck) then share the force instead of making the system singular"),
    Threshold("ANGLE_ATOL_FLOOR", 1e-15,
              "absolute tolerance floor of an angle, rad: the double precision of a tip height ~1 m"),
    Threshold("QUADRATURE_ATOL", 1e300,
              "absolute tolerance of the impulses, N s: they are quadratures of the contact forces "
              "that feed nothing back, so, as CVODES leaves quadratures out of its error test by "
              "default, they do not set the step (finite: CVODE's error weights must be positive)"),
)
THRESHOLD = {t.name: t.value for t in THRESHOLDS}
