"""The paper's Table 2 (Marghitu and Zhao, Mathematics 2020, 8, 1202; MODEL section 7) beside
what impactgen computes: the published values in one place (`PUBLISHED`), and the table.

delta_T is given twice: with the physical (regularized) friction, which sits about 15 % above
the published figures, and with ``friction_mode = "frozen"`` (the friction's direction kept
from contact start), which reproduces them (docs/model.md, "The paper's published energy
losses"). delta_r does not depend on the mode.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .errors import ImpactgenError, SolverError, ValidityWarning, warn
from .validity import FROZEN_REVERSAL


@dataclass(frozen=True)
class PublishedRow:
    """One row of the paper's Table 2: the base case with omega20 changed."""

    omega20: float  # rad/s, the initial speed of link 2 (initial.u[2])
    delta_T: float  # J, the kinetic energy lost (published to one or two significant digits)
    delta_r: float  # m, the permanent deformation


# Table 2. The -0.4 row's delta_r: the text says 1.25e-5, the figure's axis 1.200e-5 (MODEL 7).
PUBLISHED = (
    PublishedRow(-0.2, 0.005, 5.49e-6),
    PublishedRow(-0.3, 0.010, 8.64e-6),
    PublishedRow(-0.4, 0.016, 1.200e-5),
    PublishedRow(-0.5, 0.025, 1.55e-5),
)
PAPER_SCENE = "paper"  # the shipped example of the paper's base case (scenes/paper.toml)

# The columns of `paper_table`, with their units (the relative errors are fractions).
COLUMNS = {
    "omega20": "rad/s", "delta_r": "m", "delta_r_paper": "m", "delta_r_error": "1",
    "delta_T": "J", "delta_T_frozen": "J", "delta_T_paper": "J", "delta_T_error": "1",
    "delta_T_frozen_error": "1", "P_max": "N", "t_contact": "s",
}


def paper_rows(engine: str = "c") -> list[dict[str, float]]:
    """The rows of `paper_table` as plain dicts (the command's --json prints them)."""
    from .engines import simulate
    from .scene import load_scene
    rows = []
    for published in PUBLISHED:
        scene = load_scene(PAPER_SCENE, overrides={"initial.u[2]": published.omega20})
        regular = simulate(scene, engine=engine)
        # frozen friction is unphysical once the tip's slip reverses, and every row's run says so:
        # the table states it once, below, instead of a warning per row
        frozen = simulate(scene.replace({"contact.friction_mode": "frozen"}), engine=engine, warn=False)
        for text in frozen.warnings:
            if FROZEN_REVERSAL not in text:  # any other warning of these runs is news: issued
                warn(f"{scene.name}, friction_mode = \"frozen\": {text}", ValidityWarning)
        for run in (regular, frozen):
            if not run.success:
                raise SolverError(f"the paper's case omega20 = {published.omega20} rad/s: {run.message}")
        s, f = regular.summary, frozen.summary
        rows.append({
            "omega20": published.omega20,
            "delta_r": s["delta_r"], "delta_r_paper": published.delta_r,
            "delta_r_error": s["delta_r"] / published.delta_r - 1,
            "delta_T": s["delta_T"], "delta_T_frozen": f["delta_T"], "delta_T_paper": published.delta_T,
            "delta_T_error": s["delta_T"] / published.delta_T - 1,
            "delta_T_frozen_error": f["delta_T"] / published.delta_T - 1,
            "P_max": s["P_max"], "t_contact": s["t_contact"],
        })
    return rows


def paper_table(engine: str = "c") -> Any:
    """The paper's Table 2 computed again, beside the published values.

    Parameters
    ----------
    engine : {"c", "reference"}
        The engine of the eight runs (four rows, each with regularized and frozen friction).

    Returns
    -------
    pandas.DataFrame
        One row per published case, in the columns of `COLUMNS`: ``omega20`` (rad/s);
        ``delta_r`` computed, ``delta_r_paper`` published (m) and ``delta_r_error``, their
        relative difference; ``delta_T`` with the physical friction and ``delta_T_frozen``
        with ``friction_mode = "frozen"``, ``delta_T_paper`` published (J), and the relative
        differences ``delta_T_error`` and ``delta_T_frozen_error``; ``P_max`` (N) and
        ``t_contact`` (s) of the regularized run.

    Raises
    ------
    ImpactgenError
        pandas is not installed (``pip install 'impactgen[sweep]'``).
    SolverError
        A run failed.

    Examples
    --------
    >>> import impactgen.paper
    >>> table = impactgen.paper.paper_table()
    >>> bool((table["delta_r_error"].abs() < 0.03).all())
    True
    """
    try:
        import pandas as pd
    except ImportError:
        raise ImpactgenError("paper_table needs pandas: pip install 'impactgen[sweep]'") from None
    return pd.DataFrame(paper_rows(engine), columns=list(COLUMNS))


def format_paper_table(rows: list[dict[str, float]]) -> list[str]:
    """The rows as `impactgen paper-table` prints them."""
    lines = [f"{'omega20':>7}  {'delta_r (m)':>11} {'paper':>10} {'error':>8}   {'delta_T (J)':>11} "
             f"{'frozen':>7} {'paper':>6} {'error':>8}   {'P_max (N)':>9} {'t_contact (s)':>13}"]
    for r in rows:
        lines.append(f"{r['omega20']:7.1f}  {r['delta_r']:11.3e} {r['delta_r_paper']:10.3e} "
                     f"{100 * r['delta_r_error']:+7.2f}%   {r['delta_T']:11.4f} {r['delta_T_frozen']:7.4f} "
                     f"{r['delta_T_paper']:6.3f} {100 * r['delta_T_frozen_error']:+7.2f}%   "
                     f"{r['P_max']:9.1f} {r['t_contact']:13.4e}")
    lines.append("delta_T: with the physical (regularized) friction, and with friction_mode = \"frozen\", which "
                 "reproduces the published values (rounded; docs/model.md) but is not physical once the tip's "
                 "slip reverses; error: computed / published - 1")
    return lines
