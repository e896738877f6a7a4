"""Animations of a trial (``navstack animate RUN_DIR``): the run replayed from ``trajectory.npz`` and ``world.json``.

Each frame shows the robot at the measured joints ``q`` of the control step at that time, the commanded
tip path (``tip_des``) drawn up to that time, the goals (filled once reached), the time and the goal
count in the top-left corner, and, in red, the links that touch an obstacle at that instant.  The last
frame is held for :attr:`AnimationConfig.hold` seconds with the trial's outcome added to the caption.

How (PyBullet TinyRenderer, explicit matrices from :mod:`navstack.render`):

* contact is recomputed per frame from the replayed joints against the world in a DIRECT client
  (:meth:`navstack.sim.scene.Scene.contact_links`: PyBullet's closest points at distance 0 and the exact distances
  where PyBullet rounds corners), the same test as the trial's ``contacts`` metric;
* the static picture (the structure and the lathe bed) is rendered once (colour and depth) in that
  client with the robot's links hidden; each frame renders only the links, in a second client, and only
  inside the pixel rectangle that holds them, and keeps the robot's pixels where they are nearer than the
  static picture's.  A frame of the paper's truss then costs a fraction of a full render (measured,
  640 x 480: 117 ms for the whole scene, 49 ms for the robot alone; the rectangle is smaller again);
* MP4 (H.264) through imageio's ffmpeg plugin, whose ``imageio-ffmpeg`` package ships the ffmpeg binary;
  ``.gif`` through Pillow, also the fallback when no ffmpeg binary can be found.

Playback runs at ``speed`` times real time; frame k shows the last control step at or before
``k * speed / fps`` seconds of simulated time.  The output depends only on the run folder and the
configuration.  Moving obstacles (``motion``) are not supported yet: obstacles are drawn where the world
file puts them at t = 0.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from navstack.jpl import jpl_serpentine
from navstack.render import (
    CONTACT_RGB,
    VIEWS,
    LinkTint,
    View,
    auto_view,
    draw_overlay,
    framing_points,
    grab,
    outcome_line,
    project,
)
from navstack.rundir import RunData, load_run
from navstack.validate import in_range, integer

FORMATS = (".mp4", ".gif")


@dataclass(frozen=True)
class AnimationConfig:
    """How to animate a run.

    Attributes:
        fps: frames per second of the video.
        speed: simulated seconds per second of video (1 = real time).
        width, height: picture size [px], multiples of 16 (H.264 macroblocks), 160..1920.
        view: a named view of :data:`navstack.render.VIEWS` (``auto``: chosen from the trajectory).
        eye, target: an explicit camera (world, m); both or neither; they override ``view``.
        fov: vertical field of view [deg].
        hold: seconds the last frame (with the outcome) is held at the end.
    """

    fps: float = 15.0
    speed: float = 1.0
    width: int = 768
    height: int = 432
    view: str = "auto"
    eye: tuple[float, float, float] | None = None
    target: tuple[float, float, float] | None = None
    fov: float = 45.0
    hold: float = 1.5

    def __post_init__(self) -> None:
        in_range(self, "fps", lo=0.5, hi=60.0)
        in_range(self, "speed", lo=0.01, hi=100.0)
        in_range(self, "hold", lo=0.0, hi=60.0, unit=" [s]")
        in_range(self, "fov", lo=1.0, hi=170.0, unit=" [deg]")
        integer(self, "width", "height", lo=160, hi=1920)
        for key in ("width", "height"):
            if getattr(self, key) % 16:
                raise ValueError(f"AnimationConfig.{key} must be a multiple of 16 pixels (H.264 macroblocks), "
                                 f"got {getattr(self, key)!r}")
        if self.view not in VIEWS:
            raise ValueError(f"AnimationConfig.view must be one of {', '.join(VIEWS)}, got {self.view!r}")
        if (self.eye is None) != (self.target is None):
            raise ValueError("AnimationConfig.eye and target go together: give both or neither")
        if self.eye is not None:
            View(target=self.target, eye=self.eye, fov=self.fov)  # validates them


@dataclass(frozen=True)
class AnimationStats:
    """What :func:`write_animation` wrote: the file, the number of frames, the wall time [s]."""

    path: Path
    frames: int
    seconds: float
    config: AnimationConfig


def robot_points(run: RunData, chain, T0: NDArray[np.float64]) -> NDArray[np.float64]:
    """World origins of DH frames 1..21 over the run (every 10th sample) and the tip path [m]."""
    pts = [run.tip_des]
    for q in run.q[::10]:
        F = chain.frames(q)
        pts.append((F[1:, :3, 3] @ T0[:3, :3].T) + T0[:3, 3])
    return np.concatenate(pts)


def choose_view(run: RunData, config: AnimationConfig) -> View:
    """The configured camera, or :func:`navstack.render.auto_view` of the run (robot, tip path, goals,
    nearby structure)."""
    if config.eye is not None:
        return View(target=tuple(map(float, config.target)), eye=tuple(map(float, config.eye)), fov=config.fov)
    T0 = run.world.robot.base.transform()
    pts = framing_points(run.world, robot_points(run, jpl_serpentine(), T0))
    return auto_view(pts, width=config.width, height=config.height, name=config.view, toward=T0[:3, 3],
                     fov=config.fov)


def goals_reached_per_sample(run: RunData) -> NDArray[np.int64]:
    """Goals reached by each sample (the trial's rule: in order, measured tip within the tolerance)."""
    chain = jpl_serpentine()
    T0 = run.world.robot.base.transform()
    goals = run.world.goal_positions
    tol = np.array([g.tolerance for g in run.world.goals])
    out = np.empty(len(run.t), dtype=np.int64)
    k = 0
    for i, q in enumerate(run.q):
        tip = T0[:3, :3] @ chain.frames(q)[21, :3, 3] + T0[:3, 3]
        while k < len(goals) and np.linalg.norm(tip - goals[k]) <= tol[k]:
            k += 1
        out[i] = k
    return out


class ContactProbe:
    """The world's obstacles and the robot in a DIRECT client, to ask which links touch at given joints."""

    def __init__(self, world) -> None:
        from navstack.sim._bullet import direct_client
        from navstack.sim.body import RobotBody
        from navstack.sim.scene import Scene

        spec = world.robot
        self.client = direct_client()
        try:
            self.scene = Scene.build(self.client, world)
            self.robot = RobotBody.build(self.client, jpl_serpentine(), spec.base.transform(),
                                         serpentine_radius=spec.serpentine_radius, arm_radius=spec.arm_radius)
        except BaseException:
            self.close()
            raise

    def links(self, q: NDArray[np.float64]) -> frozenset[int]:
        """PyBullet links (link k carries DH frame k + 1) within distance 0 of an obstacle at joints ``q``."""
        self.robot.reset(q)
        return self.scene.contact_links(self.robot.body_id)

    def close(self) -> None:
        try:
            self.client.disconnect()
        except Exception:  # noqa: BLE001 - already disconnected
            pass


def contacts_per_sample(run: RunData) -> list[frozenset[int]]:
    """The links touching an obstacle at every sample of ``run`` (as the trial's ``contacts`` metric)."""
    probe = ContactProbe(run.world)
    try:
        return [probe.links(q) for q in run.q]
    finally:
        probe.close()


def _hide(client, body_id: int, links) -> None:
    """Make visual shapes invisible to the TinyRenderer (alpha 0 is not drawn; collision is unaffected)."""
    for k in links:
        client.changeVisualShape(body_id, k, rgbaColor=[1.0, 1.0, 1.0, 0.0])


class Replay:
    """The run rendered frame by frame.

    The :class:`ContactProbe`'s client renders the static picture once: the structure and the lathe bed
    (the robot's links hidden).  A second client holds the robot with its links only; each frame renders
    the smallest pixel rectangle that holds the links (an off-axis projection of that rectangle, on the same
    pixel grid) and keeps the robot's pixels where they are nearer than the static picture's.
    """

    def __init__(self, run: RunData, view: View, width: int, height: int) -> None:
        from navstack.sim._bullet import direct_client
        from navstack.sim.body import RobotBody

        self.width, self.height = width, height
        self.matrices = view.matrices(width, height)
        self.eye, self.fov = np.asarray(view.eye, dtype=float), view.fov
        spec = run.world.robot
        self.T0 = spec.base.transform()
        self.radius = max(spec.arm_radius, spec.serpentine_radius)
        self.chain = jpl_serpentine()
        self.probe = ContactProbe(run.world)
        self.actor_client = direct_client()
        try:
            n_links = self.probe.client.getNumJoints(self.probe.robot.body_id)
            _hide(self.probe.client, self.probe.robot.body_id, range(n_links))
            self.bg_rgb, self.bg_depth = grab(self.probe.client, *self.matrices, width, height)
            self.actor = RobotBody.build(self.actor_client, self.chain, self.T0,
                                         serpentine_radius=spec.serpentine_radius, arm_radius=spec.arm_radius)
            _hide(self.actor_client, self.actor.body_id, [-1])  # the lathe bed is in the static picture
            self.tint = LinkTint(self.actor_client, self.actor.body_id)
        except BaseException:
            self.close()
            raise

    def robot_box(self, q: NDArray[np.float64]) -> tuple[int, int, int, int] | None:
        """Pixel rectangle (u0, v0, u1, v1) that holds the robot's links at ``q``, or None if off-picture."""
        F = self.chain.frames(q)
        pts = F[1:, :3, 3] @ self.T0[:3, :3].T + self.T0[:3, 3]
        uv = project(*self.matrices, pts, self.width, self.height)
        focal = self.height / 2.0 / math.tan(math.radians(self.fov) / 2.0)
        nearest = max(float(np.min(np.linalg.norm(pts - self.eye, axis=1))), 1e-3)
        pad = focal * 1.5 * self.radius / nearest + 3.0  # a link's radius, seen from its nearest point
        u0, v0 = np.floor(uv.min(axis=0) - pad).astype(int)
        u1, v1 = np.ceil(uv.max(axis=0) + pad).astype(int)
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, self.width), min(v1, self.height)
        return (u0, v0, u1, v1) if u1 - u0 >= 2 and v1 - v0 >= 2 else None

    def _sub_projection(self, u0: int, v0: int, u1: int, v1: int) -> list[float]:
        """The projection matrix (column-major) that maps pixels [u0, u1) x [v0, v1) onto a whole picture."""
        sx, sy = (u1 - u0) / self.width, (v1 - v0) / self.height
        cx, cy = (u0 + u1) / self.width - 1.0, 1.0 - (v0 + v1) / self.height
        S = np.array([[1 / sx, 0, 0, -cx / sx], [0, 1 / sy, 0, -cy / sy], [0, 0, 1, 0], [0, 0, 0, 1]])
        P = np.asarray(self.matrices[1], dtype=float).reshape(4, 4).T
        return (S @ P).T.ravel().tolist()

    def frame(self, q: NDArray[np.float64], full: bool = False) -> tuple[NDArray[np.uint8], frozenset[int]]:
        """The picture (height, width, 3) of the robot at ``q`` and the links touching an obstacle.

        ``full`` renders the whole picture instead of the robot's rectangle (the reference in the tests).
        """
        touching = self.probe.links(q)
        self.actor.reset(q)
        self.tint.set(touching)
        out = self.bg_rgb.copy()
        box = (0, 0, self.width, self.height) if full else self.robot_box(q)
        if box is None:
            return out, touching
        u0, v0, u1, v1 = box
        proj = self.matrices[1] if full else self._sub_projection(*box)
        rgb, depth = grab(self.actor_client, self.matrices[0], proj, u1 - u0, v1 - v0)
        block = out[v0:v1, u0:u1]
        nearer = depth < self.bg_depth[v0:v1, u0:u1]  # the robot's pixels in front of the static picture
        block[nearer] = rgb[nearer]
        return out, touching

    def close(self) -> None:
        self.probe.close()
        try:
            self.actor_client.disconnect()
        except Exception:  # noqa: BLE001 - already disconnected
            pass


