"""The plain-C Dormand-Prince pair (native/dopri5.c) on textbook problems with known answers,
built alone (no model, no SUNDIALS) with tests/c/dopri5_driver.c: fifth-order convergence on
y'' = -y and on Kepler's problem, the continuous extension's order between steps, a root
located to its stated tolerance (a ball dropped from 1 m reaches the floor at sqrt(2 h / g)),
and the rule for the state after a root that dopri5.h documents."""
from __future__ import annotations

import math
import shutil
import subprocess

import pytest

from impactgen.build import COMPILE_ARGS
from conftest import ROOT

CC = shutil.which("cc") or shutil.which("gcc")
NATIVE = ROOT / "src" / "impactgen" / "native"
ORDER = 5  # the pair's order: halving a fixed step divides the global error by 2^5
DENSE_ORDER = 4  # the continuous extension's: its error inside a step is O(h^5)
ORDER_SLACK = 0.5  # observed orders within this of the theory (the error's higher terms)
IG_DOPRI5_ROOT, IG_DOPRI5_NOT_STARTED = 1, -3


@pytest.fixture(scope="module")
def printed(tmp_path_factory) -> dict[str, float]:
    if CC is None:
        pytest.skip("no C compiler")
    out = tmp_path_factory.mktemp("dopri5") / "driver"
    build = subprocess.run([CC, "-std=c99", *COMPILE_ARGS, "-Wall", "-Wextra", "-Werror", f"-I{NATIVE}",
                            str(ROOT / "tests" / "c" / "dopri5_driver.c"), str(NATIVE / "dopri5.c"), "-lm",
                            "-o", str(out)], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(out)], capture_output=True, text=True, timeout=60, check=True)
    return {name: float(value) for name, value in (line.split() for line in run.stdout.splitlines())}


def observed_orders(printed: dict[str, float], prefix: str) -> list[float]:
    """log2 of the error ratios of successive halvings of the step (the names' order)."""
    errors = [v for k, v in printed.items() if k.startswith(prefix)]
    return [math.log2(a / b) for a, b in zip(errors, errors[1:])]


def test_fifth_order_on_the_harmonic_oscillator(printed):
    orders = observed_orders(printed, "harmonic_fixed_")
    assert len(orders) == 3
    assert all(abs(p - ORDER) < ORDER_SLACK for p in orders), orders


def test_fifth_order_on_keplers_problem(printed):
    orders = observed_orders(printed, "kepler_fixed_")
    assert len(orders) == 3
    assert all(abs(p - ORDER) < ORDER_SLACK for p in orders), orders


def test_step_size_control_meets_tighter_tolerances_at_fifth_order_cost(printed):
    """Under the step-size control the error falls with rtol, and the steps grow as the
    fifth root of the accuracy asked for."""
    rtols = (6, 8, 10, 12)
    errors = [printed[f"kepler_rtol_1e-{e}"] for e in rtols]
    steps = [printed[f"kepler_steps_1e-{e}"] for e in rtols]
    assert all(a > b for a, b in zip(errors, errors[1:]))
    slope = math.log(errors[1] / errors[-1]) / math.log(steps[-1] / steps[1])
    assert abs(slope - ORDER) < 1.0, slope


def test_continuous_extension_is_fourth_order_inside_a_step(printed):
    orders = observed_orders(printed, "dense_mid_")
    assert len(orders) == 3
    assert all(abs(p - (DENSE_ORDER + 1)) < ORDER_SLACK for p in orders), orders
    # the Taylor rows (dense output of the engine) are the same polynomial
    assert printed["taylor_vs_interpolate"] < 1e-14


def test_dropped_ball_reaches_the_floor_at_sqrt_2h_over_g_within_the_root_tolerance(printed):
    assert printed["ball_flag"] == IG_DOPRI5_ROOT and printed["ball_root_found"] == 1
    exact = math.sqrt(2 * 1.0 / 9.81)
    assert printed["ball_t_exact"] == pytest.approx(exact, rel=1e-15)
    # the step ends just past the root: at most the stated tolerance beyond it, never before
    ulp = math.ulp(exact)
    assert -2 * ulp <= printed["ball_t"] - exact <= printed["ball_tolerance"] + 2 * ulp
    assert printed["ball_height"] <= 0.0
    assert printed["ball_speed"] == pytest.approx(-math.sqrt(2 * 9.81 * 1.0), rel=1e-12)


def test_state_after_a_root_follows_the_documented_rule(printed):
    """dopri5.h: after a root no step is taken until a start; the continuous extension still
    holds up to the root (r->y is its value there); a start at the root goes on."""
    assert printed["ball_after_root_step"] == IG_DOPRI5_NOT_STARTED
    assert printed["ball_interpolate_at_root"] == 0.0
    assert printed["ball_second_flag"] == IG_DOPRI5_ROOT
    assert printed["ball_second_t"] == pytest.approx(printed["ball_second_exact"], abs=1e-12)
