"""An animation of one run: the chain moving, the surface, each contact point by its phase.

An impact lasts about half a millisecond and a flight can last a second, so the frames are
not spread evenly over the simulated time. They are spread evenly over a *warped* time in
which the impacts (the runs of contact phases between two flights) share `IMPACT_SHARE` of
the frames in equal parts, and the flights and any sustained contact share the rest in
proportion to their duration. A run that is all impact, or all flight, gives all its frames
to it. The simulated time is written beside the chain in every frame.

A penetration is micrometres on a chain of metres: a panel beside the chain draws the tip's
height above the surface in micrometres (on a scale that is linear within the deepest
penetration and logarithmic beyond it, so a flight's centimetres fit as well), against the
same warped time.

The contact points are every joint and the tip, each drawn in the colour of its phase
(`point_phases`: the tip's from the run's phase spans, a joint's from its impacts). A joint
that cannot reach the surface has no contact law; should a point be found below the surface
while free, it is drawn in a warning colour.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from .errors import SceneError, excerpt
from .plots import PHASE_COLOURS, _pyplot
from .results import SimulationResult, point_number
from .scene import TOUCH_TOLERANCE, initial_surface_height

IMPACT_SHARE = 0.5  # of the frames, shared equally by the impacts when the run also has flight
CONTACT_PHASES = ("elastic", "elastoplastic", "restitution", "reloading")  # the phases of an impact
# The marker of a contact point in each phase (stronger than the plots' shading), and its label.
MARKER_COLOURS = {"free": "#ffffff", "elastic": "#4477aa", "elastoplastic": "#ee7733",
                  "restitution": "#228833", "reloading": "#aa3377", "sustained": "#777777"}
PHASE_LABELS = {"free": "free", "elastic": "elastic (I)", "elastoplastic": "elastoplastic (II)",
                "restitution": "restitution (III)", "reloading": "reloading", "sustained": "sustained"}
BELOW_COLOUR = "#dd0000"  # a point with no contact law that is below the surface
WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}
DEFAULT_FPS = 20
DEFAULT_SECONDS = 6.0
SYMLOG_ABOVE = 10.0  # flight this much above the deepest penetration: the height scale turns logarithmic
MAX_FRAMES = 5000  # a longer animation is a typing error, not a wish


def warped_time(result: SimulationResult, impact_share: float = IMPACT_SHARE) -> tuple[np.ndarray, np.ndarray]:
    """The warp as breakpoints: simulated times and warped times in [0, 1], both increasing.

    The warp is linear between breakpoints. Each impact gets `impact_share` divided by the
    number of impacts; flights and sustained contact share the rest by duration.
    """
    t_first, t_last = float(result.t[0]), float(result.t[-1])
    pieces: list[tuple[float, float, bool]] = []  # (t0, t1, is an impact), consecutive
    for span in result.phases:
        t0, t1 = max(span.t0, t_first), min(span.t1, t_last)
        if t1 <= t0:
            continue
        impact = span.phase in CONTACT_PHASES
        if pieces and pieces[-1][2] == impact:  # the phases of one impact, or flight then sustained
            pieces[-1] = (pieces[-1][0], t1, impact)
        else:
            pieces.append((t0, t1, impact))
    if not pieces:
        return np.array([t_first, t_last]), np.array([0.0, 1.0])
    pieces[0] = (t_first, *pieces[0][1:])  # the spans of a failed run may stop short of its samples
    pieces[-1] = (pieces[-1][0], t_last, pieces[-1][2])
    impacts = sum(1 for p in pieces if p[2])
    slow = sum(t1 - t0 for t0, t1, impact in pieces if not impact)
    share = impact_share if impacts and slow > 0 else (1.0 if impacts else 0.0)
    weights = [share / impacts if impact else (1.0 - share) * (t1 - t0) / slow
               for t0, t1, impact in pieces]
    times = np.array([pieces[0][0]] + [p[1] for p in pieces])
    warped = np.concatenate([[0.0], np.cumsum(weights)])
    return times, warped / warped[-1]


def frame_times(result: SimulationResult, frames: int, impact_share: float = IMPACT_SHARE) -> np.ndarray:
    """The simulated times of `frames` frames placed evenly in the warped time."""
    times, warped = warped_time(result, impact_share)
    return np.interp(np.linspace(0.0, 1.0, frames), warped, times)


def angles_at(result: SimulationResult, times: np.ndarray) -> np.ndarray:
    """q at `times`, shape (n, len(times)): from the dense output if the run kept it, else
    interpolated linearly between the samples."""
    n = result.n
    if result.sol:
        return np.asarray(result.sol(np.clip(times, result.sol.t_min, result.sol.t_max)))[:n]
    return np.vstack([np.interp(times, result.t, result.q[i]) for i in range(n)])


def base_at(result: SimulationResult, times: np.ndarray) -> np.ndarray:
    """A free chain's base point (x_0, y_0) at `times`, shape (2, len(times)), as `angles_at`
    reads the angles; zeros (the pivot) for a pinned chain."""
    if not result.scene.free:
        return np.zeros((2, len(times)))
    n = result.n
    if result.sol:
        return np.asarray(result.sol(np.clip(times, result.sol.t_min, result.sol.t_max)))[n:n + 2]
    return np.vstack([np.interp(times, result.t, result.base[i]) for i in range(2)])


def point_positions(lengths: tuple[float, ...], q: np.ndarray, base: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the pivot (or a free chain's base point, `base`: shape (2, frames)), every
    joint and the tip: shape (n + 1, len(frames)) each."""
    L = np.asarray(lengths)[:, None]
    x0, y0 = base if base is not None else np.zeros((2, q.shape[1]))
    return (x0 + np.vstack([np.zeros_like(x0), np.cumsum(L * np.cos(q), axis=0)]),
            y0 + np.vstack([np.zeros_like(y0), np.cumsum(L * np.sin(q), axis=0)]))


