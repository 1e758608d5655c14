"""Least squares of a scene's parameters against measured impacts, with honest error bars.

Each evaluation runs every measured row as one case of `run_batch` (in C): the residuals at
a point are one batch call, and the Jacobian is one more, holding the rows of every
parameter's step together. The parameters are fitted in units of their start values (each
x_j = value_j / scale_j), so that a yield strength of 1e9 Pa and a friction coefficient of
0.2 are steps of the same size to the solver.

Residuals: (model - measured) / sigma with the data's sigmas; without them, divided by the
root mean square of the measured column, so that columns in m and in s weigh alike (the
same relative error in every column is assumed, and its size is estimated from the fit).
The covariance is (J^T J)^-1 of the weighted Jacobian at the optimum, times the residual
variance chi2 / (m - k) when no sigmas are given. A direction of the parameters that the
data do not see (a singular value of J below `WEAK_DIRECTION` of the largest) has no
covariance: each parameter with a share in it is reported as not determined.
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..codegen.spec import foreign_law_keys
from ..errors import SceneError, SolverError, ValidityWarning, excerpt
from ..scene import Scene
from .data import FitParameter, Measurements

FD_STEP = 1e-6  # the forward-difference step of a parameter, relative to its scale
WEAK_DIRECTION = 1e-4  # a singular value below this fraction of the largest: a direction the data do not see
WEAK_SHARE = 0.1  # a parameter with this share (squared component) in such a direction is not determined
MAX_EVALUATIONS = 60  # of the residuals, per law
OK = "ok"


@dataclass
class LawFit:
    """One law's fit: the values, their standard errors and correlations, every row's residual."""

    law: str
    parameters: list[FitParameter]
    values: np.ndarray
    stderr: np.ndarray  # NaN for a parameter the data do not determine
    determined: np.ndarray  # bool per parameter
    correlation: np.ndarray  # NaN in the rows and columns of undetermined parameters
    fitted: dict[str, np.ndarray]  # the model's value of each measurement column, per row
    residuals: dict[str, np.ndarray]  # weighted: (model - measured) / sigma or / the column's RMS
    chi2: float  # sum of the squared weighted residuals
    count: int  # measured values (residuals)
    aic: float
    success: bool
    message: str
    evaluations: int  # calls of the residuals
    impacts: int  # impacts simulated for this law
    batch_s: float  # wall time spent in run_batch for them

    @property
    def at_bound(self) -> np.ndarray:
        """Parameters that ended on one of their bounds (their stderr is a local one)."""
        low = np.array([p.low for p in self.parameters])
        high = np.array([p.high for p in self.parameters])
        span = np.where(np.isfinite(high - low), high - low, np.abs(self.values))
        return (np.abs(self.values - low) <= 1e-9 * span) | (np.abs(high - self.values) <= 1e-9 * span)


@dataclass
class FitResult:
    """A fit of one or several laws to the same measurements, the laws ranked best first.

    Attributes
    ----------
    laws : list of LawFit
        One per law, ranked by AIC (lowest first); ``laws[0]`` is the best.
    measurements : Measurements
        The data the fit was given.
    sigma_given : bool
        Whether the residuals were weighted by the data's sigmas.
    wall_s : float
        Wall time of the whole fit.
    impacts : int
        Impacts simulated, over every law.
    batch_s : float
        Wall time spent inside `run_batch` simulating them (the rest is the fit's own).
    """

    laws: list[LawFit]
    measurements: Measurements
    sigma_given: bool
    wall_s: float = 0.0
    impacts: int = 0
    batch_s: float = 0.0
    scene_name: str = ""

    @property
    def best(self) -> LawFit:
        return self.laws[0]

    @property
    def parameters(self) -> dict[str, dict[str, Any]]:
        """The best law's parameters: key -> {"value", "stderr"} (stderr None if undetermined)."""
        fit = self.best
        return {p.key: {"value": float(v), "stderr": float(s) if d else None, "determined": bool(d)}
                for p, v, s, d in zip(fit.parameters, fit.values, fit.stderr, fit.determined)}


class _Model:
    """The weighted residuals of one law's scene at parameter points, each point set one
    `run_batch` call (the rows of several points together for the Jacobian)."""

    def __init__(self, scene: Scene, parameters: list[FitParameter], data: Measurements):
        self.scene, self.parameters, self.data = scene, parameters, data
        self.scale = np.array([abs(p.start) if p.start != 0 else _span(p) for p in parameters])
        self.columns = list(data.measured)
        self.measured = np.concatenate([data.measured[c] for c in self.columns])
        self.mask = np.isfinite(self.measured)
        self.weight = np.concatenate([self._weights(c) for c in self.columns])
        self.impacts = 0
        self.evaluations = 0
        self.batch_s = 0.0  # wall time inside run_batch
        self.last: tuple[np.ndarray, np.ndarray, Any] | None = None  # x, its residuals, its batch table

    def _weights(self, column: str) -> np.ndarray:
        if self.data.sigma is not None:
            return 1.0 / self.data.sigma[column]
        values = self.data.measured[column]
        rms = math.sqrt(np.nanmean(values ** 2))
        return np.full(len(values), 1.0 / rms if rms > 0 else 1.0)

    def run(self, points: list[np.ndarray]):
        """The batch table of every row at each point of x (scaled values), in order."""
        from ..sweep import run_batch
        rows = self.data.rows
        cases: dict[str, list[Any]] = {key: values * len(points) for key, values in self.data.inputs.items()}
        for j, p in enumerate(self.parameters):
            cases[p.key] = np.repeat([x[j] * self.scale[j] for x in points], rows).tolist()
        self.impacts += rows * len(points)
        started = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ValidityWarning)  # the trial points are the solver's, not the user's
            table = run_batch(self.scene, cases)
        self.batch_s += time.perf_counter() - started
        return table

    def model_values(self, table, point: int) -> np.ndarray:
        """The measurement columns of one point's rows, end to end (NaN where a row did not run)."""
        rows = slice(point * self.data.rows, (point + 1) * self.data.rows)
        ok = table["status"].to_numpy()[rows] == OK
        return np.concatenate([np.where(ok, table[c].to_numpy(dtype=float)[rows], np.nan) for c in self.columns])

    def residuals_of(self, values: np.ndarray) -> np.ndarray:
        r = (values - self.measured) * self.weight
        return r[self.mask]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """The weighted residuals at x (the last point's kept: the solver asks for the
        residuals and then the Jacobian of the same point)."""
        if self.last is not None and np.array_equal(self.last[0], x):
            return self.last[1].copy()
        self.evaluations += 1
        table = self.run([x])
        r = self.residuals_of(self.model_values(table, 0))
        self.last = (x.copy(), r, table)
        return r

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Forward differences, every parameter's step in one batch call (a step that would
        leave the bounds goes the other way)."""
        centre = self.residuals(x)
        steps = []
        for j, p in enumerate(self.parameters):
            h = FD_STEP * max(abs(x[j]), 1.0)
            if x[j] + h > p.high / self.scale[j]:
                h = -h
            steps.append(h)
        table = self.run([x + h * np.eye(len(x))[j] for j, h in enumerate(steps)])
        J = np.empty((len(centre), len(x)))
        for j, h in enumerate(steps):
            J[:, j] = (self.residuals_of(self.model_values(table, j)) - centre) / h
        if not np.all(np.isfinite(J)) or not np.all(np.isfinite(centre)):
            failed = table if np.all(np.isfinite(centre)) else self.last[2]
            raise SolverError(f"the model could not run every row near {self.describe(x)}: "
                              f"{_first_failure(failed, self.data.rows)}")
        return J

    def describe(self, x: np.ndarray) -> str:
        return ", ".join(f"{p.key} = {v * s:.6g}" for p, v, s in zip(self.parameters, x, self.scale))


def _span(p: FitParameter) -> float:
    width = p.high - p.low
    return width if math.isfinite(width) and width > 0 else 1.0


def _first_failure(table, rows: int) -> str:
    bad = table[table["status"] != OK]
    if bad.empty:
        return "every row ran"
    row = bad.iloc[0]
    return f"row {int(row['case']) % rows + 1} ended {row['status']}: {excerpt(str(row['message']), 200)}"


def check_start(model: _Model, x0: np.ndarray) -> None:
    """Every row runs at the start values, or one line says which row does not, and why."""
    model.residuals(x0)
    table = model.last[2]
    bad = table[table["status"] != OK]
    if not bad.empty:
        row = bad.iloc[0]
        reason = str(row["message"]) or ("no impact" if row["status"] == "no-impact" else row["status"])
        raise SceneError("DATA", f"{model.data.source}: the model cannot run row {int(row['case']) + 1} "
                                 f"(at {model.describe(x0)}): {reason[:300]}")


def fit_law(scene: Scene, law: str, parameters: list[FitParameter], data: Measurements,
            tolerance: float = 1e-8, settings: Mapping[str, Any] | None = None) -> LawFit:
    """One law's least-squares fit (see the module's docstring for the weighting and errors),
    the scene under `law` with the laws' fixed `settings` and the parameters' start values."""
    from scipy.optimize import least_squares
    from ..contact_compare import under_law
    model = _Model(under_law(scene, law, {**(settings or {}), **{p.key: p.start for p in parameters}}),
                   parameters, data)
    x0 = np.array([p.start for p in parameters]) / model.scale
    check_start(model, x0)
    low = np.array([p.low for p in parameters]) / model.scale
    high = np.array([p.high for p in parameters]) / model.scale
    solution = least_squares(model.residuals, x0, jac=model.jacobian, bounds=(low, high), method="trf",
                             ftol=tolerance, xtol=tolerance, gtol=tolerance, max_nfev=MAX_EVALUATIONS)
    x, r, J = solution.x, solution.fun, solution.jac  # the solver's Jacobian is ours at x (linear loss)
    if model.last is not None and np.array_equal(model.last[0], x):
        from ..sweep.run import warn_validity
        warn_validity(model.last[2])  # the rows at the values found: outside the model's range, say so
    chi2 = float(r @ r)
    count, k = len(r), len(parameters)
    stderr, determined, correlation = covariance(J, chi2, count, data.sigma is not None)
    stderr = stderr * model.scale
    rank = int(determined.sum())
    aic = (chi2 if data.sigma is not None else count * math.log(max(chi2, 1e-300) / count)) + 2 * rank
    values = np.full(model.measured.shape, math.nan)
    values[model.mask] = model.measured[model.mask] + r / model.weight[model.mask]
    rows = data.rows
    fitted = {c: values[i * rows:(i + 1) * rows] for i, c in enumerate(model.columns)}
    weighted = {c: (fitted[c] - data.measured[c]) * model.weight[i * rows:(i + 1) * rows]
                for i, c in enumerate(model.columns)}
    message = solution.message if solution.success else f"did not converge: {solution.message}"
    if count <= k and data.sigma is None:
        message += f"; {count} measured values for {k} parameters leave no degrees of freedom for the errors"
    return LawFit(law, parameters, x * model.scale, stderr, determined, correlation, fitted, weighted, chi2,
                  count, aic, bool(solution.success), message, model.evaluations, model.impacts,
                  model.batch_s)


def covariance(J: np.ndarray, chi2: float, count: int, sigma_given: bool
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard errors, which parameters are determined, and correlations, from the weighted
    Jacobian J (scaled parameters) at the optimum (see the module's docstring)."""
    k = J.shape[1]
    _, s, Vt = np.linalg.svd(J, full_matrices=False)
    weak = s <= WEAK_DIRECTION * (s[0] if s.size and s[0] > 0 else 1.0)
    if not sigma_given:
        weak |= count <= k  # no degrees of freedom: the residual variance is unknown
    share = (Vt[weak] ** 2).sum(axis=0) if weak.any() else np.zeros(k)
    determined = share < WEAK_SHARE
    if not sigma_given and count <= k:
        determined[:] = False
    stderr = np.full(k, math.nan)
    correlation = np.full((k, k), math.nan)
    if determined.any():
        strong = ~weak
        cov = (Vt[strong].T / s[strong] ** 2) @ Vt[strong]
        if not sigma_given:
            cov *= chi2 / (count - k)
        d = np.sqrt(np.diag(cov))
        idx = np.flatnonzero(determined)
        stderr[idx] = d[idx]
        correlation[np.ix_(idx, idx)] = cov[np.ix_(idx, idx)] / np.outer(d[idx], d[idx])
    return stderr, determined, correlation


