"""What a fit is given: the measured impacts (a CSV table) and the parameters to fit.

A table has one row per measured impact. A column named by a scene key is an input of that
row (``initial.u[2]``); a column named as a sweep's result column is a measurement
(``delta_r``, ``u_final[2]``, ``coefficients.e_N``); ``sigma:NAME`` is the standard deviation
of measurement NAME. Everything else is refused by name, before anything runs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import SceneError, excerpt
from ..scene import Scene, split_key
from ..sweep.chunk import summary_column_names

SIGMA_PREFIX = "sigma:"


@dataclass(frozen=True)
class FitParameter:
    """One fitted scene key, its bounds (infinite where not given) and its start value."""

    key: str
    low: float
    high: float
    start: float


@dataclass(frozen=True)
class Measurements:
    """The measured impacts: the inputs of each row, the measured values and their sigmas."""

    inputs: dict[str, list[Any]]  # scene key -> one value per row
    measured: dict[str, np.ndarray]  # result column -> one value per row (NaN: not measured)
    sigma: dict[str, np.ndarray] | None  # result column -> its standard deviations, or None
    source: str  # the file's name (or "data") for messages and the report

    @property
    def rows(self) -> int:
        return len(next(iter(self.measured.values())))


def parse_fit(spec: str | Sequence[str] | Mapping[str, Any], scene: Scene) -> list[FitParameter]:
    """The parameters of ``KEY[=LOW..HIGH],...`` (or a list of such items, or a mapping of
    key to None or (low, high)), each a number of `scene`, started at its value there (or
    at the middle of its bounds when the scene's value lies outside them)."""
    if isinstance(spec, Mapping):
        items = [(key, bounds) for key, bounds in spec.items()]
    else:
        texts = spec.split(",") if isinstance(spec, str) else list(spec)
        items = [_fit_item(text) for text in texts if str(text).strip()]
    if not items:
        raise SceneError("--fit", "name at least one scene key to fit, e.g. --fit rod.yield_strength=5e8..2e9")
    parameters = []
    for key, bounds in items:
        low, high = (-math.inf, math.inf) if bounds is None else (float(bounds[0]), float(bounds[1]))
        if not low < high:
            raise SceneError("--fit", f"{key}: the bounds are reversed or empty: {low:g}..{high:g} (give LOW..HIGH, LOW < HIGH)")
        value = scene[key]  # an unknown key, or an element that is not there, ends here, named
        if value is None and math.isfinite(high - low):  # a key the scene leaves unset: from its bounds
            value = _middle(low, high)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            unset = " (unset: give it in the scene or give bounds LOW..HIGH)" if value is None else ""
            raise SceneError("--fit", f"{key} is {excerpt(value)}{unset}, not a number; fit a number of the scene "
                                      "(one element of a list: initial.u[2])")
        start = float(value) if low <= value <= high else _middle(low, high)
        parameters.append(FitParameter(key, low, high, start))
    keys = [p.key for p in parameters]
    if len(set(keys)) != len(keys):
        raise SceneError("--fit", f"a key is given twice: {', '.join(keys)}")
    return parameters


def _fit_item(text: str) -> tuple[str, tuple[float, float] | None]:
    key, sep, bounds = str(text).strip().partition("=")
    key = key.strip()
    split_key(key)  # an unknown key ends here, named, with the key most likely meant
    if not sep:
        return key, None
    low, dots, high = bounds.partition("..")
    try:
        return key, (float(low), float(high))
    except ValueError:
        pass
    raise SceneError("--fit", f"{key}: expected bounds LOW..HIGH, e.g. {key}=0.5e9..2e9, got {bounds!r}"
                     + ("" if dots else " (no '..')"))


def _middle(low: float, high: float) -> float:
    if math.isinf(low) or math.isinf(high):
        finite = high if math.isinf(low) else low
        return finite
    return 0.5 * (low + high)


def read_measurements(data: str | Path | Any, scene: Scene, fitted: Sequence[str]) -> Measurements:
    """The table `data` (a CSV file or a DataFrame) as inputs, measurements and sigmas,
    every column checked against `scene` and the fitted keys `fitted`."""
    import pandas as pd
    source = "data"
    if isinstance(data, (str, Path)):
        source = Path(data).name
        try:
            frame = pd.read_csv(data)
        except FileNotFoundError:
            raise SceneError("DATA", f"no such file: {data}") from None
        except pd.errors.EmptyDataError:
            raise SceneError("DATA", f"{source} is empty: give a header line and one row per measured impact") from None
        except (pd.errors.ParserError, UnicodeDecodeError, OSError) as exc:
            raise SceneError("DATA", f"cannot read {data} as CSV: {excerpt(str(exc))}") from None
    elif hasattr(data, "columns"):
        frame = data
    else:
        raise SceneError("data", f"expected a CSV file or a pandas DataFrame, got {type(data).__name__}")
    if len(frame) == 0:
        raise SceneError("DATA", f"{source} has no rows: give one row per measured impact")
    results = set(summary_column_names(scene.n, scene.free))
    inputs: dict[str, list[Any]] = {}
    measured: dict[str, np.ndarray] = {}
    sigmas: dict[str, np.ndarray] = {}
    for name in frame.columns:
        column = str(name).strip()
        values = frame[name]
        if column.startswith(SIGMA_PREFIX):
            sigmas[column[len(SIGMA_PREFIX):]] = _numbers(values, column, source)
        elif column in results:
            measured[column] = _numbers(values, column, source)
        else:
            inputs[_input_key(column, scene, source)] = values.tolist()
    _check_columns(inputs, measured, sigmas, fitted, source)
    return Measurements(inputs, measured, sigmas or None, source)


def _input_key(column: str, scene: Scene, source: str) -> str:
    """`column` as a scene key of `scene`, or a one-line error saying what the columns may be."""
    try:
        split_key(column)
        scene[column]
    except SceneError as exc:
        raise SceneError("DATA", f"{source}: column {column!r} is neither a scene key (an input) nor a result "
                                 f"column (a measurement: delta_r, t_contact, u_final[2], coefficients.e_N, ...) "
                                 f"nor sigma:NAME ({exc})") from None
    return column


def _numbers(values: Any, column: str, source: str) -> np.ndarray:
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise SceneError("DATA", f"{source}: column {column!r} holds something other than numbers: "
                                 f"{excerpt(values.tolist())}") from None


def _check_columns(inputs: dict, measured: dict, sigmas: dict, fitted: Sequence[str], source: str) -> None:
    if not measured:
        raise SceneError("DATA", f"{source} has no measurement column: name one by a result column "
                                 "(delta_r, t_contact, u_final[2], coefficients.e_N, ...)")
    both = sorted(set(inputs) & set(fitted))
    if both:
        raise SceneError("DATA", f"{source}: {', '.join(both)} is both a column (an input per row) and fitted; "
                                 "leave it out of one")
    for name, sigma in sigmas.items():
        if name not in measured:
            raise SceneError("DATA", f"{source}: column sigma:{name} has no measurement column {name!r}")
        if not np.all(np.isfinite(sigma) & (sigma > 0)):
            raise SceneError("DATA", f"{source}: sigma:{name} must be a number > 0 in every row")
    if sigmas and set(sigmas) != set(measured):
        missing = sorted(set(measured) - set(sigmas))
        raise SceneError("DATA", f"{source}: give a sigma for every measurement or for none; missing "
                                 + ", ".join(f"sigma:{name}" for name in missing))
    for name, values in measured.items():
        if np.all(np.isnan(values)):
            raise SceneError("DATA", f"{source}: measurement column {name!r} has no value")
