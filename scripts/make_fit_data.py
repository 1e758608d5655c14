"""Write examples/fit/paper-impacts.csv: 20 impacts of the paper's double pendulum measured by
the model itself, with a known yield strength and friction coefficient plus 1 % noise.

    .venv/bin/python scripts/make_fit_data.py

The rows differ by omega20 (initial.u[2], from -0.15 to -0.5 rad/s); the measurements are the
permanent set delta_r, the contact time t_contact and the speeds after the impact
u_final[1], u_final[2], each with its sigma (1 % of its value). The true values, which
`impactgen fit` should find again (docs/fitting.md): rod.yield_strength = 0.8e9 Pa (below
the surface's 1.12e9, so the rod is the weaker material that yields) and contact.friction = 0.25.
"""
from pathlib import Path

import numpy as np

from impactgen.fitting.synthetic import synthetic_measurements

TRUTH = {"rod.yield_strength": 0.8e9, "contact.friction": 0.25}
OMEGA20 = np.round(np.linspace(-0.15, -0.5, 20), 6)
COLUMNS = ("delta_r", "t_contact", "u_final[1]", "u_final[2]")
OUT = Path(__file__).resolve().parent.parent / "examples" / "fit" / "paper-impacts.csv"


def main() -> None:
    table = synthetic_measurements("paper", TRUTH, {"initial.u[2]": OMEGA20}, COLUMNS, noise=0.01, seed=47)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT, index=False, float_format="%.9g")
    print(OUT)


if __name__ == "__main__":
    main()
