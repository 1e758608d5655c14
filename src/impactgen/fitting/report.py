"""A fit as `impactgen fit` shows it: the text, the JSON object and the figure of measured
against fitted values."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..summaries import summary_unit
from .solve import FitResult, LawFit

ROWS_SHOWN = 40  # the residual table's rows beyond these are left out of the text (all in --json)
PANELS_ACROSS = 2  # the figure's panels (one per measurement column) per row


def parameter_unit(key: str) -> str:
    """The unit of a fitted scene key, from the model's parameter table ("" if it has none)."""
    from ..codegen.parameters import PARAMETERS
    base = key.split("[", 1)[0]
    return next((p.unit for p in PARAMETERS if p.key.replace("[{i}]", "") == base and p.unit != "1"), "")


def _value_text(fit: LawFit, j: int) -> str:
    p, value = fit.parameters[j], fit.values[j]
    unit = parameter_unit(p.key)
    unit = f" {unit}" if unit else ""
    if not fit.determined[j]:
        return f"{p.key:<24} = {value:.6g}{unit}  NOT DETERMINED by the data (singular covariance: no error bar)"
    stderr = fit.stderr[j]
    relative = f" ({100 * stderr / abs(value):.2g} %)" if value != 0 else ""
    flags = "  at its bound" if fit.at_bound[j] else ""
    if value != 0 and stderr > abs(value):
        flags += "  poorly determined: the error exceeds the value"
    return f"{p.key:<24} = {value:.6g} +/- {stderr:.2g}{unit}{relative}{flags}"


def format_fit(result: FitResult) -> list[str]:
    """The lines `impactgen fit` prints: each law's values, correlations and residuals, and
    with several laws their ranking."""
    data = result.measurements
    columns = list(data.measured)
    weighting = ("weighted by the data's sigmas" if result.sigma_given else
                 "each column relative to its RMS, errors scaled by the residual variance")
    lines = [f"fit of {result.scene_name} to {data.rows} measured impacts in {data.source}: "
             f"{', '.join(columns)} ({weighting})"]
    for fit in result.laws:
        lines += _law_lines(fit, result.sigma_given)
    if len(result.laws) > 1:
        lines.append("laws ranked by AIC (lowest first):")
        lines.append(f"  {'rank':>4} {'law':<20} {'chi2':>12} {'AIC':>12} {'dAIC':>10}")
        best = result.laws[0].aic
        for k, fit in enumerate(result.laws, start=1):
            lines.append(f"  {k:>4} {fit.law:<20} {fit.chi2:12.5g} {fit.aic:12.5g} {fit.aic - best:10.4g}")
    lines += _residual_lines(result.best, data)
    lines.append(f"{result.impacts} impacts simulated; the fit took {result.wall_s:.3g} s, "
                 f"{result.batch_s:.3g} s of it in run_batch")
    return lines


def _law_lines(fit: LawFit, sigma_given: bool) -> list[str]:
    dof = fit.count - int(fit.determined.sum())
    fitness = f"chi2 = {fit.chi2:.5g} for {dof} degrees of freedom" if sigma_given else \
        f"sum of squared relative residuals = {fit.chi2:.5g} ({fit.count} values)"
    lines = [f"law {fit.law}: {fitness}, AIC = {fit.aic:.5g}; {fit.message}"]
    lines += ["  " + _value_text(fit, j) for j in range(len(fit.parameters))]
    idx = np.flatnonzero(fit.determined)
    if len(idx) > 1:
        lines.append("  correlations: " + ", ".join(
            f"{fit.parameters[a].key} ~ {fit.parameters[b].key} {fit.correlation[a, b]:+.3f}"
            for n, a in enumerate(idx) for b in idx[n + 1:]))
    return lines


