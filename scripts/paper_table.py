"""Print the paper's Table 2 rows (MODEL section 7) beside what impactgen computes: Delta T
with the physical (regularized) friction and with friction_mode = "frozen" (the friction's
direction kept from contact start), which reproduces the published energy losses
(docs/model.md, "The paper's published energy losses")."""
from pathlib import Path

import impactgen

PUBLISHED = [(-0.2, 0.005, 5.49e-6), (-0.3, 0.010, 8.64e-6), (-0.4, 0.016, 1.200e-5), (-0.5, 0.025, 1.55e-5)]
scene_file = Path(__file__).resolve().parent.parent / "scenes" / "paper.toml"

print("omega20   Delta T (J): regularized  frozen  paper   delta_r (m)   paper      error    P_m (N)  duration (s)")
for omega20, dT_paper, dr_paper in PUBLISHED:
    scene = impactgen.load_scene(scene_file, overrides={"initial.u": [-0.1, omega20]})
    s = impactgen.simulate(scene).summary
    frozen = impactgen.simulate(scene.replace({"contact.friction_mode": "frozen"})).summary
    err = 100 * (s["delta_r"] / dr_paper - 1)
    print(f"{omega20:6.1f}                {s['delta_T']:.4f}  {frozen['delta_T']:.4f}  {dT_paper:.3f}   "
          f"{s['delta_r']:.4g}    {dr_paper:.3g}   {err:+5.2f} %   {s['P_max']:7.1f}  {s['t_contact']:.4g}")
