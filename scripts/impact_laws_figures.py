"""Make the figures of docs/impact-laws.md (run from the repository root):

    .venv/bin/python scripts/impact_laws_figures.py

1. docs/impact-laws/paper_laws.png: the paper's impact, the compliant run's post-impact speeds
   and energy loss beside Newton's, Poisson's and Stronge's law given its coefficients;
2. docs/impact-laws/newton_gains_energy.png: a Kane-and-Levinson-style impact where Newton's
   law with Coulomb friction makes energy and the energetic law does not, with the tip's
   velocity through the impact against the normal impulse;
3. docs/impact-laws/e_vs_speed.png: e_N, e_P and e_E of the paper's steel contact from 0.01
   to 3 m/s normal speed (a sweep; `impactgen sweep ... --plot` draws the same figure).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import impactgen
from impactgen.impact_laws import LAWS, RigidChain, solve_impact
from impactgen.plots import _pyplot
from impactgen.sweep.coefficient_figure import coefficient_figure

OUT = Path(__file__).resolve().parent.parent / "docs" / "impact-laws"
# the Kane-and-Levinson-style case of tests/test_impact_laws.py
KANE_LEVINSON = dict(q=np.radians([-60.0, -75.0]), u=np.array([-3.232, 2.380]), e=0.5, mu=0.5)
# the paper's steel contact on a single 1 m, 1 kg bar at q = -150 deg (the tip moves along the
# surface normal), without gravity or friction: v_n0 = 0.866 u from 0.01 to 3 m/s
E_OF_V_SET = {"chain.links": 1, "chain.length": 1.0, "chain.mass": 1.0, "chain.gravity": 0.0,
              "contact.friction": 0.0, "initial.q_deg": [-150.0], "initial.u": [0.1]}
E_OF_V_VARY = {"initial.u[1]": "logspace(-1.9375,0.5396,40)"}


def paper_figure(plt) -> Path:
    scene = impactgen.load_scene("paper")
    table = impactgen.compare_laws(scene)
    print(table[["law", "e", "u_after[1]", "u_after[2]", "du_max", "energy_change", "gains_energy"]].to_string())
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    x = np.arange(len(table))
    a.bar(x - 0.2, table["u_after[1]"], 0.4, label="omega1 after")
    a.bar(x + 0.2, table["u_after[2]"], 0.4, label="omega2 after")
    a.set_xticks(x, table["law"])
    a.set_ylabel("rad/s")
    a.set_ylim(-0.3, 0.5)
    a.axhline(0.0, color="k", lw=0.5)
    a.legend(ncol=2, fontsize=8)
    a.set_title("post-impact speeds")
    b.bar(x, -table["energy_change"] * 1e3, color="gray")
    b.set_xticks(x, table["law"])
    b.set_ylabel("kinetic energy lost (mJ)")
    b.set_title("Delta T")
    first = table.iloc[0]
    fig.suptitle(f"the paper's impact: e_N = {first['e_N']:.3f}, e_P = {first['e_P']:.3f}, e_E = {first['e_E']:.3f}")
    return _save(fig, "paper_laws.png")


def newton_figure(plt) -> Path:
    chain = RigidChain((1.0, 1.0), (1.0, 1.0))
    case = KANE_LEVINSON
    outs = {law: solve_impact(chain, case["q"], case["u"], law, case["e"], case["mu"]) for law in LAWS}
    for law, out in outs.items():
        print(f"{law:10s} T {out.T_before:.4f} -> {out.T_after:.4f} J, v after {out.v_after}, P_n {out.P_n:.4f}")
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    x = np.arange(len(LAWS))
    a.bar(x - 0.2, [outs[law].T_before for law in LAWS], 0.4, label="before", color="lightgray")
    a.bar(x + 0.2, [outs[law].T_after for law in LAWS], 0.4, label="after")
    a.set_xticks(x, LAWS)
    a.set_ylabel("kinetic energy (J)")
    a.legend()
    a.set_title(f"e = {case['e']}, mu = {case['mu']}")
    b.plot(*_path(chain, case, "newton"), "o-", label="Newton: friction against the initial slip")
    b.plot(*_path(chain, case, "energetic"), "o-", label="energetic: slip stops, then sticks")
    b.axhline(0.0, color="k", lw=0.5)
    b.set_xlabel("tip tangential speed v_t (m/s)")
    b.set_ylabel("normal speed v_n (m/s)")
    b.set_title("tip velocity through the impact")
    b.legend(fontsize=8)
    fig.suptitle("Newton's law with friction makes energy (q = -60, -75 deg; v_B = (-0.5, -1) m/s)")
    return _save(fig, "newton_gains_energy.png")


def _path(chain: RigidChain, case: dict, law: str) -> tuple[np.ndarray, np.ndarray]:
    """The tip velocity (v_t, v_n) at the regime changes of a law's solution (a straight line
    for Newton's law, which has no history within the impact)."""
    out = solve_impact(chain, case["q"], case["u"], law, case["e"], case["mu"])
    _, vt, vn = zip(*out.path)
    return np.array(vt), np.array(vn)


def e_of_v_figure(plt) -> Path:
    table = impactgen.sweep(impactgen.load_scene("paper", overrides=E_OF_V_SET), vary=E_OF_V_VARY, workers=1)
    ok = table[table["status"] == "ok"]
    print(ok[["coefficients.v_n0", "coefficients.e_N", "coefficients.e_P", "coefficients.e_E"]].to_string())
    [path] = coefficient_figure(plt, ok, OUT)
    target = OUT / "e_vs_speed.png"
    path.replace(target)
    return target


def _save(fig, name: str) -> Path:
    fig.tight_layout()
    path = OUT / name
    fig.savefig(path, dpi=110)
    return path


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    plt = _pyplot()
    for make in (paper_figure, newton_figure, e_of_v_figure):
        print(make(plt))
