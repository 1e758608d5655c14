"""The compliant impact beside the rigid-body laws given its coefficients (`impactgen compare`).

The compliant run (the three-phase contact, integrated through the impact) gives the
post-impact speeds and the three coefficients of restitution of its first impact (docs/model.md
section 9). Each rigid law of `impact_laws` is then given the same pre-impact state and its own
coefficient (Newton's e_N, Poisson's e_P, Stronge's e_E) and the scene's friction coefficient:
how far its post-impact speeds are from the compliant run's, and how much kinetic energy it
takes (or, wrongly, makes).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import ImpactgenError, SceneError, SolverError
from .impact_laws import LAWS, RigidChain, solve_impact
from .results import SimulationResult, first_of, point_number
from .scene import Scene

LAW_COEFFICIENT = {"newton": "e_N", "poisson": "e_P", "energetic": "e_E"}  # the coefficient each law takes
GAIN_TOLERANCE = 1e-12  # an energy change above this fraction of T_before counts as a gain


def compare_rows(result: SimulationResult) -> list[dict[str, Any]]:
    """The rows of the comparison for the first impact of a compliant run, at whichever point
    (see `compare_laws`)."""
    impact = first_of(result.impacts, result.n)
    if impact is None or impact.i_end is None:
        raise SceneError("initial", "the run has no finished impact to compare the rigid laws with"
                         + (f": {result.message}" if result.message else ""))
    scene, n, dof = result.scene, result.n, result.scene.dof
    point = point_number(impact.point, n)
    y = result.trajectory.y
    q0, u0 = y[impact.i_start, :n], y[impact.i_start, dof:2 * dof]  # a free chain's base point's velocity too
    u_compliant = y[impact.i_end, dof:2 * dof]
    coefficients = impact.coefficients()
    chain = RigidChain.from_scene(scene)
    J = chain.point_jacobian(q0, point)
    v_after = J @ u_compliant
    rows = [_row("compliant", "", math.nan, u_compliant, u_compliant, (v_after[0], v_after[1]),
                 coefficients["P_c"] + coefficients["P_r"], coefficients["P_t"], impact.T_before, impact.T_after)]
    rows[0].update({name: coefficients[name] for name in ("e_N", "e_P", "e_E")})
    for law in LAWS:
        name = LAW_COEFFICIENT[law]
        e = coefficients[name]
        try:
            out = solve_impact(chain, q0, u0, law, e, scene.contact.friction, point)
        except ImpactgenError as exc:
            row = _row(law, name, e, np.full(dof, math.nan), u_compliant, (math.nan, math.nan), math.nan, math.nan,
                       math.nan, math.nan)
            row["note"] = str(exc)
            rows.append(row)
            continue
        rows.append(_row(law, name, e, out.u_after, u_compliant, out.v_after, out.P_n, out.P_t, out.T_before,
                         out.T_after))
    return rows


def _row(law: str, coefficient: str, e: float, u_after: np.ndarray, u_compliant: np.ndarray,
         v_after: tuple[float, float], P_n: float, P_t: float, T_before: float, T_after: float) -> dict[str, Any]:
    change = T_after - T_before
    row: dict[str, Any] = {"law": law, "coefficient": coefficient, "e": e}
    row.update({f"u_after[{i + 1}]": float(v) for i, v in enumerate(u_after)})
    row.update({"du_max": float(np.max(np.abs(u_after - u_compliant))), "v_t_after": float(v_after[0]),
                "v_n_after": float(v_after[1]), "P_n": P_n, "P_t": P_t, "T_before": T_before,
                "T_after": T_after, "energy_change": change,
                "gains_energy": bool(change > GAIN_TOLERANCE * abs(T_before)), "note": ""})
    return row


def compare_laws(scene: Scene, **options: Any):
    """The compliant impact and the rigid-body laws side by side, as a table.

    Parameters
    ----------
    scene : Scene
        The scene; its first impact is compared. A rigid law treats the impact as
        instantaneous, so gravity's impulse over the contact is left out of it.
    **options
        Passed to `impactgen.simulate` (engine, method, ...).

    Returns
    -------
    pandas.DataFrame
        One row for the compliant run, then one per law ("newton", "poisson", "energetic"):
        the coefficient it was given (`coefficient`, `e`), the speeds after (`u_after[i]`,
        rad/s), the largest difference from the compliant run's (`du_max`), the struck point's
        speeds after (`v_t_after`, `v_n_after`), the impulses (`P_n`, `P_t`, N s), the kinetic
        energy before and after and its change (`energy_change`, J), `gains_energy`, and a
        `note` where a law has no solution. The compliant row also has e_N, e_P and e_E.

    Examples
    --------
    >>> import impactgen
    >>> table = impactgen.compare_laws(impactgen.load_scene("paper"))
    >>> list(table["law"])
    ['compliant', 'newton', 'poisson', 'energetic']
    """
    from .engines import simulate
    try:
        import pandas as pd
    except ImportError:
        raise ImpactgenError("compare_laws needs pandas: pip install 'impactgen[sweep]'") from None
    result = simulate(scene, **options)
    if not result.success:
        raise SolverError(result.message)
    return pd.DataFrame(compare_rows(result))


def format_comparison(table, n: int) -> list[str]:
    """The table as `impactgen compare` prints it."""
    speeds = [f"u_after[{i + 1}]" for i in range(n)]
    first = table.iloc[0]
    lines = [f"compliant impact: e_N = {first['e_N']:.5f}, e_P = {first['e_P']:.5f}, e_E = {first['e_E']:.5f}; "
             f"P_n = {first['P_n']:.5g} N s, P_t = {first['P_t']:.5g} N s",
             f"{'law':<10} {'e':>8} " + " ".join(f"{s:>12}" for s in speeds)
             + f" {'du_max':>10} {'energy change (J)':>18}  flag"]
    for _, row in table.iterrows():
        e = "" if row["law"] == "compliant" else f"{row['e']:.5f}"
        flag = "GAINS ENERGY" if row["gains_energy"] else row["note"]
        lines.append(f"{row['law']:<10} {e:>8} " + " ".join(f"{row[s]:12.6f}" for s in speeds)
                     + f" {row['du_max']:10.3g} {row['energy_change']:18.6g}  {flag}".rstrip())
    return lines
