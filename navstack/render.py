"""Pictures of a trial: PyBullet's TinyRenderer, with the tip path, the goals and a caption drawn on top.

Used by ``scene.png`` (:func:`render_scene`, the last instant of a trial) and by the animations
(:mod:`navstack.animate`).  Units: metres, degrees for the field of view, pixels for images.

* Camera: explicit view and projection matrices (OpenGL convention, column-major as PyBullet returns
  them).  :func:`auto_view` chooses one from points that must stay in frame (the robot over the whole
  trajectory, the commanded tip path, the goals, nearby structure): it looks across the plane the motion
  spans (the least-variance direction of the points), from the robot's side, 25 degrees from above, and
  backs off until every point projects inside the picture.
* Overlays: the commanded tip path (``tip_des``), the goals (hollow until reached, then filled) and a
  caption are projected with the same matrices and drawn with Pillow, since the TinyRenderer draws no
  debug lines.
* Contact: :meth:`navstack.sim.scene.Scene.contact_links` names the robot links at distance <= 0 from an obstacle
  (PyBullet's closest points, and the exact distances where PyBullet rounds corners: the same test as the
  trial's contact metric); :class:`LinkTint` paints those links red.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.sim._bullet import pybullet
from navstack.validate import in_range

CONTACT_RGBA = (0.9, 0.08, 0.08, 1.0)
"""Colour of a robot link touching an obstacle."""
CONTACT_RGB = tuple(round(255 * c) for c in CONTACT_RGBA[:3])
PATH_RGB = (220, 20, 60)
GOAL_RGB = (230, 180, 0)
REACHED_RGB = (40, 170, 60)
LIGHT_DIRECTION = (1.0, -2.0, 3.0)
VIEWS = ("auto", "front", "side", "top")
"""Named camera directions: ``auto`` (from the trajectory), ``front`` (camera on -y looking along +y),
``side`` (camera on +x looking along -x), ``top`` (from above, 85 degrees down)."""


def project(view: Sequence[float], proj: Sequence[float], pts: NDArray[np.float64], width: int,
            height: int) -> NDArray[np.float64]:
    """Pixel coordinates (N, 2) of world points ``pts`` (N, 3) [m] (u right, v down)."""
    V = np.asarray(view, dtype=float).reshape(4, 4).T
    P = np.asarray(proj, dtype=float).reshape(4, 4).T
    h = np.c_[pts, np.ones(len(pts))] @ (P @ V).T
    ndc = h[:, :3] / h[:, 3:4]
    return np.c_[(ndc[:, 0] + 1) / 2 * width, (1 - ndc[:, 1]) / 2 * height]


_project = project  # the name used before


def camera(target: NDArray[np.float64], eye: NDArray[np.float64], width: int, height: int, fov: float = 45.0,
           near: float = 0.05, far: float = 20.0):
    """View and projection matrices looking from ``eye`` at ``target`` (world, m), z up; ``fov`` vertical [deg]."""
    view = pybullet.computeViewMatrix(list(map(float, eye)), list(map(float, target)), [0, 0, 1])
    proj = pybullet.computeProjectionMatrixFOV(fov, width / height, near, far)
    return view, proj


@dataclass(frozen=True)
class View:
    """A camera: ``eye`` looking at ``target`` (world, m), z up, vertical field of view ``fov`` [deg]."""

    target: tuple[float, float, float]
    eye: tuple[float, float, float]
    fov: float = 45.0

    def __post_init__(self) -> None:
        try:
            t, e = np.asarray(self.target, dtype=float), np.asarray(self.eye, dtype=float)
        except (TypeError, ValueError):  # not numbers ("abc", a dict...): refused below
            t = e = np.full(1, np.nan)
        if t.shape != (3,) or e.shape != (3,) or not (np.isfinite(t).all() and np.isfinite(e).all()):
            raise ValueError(f"View: eye and target must be 3 finite numbers each, got {self.eye!r}, {self.target!r}")
        if np.linalg.norm(e - t) < 1e-6:
            raise ValueError("View: eye and target must differ")
        horizontal = np.linalg.norm((e - t)[:2])
        if horizontal < 1e-6 * np.linalg.norm(e - t):
            raise ValueError("View: the camera cannot look straight down or up (z is up); move the eye sideways")
        in_range(self, "fov", lo=1.0, hi=170.0, unit=" [deg]")

    def matrices(self, width: int, height: int):
        """View and projection matrices for a ``width`` x ``height`` picture."""
        dist = float(np.linalg.norm(np.subtract(self.eye, self.target)))
        return camera(np.asarray(self.target), np.asarray(self.eye), width, height, self.fov,
                      near=max(0.01, 0.02 * dist), far=60.0 * dist + 20.0)


def _direction(points: NDArray[np.float64], name: str, toward: NDArray[np.float64] | None,
               elevation: float) -> NDArray[np.float64]:
    """Unit vector from the target to the eye for a named view."""
    z = np.array([0.0, 0.0, 1.0])
    if name == "top":
        el, h = math.radians(85.0), np.array([0.0, -1.0, 0.0])
    elif name == "front":
        el, h = math.radians(elevation), np.array([0.0, -1.0, 0.0])
    elif name == "side":
        el, h = math.radians(elevation), np.array([1.0, 0.0, 0.0])
    else:
        centred = points - points.mean(axis=0)
        _, vecs = np.linalg.eigh(centred.T @ centred)
        n = vecs[:, 0]  # least variance: the normal of the plane the motion spans
        h = n - (n @ z) * z
        if np.linalg.norm(h) < 0.3:  # motion mostly horizontal: look across its main direction from above
            main = vecs[:, 2] - (vecs[:, 2] @ z) * z
            h = np.cross(z, main) if np.linalg.norm(main) > 1e-9 else np.array([0.0, -1.0, 0.0])
            el = math.radians(max(elevation, 55.0))
        else:
            el = math.radians(elevation)
        h = h / np.linalg.norm(h)
        side = (toward - points.mean(axis=0)) if toward is not None else np.array([0.0, -1.0, 0.0])
        if h @ side < -1e-9 or (abs(h @ side) <= 1e-9 and h @ np.array([0.0, -1.0, 0.0]) < 0):
            h = -h
    return math.cos(el) * h + math.sin(el) * z


def auto_view(points: NDArray[np.float64], *, width: int, height: int, name: str = "auto",
              toward: NDArray[np.float64] | None = None, elevation: float = 25.0, fov: float = 45.0,
              margin: float = 0.06, window: tuple[float, float] = (-1.0, 1.0)) -> View:
    """The closest camera of direction ``name`` (:data:`VIEWS`) that keeps all ``points`` (N, 3) in frame.

    ``toward``: a point on the side the camera should be (the robot's base), for ``auto``.  ``margin``
    is the fraction of the picture kept free at each edge.  ``window``: the horizontal part of the
    picture the points go into, as (left, right) from -1 (left edge) to 1 (right edge), containing 0
    (the viewer keeps its control panel's side free).
    """
    if name not in VIEWS:
        raise ValueError(f"view must be one of {', '.join(VIEWS)}, got {name!r}")
    if not -1.0 <= window[0] < 0.0 < window[1] <= 1.0:
        raise ValueError(f"auto_view: window must satisfy -1 <= left < 0 < right <= 1, got {window!r}")
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) == 0:
        raise ValueError("auto_view: no finite point to keep in frame")
    target = (pts.min(axis=0) + pts.max(axis=0)) / 2.0
    d = _direction(pts, name, toward, elevation)
    f = -d
    r = np.cross(f, [0.0, 0.0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    tan_full = math.tan(math.radians(fov) / 2.0)
    tan_v = tan_full * (1.0 - 2.0 * margin)
    # the points' x / depth must lie in [lo, hi] (tangent units): the window, less the margin
    half_w = tan_full * width / height
    lo, hi = (window[0] + 2.0 * margin) * half_w, (window[1] - 2.0 * margin) * half_w
    if not lo < 0.0 < hi:
        raise ValueError(f"auto_view: window {window!r} leaves no room inside the margin {margin!r}")

    def fit(target: NDArray[np.float64]) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """The nearest distance that keeps every point inside the picture, and the points' tangents."""
        rel = pts - target
        x, y, zf = rel @ r, rel @ u, rel @ f
        dist = float(max(np.max(x / hi - zf), np.max(x / lo - zf), np.max(np.abs(y) / tan_v - zf),
                         np.max(-zf) + 0.1, 0.3))
        return dist, x / (dist + zf), y / (dist + zf)

    for _ in range(3):  # centre the points' picture in the window (perspective makes it lopsided), fit again
        dist, xn, yn = fit(target)
        shift_x = (xn.max() + xn.min()) / 2.0 - (lo + hi) / 2.0
        target = target + dist * (shift_x * r + (yn.max() + yn.min()) / 2.0 * u)
    dist, _, _ = fit(target)
    return View(target=tuple(target), eye=tuple(target + dist * d), fov=fov)


def obstacle_points(obstacle) -> NDArray[np.float64]:
    """A few world points [m] whose hull bounds the obstacle (cylinder ends, box corners, sphere poles,
    mesh bounding-box corners), for framing a view."""
    from scipy.spatial.transform import Rotation

    from navstack.world import Box, Cylinder, Mesh, Sphere

    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    if isinstance(obstacle, Cylinder):
        return np.array([obstacle.p0, obstacle.p1])
    if isinstance(obstacle, Sphere):
        return obstacle.center + obstacle.radius * np.vstack([np.eye(3), -np.eye(3)])
    if isinstance(obstacle, Box):
        R = Rotation.from_euler("xyz", obstacle.rpy).as_matrix()
        return obstacle.center + (corners * obstacle.half_extents) @ R.T
    if isinstance(obstacle, Mesh):
        v, _ = obstacle.triangles()
        lo, hi = v.min(axis=0), v.max(axis=0)
        R = Rotation.from_euler("xyz", obstacle.rpy).as_matrix()
        return obstacle.position + ((lo + hi) / 2 + corners * (hi - lo) / 2) @ R.T
    raise TypeError(f"unknown obstacle type {type(obstacle).__name__}")


def framing_points(world, robot_points: NDArray[np.float64], margin: float = 0.4,
                   reach: float = 1.0) -> NDArray[np.float64]:
    """What a view should keep in frame: ``robot_points`` (the robot over the trial, the tip path), the
    goals, and every obstacle with a point inside their bounding box grown by ``margin`` [m], its points
    clipped to that box grown by a further ``reach`` [m] (a floor or a wall does not zoom the view out)."""
    pts = np.concatenate([np.asarray(robot_points, dtype=float).reshape(-1, 3), world.goal_positions])
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    near = [pts]
    for o in world.obstacles:
        op = obstacle_points(o)
        if ((op >= lo) & (op <= hi)).all(axis=1).any():
            near.append(np.clip(op, lo - reach, hi + reach))
    return np.concatenate(near)


def grab(client: Any, view, proj, width: int, height: int) -> tuple[NDArray[np.uint8], NDArray[np.float32]]:
    """TinyRenderer picture (height, width, 3) and depth buffer (height, width; 1 = nothing drawn)."""
    img = client.getCameraImage(width, height, viewMatrix=view, projectionMatrix=proj,
                                renderer=pybullet.ER_TINY_RENDERER, lightDirection=list(LIGHT_DIRECTION),
                                shadow=0, flags=pybullet.ER_NO_SEGMENTATION_MASK)
    rgb = np.ascontiguousarray(np.reshape(np.asarray(img[2], dtype=np.uint8), (height, width, 4))[:, :, :3])
    depth = np.reshape(np.asarray(img[3], dtype=np.float32), (height, width))
    return rgb, depth


class LinkTint:
    """Paints chosen links of a body red (:data:`CONTACT_RGBA`) and restores the others' own colours."""

    def __init__(self, client: Any, body_id: int) -> None:
        self.client, self.body_id = client, body_id
        self.colours = {int(s[1]): tuple(s[7]) for s in client.getVisualShapeData(body_id)}
        self.red: frozenset[int] = frozenset()

    def set(self, links: Iterable[int]) -> None:
        """Make exactly ``links`` red (links without a visual shape are ignored)."""
        red = frozenset(k for k in links if k in self.colours)
        for k in red ^ self.red:
            self.client.changeVisualShape(self.body_id, k, rgbaColor=list(CONTACT_RGBA if k in red else
                                                                            self.colours[k]))
        self.red = red


@lru_cache(maxsize=8)
def font(size: int):
    """DejaVu Sans (shipped with matplotlib) at ``size`` pixels, for captions."""
    from matplotlib import font_manager
    from PIL import ImageFont

    return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)


def draw_overlay(rgb: NDArray[np.uint8], *, path_uv: NDArray[np.float64], goals_uv: NDArray[np.float64],
                 goals_reached: int, lines: Sequence[tuple[str, tuple[int, int, int]]],
                 legend: bool = True) -> NDArray[np.uint8]:
    """``rgb`` with the tip path, the goals and caption ``lines`` (text, colour) drawn on it."""
    from PIL import Image, ImageDraw

    h, w = rgb.shape[:2]
    scale = max(1.0, w / 640.0)
    img = Image.fromarray(rgb)
    dr = ImageDraw.Draw(img)
    if len(path_uv) > 1:
        dr.line([tuple(p) for p in path_uv], fill=PATH_RGB, width=max(2, round(2 * scale)), joint="curve")
    rad = 6 * scale
    for k, (u, v) in enumerate(goals_uv):
        box = (u - rad, v - rad, u + rad, v + rad)
        if k < goals_reached:
            dr.ellipse(box, fill=REACHED_RGB, outline=(255, 255, 255), width=1)
        else:
            dr.ellipse(box, outline=GOAL_RGB, width=max(2, round(2 * scale)))
    f = font(round(14 * scale))
    y = 6 * scale
    for text, colour in lines:
        box = dr.textbbox((8 * scale, y), text, font=f)
        dr.rectangle((box[0] - 3, box[1] - 2, box[2] + 3, box[3] + 2), fill=(255, 255, 255))
        dr.text((8 * scale, y), text, fill=colour, font=f)
        y = box[3] + 5 * scale
    if legend:
        small = font(round(11 * scale))
        x0, y0 = w - 200 * scale, h - 44 * scale
        dr.rectangle((x0 - 6, y0 - 4, w - 4, h - 4), fill=(255, 255, 255))
        dr.line([(x0, y0 + 8 * scale), (x0 + 22 * scale, y0 + 8 * scale)], fill=PATH_RGB,
                width=max(2, round(2 * scale)))
        dr.text((x0 + 28 * scale, y0), "commanded tip path", fill=(0, 0, 0), font=small)
        c = (x0 + 11 * scale, y0 + 26 * scale)
        dr.ellipse((c[0] - 5 * scale, c[1] - 5 * scale, c[0] + 5 * scale, c[1] + 5 * scale), outline=GOAL_RGB, width=2)
        dr.text((x0 + 28 * scale, y0 + 18 * scale), "goal (filled: reached)", fill=(0, 0, 0), font=small)
    return np.asarray(img)


OUTCOME_TEXT = {"reached": "reached every goal", "collision": "collision", "timeout": "timeout",
                "stalled": "stalled", "joint_limit": "joint limit", "error": "error"}


def outcome_line(result: dict[str, Any] | None, n_goals: int) -> tuple[str, tuple[int, int, int]]:
    """The caption line stating a trial's outcome and goal count (green for success, red otherwise)."""
    if result is None:
        return "outcome unknown (no result.json)", (90, 90, 90)
    reason = str(result.get("reason", "?"))
    ok = bool(result.get("success"))
    text = (f"{'SUCCESS' if ok else 'FAILURE'}: {OUTCOME_TEXT.get(reason, reason)}, "
            f"goals {result.get('goals_reached', '?')}/{n_goals}")
    contacts = (result.get("metrics") or {}).get("contacts")
    if contacts:
        text += f", contact in {contacts} steps"
    return text, ((20, 130, 40) if ok else (200, 20, 20))


def render_scene(sim, path: Path, result=None, width: int = 960, height: int = 720) -> Path:
    """Write ``path`` (PNG): the robot in its world at the end of the trial ``sim``, links that touched an
    obstacle at any control step in red, the tip path, the goals, and a title with the outcome
    (``result``: the trial's :class:`~navstack.trial.TrialResult` or its dict) and the goal count."""
    from PIL import Image

    traj = sim.trajectory
    q_all = np.asarray(traj.q, dtype=float).reshape(-1, sim.chain.n)
    tip_path = np.asarray(traj.tip_des, dtype=float).reshape(-1, 3)
    robot = sim.body.body_id
    touched: set[int] = set()
    if sim.contacts:  # replay the recorded joints to find which links touched (none when no step did)
        q_end, _ = sim.body.joint_state()
        for q in q_all:
            sim.body.reset(q)
            touched |= sim.scene.contact_links(robot)
        sim.body.reset(q_end)
    LinkTint(sim.client, robot).set(touched)
    robot_pts = [tip_path] + [(sim.T0 @ F)[1:, :3, 3] for F in map(sim.chain.frames, q_all[::10])]
    view = auto_view(framing_points(sim.world, np.concatenate(robot_pts)), width=width, height=height,
                     toward=sim.p0)
    vm, pm = view.matrices(width, height)
    rgb, _ = grab(sim.client, vm, pm, width, height)
    res = result.to_dict() if hasattr(result, "to_dict") else result
    lines = [(f"{sim.world.name}: {sim.controller_name} / {sim.planner_name}, t = {sim.steps * sim.dt:.1f} s",
              (0, 0, 0)), outcome_line(res, len(sim.goals))]
    if touched:
        lines.append((f"red: {len(touched)} links touched an obstacle", CONTACT_RGB))
    rgb = draw_overlay(rgb, path_uv=project(vm, pm, tip_path, width, height),
                       goals_uv=project(vm, pm, sim.goals, width, height), goals_reached=int(sim.goal_index),
                       lines=lines)
    path = Path(path)
    Image.fromarray(rgb).save(path)
    return path



