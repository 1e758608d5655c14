"""The generator: Kane's equations, pruning, and C that compiles cleanly and stands alone."""
from __future__ import annotations

import re
import shutil
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sympy as sm

from impactgen.codegen.emit import driver_files, generate_model
from impactgen.codegen.spec import ModelSpec
from impactgen.codegen.mechanics import derive_chain

ROOT = Path(__file__).resolve().parent.parent
CC = shutil.which("cc") or shutil.which("gcc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler")


def test_double_pendulum_equations_match_the_textbook():
    eq = derive_chain(2)
    s = eq.symbols
    q1, q2 = s.q
    L1, L2 = s.L
    m1, m2 = s.m
    M_book = sm.Matrix([[m1 * L1**2 / 3 + m2 * L1**2, m2 * L1 * L2 * sm.cos(q1 - q2) / 2],
                        [m2 * L1 * L2 * sm.cos(q1 - q2) / 2, m2 * L2**2 / 3]])
    assert sm.simplify(eq.mass_matrix - M_book) == sm.zeros(2, 2)
    # gravity and contact parts of the forcing
    f = eq.forcing.subs({s.u[0]: 0, s.u[1]: 0})
    f_book = sm.Matrix([-(m1 / 2 + m2) * s.g * L1 * sm.cos(q1) + L1 * (s.F * sm.cos(q1) - s.F_f * sm.sin(q1)),
                        -m2 * s.g * L2 * sm.cos(q2) / 2 + L2 * (s.F * sm.cos(q2) - s.F_f * sm.sin(q2))])
    assert sm.simplify(f - f_book) == sm.zeros(2, 1)


def test_mass_matrix_is_symmetric_positive_definite():
    eq = derive_chain(4)
    s = eq.symbols
    values = {**{q: v for q, v in zip(s.q, [0.3, -1.0, 2.0, 0.1])},
              **{L: v for L, v in zip(s.L, [1.0, 0.5, 2.0, 0.7])},
              **{m: v for m, v in zip(s.m, [1.0, 3.0, 0.2, 1.5])}}
    M = np.array(eq.mass_matrix.subs(values).evalf(), dtype=float)
    assert np.allclose(M, M.T)
    assert np.all(np.linalg.eigvalsh(M) > 0)


def test_generated_code_names_come_from_the_equations():
    gen = generate_model(ModelSpec(2))
    for name in ("q1", "u2", "L1", "m2", "sin_q1", "delta", "E_star", "delta_r", "R_res", "F_f", "H_over_S_y"):
        assert name in gen.source
    assert "static" in gen.source and "extern" not in gen.source.replace('extern "C"', "")


def c_code_only(text: str) -> str:
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def test_pruned_scene_generates_no_friction_and_no_plastic_code():
    full = c_code_only(generate_model(ModelSpec(2, "three-phase", "regularized")).source)
    pruned = generate_model(ModelSpec(2, "hertz", "none"))
    code = c_code_only(pruned.source + pruned.header)
    for absent in ("F_f", "mu", "eps", "MODEL_PHASE_ELASTOPLASTIC", "R_res", "delta_c", "P_c", "H_over_S_y",
                   "delta_r"):
        assert not re.search(rf"\b{absent}\b", code), absent
        assert re.search(rf"\b{absent}\b", full), absent
    assert "mu" not in pruned.param_names and "R_res" not in pruned.param_names
    assert pruned.state_names == ("q1", "q2", "u1", "u2", "W_normal", "P_normal")


@needs_cc
@pytest.mark.parametrize("spec", [ModelSpec(1, "hertz", "none"), ModelSpec(2), ModelSpec(6),
                                  ModelSpec(3, "three-phase", "none"), ModelSpec(2, "hertz", "regularized"),
                                  ModelSpec(3, "three-phase", "regularized", True, joints=(1, 2)),
                                  ModelSpec(3, "hertz", "none", True, joints=(2,)),
                                  ModelSpec(3, "three-phase", "coulomb", True, True, (1, 2)),
                                  ModelSpec(2, "three-phase", "none", True, True),
                                  ModelSpec(1, "three-phase", "regularized", True, joints=(0,), free=True),
                                  ModelSpec(3, "three-phase", "coulomb", True, True, (0, 1, 2), free=True, inclined=True)],
                         ids=lambda s: s.slug)
