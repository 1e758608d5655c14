"""Parameter sweeps and ensembles: many cases of one scene, one row per case.

    import impactgen
    table = impactgen.sweep("paper", vary={"initial.u[2]": "linspace(-0.4,-0.1,4)"})
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, Mapping

from ..scene import Scene, load_scene
from .ensemble import run_batch
from .run import check_arguments, run_sweep
from .spec import SweepSpec


def sweep(scene: Scene | str | Path, vary: Mapping[str, Any] | list[str], random: int = 0, seed: int = 0,
          workers: int | None = None, out: str | Path | None = None, progress=None,
          scheduler: str | None = None, trajectories: int | Iterable[int] = 0):
    """Run `scene` once per case of a sweep and return the table of results.

    Parameters
    ----------
    scene : Scene, str or Path
        A checked scene, a scene file, or a shipped example's name.
    vary : mapping or list of str
        KEY -> SPEC, where KEY is a scene key (an element counted from 1, e.g.
        ``"initial.u[2]"``) and SPEC a list of values, ``"linspace(a,b,n)"``,
        ``"logspace(a,b,n)"``, or with `random` ``"uniform(a,b)"``, ``"normal(mu,sigma)"``,
        ``"lognormal(mu,sigma)"``; or ``--vary`` strings ``"KEY=SPEC"``. Several keys make a
        full grid.
    random : int, default 0
        Draw this many cases from the distributions instead of the grid.
    seed : int, default 0
        Seed of the random draws: a whole number >= 0.
    workers : int, optional
        Processes of the local pool (default: every usable core; 1 runs in this process), or
        of the LocalCluster with ``scheduler="local"``. At most one per case and one per
        usable core are started (`worker_limit`); more asked for is an `ImpactgenWarning`.
    scheduler : str, optional
        Run on a Dask distributed cluster: its scheduler's address ("tcp://HOST:PORT"), or
        "local" to start a LocalCluster here.
    out : str or Path, optional
        Folder for the result: sweep.parquet (scene and specification in its metadata) and
        the parts written as chunks finish; the same call resumes an interrupted sweep.
    progress : callable, optional
        Called with the number of cases each time some finish.
    trajectories : int or iterable of int, default 0
        Keep the samples of this many evenly chosen cases (or of these case numbers) in
        ``out/_trajectories/case-N.parquet``, for figures of T(t) per case.

    Returns
    -------
    pandas.DataFrame
        One row per case, in case order: ``case``, the varied keys, every scalar summary
        field (``delta_r``, ``u_final[1]``, ``energy.W_normal``, ...), ``status``
        ("ok", "no-impact", "failed" or "invalid"), ``message``, ``warnings``, ``wall_s``.

    Raises
    ------
    SceneError
        A bad specification (unknown key, index out of range, malformed range, count 0) or
        argument (a negative or fractional seed, workers < 1, a `progress` that cannot be
        called, an `out` that is not a path, `trajectories` that are not case numbers),
        named, before any case runs.
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    spec = SweepSpec.from_vary(vary, random=random, seed=seed)
    check_arguments(workers=workers, out=out, progress=progress, scheduler=scheduler)
    return run_sweep(scene, spec, workers=workers, out=Path(out) if out is not None else None,
                     progress=progress, scheduler=scheduler, trajectories=trajectories)


__all__ = ["SweepSpec", "run_batch", "run_sweep", "sweep"]
