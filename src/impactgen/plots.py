"""Figures of one simulation: one impact like the paper's Figures 4 to 8, or the whole run.

The impact figures are against time with the contact phases shaded: link angles, angular
speeds, tip velocity, deformation and normal force, kinetic energy per link and in total,
and a bar chart of the energy budget (delta_T against the works of the forces). The
whole-run view (the default when a run has several impacts) puts the angles, the energies
and the tip's height above the surface over the whole run, with every impact marked.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import ImpactgenError, SceneError
from .results import SimulationResult, energy_balance

PHASE_COLOURS = {"free": None, "elastic": "#cfe8ff", "elastoplastic": "#ffd9b3",
                 "restitution": "#d9f2d9", "reloading": "#f2d9f2", "sustained": "#e6e6e6"}


def _pyplot():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImpactgenError("plotting needs matplotlib: pip install 'impactgen[plot]'") from None
    return plt


# The lines marking each point's impacts in the whole-run view (the tip's last), colour-blind safe.
POINT_COLOURS = ("#4477aa", "#228833", "#ccbb44", "#66ccee", "#aa3377", "#bbbbbb", "#000000", "#ee6677")
WINDOW_MARGIN = 0.05  # of an impact's duration, shown before and after it


def _impact_window(result: SimulationResult, k: int) -> tuple[float, float]:
    """Times around impact k (from 1), with a margin."""
    if k > len(result.impacts):
        raise SceneError("--impact", f"the run has {len(result.impacts)} impacts, not {k}")
    impact = result.impacts[k - 1]
    t0 = impact.t_start
    t1 = impact.t_end if impact.t_end is not None else float(result.t[-1])
    margin = WINDOW_MARGIN * (t1 - t0)
    return t0 - margin, t1 + margin


def _mask(result: SimulationResult, window: tuple[float, float]) -> np.ndarray:
    mask = (result.t >= window[0]) & (result.t <= window[1])
    if mask.sum() < 2:
        raise SceneError("--window", f"fewer than two samples between {window[0]:g} and {window[1]:g} s "
                                     f"(the run spans 0 to {result.t[-1]:g} s)")
    return mask


def _shade(ax, result: SimulationResult, scale: float) -> None:
    seen = set()
    for span in result.phases:
        colour = PHASE_COLOURS.get(span.phase)
        if colour is None:
            continue
        label = span.phase if span.phase not in seen else None
        seen.add(span.phase)
        ax.axvspan(span.t0 * scale, span.t1 * scale, color=colour, alpha=0.6, lw=0, label=label)


def plot_simulation(result: SimulationResult, out_dir: Path, impact: int | None = None,
                    window: tuple[float, float] | None = None, whole_run: bool = False) -> list[Path]:
    """Write the figures of `result` as PNG files into `out_dir`; return their paths.

    Parameters
    ----------
    result : SimulationResult
    out_dir : Path
    impact : int, optional
        The figures of this impact (numbered from 1).
    window : (float, float), optional
        The figures between these two times, in s.
    whole_run : bool
        The whole-run view, even for a run with one impact. It is the default when the run
        has several impacts and neither `impact` nor `window` is given.
    """
    plt = _pyplot()
    out_dir.mkdir(parents=True, exist_ok=True)
    if window is None and impact is None and (whole_run or len(result.impacts) > 1):
        return _plot_whole_run(plt, result, out_dir)
    if window is None:
        window = _impact_window(result, impact or 1) if result.impacts else (0.0, float(result.t[-1]))
    return _plot_window(plt, result, out_dir, _mask(result, window), impact)


def save_figure(fig, out: Path) -> Path:
    """Write `fig` to `out` (PNG, tight layout) and close it; a path that cannot be written is
    a SceneError naming --out, not a traceback from matplotlib."""
    plt = _pyplot()
    fig.tight_layout()
    try:
        fig.savefig(out, dpi=120)
    except OSError as exc:
        raise SceneError("--out", f"cannot write the figure to {out}: {exc}") from None
    finally:
        plt.close(fig)
    return out


def _save(plt, fig, path: Path, paths: list[Path]) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    paths.append(path)


def _plot_window(plt, result: SimulationResult, out_dir: Path, mask: np.ndarray, impact: int | None) -> list[Path]:
    t_ms = result.t[mask] * 1e3
    n = result.n
    name = result.scene.name
    which = f"impact {impact}" if impact else ("first impact" if result.impacts else "run")
    paths: list[Path] = []

    def figure(filename: str, title: str, series, ylabel: str, twin=None) -> None:
        fig, ax = plt.subplots(figsize=(7, 4))
        _shade(ax, result, 1e3)
        for label, values in series:
            ax.plot(t_ms, values[mask], label=label, lw=1.5)
        ax.set_xlim(t_ms[0], t_ms[-1])
        ax.set_xlabel("t (ms)")
        ax.set_ylabel(ylabel)
        ax.set_title(f"{name}: {title}")
        ax.grid(alpha=0.3)
        if twin is not None:
            ax2 = ax.twinx()
            twin_label, twin_values, twin_unit = twin
            ax2.plot(t_ms, twin_values[mask], color="k", ls="--", lw=1.2, label=twin_label)
            ax2.set_ylabel(twin_unit)
            ax2.legend(loc="upper right", fontsize=8)
        ax.legend(loc="upper left", fontsize=8)
        _save(plt, fig, out_dir / filename, paths)

    figure("angles.png", "link angles (Fig. 4)",
           [(f"q{i + 1}", np.degrees(result.q[i])) for i in range(n)], "q, link angle (deg)")
    figure("angular_speeds.png", "angular speeds (Fig. 5)",
           [(f"u{i + 1}", result.u[i]) for i in range(n)], "u, angular speed (rad/s)")
    figure("tip_velocity.png", "tip velocity (Fig. 6)",
           [("v_Bx", result.v_Bx), ("v_By", result.v_By)], "v_B, tip velocity (m/s)")
    figure("deformation_force.png", "deformation and normal force (Fig. 7)",
           [("delta", result.delta * 1e6)], "delta (um)", twin=("F", result.F, "F (N)"))
    figure("kinetic_energy.png", "kinetic energy (Fig. 8)",
           [(f"T{i + 1}", result.T_links[i]) for i in range(n)] + [("T", result.T)], "T, kinetic energy (J)")
    idx = np.flatnonzero(mask)
    _energy_bars(plt, result, out_dir, _budget_between(result, idx[0], idx[-1]), which, paths)
    return paths


def _budget_between(result: SimulationResult, i0: int, i1: int) -> dict[str, float]:
    """The energy budget between two of the samples shown (t_eval's, if given)."""
    T0, Tf = float(result.T[i0]), float(result.T[i1])
    return {"delta_T": T0 - Tf, **energy_balance(T0, Tf, float(result.W_normal[i1] - result.W_normal[i0]),
                                                 float(result.W_friction[i1] - result.W_friction[i0]),
                                                 float(result.V[i0] - result.V[i1]))}


def _energy_bars(plt, result: SimulationResult, out_dir: Path, e: dict[str, float], which: str,
                 paths: list[Path]) -> None:
    labels = ["delta_T = T0 - Tf", "-W_normal (plastic)", "-W_friction", "-W_gravity", "residual"]
    values = [e["delta_T"], -e["W_normal"], -e["W_friction"], -e["W_gravity"], e["residual"]]
    fig, ax = plt.subplots(figsize=(7, 4))
    bars = ax.bar(labels, values, color=["#4477aa", "#ee6677", "#228833", "#ccbb44", "#bbbbbb"])
    for bar, v in zip(bars, values):
        ax.annotate(f"{v:.3g} J", (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                    ha="center", va="bottom", fontsize=8)
    ax.set_ylabel("energy (J)")
    ax.set_title(f"{result.scene.name}: energy budget of the {which}")
    ax.tick_params(axis="x", labelsize=8)
    _save(plt, fig, out_dir / "energy_budget.png", paths)


def _plot_whole_run(plt, result: SimulationResult, out_dir: Path) -> list[Path]:
    """Angles, energies and tip height over the whole run, with every impact marked."""
    paths: list[Path] = []
    t = result.t
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for i in range(result.n):
        axes[0].plot(t, np.degrees(result.q[i]), lw=1.0, label=f"q{i + 1}")
    axes[0].set_ylabel("q, link angle (deg)")
    works = result.W_normal + result.W_friction
    axes[1].plot(t, result.T, lw=1.0, label="T (kinetic)")
    axes[1].plot(t, result.V - result.V[0], lw=1.0, label="V - V(0) (gravity)")
    axes[1].plot(t, result.T + result.V - result.V[0] - works, lw=1.0, ls="--",
                 label="T + V - V(0) - works (constant if the budget closes)")
    axes[1].set_ylabel("energy (J)")
    axes[2].plot(t, -result.delta * 1e3, lw=1.0, color="k", label="-delta, tip height above the surface")
    axes[2].set_ylabel("-delta (mm)")
    axes[2].set_xlabel("t (s)")
    starts = [i.t_start for i in result.impacts]
    points = sorted({i.point for i in result.impacts}, key=lambda p: (p == "tip", p))
    colours = dict(zip(points, POINT_COLOURS)) if len(points) > 1 else {"tip": "#ee6677"}
    for ax in axes:
        for impact in result.impacts:
            ax.axvline(impact.t_start, color=colours.get(impact.point, "#ee6677"), lw=0.4, alpha=0.5)
        for span in result.phases:
            if span.phase == "sustained":
                ax.axvspan(span.t0, span.t1, color=PHASE_COLOURS["sustained"], alpha=0.6, lw=0)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    sustained = f", sustained contact from {result.summary['t_sustained']:.4g} s" \
        if result.summary["t_sustained"] is not None else ""
    if len(points) > 1:  # a line per impact, coloured by its point
        for point in points:
            axes[0].plot([], [], color=colours[point], lw=1.5, label=f"impacts: {point}")
        axes[0].legend(loc="upper right", fontsize=8)
        axes[0].set_title(f"{result.scene.name}: {len(starts)} impacts at {len(points)} points "
                          f"(lines coloured by point){sustained}")
    else:
        axes[0].set_title(f"{result.scene.name}: {len(starts)} impacts (red lines){sustained}")
    _save(plt, fig, out_dir / "run_overview.png", paths)
    _energy_bars(plt, result, out_dir, _budget_between(result, 0, len(t) - 1), "whole run", paths)
    return paths
