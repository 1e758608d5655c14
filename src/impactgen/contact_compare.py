"""The scene's impact under each compliant contact law, side by side (`impactgen compare --laws`).

Each law is the scene with `contact.model` set to it and run to the end of its first impact
(`solver.t_end = "separation"`): the same chain, state and materials, only the normal force
law changes. The laws are whatever the scene schema accepts (`CONTACT_MODELS`), so a law added
there is compared without a change here. The runs go through `run_batch`, in C.

The normal impact speed of a scene is the speed with which its tip meets the surface, the
normal component of the tip's velocity at contact start, -J_n(q0) u0 (the impacts' `v_n0`).
With `surface.height = "initial"` the tip starts on the surface, so it is the initial one,
and a sweep over it scales `initial.u` as a whole: the chain's motion keeps its shape and
only its size changes.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .codegen.spec import EVERY_LAW_KEY, LAW_KEYS, foreign_law_keys
from .errors import SceneError
from .scene import CONTACT_MODELS, Scene

# The table's quantities: the sweep's column and the heading it is printed under.
TABLE_COLUMNS = {"coefficients.e_N": "e_N", "coefficients.e_E": "e_E", "delta_max": "delta_max (m)",
                 "delta_r": "delta_r (m)", "P_max": "P_max (N)", "t_contact": "t_contact (s)",
                 "coefficients.v_n0": "v_n0 (m/s)"}
# The speed figure's panels: the column drawn against |v_n0|, and its axis label.
SPEED_PANELS = {"coefficients.e_N": "e_N (kinematic)", "delta_max": "delta_max (m)",
                "t_contact": "t_contact (s)"}
DEFAULT_SPEED_COUNT = 10  # speeds of a LOW..HIGH sweep without :N


def check_laws(laws: str | Sequence[str], flag: str = "--laws") -> tuple[str, ...]:
    """The laws as a tuple, each one the scene schema accepts (`CONTACT_MODELS`), each once.

    Raises
    ------
    SceneError
        An empty list, or a name the scene does not know (the message lists the laws).
    """
    names = [name.strip() for name in laws.split(",")] if isinstance(laws, str) else [str(v) for v in laws]
    names = [name for name in names if name]
    if not names:
        raise SceneError(flag, f"name at least one contact law: {', '.join(CONTACT_MODELS)}")
    for name in names:
        if name not in CONTACT_MODELS:
            raise SceneError(flag, f"unknown contact law {name!r}; the scene's contact.model takes "
                                       f"{', '.join(CONTACT_MODELS)}")
    return tuple(dict.fromkeys(names))


def law_keys(settings: Mapping[str, Any] | None) -> dict[str, Any]:
    """The keys among `settings` that belong to some law (contact.restitution, ...): what
    `under_law` gives each law that reads them."""
    return {key: value for key, value in (settings or {}).items() if key in EVERY_LAW_KEY}


def under_law(scene: Scene, law: str, settings: Mapping[str, Any] | None = None) -> Scene:
    """`scene` under contact law `law`: the other laws' keys dropped (a scene refuses a key its
    law does not read), the law's own taken from `settings` where given there, else kept.

    Raises
    ------
    SceneError
        The law needs a key that neither the scene nor `settings` gives (named, with the law).
    """
    own = LAW_KEYS.get(law, ())
    change: dict[str, Any] = {"contact.model": law}
    change.update({key: None for key in foreign_law_keys(law) if scene[key] is not None})
    change.update({key: value for key, value in (settings or {}).items() if key in own})
    return scene.replace(change)


def first_impact_scene(scene: Scene, law: str, settings: Mapping[str, Any] | None = None) -> Scene:
    """`scene` under `law` (`under_law`), run to the end of its first impact."""
    return under_law(scene, law, settings).replace({"solver.t_end": "separation"})


def compare_contact_laws(scene: Scene | str, laws: str | Sequence[str],
                         settings: Mapping[str, Any] | None = None):
    """The scene's first impact under each contact law, one row per law.

    Parameters
    ----------
    scene : Scene or str
        The scene (or a shipped example's name); its `contact.model` is replaced by each law
        and it is run to the end of its first impact.
    laws : str or sequence of str
        Contact laws the scene accepts (``"three-phase,hertz"`` or a list).
    settings : mapping, optional
        The laws' own keys (``{"contact.restitution": 0.8, "contact.stiffness": 2e7}``), each
        given to the laws that read it; the scene's own are kept where `settings` lacks them.

    Returns
    -------
    pandas.DataFrame
        One row per law, in the order given: ``law``, ``status``, ``message`` and the sweep's
        columns ``coefficients.e_N``, ``coefficients.e_P``, ``coefficients.e_E``,
        ``delta_max`` (m), ``delta_r`` (m, the permanent set), ``P_max`` (N), ``t_contact``
        (s), ``coefficients.v_n0`` (m/s, the normal speed at contact start).

    Examples
    --------
    >>> import impactgen
    >>> table = impactgen.compare_contact_laws("paper", "three-phase,hertz")
    >>> list(table["law"])
    ['three-phase', 'hertz']
    """
    from .scene import load_scene
    from .sweep import run_batch
    import pandas as pd
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    laws = check_laws(laws)
    rows = []
    for law in laws:
        # one case: the scene as it is (its first initial speed as the one "varied" value)
        table = run_batch(first_impact_scene(scene, law, settings), {"initial.u[1]": [scene["initial.u[1]"]]})
        row = table.iloc[0]
        rows.append({"law": law, "status": row["status"], "message": row["message"],
                     **{name: float(row[name]) for name in (*TABLE_COLUMNS, "coefficients.e_P")}})
    return pd.DataFrame(rows)


def format_law_table(table) -> list[str]:
    """The table as `impactgen compare --laws` prints it."""
    lines = [f"{'law':<20}" + "".join(f" {title:>14}" for title in TABLE_COLUMNS.values()) + "  status"]
    for _, row in table.iterrows():
        values = "".join(f" {row[name]:14.6g}" for name in TABLE_COLUMNS)
        status = row["status"] if row["status"] == "ok" else f"{row['status']}: {row['message']}"
        lines.append(f"{row['law']:<20}{values}  {status}")
    return lines


def parse_speeds(text: str) -> np.ndarray:
    """`LOW..HIGH[:N]` (m/s, 0 < LOW < HIGH): N speeds evenly spaced (default 10)."""
    spec, _, count = text.partition(":")
    low, sep, high = spec.partition("..")
    try:
        values = (float(low), float(high), int(count) if count else DEFAULT_SPEED_COUNT)
    except ValueError:
        values = None
    if not sep or values is None:
        raise SceneError("--speeds", f"expected LOW..HIGH[:N] in m/s, e.g. 0.05..1:12, got {text!r}")
    low_v, high_v, n = values
    if not (math.isfinite(low_v) and math.isfinite(high_v)) or not 0 < low_v < high_v or n < 2:
        raise SceneError("--speeds", f"expected speeds 0 < LOW < HIGH and N >= 2, got {text!r}")
    return np.linspace(low_v, high_v, n)


def normal_speed(scene: Scene) -> float:
    """The tip's normal speed at t = 0 (m/s, negative toward the surface): J_n(q0) u0."""
    from .impact_laws import RigidChain
    q0, u0 = np.asarray(scene["initial.q"], float), np.asarray(scene["initial.u"], float)
    return float(RigidChain.from_scene(scene).tip_jacobian(q0)[1] @ u0)


def speed_cases(scene: Scene, speeds: np.ndarray) -> dict[str, np.ndarray]:
    """`initial.u` scaled so that the tip meets the surface at each speed (m/s).

    Raises
    ------
    SceneError
        The tip does not start on the surface, or the initial speeds do not move it toward it.
    """
    if scene["surface.height"] != "initial":
        raise SceneError("--speeds", "sets the normal impact speed through the initial speeds, so the "
                                     "tip must start on the surface: give --set surface.height=initial")
    v_n = normal_speed(scene)
    if not v_n < 0:
        raise SceneError("--speeds", f"the scene's initial.u moves the tip away from the surface "
                                     f"(v_n = {v_n:.4g} m/s); give initial speeds toward it")
    u0 = np.asarray(scene["initial.u"], float)
    return {f"initial.u[{i + 1}]": u0[i] * speeds / -v_n for i in range(scene.n)}


def speed_sweep(scene: Scene | str, laws: str | Sequence[str], speeds: Sequence[float],
                settings: Mapping[str, Any] | None = None):
    """Each law's first impact over a range of normal impact speeds.

    Parameters
    ----------
    scene : Scene or str
        The scene; its tip must start on the surface (``surface.height = "initial"``).
    laws : str or sequence of str
        Contact laws the scene accepts.
    speeds : sequence of float
        Normal impact speeds in m/s (> 0); `initial.u` is scaled to each.
    settings : mapping, optional
        The laws' own keys, as in `compare_contact_laws`.

    Returns
    -------
    pandas.DataFrame
        One row per law and speed: ``law``, ``speed`` (m/s), then `run_batch`'s columns.
    """
    from .scene import load_scene
    from .sweep import run_batch
    import pandas as pd
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    laws = check_laws(laws)
    speeds = np.asarray(speeds, float)
    cases = speed_cases(scene, speeds)
    parts = []
    for law in laws:
        table = run_batch(first_impact_scene(scene, law, settings), cases)
        table.insert(0, "speed", speeds)
        table.insert(0, "law", law)
        parts.append(table)
    return pd.concat(parts, ignore_index=True)


def plot_speed_sweep(frame, out: Path, title: str) -> Path:
    """e_N, delta_max and the contact time against the impact speed, every law in each panel."""
    from .plots import _pyplot, save_figure
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(SPEED_PANELS), figsize=(5 * len(SPEED_PANELS), 4.2))
    for law, rows in frame.groupby("law", sort=False):
        ok = rows[rows["status"] == "ok"]
        for ax, column in zip(axes, SPEED_PANELS):
            ax.plot(ok["speed"], ok[column], marker="o", markersize=3, label=law)
    for ax, (column, label) in zip(axes, SPEED_PANELS.items()):
        ax.set_xlabel("normal impact speed |v_n0| (m/s)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend()
    fig.suptitle(title)
    return save_figure(fig, out)


def speeds_json(frame) -> list[dict[str, Any]]:
    """The speed sweep's rows for --json: the figure's numbers."""
    shown = ["law", "speed", "status", *SPEED_PANELS, "coefficients.e_E", "delta_r", "P_max"]
    return [{name: _plain(row[name]) for name in shown} for _, row in frame.iterrows()]


def _plain(value: Any) -> Any:
    value = value.item() if hasattr(value, "item") else value
    return None if isinstance(value, float) and not math.isfinite(value) else value


__all__ = ["compare_contact_laws", "speed_sweep", "plot_speed_sweep", "check_laws", "parse_speeds"]