def point_phases(result: SimulationResult, times: np.ndarray) -> np.ndarray:
    """The phase of every contact point at `times`: shape (n + 1, len(times)), the base (a
    free chain's base point; a pinned chain's pivot, always "free"), joints 1 to n-1, then the
    tip. The tip's row is read from the result's phase spans; another point's from its
    impacts (each begins elastic and goes through its switches to its end); a point without
    impacts is "free" throughout."""
    phases = np.full((result.n + 1, len(times)), "free", dtype=object)
    spans = result.phases
    if spans:
        starts = np.array([s.t0 for s in spans])
        k = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(spans) - 1)
        phases[-1] = [spans[i].phase for i in k]
    for impact in result.impacts:
        if impact.point == "tip":
            continue
        row = phases[point_number(impact.point, result.n)]
        end = math.inf if impact.t_end is None else impact.t_end
        changes = [(impact.t_start, "elastic")] + [(t, to) for t, _, to in impact.switches]
        for (t0, phase), (t1, _) in zip(changes, changes[1:] + [(end, "")]):
            row[(times >= t0) & (times < t1)] = phase
    return phases


def upright(x: np.ndarray, y: np.ndarray, angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions in the surface's frame (x along it, y normal to it) turned so that gravity
    points down the page: the surface descends towards +x at `angle_deg`."""
    if not angle_deg:
        return x, y
    a = np.radians(angle_deg)
    return x * np.cos(a) + y * np.sin(a), -x * np.sin(a) + y * np.cos(a)


def surface_height(result: SimulationResult) -> float:
    """The surface's height: the scene's, or its lowest contact point's at the start for "initial"."""
    return initial_surface_height(result.scene)


def default_path(scene_name: str) -> Path:
    """`<scene name>.gif` in the current folder, the name made a plain file name."""
    return Path((re.sub(r"[^A-Za-z0-9._-]+", "_", scene_name).strip("._") or "animation") + ".gif")


def check_output(path: Path, fps: int = DEFAULT_FPS, seconds: float = DEFAULT_SECONDS) -> int:
    """Check, before a run, that `path` can be written with the tools installed and that
    `fps` and `seconds` make a sensible animation; return its number of frames.

    Raises
    ------
    SceneError
        An unknown suffix, .mp4 without ffmpeg, a folder that does not exist, or bad numbers.
    ImpactgenError
        matplotlib is not installed.
    """
    _pyplot()
    suffix = path.suffix.lower()
    if suffix not in WRITERS:
        raise SceneError("--out", f"cannot write a {suffix or 'suffix-less'} file {excerpt(path.name)}: "
                                  "give a .gif or .mp4 file")
    if not _writer_available(WRITERS[suffix]):
        raise SceneError("--out", f"writing {path.name} needs ffmpeg, which is not installed: install "
                                  "ffmpeg (e.g. apt install ffmpeg) or write a .gif")
    if not path.resolve().parent.is_dir():
        raise SceneError("--out", f"cannot write {path}: its folder {path.parent} does not exist")
    return _frame_count(fps, seconds)


def _writer_available(name: str) -> bool:
    from matplotlib import animation
    return animation.writers.is_available(name)


def animate(result: SimulationResult, path: str | Path, *, fps: int = DEFAULT_FPS,
            seconds: float = DEFAULT_SECONDS, dpi: int = 100, impact_share: float = IMPACT_SHARE) -> Path:
    """Write an animation of `result` to a GIF or MP4 file and return its path.

    Parameters
    ----------
    result : SimulationResult
        A run, best made with ``dense_output=True`` (positions between the samples are then
        the integrator's own; without it they are interpolated linearly).
    path : str or Path
        A ``.gif`` (written with Pillow) or ``.mp4`` (needs ffmpeg) file.
    fps : int
        Frames per second of the animation.
    seconds : float
        Its length; it has ``round(fps * seconds)`` frames (at least 2).
    dpi : int
        Resolution of the frames (the figure is 9 x 5 inches).
    impact_share : float
        Share of the frames the impacts get, equally, when the run also has flight.

    Raises
    ------
    SceneError
        An unknown suffix, .mp4 without ffmpeg, bad numbers, a run with nothing to show, or
        a file that cannot be written.
    ImpactgenError
        matplotlib is not installed.
    """
    path = Path(path)
    frames = check_output(path, fps, seconds)
    if not 0.0 < impact_share < 1.0:
        raise SceneError("impact_share", f"expected a share between 0 and 1, got {excerpt(impact_share)}")
    if not isinstance(dpi, (int, np.integer)) or dpi < 1:
        raise SceneError("dpi", f"expected a whole number of dots per inch >= 1, got {excerpt(dpi)}")
    if len(result.t) < 2 or not result.t[-1] > result.t[0]:
        raise SceneError(None, f"the run ended at its first sample (t = {result.t[0]:g} s): nothing to animate"
                               + (f"; {result.message}" if result.message else ""))
    from matplotlib import animation
    plt = _pyplot()
    writer = animation.PillowWriter(fps=fps) if path.suffix.lower() == ".gif" else animation.FFMpegWriter(fps=fps)
    times = frame_times(result, frames, impact_share)
    x, y = point_positions(result.scene.chain.length, angles_at(result, times), base_at(result, times))
    drawing = _Drawing(plt, result, times, x, y, impact_share, fps)
    try:
        with writer.saving(drawing.fig, str(path), dpi):
            for k in range(frames):
                drawing.show(k)
                writer.grab_frame()
    except OSError as exc:
        raise SceneError("--out", f"cannot write {path}: {exc}") from None
    finally:
        plt.close(drawing.fig)
    return path


def _frame_count(fps: int, seconds: float) -> int:
    if not isinstance(fps, (int, np.integer)) or fps < 1:
        raise SceneError("--fps", f"expected a whole number of frames per second >= 1, got {excerpt(fps)}")
    if not (isinstance(seconds, (int, float)) and np.isfinite(seconds) and seconds > 0):
        raise SceneError("--seconds", f"expected a length in seconds > 0, got {excerpt(seconds)}")
    frames = max(2, round(fps * seconds))
    if frames > MAX_FRAMES:
        raise SceneError("--seconds", f"{fps} fps for {seconds:g} s is {frames} frames, more than "
                                      f"{MAX_FRAMES}: lower --fps or --seconds")
    return frames


class _Drawing:
    """The figure and the artists one frame changes."""

    def __init__(self, plt, result: SimulationResult, times: np.ndarray, x: np.ndarray, y: np.ndarray,
                 impact_share: float, fps: int):
        self.result, self.times, self.fps = result, times, fps
        self.y_s = surface_height(result)
        self.tip_height = y[-1] - self.y_s  # in the surface's frame, as the run computes it
        self.x, self.y = upright(x, y, result.scene.surface_angle_deg)  # drawn with gravity down
        self.phases = point_phases(result, times)
        slack = TOUCH_TOLERANCE * max(1.0, sum(result.scene.chain.length))
        below = y < self.y_s - slack  # (n + 1, frames): a point under the surface
        below[0] &= result.scene.free  # (a pinned chain's pivot is no contact point)
        self.warned = below & (self.phases == "free")  # ... with no contact law holding it
        self.warp = warped_time(result, impact_share)
        self.fig = plt.figure(figsize=(9, 5))
        grid = self.fig.add_gridspec(2, 2, width_ratios=[3, 2], height_ratios=[1, 1])
        self.ax = self.fig.add_subplot(grid[:, 0])
        self._draw_scene()
        self._draw_tip_height(self.fig.add_subplot(grid[0, 1]))
        self._draw_key(self.fig.add_subplot(grid[1, 1]))
        self.fig.tight_layout()

    def _draw_scene(self) -> None:
        ax, x, y = self.ax, self.x, self.y
        reach = float(sum(self.result.scene.chain.length))
        margin = 0.08 * reach
        x0, x1 = min(x.min(), -0.1 * reach) - margin, max(x.max(), 0.1 * reach) + margin
        angle = self.result.scene.surface_angle_deg
        # the surface's line y = y_s of its own frame, drawn across the view and below it
        along = np.array([x0 - 2 * reach, x1 + 2 * reach])
        line_x, line_y = upright(along, np.full(2, self.y_s), angle)
        slope = -np.tan(np.radians(angle))
        y_line = (lambda xs: line_y[0] + slope * (np.asarray(xs) - line_x[0]))
        y0 = min(y.min(), float(y_line([x0, x1]).min())) - 2.5 * margin
        y1 = max(y.max(), 0.0) + margin
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.fill_between([x0, x1], y0, y_line([x0, x1]), facecolor="#eeeeee", edgecolor="#999999",
                        hatch="///", lw=0)
        ax.plot([x0, x1], y_line([x0, x1]), color="k", lw=1.2)
        free = self.result.scene.free
        if not free:  # the pivot; a free chain's base point is a contact point, drawn as the joints
            ax.plot([0.0], [0.0], marker="^", color="k", ms=9, zorder=4)
        (self.links,) = ax.plot([], [], "-", color="#333333", lw=3, solid_capstyle="round", zorder=3)
        self.first = 0 if free else 1  # the first of the drawn contact points
        self.points = ax.scatter(x[self.first:, 0], y[self.first:, 0], s=[40] * (self.result.n - self.first) + [90],
                                 edgecolors="k", linewidths=1.0, zorder=5)
        tilt = f" (the surface inclined by {angle:g} degrees, gravity down)" if angle else ""
        ax.set_xlabel(f"horizontal (m){tilt}" if angle else "x (m)", fontsize=9 if angle else None)
        ax.set_ylabel("vertical (m)" if angle else "y (m)")
        count = len(self.result.impacts)
        ax.set_title(f"{self.result.scene.name}: {count} impact{'' if count == 1 else 's'}, "
                     f"{self.result.status}", fontsize=10)

    def _draw_key(self, ax) -> None:
        """The clock and the legend of the contact points' colours."""
        from matplotlib.lines import Line2D
        ax.axis("off")
        self.clock = ax.text(0.0, 1.0, "", transform=ax.transAxes, va="top", ha="left",
                             family="monospace", fontsize=9)
        ran = {s.phase for s in self.result.phases}
        shown = ["free"] + [p for p in MARKER_COLOURS if p != "free" and (p in ran or (self.phases == p).any())]
        handles = [Line2D([], [], ls="", marker="o", mfc=MARKER_COLOURS[p], mec="k", label=PHASE_LABELS[p])
                   for p in shown]
        if self.warned.any():
            handles.append(Line2D([], [], ls="", marker="o", mfc=BELOW_COLOUR, mec="k",
                                  label="below the surface, no contact law"))
        ax.legend(handles=handles, loc="lower left", fontsize=8, frameon=False,
                  title="contact points (base, joints, tip)" if self.result.scene.free
                  else "contact points (joints, tip)", title_fontsize=8)

    def _draw_tip_height(self, ax) -> None:
        """The tip's height above the surface in micrometres against the warped time: an
        impact's penetration is too small to see on the chain."""
        from matplotlib.ticker import FuncFormatter, NullLocator
        r = self.result
        times, warped = self.warp
        height_um = -r.delta * 1e6
        depth_um = max(float(np.nanmax(r.delta, initial=0.0)) * 1e6, 1e-3)
        highest = float(np.nanmax(height_um, initial=0.0))
        if highest > SYMLOG_ABOVE * depth_um:  # a flight's centimetres as well
            ax.set_yscale("symlog", linthresh=depth_um, linscale=2.0)
            decades = 10.0 ** np.arange(np.ceil(np.log10(SYMLOG_ABOVE * depth_um)), np.log10(highest) + 1)
            ax.set_yticks([-float(f"{depth_um:.1g}"), 0.0, *decades])
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.yaxis.set_minor_locator(NullLocator())
        for phase, colour in PHASE_COLOURS.items():  # one collection per phase: hundreds of impacts draw fast
            ends = np.array([(s.t0, s.t1) for s in r.phases if s.phase == phase]).reshape(-1, 2)
            if colour is not None and len(ends):
                w0, w1 = np.interp(ends[:, 0], times, warped), np.interp(ends[:, 1], times, warped)
                ax.broken_barh(list(zip(w0, w1 - w0)), (0.0, 1.0), facecolors=colour, lw=0,
                               transform=ax.get_xaxis_transform())
        ax.axhline(0.0, color="k", lw=0.8)
        ax.plot(np.interp(r.t, times, warped), height_um, color="#555555", lw=0.8)
        ax.set_xlim(0.0, 1.0)
        ax.set_xticks([])
        ax.tick_params(labelsize=7)
        ax.set_title("tip above the surface (\u00b5m)", fontsize=9)
        ax.set_xlabel("animation time (impacts shaded)", fontsize=8)
        self.cursor = ax.axvline(0.0, color="k", lw=0.6, ls=":")
        self.dot = ax.scatter([0.0], [height_um[0]], s=40, edgecolors="k", linewidths=0.8, zorder=5)

    def show(self, k: int) -> None:
        """Move the artists to frame k."""
        x, y, t = self.x[:, k], self.y[:, k], float(self.times[k])
        self.links.set_data(x, y)
        colours = [BELOW_COLOUR if warned else MARKER_COLOURS.get(phase, "#ffffff")
                   for phase, warned in zip(self.phases[self.first:, k], self.warned[self.first:, k])]
        self.points.set_offsets(np.column_stack([x[self.first:], y[self.first:]]))
        self.points.set_facecolors(colours)
        times, warped = self.warp
        w = float(np.interp(t, times, warped))
        self.cursor.set_xdata([w, w])
        self.dot.set_offsets([[w, self.tip_height[k] * 1e6]])
        self.dot.set_facecolors([colours[-1]])
        rate = self._sim_per_video_second(k)
        digits = int(np.clip(np.ceil(-np.log10(max(rate / self.fps, 1e-15))) + 1, 3, 12))  # a frame's step shows
        self.clock.set_text(f"t = {t:.{digits}f} s\ntip: {PHASE_LABELS.get(self.phases[-1, k], self.phases[-1, k])}"
                            f"\n1 s of video = {rate:.3g} s")

    def _sim_per_video_second(self, k: int) -> float:
        """Simulated seconds per second of video around frame k (the warp's local rate)."""
        k0, k1 = max(k - 1, 0), min(k + 1, len(self.times) - 1)
        return float(self.times[k1] - self.times[k0]) / (k1 - k0) * self.fps
