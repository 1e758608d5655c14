"""`impactgen animate`: a GIF of the chain moving, frames spread over a warped time."""
from __future__ import annotations

import sys

import numpy as np
import pytest

pytest.importorskip("matplotlib")
from PIL import Image, ImageChops  # noqa: E402  (a dependency of matplotlib)

from conftest import PAPER  # noqa: E402

FRAMES = 8  # fps 8 for one second: a short GIF
IMPACT_PHASES = ("elastic", "elastoplastic", "restitution", "reloading")


@pytest.fixture(scope="module")
def bouncing_paper():
    """The paper's chain for 0.15 s: impacts with flights between them, with dense output."""
    import impactgen
    return impactgen.simulate(impactgen.load_scene(PAPER, {"solver.t_end": 0.15}), dense_output=True)


def _in_impact(result, times: np.ndarray) -> np.ndarray:
    return np.array([any(s.phase in IMPACT_PHASES and s.t0 <= t <= s.t1 for s in result.phases) for t in times])


def _frames(path) -> list[Image.Image]:
    with Image.open(path) as gif:
        assert gif.format == "GIF"
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            frames.append(gif.convert("RGB"))
        return frames


def test_a_gif_of_the_chain_moving(bouncing_paper, tmp_path):
    from impactgen.animate import animate
    path = animate(bouncing_paper, tmp_path / "paper.gif", fps=FRAMES, seconds=1.0, dpi=40)
    assert path == tmp_path / "paper.gif"
    frames = _frames(path)
    assert len(frames) == FRAMES
    # the left half holds the chain alone (the clock and the tip's height are on the right)
    halves = [f.crop((0, 0, f.width // 2, f.height)) for f in frames]
    moved = [ImageChops.difference(a, b).getbbox() is not None for a, b in zip(halves, halves[1:])]
    assert sum(moved) >= FRAMES // 2


def test_the_warped_time_shows_the_impacts(bouncing_paper):
    from impactgen.animate import IMPACT_SHARE, frame_times
    assert len(bouncing_paper.impacts) >= 2
    frames = 40
    times = frame_times(bouncing_paper, frames)
    assert times[0] == bouncing_paper.t[0] and times[-1] == pytest.approx(bouncing_paper.t[-1])
    assert np.all(np.diff(times) >= 0)
    inside = _in_impact(bouncing_paper, times).sum()
    # evenly spread frames would put none in a 0.5 ms impact out of 0.15 s; the warp gives the impacts their share
    assert inside >= 0.8 * IMPACT_SHARE * frames
    assert inside <= frames - 0.8 * (1 - IMPACT_SHARE) * frames  # and the flights are shown too


def test_a_run_that_is_one_impact_gives_it_every_frame(paper_result):
    from impactgen.animate import frame_times
    times = frame_times(paper_result, 12)
    assert _in_impact(paper_result, times).all()
    assert len(np.unique(times)) == 12


def test_the_tip_has_the_run_s_phase_and_the_joints_are_free(bouncing_paper):
    from impactgen.animate import frame_times, point_phases
    times = frame_times(bouncing_paper, 30)
    phases = point_phases(bouncing_paper, times)
    assert phases.shape == (bouncing_paper.n + 1, 30)  # the pivot, the joint, the tip
    assert set(phases[0]) == {"free"} and set(phases[1]) == {"free"}
    assert _in_impact(bouncing_paper, times).tolist() == [p in IMPACT_PHASES for p in phases[-1]]


def test_positions_without_dense_output_follow_the_samples(bouncing_paper, paper_result):
    """Linear interpolation between the samples, when the run kept no dense output, lands
    near the integrator's own interpolant."""
    from impactgen.animate import angles_at, frame_times
    assert not paper_result.sol  # no dense output kept (calling it says how to ask for it)
    times = frame_times(paper_result, 15)
    dense = bouncing_paper.sol(times)[: paper_result.n]  # the same start, before the first separation
    assert np.allclose(angles_at(paper_result, times), dense, atol=1e-7)


@pytest.mark.parametrize("name, missing, words", [
    ("chain.avi", None, "give a .gif or .mp4 file"),
    ("chain", None, "give a .gif or .mp4 file"),
    ("chain.mp4", "ffmpeg", "install ffmpeg"),
])
def test_a_file_it_cannot_write_is_one_clear_error(bouncing_paper, tmp_path, monkeypatch, name, missing, words):
    from impactgen import animate as module
    from impactgen.errors import SceneError
    monkeypatch.setattr(module, "_writer_available", lambda writer: writer != missing)
    with pytest.raises(SceneError, match=words) as caught:
        module.animate(bouncing_paper, tmp_path / name, fps=2, seconds=1.0)
    assert "\n" not in str(caught.value)
    assert not (tmp_path / name).exists()


def test_without_matplotlib_one_clear_error(bouncing_paper, tmp_path, monkeypatch):
    from impactgen.animate import animate
    from impactgen.errors import ImpactgenError
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImpactgenError, match=r"pip install 'impactgen\[plot\]'"):
        animate(bouncing_paper, tmp_path / "chain.gif")


def test_the_command_writes_the_gif(tmp_path, monkeypatch, capsys):
    from impactgen import cli
    monkeypatch.chdir(tmp_path)
    assert cli.main(["animate", str(PAPER), "--fps", "3", "--seconds", "1", "--set", "solver.t_end=0.1"]) == 0
    written = tmp_path / "paper-double-pendulum.gif"  # the scene's name, in the current folder
    assert capsys.readouterr().out.strip() == str(written.relative_to(tmp_path))
    assert len(_frames(written)) == 3


def test_the_command_refuses_a_bad_suffix_before_the_run(tmp_path, capsys):
    from impactgen import cli
    assert cli.main(["animate", str(PAPER), "--out", str(tmp_path / "chain.webm")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactgen: error: --out:") and "\n" not in err


def test_the_default_file_is_named_after_the_scene():
    from impactgen.animate import default_path
    assert str(default_path("paper-double-pendulum")) == "paper-double-pendulum.gif"
    assert str(default_path("chain 3/free")) == "chain_3_free.gif"  # a plain file in the current folder
    assert str(default_path("..")) == "animation.gif"


def test_a_joint_on_the_surface_is_drawn_in_its_contact_phase(tmp_path):
    """A joint that swings onto the surface has its own contact: in the frames of its impacts it
    is drawn in the colour of its phase, and no point is drawn in the warning colour."""
    import impactgen
    from impactgen.animate import animate, frame_times, point_phases
    scene = impactgen.load_scene(PAPER, {"initial.q_deg": [-10, -45], "initial.u": [-3, 0], "solver.t_end": 0.5})
    result = impactgen.simulate(scene, dense_output=True)
    joint_impacts = [i for i in result.impacts if i.point == "joint 1"]
    assert joint_impacts
    first = joint_impacts[0]
    middle = np.array([(first.t_start + first.t_end) / 2])
    assert point_phases(result, middle)[1, 0] in ("elastic", "elastoplastic", "restitution", "reloading")  # joint 1
    frames = 12
    assert frame_times(result, frames).size == frames
    path = animate(result, tmp_path / "onto.gif", fps=frames, seconds=1.0, dpi=40)
    for frame in _frames(path):
        left = np.asarray(frame.crop((0, 0, frame.width // 2, frame.height))).astype(int)
        red = (left[..., 0] > 120) & (left[..., 0] > 2.5 * left[..., 1]) & (left[..., 0] > 2.5 * left[..., 2])
        assert not red.any()


def test_a_free_rod_moves_with_its_base_point(tmp_path):
    """rod-drop: the drawing follows the base point (the rod falls, its lower end strikes), and
    the base point's row of phases has its impacts."""
    import impactgen
    from impactgen.animate import animate, base_at, frame_times, point_phases
    result = impactgen.simulate(impactgen.load_scene("rod-drop"), dense_output=True, warn=False)
    times = frame_times(result, 40)
    base = base_at(result, times)
    assert base[1, 0] == pytest.approx(0.05) and base[1].min() < 0.002  # from 5 cm down to the plate
    assert point_phases(result, times).shape == (2, 40)
    first = result.impacts[0]
    assert first.point == "base"
    middle = np.array([(first.t_start + first.t_end) / 2])
    assert point_phases(result, middle)[0, 0] in ("elastic", "elastoplastic", "restitution", "reloading")
    path = animate(result, tmp_path / "rod.gif", fps=FRAMES, seconds=1.0, dpi=40)
    assert path.stat().st_size > 0


def test_an_inclined_surface_is_drawn_at_its_angle_with_gravity_down():
    """The surface's frame (x along the surface, y normal to it) is turned for the drawing:
    gravity (g sin a, -g cos a) there points straight down, and the surface descends towards
    +x at its angle."""
    from impactgen.animate import upright
    a = 20.0
    g_x, g_y = upright(np.array([np.sin(np.radians(a))]), np.array([-np.cos(np.radians(a))]), a)
    assert g_x[0] == pytest.approx(0.0, abs=1e-15) and g_y[0] == pytest.approx(-1.0)
    x, y = upright(np.array([0.0, 1.0]), np.array([-0.1, -0.1]), a)
    assert (y[1] - y[0]) / (x[1] - x[0]) == pytest.approx(-np.tan(np.radians(a)))
    level = upright(np.array([0.3]), np.array([0.2]), 0.0)
    assert level[0][0] == 0.3 and level[1][0] == 0.2
