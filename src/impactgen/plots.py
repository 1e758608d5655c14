"""Figures of one simulation, like the paper's Figures 4 to 8, and its energy budget.

Every figure is against time with the contact phases shaded: link angles, angular speeds,
tip velocity, deformation and normal force, kinetic energy per link and in total; and a
bar chart of the energy budget (Delta T against the works of the forces).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import ImpactgenError
from .results import SimulationResult

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


def _window(result: SimulationResult) -> np.ndarray:
    """Samples of the first impact (with a margin), or the whole run without impacts."""
    t = result.t
    if not result.impacts:
        return np.ones(len(t), bool)
    impact = result.impacts[0]
    t0 = impact.t_start
    t1 = impact.t_end if impact.t_end is not None else t[-1]
    margin = 0.05 * (t1 - t0)
    return (t >= t0 - margin) & (t <= t1 + margin)


def _shade(ax, result: SimulationResult, scale: float) -> None:
    seen = set()
    for span in result.phases:
        colour = PHASE_COLOURS.get(span.phase)
        if colour is None:
            continue
        label = span.phase if span.phase not in seen else None
        seen.add(span.phase)
        ax.axvspan(span.t0 * scale, span.t1 * scale, color=colour, alpha=0.6, lw=0, label=label)


def plot_simulation(result: SimulationResult, out_dir: Path) -> list[Path]:
    """Write the figures of `result` as PNG files into `out_dir`; return their paths."""
    plt = _pyplot()
    out_dir.mkdir(parents=True, exist_ok=True)
    mask = _window(result)
    t_ms = result.t[mask] * 1e3
    n = result.n
    name = result.scene.name
    paths = []

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
        fig.tight_layout()
        path = out_dir / filename
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)

    figure("angles.png", "link angles (Fig. 4)",
           [(f"q{i + 1}", np.degrees(result.q[:, i])) for i in range(n)], "angle (deg)")
    figure("angular_speeds.png", "angular speeds (Fig. 5)",
           [(f"omega{i + 1}", result.u[:, i]) for i in range(n)], "rad/s")
    figure("tip_velocity.png", "tip velocity (Fig. 6)",
           [("v_Bx", result.v_B[:, 0]), ("v_By", result.v_B[:, 1])], "m/s")
    figure("deformation_force.png", "deformation and normal force (Fig. 7)",
           [("delta", result.delta * 1e6)], "delta (um)", twin=("F", result.F, "F (N)"))
    figure("kinetic_energy.png", "kinetic energy (Fig. 8)",
           [(f"T{i + 1}", result.T_links[:, i]) for i in range(n)] + [("T", result.T)], "J")

    s = result.summary
    e = s["energy"]
    labels = ["Delta T = T0 - Tf", "-W_normal (plastic)", "-W_friction", "-W_gravity", "residual"]
    values = [s["delta_T"], -e["W_normal"], -e["W_friction"], -e["W_gravity"], e["residual"]]
    fig, ax = plt.subplots(figsize=(7, 4))
    bars = ax.bar(labels, values, color=["#4477aa", "#ee6677", "#228833", "#ccbb44", "#bbbbbb"])
    for bar, v in zip(bars, values):
        ax.annotate(f"{v:.3g} J", (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                    ha="center", va="bottom", fontsize=8)
    ax.set_ylabel("J")
    ax.set_title(f"{name}: energy budget of the first impact")
    ax.tick_params(axis="x", labelsize=8)
    fig.tight_layout()
    path = out_dir / "energy_budget.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    paths.append(path)
    return paths
