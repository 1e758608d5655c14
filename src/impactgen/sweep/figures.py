"""Figures of a sweep, chosen by what it varied (the paper's Figures 9 to 12 among them).

- kept trajectories: the kinetic energy T(t) of each case through its first impact (Figs. 9, 11);
- delta_T against delta_r over the cases (Fig. 10a);
- one or two varied keys (a grid): the summary fields against the first key's values, one
  line per value of the second (delta_r against |omega20| is Fig. 10b, against q20 Fig. 12);
  an angular speed whose values are all <= 0 is drawn against its magnitude, as the paper does;
- random draws: histograms of the summary fields and scatter plots against each key;
- the coefficients of restitution against the normal impact speed (coefficient_figure.py).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..codegen.parameters import PARAMETERS
from ..summaries import summary_unit
from .coefficient_figure import coefficient_figure
from .spec import SweepSpec

# The summary fields drawn, each under its own name and in plain words (units: SUMMARY_UNITS).
FIELDS = {"delta_r": "permanent deformation", "delta_max": "maximum deformation", "P_max": "maximum force",
          "delta_T": "kinetic energy lost", "t_contact": "contact time"}
# The units of the scene keys a sweep varies that are not model parameters (those have theirs
# in the parameter table, codegen/parameters.py).
KEY_UNITS = {"initial.q": "rad", "initial.q_deg": "deg", "initial.u": "rad/s", "solver.t_end": "s",
             "solver.t_max": "s"}


def key_unit(key: str) -> str | None:
    """The unit of a varied scene key ("initial.u[2]", "rod.E", "chain.length[1]"), None if
    it has none (a tolerance, a choice)."""
    name = key.split("[", 1)[0]
    if name in KEY_UNITS:
        return KEY_UNITS[name]
    return next((p.unit for p in PARAMETERS if p.key.split("[", 1)[0] == name and p.key), None)


def labelled(name: str, unit: str | None) -> str:
    """An axis label: the name and its unit, "delta_r (m)" (a ratio's unit "1" is shown too)."""
    return f"{name} ({unit})" if unit else name


def _value_label(key: str, value: float) -> str:
    """A legend's entry for one value of a varied key, with its unit: "initial.u[2] = -0.2 rad/s"."""
    unit = key_unit(key)
    return f"{key} = {value:.4g}" + (f" {unit}" if unit and unit != "1" else "")


def field_label(field: str) -> str:
    """A summary field's axis label: its name and unit, "t_contact (s)"."""
    return labelled(field, summary_unit(field))


def plot_sweep(frame, spec: SweepSpec, out: Path) -> list[Path]:
    """Write the figures of a sweep's table (and its kept trajectories) into out/_figures."""
    from ..plots import _pyplot
    plt = _pyplot()
    from .run import FIGURES, TRAJECTORIES
    folder = out / FIGURES
    folder.mkdir(parents=True, exist_ok=True)
    ok = frame[frame["status"] == "ok"]
    paths: list[Path] = []
    if (out / TRAJECTORIES).is_dir():
        paths += _kinetic_energy(plt, ok, spec, out / TRAJECTORIES, folder)
    if len(ok) and {"delta_T", "delta_r"} <= set(ok.columns):
        fig, ax = plt.subplots(figsize=(6, 4))
        order = np.argsort(ok["delta_r"].to_numpy())
        ax.plot(ok["delta_r"].to_numpy()[order], ok["delta_T"].to_numpy()[order],
                "o-" if not spec.random else "o", ms=4, lw=1)
        ax.set_xlabel(field_label("delta_r"))
        ax.set_ylabel(field_label("delta_T"))
        ax.set_title("kinetic energy lost against permanent deformation (Fig. 10a)")
        ax.grid(alpha=0.3)
        paths.append(_save(plt, fig, folder / "delta_T_vs_delta_r.png"))
    if spec.random:
        paths += _random_figures(plt, ok, spec, folder)
    else:
        paths += _grid_figures(plt, ok, spec, folder)
    paths += coefficient_figure(plt, ok, folder)  # e_N, e_P, e_E against |v_n0| (docs/impact-laws.md)
    return paths


def _save(plt, fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _axis_values(frame, key: str) -> tuple[np.ndarray, str]:
    """A varied key's values and axis label (with its unit): an angular speed whose values
    are all <= 0 by its magnitude, as the paper draws it."""
    values = frame[key].to_numpy(dtype=float)
    if key.startswith("initial.u") and len(values) and np.all(values <= 0):
        return np.abs(values), labelled(f"|{key}|", key_unit(key))
    return values, labelled(key, key_unit(key))


def _grid_figures(plt, ok, spec: SweepSpec, folder: Path) -> list[Path]:
    if not len(ok) or len(spec.axes) > 2:
        return []
    first = spec.axes[0].key
    groups = [(None, ok)] if len(spec.axes) == 1 else list(ok.groupby(spec.axes[1].key))
    paths = []
    for field, words in FIELDS.items():
        if field not in ok.columns:
            continue
        fig, ax = plt.subplots(figsize=(6, 4))
        for value, part in groups:
            x, label = _axis_values(part, first)
            order = np.argsort(x)
            ax.plot(x[order], part[field].to_numpy()[order], "o-", ms=4, lw=1,
                    label=None if value is None else _value_label(spec.axes[1].key, value))
        ax.set_xlabel(label)
        ax.set_ylabel(field_label(field))
        ax.set_title(f"{field}, {words}, against {first}")
        ax.grid(alpha=0.3)
        if len(groups) > 1:
            ax.legend(fontsize=8)
        paths.append(_save(plt, fig, folder / f"{field}_vs_{_filename(first)}.png"))
    return paths


def _random_figures(plt, ok, spec: SweepSpec, folder: Path) -> list[Path]:
    if not len(ok):
        return []
    fields = [f for f in FIELDS if f in ok.columns]
    fig, axes = plt.subplots(1, len(fields), figsize=(3.2 * len(fields), 3.2))
    for ax, field in zip(np.atleast_1d(axes), fields):
        ax.hist(ok[field].to_numpy(), bins=40, color="#4477aa")
        ax.set_xlabel(field_label(field))
        ax.set_ylabel("cases (1)")
    fig.suptitle(f"{len(ok)} random cases")
    paths = [_save(plt, fig, folder / "histograms.png")]
    keys = [a.key for a in spec.axes]
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * len(keys), 3.2), squeeze=False)
    for ax, key in zip(axes[0], keys):
        ax.plot(ok[key].to_numpy(), ok["delta_r"].to_numpy(), ".", ms=2, alpha=0.5)
        ax.set_xlabel(labelled(key, key_unit(key)))
        ax.set_ylabel(field_label("delta_r"))
    fig.suptitle("delta_r, permanent deformation, against each drawn input")
    paths.append(_save(plt, fig, folder / "scatter_delta_r.png"))
    return paths


