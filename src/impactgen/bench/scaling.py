"""Where the cost goes as n grows: time to derive (Kane's method, or its checked closed form
beyond mechanics.KANE_MAX_LINKS links), emit (prune, CSE, print, templates) and compile (cffi +
CVODE glue), the size of the generated C, and the time of one impact; with the log-log slopes."""
from __future__ import annotations

import math
import os
import statistics
import tempfile
import time

from .. import build
from ..codegen import emit, expressions, mechanics
from ..codegen.spec import ModelSpec


def _clear_caches() -> None:
    for fn in (mechanics.kane_system, mechanics.derive_chain, mechanics.closed_form_chain, expressions.assemble_model,
               emit.generate_model):
        fn.cache_clear()
    build._loaded.clear()


IMPACT_RTOL = 1e-8  # the per-impact time is measured at the work-precision benchmark's headline rtol
IMPACT_RUNS = 7  # warm runs; the median is reported


def impact_ms(n: int) -> float:
    """Median wall time of the n-link steel chain's impact (to separation, summary read), warm."""
    import impactgen
    from ..scene import steel_chain_scene
    scene = steel_chain_scene(n).replace({"solver.rtol": IMPACT_RTOL, "solver.jacobian": "difference"})
    impactgen.simulate(scene).summary
    times = []
    for _ in range(IMPACT_RUNS):
        started = time.perf_counter()
        impactgen.simulate(scene).summary
        times.append(time.perf_counter() - started)
    return statistics.median(times) * 1e3


def loglog_slope(rows: list[dict], key: str) -> float:
    """Least-squares slope of log(key) against log(links): the power of n the cost grows with."""
    pts = [(math.log(r["links"]), math.log(r[key])) for r in rows if r.get(key, 0) > 0]
    if len(pts) < 2:
        return math.nan
    mx = sum(x for x, _ in pts) / len(pts)
    my = sum(y for _, y in pts) / len(pts)
    return sum((x - mx) * (y - my) for x, y in pts) / sum((x - mx) ** 2 for x, _ in pts)


def scaling(links: tuple[int, ...], jacobian: bool = False) -> list[dict]:
    rows = []
    saved = os.environ.get("IMPACTGEN_CACHE_DIR")
    with tempfile.TemporaryDirectory() as cache:
        os.environ["IMPACTGEN_CACHE_DIR"] = cache
        try:
            for n in links:
                _clear_caches()
                spec = ModelSpec(n, "three-phase", "regularized", jacobian)
                t0 = time.perf_counter()
                mechanics.chain_equations(n)
                t1 = time.perf_counter()
                gen = emit.generate_model(spec)
                t2 = time.perf_counter()
                build.compile_model(spec)
                t3 = time.perf_counter()
                rows.append({"links": n, "jacobian": jacobian, "derive_s": t1 - t0, "emit_s": t2 - t1,
                             "compile_s": t3 - t2, "total_s": t3 - t0,
                             "c_bytes": len(gen.source.encode()), "c_lines": gen.source.count("\n"),
                             "impact_ms": impact_ms(n)})
        finally:
            if saved is None:
                os.environ.pop("IMPACTGEN_CACHE_DIR", None)
            else:
                os.environ["IMPACTGEN_CACHE_DIR"] = saved
    return rows