def test_model_c_compiles_standalone_without_warnings(tmp_path, spec):
    gen = generate_model(spec)
    (tmp_path / "model.h").write_text(gen.header)
    (tmp_path / "model.c").write_text(gen.source)
    for optimization in ("-O0", "-O3"):  # -O3 inlines, and so sees more (maybe-uninitialized)
        res = subprocess.run([CC, "-std=c99", "-pedantic", optimization, "-Wall", "-Wextra", "-Werror", "-Wshadow",
                              "-Wconversion", "-c", "model.c", "-o", "model.o"],
                             cwd=tmp_path, capture_output=True, text=True)
        assert res.returncode == 0, res.stderr


@needs_cc
def test_model_embeds_in_a_plain_c_program(tmp_path):
    """No Python, no SUNDIALS: a C program calls the RHS and gets what the cffi build gets."""
    from impactgen.build import compile_model

    gen = generate_model(ModelSpec(2))
    (tmp_path / "model.h").write_text(gen.header)
    (tmp_path / "model.c").write_text(gen.source)
    (tmp_path / "main.c").write_text(textwrap.dedent("""
        #include <stdio.h>
        #include "model.h"
        int main(void) {
            model_params p = {0};
            model_point_contact *tip = &p.point[MODEL_TIP_POINT];
            p.L1 = 1.0; p.L2 = 1.0; p.m1 = 1.0; p.m2 = 1.0; p.g = 9.81; tip->y_s = -1.7735;
            p.E_star = 1.15e11; tip->R = 0.005; p.mu = 0.2; p.eps = 1e-6;
            tip->phase = MODEL_PHASE_ELASTIC;
            const double y[MODEL_NSTATE] = {-1.2, -1.0, -0.1, -0.2, 0.0, 0.0, 0.0, 0.0};
            double ydot[MODEL_NSTATE];
            if (model_rhs(0.0, y, ydot, &p) != 0) return 1;
            for (int k = 0; k < MODEL_NSTATE; ++k) printf("%.17g\\n", ydot[k]);
            return 0;
        }
    """))
    res = subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "main.c", "model.c", "-lm", "-o", "demo"],
                         cwd=tmp_path, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    out = subprocess.run([str(tmp_path / "demo")], capture_output=True, text=True, check=True).stdout
    standalone = np.array([float(v) for v in out.split()])

    model = compile_model(ModelSpec(2))
    p = model.ffi.new("model_params *")
    for k, v in dict(L1=1.0, L2=1.0, m1=1.0, m2=1.0, g=9.81, E_star=1.15e11, mu=0.2, eps=1e-6).items():
        setattr(p, k, v)
    tip = p.point[model.lib.MODEL_TIP_POINT]
    tip.y_s, tip.R, tip.phase = -1.7735, 0.005, model.lib.MODEL_PHASE_ELASTIC
    y = model.ffi.new("double[]", [-1.2, -1.0, -0.1, -0.2, 0.0, 0.0, 0.0, 0.0])  # q, u, works, impulses
    ydot = model.ffi.new("double[]", 8)
    assert model.lib.model_rhs(0.0, y, ydot, p) == 0
    assert np.array_equal(standalone, np.array(list(ydot)))
    assert standalone[4] != 0.0  # the tip is ~1e-5 m into the surface: the normal force works


@pytest.mark.parametrize("folder", ["paper-double-pendulum", "chain3"])
def test_committed_generated_code_is_up_to_date(folder):
    import impactgen
    from impactgen.engines import model_spec
    from impactgen.scene import steel_chain_scene
    scene = impactgen.load_scene(ROOT / "scenes" / "paper.toml") if folder != "chain3" else steel_chain_scene(3)
    gen = generate_model(model_spec(scene))
    where = ROOT / "generated" / folder
    for name, text in driver_files(gen, scene).items():
        assert (where / name).read_text() == text, f"regenerate {where} (see generated/README.md)"


def _jacobian_and_differences(model, y: np.ndarray, p, columns: int, stretch: float = 1.0
                              ) -> tuple[np.ndarray, np.ndarray]:
    """The model's analytic Jacobian at y (of the motion, y = (q, u): the works and impulses
    are quadratures), and central differences of its right-hand side's motion rows in the
    first `columns` states (the rest left 0), their steps `stretch` times the contact's."""
    ffi, lib, N, n = model.ffi, model.lib, model.nstate, model.spec.dof  # the coordinates: angles (and x_0, y_0)
    M = lib.MODEL_NMOTION
    J = ffi.new("double[]", M * M)
    assert lib.model_jacobian(0.0, ffi.new("double[]", list(y)), J, p) == 0
    fd = np.zeros((M, M))
    for j in range(columns):
        # small steps: the penetration is only ~1e-5 m, and moves by L h per step in q
        h = stretch * (1e-9 if j < n else 1e-8) if j < 2 * n else 1e-3
        out = []
        for sign in (1, -1):
            yy = y.copy()
            yy[j] += sign * h
            f = ffi.new("double[]", N)
            assert lib.model_rhs(0.0, ffi.new("double[]", list(yy)), f, p) == 0
            out.append(np.array(list(f))[:M])
        fd[:, j] = (out[0] - out[1]) / (2 * h)
    return np.array(list(J)).reshape(M, M), fd