def _kinetic_energy(plt, ok, spec: SweepSpec, trajectories: Path, folder: Path) -> list[Path]:
    """T(t) of every kept case, from its first contact (the paper's Figures 9 and 11)."""
    import pyarrow.parquet as pq
    files = sorted(trajectories.glob("case-*.parquet"), key=lambda p: int(p.stem.split("-")[1]))
    if not files:
        return []
    keys = [a.key for a in spec.axes]
    by_case = ok.set_index("case")
    fig, ax = plt.subplots(figsize=(7, 4))
    for path in files:
        case = int(path.stem.split("-")[1])
        if case not in by_case.index:
            continue
        table = pq.read_table(path, columns=["t", "T", "phase"]).to_pandas()
        contact = table[table["phase"] != "free"]
        if contact.empty:
            continue
        t0 = contact["t"].iloc[0]
        label = ", ".join(_value_label(k, by_case.loc[case, k]) for k in keys)
        ax.plot((contact["t"] - t0) * 1e3, contact["T"], lw=1.2, label=label)
    ax.set_xlabel("t from first contact (ms)")
    ax.set_ylabel("T, kinetic energy (J)")
    ax.set_title("kinetic energy through the impact (Figs. 9 and 11)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return [_save(plt, fig, folder / "kinetic_energy.png")]


def _filename(key: str) -> str:
    return key.replace("[", "").replace("]", "").replace(".", "_")