def frame_times(duration: float, cfg: AnimationConfig) -> NDArray[np.float64]:
    """Simulated times [s] of the frames: every ``speed / fps`` seconds, and the end of the run last."""
    step = cfg.speed / cfg.fps
    times = np.arange(int(math.floor(duration / step + 1e-9)) + 1) * step
    if duration - times[-1] > 1e-9:
        times = np.append(times, duration)
    return times


def _ffmpeg_available() -> bool:
    try:
        import imageio_ffmpeg

        return bool(imageio_ffmpeg.get_ffmpeg_exe())
    except (ImportError, RuntimeError):
        return False


class _Writer:
    """Frames to an MP4 (imageio + ffmpeg, streamed) or a GIF (Pillow, at the end)."""

    def __init__(self, path: Path, fps: float) -> None:
        self.path, self.fps = path, fps
        self.gif: list = []
        self.mp4 = None
        if path.suffix.lower() == ".mp4":
            import imageio.v2 as imageio

            # quality 7 is x264's -crf 15; the veryfast preset took 60 % of the default preset's CPU time (measured)
            self.mp4 = imageio.get_writer(path, format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=7,
                                          pixelformat="yuv420p", macro_block_size=16, ffmpeg_log_level="error",
                                          output_params=["-preset", "veryfast"])

    def append(self, rgb: NDArray[np.uint8], repeat: int = 1) -> None:
        if self.mp4 is not None:
            for _ in range(repeat):
                self.mp4.append_data(rgb)
        else:
            from PIL import Image

            frame = Image.fromarray(rgb).quantize(colors=128, method=Image.Quantize.MEDIANCUT,
                                                  dither=Image.Dither.NONE)
            self.gif.append((frame, repeat))  # a GIF holds a frame by its duration

    def close(self) -> None:
        if self.mp4 is not None:
            self.mp4.close()
        elif self.gif:
            frames = [f for f, _ in self.gif]
            durations = [round(1000.0 * r / self.fps) for _, r in self.gif]
            frames[0].save(self.path, save_all=True, append_images=frames[1:], duration=durations, loop=0)


