"""What a hostile user tried (issue 37): each input must end in a correct result or in one
clear line of the project's error family, never in a silent wrong answer or a foreign
exception. docs/safety.md lists the classes and what each gets."""
from __future__ import annotations

import numpy as np
import pytest

import impactgen
from impactgen.errors import ImpactgenError, SceneError


# -- 1. silent wrong answers: dense output and t_eval -----------------------------------------

@pytest.fixture(scope="module")
def bouncing_dense():
    """The issue's run: its method "auto" hands segments from the explicit pair to BDF."""
    scene = impactgen.load_scene("bouncing", overrides={"solver.t_end": 5.0})
    return impactgen.simulate(scene, rtol=1e-8, atol=1e-10, dense_output=True)


def test_dense_output_is_finite_where_the_pair_hands_over_to_bdf(bouncing_dense):
    r = bouncing_dense
    t = 2.530157208020547  # the end of the pair's last step before BDF took the segment
    k = int(np.argmin(abs(r.t - t)))
    assert r.t[k] == t
    np.testing.assert_allclose(r.sol(t), r.y[:, k], rtol=1e-9, atol=1e-12)
    times = np.linspace(0.0, r.t[-1], 20001)
    assert np.isfinite(r.sol(times)).all()


def test_dense_output_reproduces_every_step(bouncing_dense):
    """Each step's polynomial ends at that step's sample: no step is left without one."""
    r = bouncing_dense
    np.testing.assert_allclose(r.sol(r.t[1:]), r.y[:, 1:], rtol=1e-7, atol=1e-9)


def test_t_eval_around_a_handed_over_step_agrees_with_dense_output(bouncing_dense):
    r0 = bouncing_dense
    k = int(np.argmin(abs(r0.t - 2.530157208020547)))
    ends = r0.t[k - 3:k + 4]
    times = np.sort(np.concatenate([ends, 0.5 * (ends[1:] + ends[:-1])]))
    r = impactgen.simulate(r0.scene, rtol=1e-8, atol=1e-10, t_eval=times)
    assert np.isfinite(r.y).all()
    np.testing.assert_allclose(r.y, r0.sol(times), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_dense_output_outside_the_run_is_refused(paper_scene, engine):
    r = impactgen.simulate(paper_scene, engine=engine, dense_output=True)
    t_final = float(r.t[-1])
    assert np.isfinite(r.sol(0.0)).all() and np.isfinite(r.sol(t_final)).all()
    for bad in (-1.0, t_final + 1.0, [0.0, t_final * 2], float("nan")):
        with pytest.raises(SceneError, match=r"outside the run \[0, "):
            r.sol(bad)


@pytest.mark.parametrize("engine", ["c", "reference"])
def test_t_eval_after_the_end_is_dropped_with_a_warning(paper_scene, engine):
    r = impactgen.simulate(paper_scene, engine=engine, t_eval=[0.0, 1e-4, 1.0])
    assert len(r.t) == 2
    t_final = float(r.trajectory.t[-1])
    notes = [w for w in r.warnings if "t_eval" in w]
    assert len(notes) == 1
    assert "1 of the 3 t_eval times" in notes[0] and f"{t_final:.6g}" in notes[0]
    full = impactgen.simulate(paper_scene, engine=engine, t_eval=[0.0, 1e-4])
    assert not [w for w in full.warnings if "t_eval" in w]
