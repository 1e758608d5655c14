"""The figures tell their lines apart and label their axes with the fields' names and units
(issue 49, items 7 and 8)."""
from __future__ import annotations

import re

import pytest

from impactgen.bench import workprecision as wp
from impactgen.bench.contenders import available_contenders

pytest.importorskip("matplotlib")
LABEL = re.compile(r"\((?:[^()]+)\)$")  # "delta_r (m)": a label ends in its unit


def _runs(names_families, scene="paper"):
    return [wp.Run(scene, name, family, rtol, "ok", wall_s=rtol ** -0.1 * 1e-3, err_u_final=rtol,
                   err_delta_r=rtol, err_delta_T=rtol)
            for name, family in names_families for rtol in (1e-4, 1e-8)]


def test_every_work_precision_line_has_its_own_colour_and_marker(tmp_path, monkeypatch):
    contenders, _ = available_contenders()
    runs = _runs([(c.name, c.family) for c in contenders]
                 + [("scikit-sundae CVODE (Python callbacks)", "scikit-sundae"), ("PyDy cython", "PyDy")])
    styles = wp.line_styles(runs)
    assert len(styles) == len({r.contender for r in runs}) >= 15
    assert len({s["color"] for s in styles.values()}) == len(styles)
    assert len({s["marker"] for s in styles.values()}) == len(styles)
    lines = {s["linestyle"] for name, s in styles.items() if "impactgen" in name}
    assert lines == {"-"} and all(s["linestyle"] == "--" for name, s in styles.items() if name.startswith("scipy"))
    many = wp.line_styles(_runs([(f"contender {i}", "impactgen") for i in range(30)]))
    assert len({s["color"] for s in many.values()}) == 30  # beyond tab20's colours, still one each
    drawn = []
    from impactgen import plots
    plt = plots._pyplot()
    monkeypatch.setattr(plt, "close", lambda fig: drawn.append(fig))
    path = wp.plot_workprecision(runs, "paper", tmp_path)
    assert path.exists()
    for ax in drawn[0].axes:
        look = [(tuple(line.get_color()), line.get_marker(), line.get_linestyle()) for line in ax.get_lines()]
        assert len(look) == len(styles) and len(set(look)) == len(look)
        assert LABEL.search(ax.get_xlabel()) and LABEL.search(ax.get_ylabel())


def _labels(monkeypatch):
    """The axis labels of every figure plot_sweep saves, by file name."""
    from impactgen.sweep import figures
    seen, legends = {}, {}
    saved = figures._save

    def save(plt, fig, path):
        seen[path.name] = [(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes]
        legends[path.name] = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
        return saved(plt, fig, path)
    monkeypatch.setattr(figures, "_save", save)
    return seen, legends


def _table(keys):
    import numpy as np
    import pandas as pd
    rows = 6
    frame = pd.DataFrame({"case": range(rows), "status": ["ok"] * rows})
    for key, values in keys.items():
        frame[key] = values
    for field in ("delta_r", "delta_max", "P_max", "delta_T", "t_contact"):
        frame[field] = np.linspace(1, 2, rows)
    return frame


def test_the_sweep_figures_label_every_axis_with_a_unit(tmp_path, monkeypatch):
    from impactgen.sweep import SweepSpec
    from impactgen.sweep.figures import plot_sweep
    seen, legends = _labels(monkeypatch)
    grid = {"initial.u[2]": [-0.2, -0.3, -0.4] * 2, "rod.E": [2e11] * 3 + [1e11] * 3}
    plot_sweep(_table(grid), SweepSpec.from_vary({"initial.u[2]": [-0.2, -0.3, -0.4], "rod.E": [2e11, 1e11]}),
               tmp_path)
    drawn = _table({"initial.q_deg[2]": [-60, -62, -64, -66, -68, -70], "contact.friction": [0.1] * 6})
    plot_sweep(drawn, SweepSpec.from_vary({"initial.q_deg[2]": "uniform(-70,-50)",
                                           "contact.friction": "uniform(0,0.5)"}, random=6), tmp_path / "random")
    assert seen["t_contact_vs_initial_u2.png"] == [("|initial.u[2]| (rad/s)", "t_contact (s)")]
    assert seen["delta_T_vs_delta_r.png"] == [("delta_r (m)", "delta_T (J)")]
    assert legends["delta_r_vs_initial_u2.png"] == ["rod.E = 1e+11 Pa", "rod.E = 2e+11 Pa"]
    assert seen["scatter_delta_r.png"] == [("initial.q_deg[2] (deg)", "delta_r (m)"),
                                           ("contact.friction (1)", "delta_r (m)")]
    for name, axes in seen.items():
        for x, y in axes:
            assert LABEL.search(x) and LABEL.search(y), (name, x, y)
            assert not re.search(r"\bdelta_m\b|\bP_m\b|Delta T|duration", x + y), (name, x, y)


def test_the_coefficient_figure_labels_its_axes_with_units(tmp_path, monkeypatch):
    import numpy as np
    import pandas as pd
    from impactgen import plots
    from impactgen.sweep.coefficient_figure import coefficient_figure
    plt = plots._pyplot()
    drawn = []
    monkeypatch.setattr(plt, "close", lambda fig: drawn.append(fig))
    frame = pd.DataFrame({"coefficients.v_n0": [-0.1, -0.2, -0.4], **{f"coefficients.{e}": np.full(3, 0.9)
                                                                     for e in ("e_N", "e_P", "e_E")}})
    coefficient_figure(plt, frame, tmp_path)
    ax = drawn[0].axes[0]
    assert ax.get_xlabel().endswith("(m/s)") and ax.get_ylabel().endswith("(1)")


def test_the_run_figures_name_the_fields_and_their_units(tmp_path, monkeypatch):
    import impactgen
    from impactgen import plots
    plt = plots._pyplot()
    drawn = []
    monkeypatch.setattr(plt, "close", lambda fig: drawn.append(fig))
    plots.plot_simulation(impactgen.simulate("paper"), tmp_path)
    legends = [t.get_text() for fig in drawn for ax in fig.axes if ax.get_legend()
               for t in ax.get_legend().get_texts()]
    labels = [ax.get_ylabel() for fig in drawn for ax in fig.axes]
    ticks = [t.get_text() for fig in drawn for ax in fig.axes for t in ax.get_xticklabels()]
    assert {"u1", "u2", "q1", "v_Bx", "T"} <= set(legends) and not any("omega" in text for text in legends)
    assert all(LABEL.search(label) for label in labels), labels
    assert "delta_T = T0 - Tf" in ticks and not any("Delta" in t for t in ticks)
