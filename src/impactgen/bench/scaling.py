"""Where the cost goes as n grows: time to derive (Kane's method), emit (prune, CSE, print,
templates) and compile (cffi + CVODE glue), and the size of the generated C."""
from __future__ import annotations

import os
import tempfile
import time

from .. import build
from ..codegen import emit, expressions, mechanics
from ..codegen.expressions import ModelSpec


def _clear_caches() -> None:
    for fn in (mechanics.kane_system, mechanics.derive_chain, expressions.assemble_model,
               emit.generate_model):
        fn.cache_clear()
    build._loaded.clear()


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
                mechanics.derive_chain(n)
                t1 = time.perf_counter()
                gen = emit.generate_model(spec)
                t2 = time.perf_counter()
                build.compile_model(spec)
                t3 = time.perf_counter()
                rows.append({"links": n, "jacobian": jacobian, "derive_s": t1 - t0, "emit_s": t2 - t1,
                             "compile_s": t3 - t2, "total_s": t3 - t0,
                             "c_bytes": len(gen.source.encode()), "c_lines": gen.source.count("\n")})
        finally:
            if saved is None:
                os.environ.pop("IMPACTGEN_CACHE_DIR", None)
            else:
                os.environ["IMPACTGEN_CACHE_DIR"] = saved
    return rows
