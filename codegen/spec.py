"""The structure of a generated model, and the names of its phases and machine states.

No sympy here: the runtime (build cache lookup, the phase machine's wrapper) imports this at
start-up, and a run whose model is already built never needs the generator.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass

# Phases of MODEL.md section 4, as the C enum values, and the sustained contact that ends a
# chattering sequence of impacts (the tip held on the surface by a constraint force).
PHASES = ("free", "elastic", "elastoplastic", "restitution", "sustained")
FRICTION_KINDS = ("none", "regularized", "coulomb", "frozen")

# The normal-contact laws a scene chooses with contact.model (docs/contact-laws.md): the
# paper's, Hertz's, the four Hertz laws with hysteresis damping F = K delta^1.5 (1 + chi v/v0),
# the linear spring-dashpot and Thornton's elastic-perfectly plastic law.
HERTZ_DAMPED = ("hunt-crossley", "lankarani-nikravesh", "flores", "gonthier")
CONTACT_MODELS = ("three-phase", "hertz", *HERTZ_DAMPED, "kelvin-voigt", "thornton")
RATE_LAWS = (*HERTZ_DAMPED, "kelvin-voigt")  # the force depends on d(delta)/dt: it may reach 0 while penetrating
PLASTIC_LAWS = ("three-phase", "thornton")  # yield, a permanent set, unloading about a larger radius
# The scene keys each law reads beyond the materials (a law refuses the others)
LAW_KEYS = {**{name: ("contact.restitution",) for name in HERTZ_DAMPED},
            "kelvin-voigt": ("contact.stiffness", "contact.damping"),
            "thornton": ("contact.limiting_pressure",)}
EVERY_LAW_KEY = tuple(sorted({key for keys in LAW_KEYS.values() for key in keys}))  # the keys some law reads


def foreign_law_keys(law: str) -> tuple[str, ...]:
    """The other laws' keys that `law` does not read (a scene under it refuses them)."""
    return tuple(key for key in EVERY_LAW_KEY if key not in LAW_KEYS.get(law, ()))

# Machine states: contact phases, plus reloading (restitution's law, watching delta_m).
STATES = ("free", "elastic", "elastoplastic", "restitution", "reloading", "sustained")
STATE_LAW = {"free": "free", "elastic": "elastic", "elastoplastic": "elastoplastic",
             "restitution": "restitution", "reloading": "restitution", "sustained": "sustained"}


BASE_POINT = 0  # a free chain's base point (the start of link 1) is contact point 0


def point_name(number: int, n: int) -> str:
    """The name of contact point `number` (0 to n) of an n-link chain: "base" (a free chain's
    base point, 0), "joint k" (the end of link k), or "tip" (n)."""
    return "tip" if number == n else "base" if number == BASE_POINT else f"joint {number}"


def point_number(point: str, n: int) -> int:
    """A point's number as the C engine records it: 0 for "base", k for "joint k", n for "tip"."""
    return n if point == "tip" else BASE_POINT if point == "base" else int(point.split()[-1])


@dataclass(frozen=True)
class ModelSpec:
    """What the generated C must be able to do; two scenes with equal specs share a build."""

    links: int
    contact_model: str = "three-phase"  # one of CONTACT_MODELS
    friction_law: str = "regularized"  # "none" | "regularized" | "coulomb" (exact stick-slip) | "frozen"
    jacobian: bool = False  # emit the analytic Jacobian (for BDF)
    sustained: bool = False  # emit the sustained-contact phase (repeated impacts to a time)
    # the joints (1 to links - 1, the end of that link) that can reach the surface and so get
    # contact code of their own beside the tip's; the others are pruned (docs/model.md). A free
    # chain's base point is point 0 and is listed here too when it can reach the surface.
    joints: tuple[int, ...] = ()
    free: bool = False  # nothing holds the chain: its base point's x_0, y_0 join the coordinates
    inclined: bool = False  # the surface is inclined (surface.angle_deg): gravity has an x component

    def __post_init__(self) -> None:
        if self.links < 1:
            raise ValueError("links must be >= 1")
        if self.contact_model not in CONTACT_MODELS:
            raise ValueError(f"unknown contact model {self.contact_model!r}")
        if self.jacobian and self.rate_law:
            raise ValueError(f"the analytic Jacobian does not cover the rate-dependent law {self.contact_model!r}")
        if self.friction_law not in FRICTION_KINDS:
            raise ValueError(f"unknown friction law {self.friction_law!r}")
        first = BASE_POINT if self.free else 1
        if self.joints and (list(self.joints) != sorted(set(self.joints)) or not first <= self.joints[0]
                            or not self.joints[-1] < self.links):
            raise ValueError(f"joints must be distinct, increasing, between {first} and {self.links - 1}")

    @property
    def dof(self) -> int:
        """The generalized coordinates: the links' angles, and a free chain's base point's two."""
        return self.links + (2 if self.free else 0)

    @property
    def has_friction(self) -> bool:
        return self.friction_law != "none"

    @property
    def coulomb(self) -> bool:
        return self.friction_law == "coulomb"

    @property
    def frozen(self) -> bool:
        """Friction keeps the direction it had at contact start (the paper's published losses)."""
        return self.friction_law == "frozen"

    @property
    def constrained(self) -> bool:
        """Whether some phase holds a tip velocity by a constraint force (stick, sustained)."""
        return self.coulomb or self.sustained

    @property
    def plastic(self) -> bool:
        """Whether the law yields and leaves a permanent set (the paper's, Thornton's)."""
        return self.contact_model in PLASTIC_LAWS

    @property
    def rate_law(self) -> bool:
        """Whether the normal force depends on d(delta)/dt (a damped law)."""
        return self.contact_model in RATE_LAWS

    @property
    def slug(self) -> str:
        """A short readable name, e.g. 'chain2-three-phase-regularized'."""
        return (f"chain{self.links}-{self.contact_model}-{self.friction_law}"
                + ("-jacobian" if self.jacobian else "") + ("-sustained" if self.sustained else "")
                + ("-joints" + "-".join(map(str, self.joints)) if self.joints else "")
                + ("-free" if self.free else "") + ("-inclined" if self.inclined else ""))

    def to_json(self) -> str:
        facts = asdict(self)
        for key in ("joints", "free", "inclined"):  # a model keeps the key (and the cache) it had before them
            if not facts[key]:
                del facts[key]
        return json.dumps(facts, sort_keys=True)
