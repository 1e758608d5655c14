"""The coefficients of restitution of a sweep's cases against their normal impact speed
(docs/impact-laws.md): e_N (Newton's, kinematic), e_P (Poisson's, kinetic) and e_E
(Stronge's, energetic) of each case's first impact, over |v_n0|, the tip's normal speed at
first contact. A logarithmic speed axis when the speeds span more than a decade."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..impacts import COEFFICIENT_UNITS

COEFFICIENT_COLUMNS = {"coefficients.e_N": "e_N (kinematic, Newton)", "coefficients.e_P": "e_P (kinetic, Poisson)",
                       "coefficients.e_E": "e_E (energetic, Stronge)"}
SPEED_COLUMN = "coefficients.v_n0"
LOG_SPAN = 10.0  # speeds spanning more than this ratio get a logarithmic axis


def coefficient_figure(plt, ok, folder: Path) -> list[Path]:
    """e_N, e_P and e_E against |v_n0| over the finished cases that have them (none: no figure)."""
    if SPEED_COLUMN not in ok.columns or not set(COEFFICIENT_COLUMNS) <= set(ok.columns):
        return []
    speed = np.abs(ok[SPEED_COLUMN].to_numpy(dtype=float))
    have = np.isfinite(speed) & (speed > 0)
    if not have.any():
        return []
    order = np.argsort(speed[have])
    fig, ax = plt.subplots(figsize=(6, 4))
    for column, label in COEFFICIENT_COLUMNS.items():
        values = ok[column].to_numpy(dtype=float)[have][order]
        ax.plot(speed[have][order], values, "o-", ms=3, lw=1, label=label)
    if speed[have].max() > LOG_SPAN * speed[have].min():
        ax.set_xscale("log")
    ax.set_xlabel(f"|v_n0|, normal impact speed ({COEFFICIENT_UNITS['v_n0']})")
    ax.set_ylabel(f"e_N, e_P, e_E ({COEFFICIENT_UNITS['e_N']})")
    ax.set_title("coefficients of restitution against impact speed")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    path = folder / "coefficients_vs_speed.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return [path]