@pytest.mark.parametrize("spec", [ModelSpec(1, jacobian=True), ModelSpec(2, jacobian=True),
                                  ModelSpec(4, "three-phase", "none", True), ModelSpec(3, "hertz", "regularized", True)],
                         ids=lambda s: s.slug)
def test_analytic_jacobian_matches_central_differences(spec):
    from impactgen.build import compile_model
    model = compile_model(spec)
    ffi, lib = model.ffi, model.lib
    rng = np.random.default_rng(spec.links)
    n, N = spec.links, model.nstate
    p = ffi.new("model_params *")
    values = {**{f"L{i + 1}": rng.uniform(0.5, 1.5) for i in range(n)},
              **{f"m{i + 1}": rng.uniform(0.5, 2.0) for i in range(n)},
              "g": 9.81, "E_star": 1.15e11, "R": 0.005, "delta_c": 3.0e-6, "P_c": 9.0,
              "C_j": 1.6, "B": 0.175, "delta_m": 2.0e-5, "delta_r": 5.0e-6, "R_res": 0.0084,
              "mu": 0.2, "eps": 1e-3}
    values.update(inv_delta_c=1 / values["delta_c"],  # as model_derive makes them
                  theta_c=np.pi * np.sqrt(values["delta_c"] / values["R"]) * 1.9 ** (-values["B"] / 2))
    tip = p.point[lib.MODEL_TIP_POINT]
    for name in model.param_names:
        if name in values:  # the constants the laws read (not the materials they come from)
            setattr(p, name, values[name])
    for name, _ in ffi.typeof("model_point_contact").fields:  # and the tip's own
        if name in values:
            setattr(tip, name, values[name])
    for phase in model.phases:
        tip.phase = model.phases.index(phase) if phase != "restitution" else lib.MODEL_PHASE_RESTITUTION
        for _ in range(3):
            y = np.concatenate([rng.uniform(-2.5, -0.5, n), rng.uniform(-1, 1, n), np.zeros(N - 2 * n)])
            y_B = sum(values[f"L{i + 1}"] * np.sin(y[i]) for i in range(n))
            tip.y_s = y_B + 1.2e-5  # inside the contact, clear of every law's kinks
            J, fd = _jacobian_and_differences(model, y, p, 2 * n)
            scale = np.maximum(np.abs(fd).max(axis=1, keepdims=True), 1e-12)
            assert np.all(np.abs(J - fd) <= 1e-5 * scale + 1e-9), phase


def test_generated_jackson_green_law_equals_the_papers_powers(paper_scene):
    """The C law takes its fractional powers from one exponential (w^(1/180) products) and the
    contact radius as theta_c w^((1 + B)/2); it must agree with the reference engine's w ** k
    and a = (R delta (w / 1.9)^B)^(1/2) to rounding over the whole elasto-plastic range."""
    from impactgen.build import compile_model
    from impactgen.engines import model_spec
    from impactgen.model_params import fill_params
    from impactgen.reference import ReferenceModel
    model = compile_model(model_spec(paper_scene))
    params = fill_params(model, paper_scene)
    tip = model.lib.MODEL_TIP_POINT
    params.point[tip].phase = model.lib.MODEL_PHASE_ELASTOPLASTIC
    contact = ReferenceModel.from_scene(paper_scene).contact
    for w in np.geomspace(1.9, 1e4, 200):
        delta = w * contact.delta_c
        c_force, exact = model.lib.model_normal_force(tip, delta, params), contact.jackson_green(delta)
        assert c_force == pytest.approx(exact, rel=2e-14, abs=0.0), w