def law_parameters(parameters: list[FitParameter], law: str) -> list[FitParameter]:
    """The fitted parameters `law` takes: all but the other laws' own keys (a Hunt-Crossley
    fit takes contact.restitution, a three-phase fit of the same data leaves it out)."""
    theirs = foreign_law_keys(law)
    return [p for p in parameters if p.key not in theirs]


def fit(scene: Scene | str, data: Any, parameters: Any, laws: Any = None, tolerance: float = 1e-8,
        settings: Mapping[str, Any] | None = None) -> FitResult:
    """Fit scene parameters to measured impacts by least squares, with the compiled model.

    Parameters
    ----------
    scene : Scene or str
        The scene (or a shipped example's name) every measured row is a case of.
    data : str, pathlib.Path or pandas.DataFrame
        One row per measured impact. Columns named by scene keys are the row's inputs
        (``initial.u[2]``); columns named as the sweep's result columns are measurements
        (``delta_r``, ``t_contact``, ``u_final[2]``, ``coefficients.e_N``); ``sigma:NAME``
        columns their standard deviations (for every measurement, or for none).
    parameters : str, sequence of str or mapping
        The keys to fit: ``"rod.yield_strength=5e8..2e9,contact.friction"``, a list of such
        items, or a mapping of key to None or (low, high). Each starts at its scene value
        (the middle of its bounds if that lies outside them).
    laws : str or sequence of str, optional
        Contact laws to fit each in turn and rank (``"three-phase,hunt-crossley"``); default
        the scene's own `contact.model`. Each law is fitted in the parameters it takes: a
        law's own key (``contact.restitution``) is left out of the other laws' fits.
    settings : mapping, optional
        Laws' own keys held fixed (``{"contact.restitution": 0.8}``), each given to the laws
        that read it.
    tolerance : float
        The solver's ftol, xtol and gtol (scipy.optimize.least_squares).

    Returns
    -------
    FitResult
        ``result.parameters``: the best law's key -> {"value", "stderr", "determined"}
        (stderr None where the data cannot determine the parameter); ``result.laws``: every
        law's `LawFit` (values, stderr, correlation, fitted values, residuals, chi2, AIC),
        ranked by AIC.

    Raises
    ------
    SceneError
        An unknown key or column, no measurement column, reversed bounds, an empty table, or
        a row the model cannot run at the start values.

    Examples
    --------
    >>> import impactgen
    >>> result = impactgen.fit("paper", "examples/fit/paper-impacts.csv",
    ...                        "rod.yield_strength=3e8..1.1e9,contact.friction=0..1")  # doctest: +SKIP
    >>> result.parameters["contact.friction"]["value"]  # doctest: +SKIP
    """
    from ..contact_compare import check_laws
    from ..scene import load_scene
    from .data import parse_fit, read_measurements
    started = time.perf_counter()
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    law_names = check_laws(laws if laws is not None else [scene["contact.model"]], "--law")
    fitted = parse_fit(parameters, scene)
    measurements = read_measurements(data, scene, [p.key for p in fitted])
    fits = [fit_law(scene, law, law_parameters(fitted, law), measurements, tolerance, settings)
            for law in law_names]
    fits.sort(key=lambda f: (not math.isfinite(f.aic), f.aic))
    return FitResult(fits, measurements, measurements.sigma is not None, time.perf_counter() - started,
                     sum(f.impacts for f in fits), sum(f.batch_s for f in fits), scene.name)
