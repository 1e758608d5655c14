"""Write a result to files: the trajectories, the impacts table and the JSON summary.

Columns keep plain names (t, q1, u1, delta, F, ...); their units go with them: in the
Parquet schema's field metadata ("unit"), and in a first comment line of a CSV file
(`pandas.read_csv(path, comment="#")` reads it back).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .errors import ImpactgenError, SceneError, excerpt
from .results import IMPACT_UNITS, OUTPUT_UNITS, SimulationResult, point_number

FORMATS = ("parquet", "csv")


def default_format() -> str:
    """Parquet when pyarrow is installed, else CSV."""
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return "csv"
    return "parquet"


def trajectory_columns(result: SimulationResult) -> dict[str, tuple[np.ndarray, str]]:
    """Name -> (samples, unit) of every column of the trajectory table."""
    columns: dict[str, tuple[np.ndarray, str]] = {"t": (result.t, "s")}
    units = {"q": "rad", "u": "rad/s", "W": "J", "P": "N s"}  # P_*: the contact forces' impulses
    for name, row in zip(result.state_names, result.y):
        columns[name] = (row, units[name[0]])
    for name, values in result.outputs.items():
        unit = OUTPUT_UNITS.get(name, "J")  # T1..Tn: kinetic energy per link
        columns[name] = (values, unit)
    columns["phase"] = (result.phase, "")
    return columns


def write_run(result: SimulationResult, out: Path, fmt: str | None = None) -> list[Path]:
    """Write trajectory.<fmt>, impacts.<fmt> and summary.json into folder `out`."""
    fmt = fmt or default_format()
    if fmt not in FORMATS:
        raise SceneError("--format", f"{excerpt(fmt)} is not one of {', '.join(FORMATS)}")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError("--out", f"cannot create the folder {out}: {exc}") from None
    trajectory = trajectory_columns(result)
    # the point as a number: k for joint k, n for the tip (the floor net's numbering)
    impacts = {"point": (np.array([point_number(i.point, result.n) for i in result.impacts], dtype=np.int64), "")}
    impacts.update({k: (np.array([getattr(i, k) if getattr(i, k) is not None else np.nan
                                  for i in result.impacts], dtype=float), unit)
                    for k, unit in IMPACT_UNITS.items() if k not in ("duration", "point")})
    impacts["duration"] = (np.array([i.duration if i.duration is not None else np.nan
                                     for i in result.impacts], dtype=float), "s")
    paths = [out / f"trajectory.{fmt}", out / f"impacts.{fmt}", out / "summary.json"]
    writer = write_parquet if fmt == "parquet" else _write_csv
    try:
        writer(paths[0], trajectory, {"scene": result.scene.to_toml(), "engine": result.engine})
        writer(paths[1], impacts, {"scene": result.scene.to_toml(), "engine": result.engine})
        paths[2].write_text(json.dumps(result.to_json_dict(), indent=1) + "\n")
    except OSError as exc:
        raise SceneError("--out", f"cannot write into {out}: {exc}") from None
    return paths


def write_parquet(path: Path, columns: dict[str, tuple[np.ndarray, str]], meta: dict[str, str]) -> None:
    """Columns (values, unit) as a Parquet file: each unit in its field's metadata, `meta` in
    the schema's as impactgen.KEY."""
    try:
        import pyarrow as pa
    except ImportError:
        raise ImpactgenError("Parquet needs pyarrow: pip install 'impactgen[sweep]', or use --format csv") from None
    fields, arrays = [], []
    for name, (values, unit) in columns.items():
        array = pa.array(np.asarray(values).tolist() if values.dtype.kind in "US" else values)
        fields.append(pa.field(name, array.type, metadata={"unit": unit}))
        arrays.append(array)
    write_table(pa.Table.from_arrays(arrays, schema=pa.schema(fields, metadata={f"impactgen.{k}": v
                                                                               for k, v in meta.items()})), path)


def write_table(table, path: Path) -> None:
    """A pyarrow table to `path`, whole or not at all (written aside, then renamed)."""
    import pyarrow.parquet as pq
    temporary = path.with_name(path.name + ".tmp")
    pq.write_table(table, temporary)
    os.replace(temporary, path)


def _write_csv(path: Path, columns: dict[str, tuple[np.ndarray, str]], meta: dict[str, str]) -> None:
    del meta  # the scene travels in summary.json beside the CSV files
    names = list(columns)
    with path.open("w", encoding="utf-8") as f:
        f.write("# units: " + ", ".join(f"{k} [{u or '-'}]" for k, (_, u) in columns.items()) + "\n")
        f.write(",".join(names) + "\n")
        rows = zip(*(columns[k][0] for k in names))
        for row in rows:
            f.write(",".join(v if isinstance(v, str) else repr(float(v)) for v in row) + "\n")