def _contact_law() -> dict[str, float]:
    """A contact point's law record (the paper's steel, in restitution after delta_m = 20 um)
    for the Jacobian tests."""
    law = {"E_star": 1.15e11, "R": 0.005, "delta_c": 3.0e-6, "P_c": 9.0, "C_j": 1.6, "B": 0.175,
           "delta_m": 2.0e-5, "delta_r": 5.0e-6, "R_res": 0.0084, "mu": 0.2, "eps": 1e-3}
    law.update(inv_delta_c=1 / law["delta_c"],
               theta_c=np.pi * np.sqrt(law["delta_c"] / law["R"]) * 1.9 ** (-law["B"] / 2))
    return law


@pytest.mark.parametrize("spec", [ModelSpec(3, "three-phase", "regularized", True, joints=(1, 2)),
                                  ModelSpec(3, "hertz", "none", True, joints=(2,)),
                                  ModelSpec(3, "three-phase", "regularized", True, True, joints=(1, 2))],
                         ids=lambda s: s.slug)
def test_analytic_jacobian_covers_every_contact_point(spec):
    """Every contact point's force enters the equations as J^T (F_f, F), and the analytic
    Jacobian follows each of them: the joints and the tip all in contact at once, against
    central differences of the right-hand side."""
    from impactgen.build import compile_model
    model = compile_model(spec)
    ffi, lib = model.ffi, model.lib
    rng = np.random.default_rng(7)
    n, N = spec.links, model.nstate
    p = ffi.new("model_params *")
    law = _contact_law()
    values = {**{f"L{i + 1}": rng.uniform(0.5, 1.5) for i in range(n)},
              **{f"m{i + 1}": rng.uniform(0.5, 2.0) for i in range(n)}, "g": 9.81, **law}
    for name in model.param_names:
        if name in values:
            setattr(p, name, values[name])
    restitution = lib.MODEL_PHASE_RESTITUTION
    own = [name for name, _ in ffi.typeof("model_point_contact").fields if name in law]
    for phase in (1, restitution):
        y = np.concatenate([rng.uniform(-2.5, -0.5, n), rng.uniform(-1, 1, n), np.zeros(N - 2 * n)])
        heights = np.cumsum([values[f"L{i + 1}"] * np.sin(y[i]) for i in range(n)])
        for point, number in zip(p.point, (*spec.joints, n)):  # every point inside its own contact
            point.phase, point.y_s = phase, heights[number - 1] + 1.1e-5
            for name in own:
                setattr(point, name, law[name])
        J, fd = _jacobian_and_differences(model, y, p, 2 * n)
        scale = np.maximum(np.abs(fd).max(axis=1, keepdims=True), 1e-12)
        assert np.abs(fd[n:2 * n]).max() > 1e3  # the contact forces dominate the accelerations
        assert np.all(np.abs(J - fd)[:, :2 * n] <= 1e-5 * scale + 1e-9), phase
        _assert_split_rhs(model, y, p)
    if spec.sustained:  # a point held by a constraint force (resting): the quadratures take it too
        p.point[0].phase = lib.MODEL_PHASE_SUSTAINED
        _assert_split_rhs(model, y, p)


FREE_JACOBIAN_SPECS = [ModelSpec(n, "three-phase", friction, True, joints=tuple(range(n)), free=True, inclined=inclined)
                       for n in (1, 2, 3) for inclined in (False, True) for friction in ("none", "regularized")]