def _caption(run: RunData, t: float, reached: int, touching: frozenset[int], final: bool):
    res = run.result or {}
    who = f"{run.world.name}: {res.get('controller', '?')} / {res.get('planner', '?')}" if res else run.world.name
    lines = [(who, (0, 0, 0)), (f"t = {t:5.1f} s   goals {reached}/{len(run.world.goals)}", (0, 0, 0))]
    if touching:
        lines.append((f"contact: {len(touching)} link{'s' if len(touching) > 1 else ''} touching", CONTACT_RGB))
    if final:
        lines.append(outcome_line(run.result, len(run.world.goals)))
    return lines


def write_animation(run: RunData, out: str | os.PathLike[str], config: AnimationConfig | None = None) -> AnimationStats:
    """Render ``run`` to ``out`` (``.mp4`` or ``.gif``) and return what was written.

    Raises ``ValueError`` for an unknown file extension and ``OSError`` when ``out`` cannot be written.
    """
    cfg = config or AnimationConfig()
    out = Path(out)
    if out.suffix.lower() not in FORMATS:
        raise ValueError(f"{out}: the animation file must end in .mp4 or .gif")
    if not out.parent.is_dir():
        raise OSError(f"{out.parent}: the folder for the animation does not exist")
    wall0 = time.perf_counter()
    view = choose_view(run, cfg)
    reached = goals_reached_per_sample(run)
    times = frame_times(run.duration, cfg)
    n_frames = len(times)
    index = np.clip(np.searchsorted(run.t, times + 1e-9, side="right") - 1, 0, len(run.t) - 1)
    goals = run.world.goal_positions
    replay = Replay(run, view, cfg.width, cfg.height)
    vm, pm = replay.matrices
    path_uv = project(vm, pm, run.tip_des, cfg.width, cfg.height)
    goals_uv = project(vm, pm, goals, cfg.width, cfg.height)
    tmp = out.with_name(out.stem + ".part" + out.suffix)
    writer = _Writer(tmp, cfg.fps)
    try:
        for k, i in enumerate(index):
            final = k == n_frames - 1
            rgb, touching = replay.frame(run.q[i])
            lines = _caption(run, float(run.t[i]), int(reached[i]), touching, final)
            frame = draw_overlay(rgb, path_uv=path_uv[: i + 1], goals_uv=goals_uv, goals_reached=int(reached[i]),
                                 lines=lines)
            writer.append(frame, repeat=1 + (round(cfg.hold * cfg.fps) if final else 0))
        writer.close()
    except BaseException:
        writer.close()
        tmp.unlink(missing_ok=True)
        raise
    finally:
        replay.close()
    os.replace(tmp, out)
    return AnimationStats(path=out, frames=n_frames, seconds=time.perf_counter() - wall0, config=cfg)