def _residual_lines(fit: LawFit, data) -> list[str]:
    columns = list(data.measured)
    heading = "".join(f" {c + ' measured':>24} {'fitted':>12} {'resid':>7}" for c in columns)
    lines = [f"residuals of law {fit.law} (resid: weighted, model - measured):", f"  {'row':>4}{heading}"]
    for i in range(min(data.rows, ROWS_SHOWN)):
        lines.append(f"  {i + 1:>4}" + "".join(
            f" {data.measured[c][i]:24.6g} {fit.fitted[c][i]:12.6g} {fit.residuals[c][i]:7.3f}" for c in columns))
    if data.rows > ROWS_SHOWN:
        lines.append(f"  ... ({data.rows - ROWS_SHOWN} more rows: --json has every row)")
    return lines


def fit_json(result: FitResult) -> dict[str, Any]:
    """The JSON object of `impactgen fit --json`: the best law's parameters (value, stderr:
    null where undetermined), correlations and residuals, and with several laws the ranking."""
    best = result.best
    out: dict[str, Any] = {"scene": result.scene_name, "data": result.measurements.source, "law": best.law,
                           **_law_json(best, result.measurements)}
    out.update({"impacts_simulated": result.impacts, "wall_s": result.wall_s, "batch_s": result.batch_s,
                "weighting": "sigma" if result.sigma_given else "relative"})
    if len(result.laws) > 1:
        out["ranking"] = [{"rank": k, "law": fit.law, "chi2": fit.chi2, "aic": fit.aic,
                           "parameters": _law_json(fit, result.measurements)["parameters"]}
                          for k, fit in enumerate(result.laws, start=1)]
    return out


def _law_json(fit: LawFit, data) -> dict[str, Any]:
    keys = [p.key for p in fit.parameters]
    parameters = {p.key: {"value": float(v), "stderr": _number(s) if d else None, "determined": bool(d),
                          "at_bound": bool(b), "unit": parameter_unit(p.key)}
                  for p, v, s, d, b in zip(fit.parameters, fit.values, fit.stderr, fit.determined, fit.at_bound)}
    correlations = {a: {b: _number(fit.correlation[i, j]) for j, b in enumerate(keys)} for i, a in enumerate(keys)}
    rows = []
    for i in range(data.rows):
        rows.append({"row": i + 1, **{c: {"measured": _number(data.measured[c][i]), "fitted": _number(fit.fitted[c][i]),
                                          "residual": _number(fit.residuals[c][i])} for c in data.measured}})
    return {"parameters": parameters, "correlations": correlations, "chi2": fit.chi2, "aic": fit.aic,
            "measured_values": fit.count, "converged": fit.success, "message": fit.message, "residuals": rows}


def _number(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def plot_fit(result: FitResult, out: Path) -> Path:
    """Measured against fitted, one panel per measurement column, every law's points (the
    best law's with the data's error bars) beside the line of equality."""
    from ..plots import _pyplot, save_figure
    plt = _pyplot()
    columns = list(result.measurements.measured)
    across = min(len(columns), PANELS_ACROSS)
    down = -(-len(columns) // across)
    fig, axes = plt.subplots(down, across, figsize=(4.4 * across, 4.0 * down), squeeze=False)
    for ax in axes.flat[len(columns):]:
        ax.set_visible(False)
    for ax, column in zip(axes.flat, columns):
        measured = result.measurements.measured[column]
        sigma = result.measurements.sigma[column] if result.sigma_given else None
        for k, fit in enumerate(result.laws):
            label = f"{fit.law} (best)" if k == 0 and len(result.laws) > 1 else fit.law
            ax.errorbar(measured, fit.fitted[column], xerr=sigma if k == 0 else None, fmt="o", markersize=3,
                        label=label, alpha=1.0 if k == 0 else 0.6)
        finite = measured[np.isfinite(measured)]
        span = [float(finite.min()), float(finite.max())]
        ax.plot(span, span, color="0.5", linewidth=0.8, label="measured = fitted")
        unit = summary_unit(column)
        unit = f" ({unit})" if unit and unit != "1" else ""
        ax.set_xlabel(f"measured {column}{unit}")
        ax.set_ylabel(f"fitted {column}{unit}")
        ax.locator_params(axis="x", nbins=5)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"{result.scene_name}: measured against fitted ({result.measurements.source})")
    return save_figure(fig, out)