@needs_cc
@pytest.mark.parametrize("spec", FREE_JACOBIAN_SPECS, ids=lambda s: s.slug)
def test_analytic_jacobian_of_a_free_chain_matches_central_differences(spec):
    """A free chain's Jacobian, over its angles and its base point's (x_0, y_0) and their
    rates, on a level or an inclined surface: every point (the base point 0, the joints, the
    tip) inside its own contact in each phase of the law, against central differences of the
    right-hand side at random states."""
    from impactgen.build import compile_model
    model = compile_model(spec)
    ffi, lib = model.ffi, model.lib
    rng = np.random.default_rng(11 * spec.links + spec.inclined)
    n, dof, N = spec.links, spec.dof, model.nstate
    assert lib.MODEL_NDOF == dof == n + 2 and lib.MODEL_NMOTION == 2 * dof
    p = ffi.new("model_params *")
    law = _contact_law()
    values = {**{f"L{i + 1}": rng.uniform(0.5, 1.5) for i in range(n)},
              **{f"m{i + 1}": rng.uniform(0.5, 2.0) for i in range(n)}, "g": 9.81, "angle_deg": 20.0, **law}
    assert ("angle_deg" in model.param_names) == spec.inclined
    for name in model.param_names:
        if name in values:
            setattr(p, name, values[name])
    own = [name for name, _ in ffi.typeof("model_point_contact").fields if name in law]
    for phase in model.phases:
        code = model.phases.index(phase) if phase != "restitution" else lib.MODEL_PHASE_RESTITUTION
        for _ in range(2):
            y = np.concatenate([rng.uniform(-2.5, -0.5, n), rng.uniform(-1, 1, 2),
                                rng.uniform(-1, 1, dof), np.zeros(N - 2 * dof)])
            # the heights of the base point (0), the joints and the tip (n)
            heights = y[n + 1] + np.cumsum([0.0] + [values[f"L{i + 1}"] * np.sin(y[i]) for i in range(n)])
            for point, number in zip(p.point, (*spec.joints, n)):  # every point inside its own contact
                point.phase, point.y_s = code, heights[number] + 1.1e-5
                for name in own:
                    setattr(point, name, law[name])
            # in free flight nothing is as stiff as a contact: steps of 1e-5 keep the rounding of
            # gravity's rows (a free body's own angles barely move them) below the tolerance
            J, fd = _jacobian_and_differences(model, y, p, 2 * dof, 1e4 if phase == "free" else 1.0)
            scale = np.maximum(np.abs(fd).max(axis=1, keepdims=True), 1e-12)
            if phase != "free":
                assert np.abs(fd[dof:]).max() > 1e3  # the contact forces dominate the accelerations
                assert np.abs(J[dof:, n:dof]).max() > 1e3  # and x_0, y_0 move them (y_0 at least)
            assert np.all(np.abs(J - fd) <= 1e-5 * scale + 1e-9), phase
            if phase != "free":
                _assert_split_rhs(model, y, p)


def _assert_split_rhs(model, y: np.ndarray, p) -> None:
    """The right-hand side in two parts, the motion's and the quadratures' (the works and
    impulses, which BDF integrates outside its Newton iteration), is the whole one."""
    ffi, lib, N, n = model.ffi, model.lib, model.nstate, model.spec.dof
    y_c = ffi.new("double[]", list(y))
    whole, motion = ffi.new("double[]", N), ffi.new("double[]", 2 * n)
    quadratures = ffi.new("double[]", N - 2 * n)
    assert lib.model_rhs(0.0, y_c, whole, p) == 0
    assert lib.model_motion_rhs(0.0, y_c, motion, p) == 0
    assert lib.model_quadratures(0.0, y_c, quadratures, p) == 0
    assert list(motion) + list(quadratures) == list(whole)
    assert np.abs(list(quadratures)).max() > 1.0  # the points' forces are in them


def test_models_of_two_prefixes_link_into_one_program(tmp_path):
    """--prefix gives every file and name of the model and of its phase machine the prefix, so
    that two models (here with and without joint contact and exact Coulomb friction) compile
    warning-free and link into one C program, each starting its own machine."""
    from impactgen.codegen.emit import machine_files
    specs = {"pend": ModelSpec(2), "fold": ModelSpec(4, "three-phase", "coulomb", True, True, (2, 3))}
    for prefix, spec in specs.items():
        for name, text in {**generate_model(spec, prefix).files(), **machine_files(prefix)}.items():
            (tmp_path / name).write_text(text)
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "pend_machine.h"\n#include "fold_machine.h"\n'
        "int main(void)\n{\n"
        "    pend_params p = {0};\n    fold_params f = {0};\n    pend_machine pm;\n    fold_machine fm;\n"
        "    double y[PEND_NSTATE] = {0}, z[FOLD_NSTATE] = {0};\n"
        "    p.L1 = p.L2 = p.m1 = p.m2 = 1.0;\n    f.L1 = f.L2 = f.L3 = f.L4 = f.m1 = f.m2 = f.m3 = f.m4 = 1.0;\n"
        "    p.surface_height = f.surface_height = -10.0;\n"
        "    printf(\"%d %d\\n\", pend_machine_start(&pm, &p, 0.0, y, 1), fold_machine_start(&fm, &f, 0.0, z, 1));\n"
        "    return 0;\n}\n")
    sources = sorted(str(p) for p in tmp_path.glob("*.c"))
    built = subprocess.run(["cc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-I", str(tmp_path), *sources,
                            "-lm", "-o", str(tmp_path / "both")], capture_output=True, text=True)
    assert built.returncode == 0, built.stderr[-2000:]
    ran = subprocess.run([str(tmp_path / "both")], capture_output=True, text=True)
    assert ran.returncode == 0 and ran.stdout.split() == ["0", "0"]  # both free, far above the surface