def default_output(run_dir: str | os.PathLike[str]) -> Path:
    """``RUN_DIR/animation.mp4``, or ``animation.gif`` where no ffmpeg binary is available."""
    return Path(run_dir) / ("animation.mp4" if _ffmpeg_available() else "animation.gif")


def animate_run(run_dir: str | os.PathLike[str], out: str | os.PathLike[str] | None = None,
                config: AnimationConfig | None = None, world=None) -> Path:
    """Animate the run folder ``run_dir`` (see the module docstring) and return the file written.

    ``out`` defaults to :func:`default_output`; an ``.mp4`` asked for where ffmpeg is missing becomes a
    ``.gif`` beside it.  ``world`` overrides ``run_dir/world.json`` (folders written before it existed).
    For sweeps and reports: ``animate_run(trial_dir)`` after the trial's ``run_trial(..., out_dir=trial_dir)``.
    """
    return animate_stats(run_dir, out, config, world).path


def animate_stats(run_dir: str | os.PathLike[str], out: str | os.PathLike[str] | None = None,
                  config: AnimationConfig | None = None, world=None) -> AnimationStats:
    """:func:`animate_run` returning the :class:`AnimationStats` (frames, wall time) too."""
    run = load_run(run_dir, world)
    path = default_output(run_dir) if out is None else Path(out)
    if path.suffix.lower() == ".mp4" and not _ffmpeg_available():
        path = path.with_suffix(".gif")
    if path.is_dir():  # found before the frames are drawn, not after
        raise ValueError(f"{path} is a folder; give the animation file to write (.mp4 or .gif)")
    return write_animation(run, path, config)
