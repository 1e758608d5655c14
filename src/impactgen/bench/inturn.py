"""The target contenders timed in turn: the ratios the speed targets judge, side by side.

The work-precision sweep times each contender at every tolerance once, minutes apart from
the others, and this host's speed moves by tens of percent from minute to minute. The
ratios of the targets compare a few contenders at one error, so those are timed again here,
one contender after the other, round after round: each contender's two work-precision runs
that bracket the error (the same tolerances, so the same steps and the same errors) are run
again in every round, each round's times are interpolated at the error as `time_at_error`
interpolates the sweep's own, and the rounds' median is the contender's time.
"""
from __future__ import annotations

import statistics

from .contenders import available_contenders
from .workprecision import Run, Settings, bench_scenes, bracketing, log_log_at, progress_bar, repeat_timed

ROUNDS = 5  # each contender timed this many times, in turn with the others; medians


def _at_error(points: list[tuple[float, float]], error: float) -> float:
    """(error, seconds) points at `error`: interpolated between two, or the one's time."""
    return points[0][1] if len(points) == 1 else log_log_at(points[0], points[1], error)


def time_in_turn(runs: list[Run], scene_name: str, error: float, names: list[str], settings: Settings,
                 rounds: int = ROUNDS) -> dict:
    """Milliseconds each named contender needs for `error` on `scene_name`, timed in turn.

    Returns {"error", "rounds", "ms": {name: ms}, "round_ms": {name: [ms per round]}}; a
    contender that does not reach the error, or fails here, is left out."""
    contenders = {c.name: c for c in available_contenders()[0]}
    scene = bench_scenes((scene_name,))[scene_name]
    plan = {name: [(r.err_u_final, r.rtol) for r in
                   bracketing([r for r in runs if r.scene == scene_name and r.contender == name], error)]
            for name in names if name in contenders}
    plan = {name: points for name, points in plan.items() if points}
    seconds: dict[tuple[str, float], list[float]] = {(n, rtol): [] for n, pts in plan.items() for _, rtol in pts}
    failed: set[str] = set()
    for k in range(rounds):
        progress_bar(k, rounds, f"{scene_name}: the target contenders in turn, round {k + 1}")
        for name, points in plan.items():
            for _, rtol in points:
                if name in failed:
                    continue
                try:
                    times, result = repeat_timed(contenders[name], scene, rtol, settings)
                except Exception:  # it ran in the sweep at this tolerance: a failure here leaves it out
                    failed.add(name)
                    continue
                if not result.success:
                    failed.add(name)
                    continue
                seconds[(name, rtol)].append(statistics.median(times))
    progress_bar(rounds, rounds, f"{scene_name}: the target contenders in turn")
    ms, round_ms = {}, {}
    for name, points in plan.items():
        if name in failed:
            continue
        per_round = zip(*(seconds[(name, rtol)] for _, rtol in points))
        round_ms[name] = [_at_error([(err, t) for (err, _), t in zip(points, ts)], error) * 1e3 for ts in per_round]
        ms[name] = statistics.median(round_ms[name])
    return {"scene": scene_name, "error": error, "rounds": rounds, "ms": ms, "round_ms": round_ms}
