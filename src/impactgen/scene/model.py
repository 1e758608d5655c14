"""The checked scene as frozen dataclasses: the chain, the two materials, the contact, the
solver settings, and the Scene that holds them (read by the same dotted keys as the file)."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from ..errors import SceneError
from ..materials import MATERIAL_KEYS, MATERIALS
from .schema import SCHEMA, all_keys, did_you_mean, split_key


class _KeyHint:
    """An attribute a scene part does not have ends in an AttributeError that names the
    dotted key meant (`scene.surface.height` is ``scene["surface.height"]``)."""

    _section = ""  # the scene file's table of this part ("" for the scene itself)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):  # copy, pickle and numpy probe such names: no hint, no cost
            raise AttributeError(name)
        if not self._section and name in SCHEMA:  # a table of the file that is no field: [initial]
            hint = f" (the [{name}] table's keys: {', '.join(f'{name}.{key}' for key in SCHEMA[name])})"
        else:
            hint = did_you_mean(f"{self._section}.{name}" if self._section else name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}; a scene's values are "
                             f"read by their dotted keys, as the file names them: scene['section.key']{hint}")


@dataclass(frozen=True)
class Material(_KeyHint):
    """Elastic and yield properties of one body in contact, the named material they default
    to (``rod.material``, None if none) and, for the rod, its density (kg/m^3, None if
    neither rod.density nor a material gives one)."""

    E: float
    nu: float
    yield_strength: float
    material: str | None = None
    density: float | None = None

    _section = "rod"  # the surface's keys are the rod's but for height and density: one spelling


@dataclass(frozen=True)
class Chain(_KeyHint):
    """The links: their number, lengths and masses (given, or rod.density x cross-section x
    length where `diameter` or `area`, one per link, is given) and gravity."""

    links: int
    length: tuple[float, ...]
    mass: tuple[float, ...]
    gravity: float
    diameter: tuple[float, ...] | None = None
    area: tuple[float, ...] | None = None
    base: str = "pinned"  # "pinned" | "free" (chain.base)

    _section = "chain"


@dataclass(frozen=True)
class Contact(_KeyHint):
    model: str
    friction: float
    friction_mode: str
    friction_eps: float
    # contact.joint_radius as given, one per joint (n - 1); None: every joint has the tip's radius
    joint_radius: tuple[float, ...] | None = None
    # contact.base_radius as given (a free chain's); None: the base has the tip's radius
    base_radius: float | None = None

    _section = "contact"


@dataclass(frozen=True)
class Solver(_KeyHint):
    method: str
    jacobian: str  # "analytic" | "difference" (auto resolved by the method)
    rtol: float
    atol: float
    t_end: float | None  # None: stop at the first separation
    t_max: float  # longest free flight to wait for a first contact when t_end is None
    max_steps: int
    sustained_contact: bool = True  # with t_end a time: hold the tip once impacts chatter
    jacobian_setting: str = "auto"  # the key as given, before "auto" was resolved into `jacobian`

    _section = "solver"


@dataclass(frozen=True)
class Scene(_KeyHint):
    """A checked scene. Angles are radians; `surface_height` None means 'initial'.

    A free chain (``chain.base = "free"``) has its base point's start `base0` and velocity
    `base_u0` ([x, y] and [vx, vy] in the surface's frame); a pinned one has None for both.
    `surface_angle_deg` is the surface's inclination (it descends towards +x)."""

    name: str
    chain: Chain
    rod: Material
    tip_radius: float
    surface: Material
    surface_height: float | None
    contact: Contact
    q0: tuple[float, ...]
    u0: tuple[float, ...]
    solver: Solver
    source: str = field(default="<memory>", compare=False)
    surface_angle_deg: float = 0.0
    base0: tuple[float, float] | None = None
    base_u0: tuple[float, float] | None = None

    @property
    def n(self) -> int:
        return self.chain.links

    @property
    def joint_radii(self) -> tuple[float, ...]:
        """The contact radius of every joint (the end of link k, k = 1..n-1), in m: n - 1
        values, the tip radius where `contact.joint_radius` is not given (empty for one link)."""
        given = self.contact.joint_radius
        return given if given is not None else (self.tip_radius,) * (self.n - 1)

    @property
    def free(self) -> bool:
        """True for a free chain: its base point moves and is a contact point (point 0)."""
        return self.chain.base == "free"

    @property
    def dof(self) -> int:
        """The generalized coordinates: the links' angles, and a free chain's base point's x, y."""
        return self.n + (2 if self.free else 0)

    def point_radius(self, number: int) -> float:
        """The contact radius of contact point `number`, in m: a free chain's base point (0),
        joint k (k), the tip (n)."""
        if number == self.n:
            return self.tip_radius
        return self.base_radius if number == 0 else self.joint_radii[number - 1]

    @property
    def motion_start(self) -> tuple[float, ...]:
        """The motion's state at the start, in the generated model's order: the angles (and a
        free chain's base point), then their rates (and the base point's velocity)."""
        if not self.free:
            return self.q0 + self.u0
        return self.q0 + self.base_start + self.u0 + self.base_velocity

    @property
    def surface_angle(self) -> float:
        """The surface's inclination in radians (positive: it descends towards +x)."""
        return math.radians(self.surface_angle_deg)

    @property
    def base_radius(self) -> float:
        """The contact radius of a free chain's base point, in m: `contact.base_radius`, else
        the tip's."""
        given = self.contact.base_radius
        return given if given is not None else self.tip_radius

    @property
    def base_start(self) -> tuple[float, float]:
        """The base point's position at the start, in m: the free chain's `initial.base`, the
        pivot (the origin) for a pinned chain."""
        return self.base0 if self.base0 is not None else (0.0, 0.0)

    @property
    def base_velocity(self) -> tuple[float, float]:
        """The base point's velocity at the start, in m/s (zero for a pinned chain)."""
        return self.base_u0 if self.base_u0 is not None else (0.0, 0.0)

    # Read by key, not iterated: `for x in scene` would walk integer "keys".
    __iter__ = None

    def __getitem__(self, key: str) -> Any:
        """The value of a scene key, named as in the scene file, `--set` and `overrides`.

        Parameters
        ----------
        key : str
            A dotted key (``"surface.height"``), or one element of a per-link or per-joint
            list, counted from 1 (``"initial.u[2]"``).

        Returns
        -------
        Any
            The value as the scene file states it: a number, a string (``"initial"``,
            ``"separation"``, a choice) or a list (one number per link or joint, also where the
            file gave one number for all). ``initial.q`` is in radians, ``initial.q_deg`` the same
            angles in degrees; ``contact.joint_radius`` the joints' radii, the tip's where the
            file gives none; ``solver.jacobian`` the setting as given (``"auto"``).

        Raises
        ------
        SceneError
            The key is unknown (with the closest key, as `--set` says it), or the element is out
            of range.

        Examples
        --------
        >>> import impactgen
        >>> scene = impactgen.load_scene("paper")
        >>> scene["surface.height"], scene["initial.u[2]"], scene["rod.tip_radius"]
        ('initial', -0.2, 0.005)
        """
        if not isinstance(key, str):
            raise SceneError(None, f"a scene key is a dotted string such as 'surface.height' or 'initial.u[2]', "
                                   f"got {type(key).__name__} {key!r:.60}")
        section, name, index = split_key(key)
        value = _whole_value(self, section, name)
        if index is None:
            return value
        if index > len(value):
            per = {"joint_floats": "joint", "pair": "coordinate"}.get(SCHEMA[section][name].kind, "link")
            raise SceneError(key, f"index {index} is out of range: {section}.{name} has {len(value)} elements "
                                  f"(one per {per}, numbered from 1)")
        return value[index - 1]

    def get(self, key: str, default: Any = None) -> Any:
        """The value of a scene key, as ``scene[key]``; `default` where the scene leaves the
        key unset (``rod.material``, ``rod.density``, ``chain.diameter`` and ``chain.area``
        may be None). An unknown key still raises `SceneError`, never gives `default`: a
        misspelt key is not a missing one."""
        value = self[key]
        return default if value is None else value

    def keys(self) -> tuple[str, ...]:
        """Every key the scene can be read (and changed) by, without element indices."""
        return tuple(all_keys())

    def replace(self, overrides: Mapping[str, Any] | None = None, **fields: Any) -> "Scene":
        """A new scene with some values changed, checked like `load_scene`.

        Parameters
        ----------
        overrides : mapping, optional
            Dotted scene keys to new values, as in `load_scene` (``{"initial.u[2]": -0.3}``).
        **fields
            Whole fields of the dataclass (``solver=dataclasses.replace(scene.solver, ...)``).

        Returns
        -------
        Scene
            The checked scene. A change that leaves it inconsistent (three links with two
            initial angles, a tip inside the surface) raises `SceneError` naming the key.
        """
        from .loading import scene_from_dict
        from .overrides import checked_overrides
        from .updates import check_fields, scene_with
        overrides = checked_overrides(overrides)
        if fields:  # whole fields: the scene they make is read in full
            check_fields(self, fields)
            changed = dataclasses.replace(self, **fields)
            return scene_from_dict(changed.to_dict(), overrides, source=self.source)
        return scene_with(self, overrides)

    def to_dict(self) -> dict[str, Any]:
        """The scene as nested dicts of plain values, as a TOML file states it (angles in
        radians): `scene_from_dict(scene.to_dict())` gives the same scene."""
        s, chain = self.solver, self.chain
        return {
            "name": self.name,
            "chain": {"links": chain.links, "length": list(chain.length), **_stated_masses(chain),
                      "gravity": chain.gravity, **({"base": chain.base} if self.free else {})},
            "rod": {**_stated_material(self.rod), "tip_radius": self.tip_radius},
            "surface": {**_stated_material(self.surface),
                        "height": "initial" if self.surface_height is None else self.surface_height,
                        **({"angle_deg": self.surface_angle_deg} if self.surface_angle_deg else {})},
            "contact": {"model": self.contact.model, "friction": self.contact.friction,
                        "friction_mode": self.contact.friction_mode,
                        "friction_eps": self.contact.friction_eps,
                        # left out when not given: the joints then follow rod.tip_radius
                        **({} if self.contact.joint_radius is None
                           else {"joint_radius": list(self.contact.joint_radius)}),
                        **({} if self.contact.base_radius is None else {"base_radius": self.contact.base_radius})},
            "initial": {"q": list(self.q0), "u": list(self.u0),
                        **({"base": list(self.base_start), "base_velocity": list(self.base_velocity)}
                           if self.free else {})},
            "solver": {"method": s.method, "jacobian": s.jacobian_setting, "rtol": s.rtol,
                       "atol": s.atol, "t_end": "separation" if s.t_end is None else s.t_end,
                       "t_max": s.t_max, "max_steps": s.max_steps,
                       "sustained_contact": s.sustained_contact},
        }

    def to_toml(self) -> str:
        """The scene as a TOML file that `load_scene` reads back to the same scene."""
        lines = [f"name = {_toml_value(self.name)}"]
        for section, values in self.to_dict().items():
            if isinstance(values, dict):
                lines += ["", f"[{section}]"] + [f"{k} = {_toml_value(v)}" for k, v in values.items()]
        return "\n".join(lines) + "\n"


def _whole_value(scene: Scene, section: str, key: str) -> Any:
    """The value of key `section.key` of `scene` (not an element of it), as `Scene.__getitem__`
    gives it."""
    if section == "initial":
        angles = {"q": list(scene.q0), "q_deg": [math.degrees(v) for v in scene.q0], "u": list(scene.u0),
                  "base": list(scene.base0) if scene.base0 is not None else None,
                  "base_velocity": list(scene.base_u0) if scene.base_u0 is not None else None}
        return angles[key]
    if section == "contact" and key == "joint_radius":
        return list(scene.joint_radii)
    if section == "contact" and key == "base_radius":  # a pinned chain's base is no contact point
        return scene.base_radius if scene.free else None
    if (section, key) == ("chain", "base"):
        return scene.chain.base
    if (section, key) == ("surface", "angle_deg"):
        return scene.surface_angle_deg
    if section in ("chain", "rod", "surface") and key in _RESOLVED:  # given, or from a key that gives it
        value = getattr(getattr(scene, section), key)
        return list(value) if isinstance(value, tuple) else value
    stated = scene.to_dict()
    return (stated[section] if section else stated).get(key)  # a key left unset: None


# The keys a scene reads as resolved (the masses from a cross-section, a material's values),
# which the file may not state: read from the fields, not from `to_dict`.
_RESOLVED = ("mass", "diameter", "area", "material", "E", "nu", "yield_strength", "density")


def _stated_masses(chain: Chain) -> dict[str, list[float]]:
    """How the file states the links' masses: the cross-section they come from, or the masses."""
    if chain.diameter is not None:
        return {"diameter": list(chain.diameter)}
    if chain.area is not None:
        return {"area": list(chain.area)}
    return {"mass": list(chain.mass)}


def _stated_material(part: Material) -> dict[str, Any]:
    """The keys of a [rod] or [surface] table that state `part`: its material, and the values
    that differ from the material's (all of them without one)."""
    named = MATERIALS.get(part.material) if part.material is not None else None
    stated: dict[str, Any] = {} if named is None else {"material": part.material}
    for key in MATERIAL_KEYS:
        value = getattr(part, key)
        if value is not None and (named is None or value != getattr(named, key)):
            stated[key] = value
    return stated


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v)  # shortest repr that reads back to the same double
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return str(v)
