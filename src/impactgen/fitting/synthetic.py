"""Measurements made by the model itself: known parameter values plus noise, to check that a
fit finds them again (the tests, and the shipped example data of scripts/make_fit_data.py)."""
from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import SceneError
from ..scene import Scene, load_scene
from .data import SIGMA_PREFIX


def synthetic_measurements(scene: Scene | str, truth: Mapping[str, float], inputs: Mapping[str, Sequence[Any]],
                           columns: Sequence[str], noise: float = 0.01, seed: int = 0):
    """A table of measured impacts as `impactgen fit` reads it, made by the model.

    Parameters
    ----------
    scene : Scene or str
        The scene every row is a case of.
    truth : mapping of str to float
        The parameter values the measurements are made with (not in the table).
    inputs : mapping of str to sequence
        Each row's inputs by scene key (the table's input columns).
    columns : sequence of str
        The result columns measured (``delta_r``, ``u_final[2]``, ...).
    noise : float
        Relative standard deviation of the Gaussian noise added to each value; the table's
        ``sigma:NAME`` columns state it (noise times the value's size).
    seed : int
        Seed of the noise.

    Returns
    -------
    pandas.DataFrame
        The inputs, the measured columns and their ``sigma:`` columns.
    """
    from ..sweep import run_batch
    import pandas as pd
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    count = len(next(iter(inputs.values())))
    cases = {key: list(values) for key, values in inputs.items()}
    cases.update({key: [value] * count for key, value in truth.items()})
    table = run_batch(scene, cases)
    if not (table["status"] == "ok").all():
        bad = table[table["status"] != "ok"].iloc[0]
        raise SceneError("inputs", f"case {int(bad['case'])} did not run: {bad['status']} {bad['message']}")
    rng = np.random.default_rng(seed)
    out = pd.DataFrame({key: list(values) for key, values in inputs.items()})
    for name in columns:
        exact = table[name].to_numpy(dtype=float)
        sigma = noise * np.abs(exact)
        out[name] = exact + sigma * rng.standard_normal(count)
        out[SIGMA_PREFIX + name] = sigma
    return out
