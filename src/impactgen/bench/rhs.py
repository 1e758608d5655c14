"""Nanoseconds per right-hand-side call: generated C from C (in every contact phase), the
same through cffi, sympy lambdify (numpy), and the pure-Python reference (the last three in
the elasto-plastic phase, the costliest force law)."""
from __future__ import annotations

import dataclasses
import shutil
import subprocess
import tempfile
import textwrap
import timeit
from pathlib import Path

import numpy as np

from ..build import COMPILE_ARGS, compile_model
from ..codegen.emit import generate_model
from ..codegen.spec import ModelSpec
from ..model_params import params_at_start
from ..reference import ReferenceModel
from ..scene import steel_chain_scene

PHASE = "elastoplastic"  # the costliest force law


def _state(scene, delta: float = 1.5e-5) -> tuple[np.ndarray, float]:
    """The initial state of the steel chain, with the surface delta above the tip."""
    integrals = 4 if scene.contact.friction > 0 else 2  # the works and the impulses
    y = np.concatenate([scene.q0, scene.u0, np.zeros(integrals)])
    y_B = sum(L * np.sin(q) for L, q in zip(scene.chain.length, scene.q0))
    return y, y_B + delta


def c_from_c(spec: ModelSpec, params_source: str, y: np.ndarray, repeats: int = 7) -> float:
    """ns per model_rhs call from a C loop: the fastest of `repeats` loops of about 50 ms each
    (as timeit advises for micro-benchmarks: noise on a shared machine only adds time)."""
    calls = max(20_000, 2_000_000 // spec.links ** 2)
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return float("nan")
    gen = generate_model(spec)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "model.h").write_text(gen.header)
        (d / "model.c").write_text(gen.source)
        state = ", ".join(repr(float(v)) for v in y)
        (d / "bench.c").write_text(textwrap.dedent(f"""
            #define _POSIX_C_SOURCE 199309L
            #include <stdio.h>
            #include <time.h>
            #include "model.h"
            int main(void) {{
                model_params p = {{0}};
                {params_source}
                double y[MODEL_NSTATE] = {{{state}}};
                double ydot[MODEL_NSTATE];
                double sink = 0.0, best = 1e300;
                for (int r = 0; r < {repeats}; ++r) {{
                    struct timespec a, b;
                    clock_gettime(CLOCK_MONOTONIC, &a);
                    for (long k = 0; k < {calls}; ++k) {{
                        y[{spec.links}] += 1e-12;  /* a new state every call */
                        model_rhs(0.0, y, ydot, &p);
                        sink += ydot[{spec.links}];
                    }}
                    clock_gettime(CLOCK_MONOTONIC, &b);
                    const double ns = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / {calls}.0;
                    if (ns < best) best = ns;
                }}
                printf("%.3f %g\\n", best, sink);
                return 0;
            }}
        """))
        subprocess.run([cc, "-std=c99", *COMPILE_ARGS, "bench.c", "model.c", "-lm", "-o", "bench"], cwd=d, check=True)
        out = subprocess.run([str(d / "bench")], capture_output=True, text=True, check=True).stdout
    return float(out.split()[0])


def rhs_benchmark(links: tuple[int, ...]) -> list[dict]:
    import sympy as sm
    from ..codegen.mechanics import derive_chain
    rows = []
    for n in links:
        scene = steel_chain_scene(n)
        spec = ModelSpec(n, "three-phase", "regularized", jacobian=False)
        model = compile_model(spec)
        y, y_s = _state(scene)
        scene = dataclasses.replace(scene, surface_height=y_s)  # in contact on purpose: no start checks
        params = params_at_start(model, scene)
        tip = params.point[model.lib.MODEL_TIP_POINT]
        tip.delta_m, tip.delta_r, tip.R_res = 2.0e-5, 5.0e-6, 0.0084  # a restitution state
        tip.phase = 2
        point_fields = [name for name, _ in model.ffi.typeof("model_point_contact").fields if name != "phase"]
        params_source = " ".join([f"p.{name} = {getattr(params, name)!r};" for name in model.param_names]
                                 + [f"p.point[MODEL_TIP_POINT].{name} = {getattr(tip, name)!r};" for name in point_fields])
        c_ns = {f"c_{law}_ns": c_from_c(spec, params_source + f" p.point[MODEL_TIP_POINT].phase = {code};", y)
                for code, law in enumerate(("free", "elastic", "elastoplastic", "restitution"))}
        ffi, lib = model.ffi, model.lib
        y_c, ydot_c = ffi.new("double[]", list(y)), ffi.new("double[]", len(y))
        number = 20000
        cffi_ns = min(timeit.repeat(lambda: lib.model_rhs(0.0, y_c, ydot_c, params), number=number, repeat=5)) / number * 1e9

        ref = ReferenceModel.from_scene(scene)
        ref_ns = min(timeit.repeat(lambda: ref.rhs(0.0, y, PHASE), number=2000, repeat=3)) / 2000 * 1e9

        eq = derive_chain(n)
        s = eq.symbols
        args = list(s.q) + list(s.u) + list(s.L) + list(s.m) + [s.g, s.F, s.F_f]
        M_f = sm.lambdify(args, eq.mass_matrix, "numpy")
        f_f = sm.lambdify(args, eq.forcing, "numpy")
        consts = list(scene.chain.length) + list(scene.chain.mass) + [scene.chain.gravity]

        def lambdified() -> np.ndarray:
            q, u = y[:n], y[n:2 * n]
            _, y_B, v_Bx, v_By = ref.chain.point(q, u, n)
            F = ref.contact.normal_force(PHASE, ref.contact.y_s - y_B)
            F_f = ref.contact.friction(F, v_Bx)
            a = list(q) + list(u) + consts + [F, F_f]
            du = np.linalg.solve(M_f(*a), np.asarray(f_f(*a), float).ravel())
            return np.concatenate([u, du, [F * v_By, F_f * v_Bx]])

        lam_ns = min(timeit.repeat(lambdified, number=2000, repeat=3)) / 2000 * 1e9
        rows.append({"links": n, **c_ns, "cffi_ns": cffi_ns, "lambdify_ns": lam_ns, "reference_ns": ref_ns})
    return rows
