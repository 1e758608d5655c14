"""A batch of cases given as a table, run as a sweep's chunks run (in C where they can be):
`run_batch`, for the caller that makes its own cases (a fit, an uncertainty study)."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ..errors import SceneError, excerpt
from ..scene import Scene, load_scene, split_key
from .execute import MAX_CHUNK
from .chunk import CaseOptions, ChunkRows, run_chunk
from .run import column_order, warn_validity


def run_batch(scene: Scene | str, cases: Any):
    """Run one case of `scene` per row of `cases`, and return one row of results per case.

    Cases that change only model parameters and initial elements by real numbers run in C,
    one call per 2000 cases (no Python between them); any other case runs as `simulate`
    runs it. The rows are the same, bit for bit, either way.

    Parameters
    ----------
    scene : Scene or str
        A checked scene, a scene file, or a shipped example's name: the base of every case.
    cases : pandas.DataFrame or mapping of str to array_like
        One column per varied scene key (an element counted from 1, e.g. ``"initial.u[2]"``,
        ``"rod.yield_strength"``), one row per case; every column the same length.

    Returns
    -------
    pandas.DataFrame
        The columns of `sweep`'s table: ``case`` (the row's position), the keys, every scalar
        summary field, ``status`` ("ok", "no-impact", "failed" or "invalid"), ``message``,
        ``warnings``, ``wall_s``. A case whose values the scene refuses is a row with status
        "invalid" and the reason; a failing case is a row with status "failed".

    Raises
    ------
    SceneError
        `cases` is not a table of columns, a column name is not a scene key, or the columns
        differ in length.

    Examples
    --------
    >>> import impactgen
    >>> table = impactgen.run_batch("paper", {"initial.u[2]": [-0.2, -0.4], "rod.yield_strength": [1.1e9, 1.2e9]})
    >>> list(table["status"])
    ['ok', 'ok']
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    columns = _columns(cases)
    keys = tuple(columns)
    for key in keys:
        scene[key]  # an element beyond the scene's (initial.u[5] of 2 links) ends here, named
    count = len(next(iter(columns.values()))) if columns else 0
    payload = scene.to_dict()
    parts: list[ChunkRows] = []
    for start in range(0, count, MAX_CHUNK):
        rows = range(start, min(start + MAX_CHUNK, count))
        chunk = [(i, {key: columns[key][i] for key in keys}) for i in rows]
        parts.append(run_chunk(payload, chunk, CaseOptions()))
    import pandas as pd
    if not parts:
        return pd.DataFrame(columns=["case", *keys, "status", "message", "warnings", "wall_s"])
    joined = ChunkRows.joined(parts)
    table = pd.DataFrame({name: joined[name] for name in column_order(joined, keys)})
    warn_validity(table)  # one ValidityWarning for the batch, as a sweep gives
    return table


def _columns(cases: Any) -> dict[str, list[Any]]:
    """`cases` as plain columns by key, each key checked, every column as long."""
    if hasattr(cases, "to_dict") and hasattr(cases, "columns"):  # a DataFrame
        cases = {name: cases[name].to_numpy() for name in cases.columns}
    if not isinstance(cases, Mapping):
        raise SceneError("cases", f"expected a pandas DataFrame or a mapping of scene keys to arrays, got "
                                  f"{type(cases).__name__} {excerpt(cases)}")
    columns: dict[str, list[Any]] = {}
    for key, values in cases.items():
        if not isinstance(key, str):
            raise SceneError("cases", f"a column must be named by a scene key, got {excerpt(key)}")
        split_key(key)  # an unknown key ends here, named
        if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
            raise SceneError(key, f"expected one value per case (an array or list), got {excerpt(values)}")
        array = np.asarray(values) if not isinstance(values, (list, tuple)) else None
        columns[key] = array.tolist() if array is not None and array.ndim == 1 else list(values)
    lengths = {key: len(values) for key, values in columns.items()}
    if len(set(lengths.values())) > 1:
        raise SceneError("cases", f"every column needs one value per case; the lengths differ: {lengths}")
    return columns


__all__ = ["run_batch"]
