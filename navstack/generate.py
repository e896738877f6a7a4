"""Randomized world generators (families) built around a feasible reference path, and their checks.

``generate_world(family, seed, difficulty)`` returns a :class:`~navstack.world.World` of one of
:data:`FAMILIES`, deterministic in its arguments.  Every world is built around a *reference tip path*:
the cubic spline that :class:`navstack.scripted.ScriptedPlanner` would follow through the reference
via points (start tip, leaving along the tip's heading, then the via points, chord-length
parameterised; :func:`reference_path`).  For worlds whose obstacles match the goals the via points are
the goals; for a truss displaced from its drawing they are the goals moved towards the *actual*
truss by at most 90 % of their tolerance (the path a robot that senses the truss can take).  The via
points and the number of leading "structure" obstacles are stored in
``extra.generator.reference_via`` / ``structure_obstacles``, so :func:`check_world` can re-check a
saved world.

Families (robot: the paper's demo placement, base (0, 0, 0.3) m, rpy (0, -pi/2, pi), tip at
(1.8085, 0.1079, 1.1668) m heading +x, lathe bed along +x):

``truss``
    The paper's box-bay truss (1 or 2 x 3 x 2 bays) placed so that an opening of the middle upper
    bay's front face (bottom-right or top-left triangle) is ``standoff`` ahead of the tip.  A random
    manoeuvre: ``climb`` (in, up on an arc of radius R, out through the top face: the paper's),
    ``through`` (straight through the bay and out of the back face, or into the second bay), or
    ``side`` (turn on a horizontal arc through the side face into the neighbouring bay).  Goals are
    drawn in the truss's *drawing*; the actual truss is displaced by a random error (offset up to
    0.06 m x difficulty, rotation up to 3 deg x difficulty about the entry opening's centre), and
    difficulty shrinks the bay side (0.5 -> 0.42 m) and grows the member radius (0.02 -> 0.025 m).
``cluttered-truss``
    As ``truss`` plus unmodelled cables (cylinders of radius 0.005-0.01 m) and equipment boxes placed
    near the path (more, and closer, with difficulty), never within the clearance the slithering body
    needs around the drawn path or the reference path.
``pipe-rack``
    2-3 layers of horizontal pipes (along y, yawed up to 10 deg, radius 0.025-0.045 m) stacked in z;
    each layer leaves a free gap around the path's crossing, the crossings alternate up and down (by
    up to 0.3 x layer spacing^2, what a turn radius of 0.25 m allows) so the tip weaves, and the gap
    shrinks with difficulty (0.25 -> 0.13 m).  Goals: at each crossing and behind the rack.
``sphere-field``
    A random goal path (2-3 via goals on a smooth bump of 0.11-0.14 m across the heading, a final goal
    0.9-1.15 m ahead) and spheres (radius 0.04-0.12 m) beside it, plus spheres on the straight line
    start -> final goal where the bump leaves room, so that line is blocked; more spheres, closer to the
    path, with difficulty.

Fixed worlds of the sensor-planner issue (:func:`write_issue_worlds`): ``truss_displaced.json`` (the
paper's truss 0.046 m / 3 deg away from its drawing), ``truss_clutter.json`` (the paper's truss with
an unmodelled cable and an equipment box), ``u_trap.json`` (a U of boxes straight ahead, the goal
behind it, the way round over the top) and ``pipe_rack.json`` (a generated rack).

Checks (:func:`check_world`; a candidate that fails any of them is discarded and the next sub-seed
``attempt`` is drawn, up to :data:`MAX_ATTEMPTS`), thresholds in :class:`CheckConfig`:

1. goals: every goal is at least ``goal_clearance`` (0.06 m) from every obstacle surface;
2. reference path: every point of the reference tip path (sampled every 2 mm) is at least
   ``serpentine_radius + path_margin`` (0.04 m) from every obstacle surface, its smallest radius of
   curvature is at least ``min_turn_radius`` (0.25 m), and it passes within 90 % of each goal's
   tolerance, in order;
3. slithering body: the chord chain (tip, J1..J6, one link apart along the recorded path, as
   :class:`navstack.path.PathMemory` computes it, starting from the initial backbone) is evaluated
   every 1 cm of tip travel; every link capsule keeps a surface clearance of at least ``body_margin``
   (0.01 m);
4. length rule: the part of the reference path from where it first enters the structure's bounding
   box (grown by 0.05 m) to the last goal is at most ``max_inside_length`` (1.1 m), and the flange's
   (J6) travel along the lathe axis fits the lathe's remaining travel;
5. arm: the arm's capsules (frames 1..9 at ``q0``, radius ``arm_radius``) translated by every
   displacement of J6 along the slither keep a surface clearance of at least ``arm_margin`` (0.03 m)
   (a cheap stand-in for the lathe bed carrying the arm forward);
6. start: the robot at ``q0``, built in PyBullet (:class:`navstack.sim.body.RobotBody`,
   :class:`navstack.sim.scene.Scene`), has ``scene.clearance >= start_clearance`` (0.05 m).

For the truss families the path through the goals is also checked (1-3) against the truss as
*drawn*, so the drawn goals make sense; the surface clearance of the body slithering along it, against
the actual obstacles, is recorded in ``extra.generator.drawn_path_clearance`` (negative: a planner that
trusts the drawing hits the truss; the scripted planner's ``min_clearance`` is close to it).
Distances are exact point-to-primitive distances (flat-ended cylinders, boxes, spheres), sampled
along curves every 2 mm (tip path), 1 cm (capsule axes) and 2 cm (arm); mesh obstacles are not
supported by the checks.

Sub-seeds: attempt ``k`` of ``(family, seed)`` draws from ``numpy.random.default_rng([1, family
index, seed, k])``; difficulty does not enter the seed, so one seed at several difficulties gives
related layouts.  Units: metres, radians, seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from navstack.guide import GuidePath, goal_spline
from navstack.jpl import BACKBONE_FRAMES, LINK_LENGTH, Q_DEFAULT, jpl_serpentine
from navstack.registry import FAMILIES as _REGISTERED
from navstack.truss import PAPER_BASE_RPY, incircle_offset, paper_truss_world, robot_tip_start, truss_members
from navstack.world import Box, Cylinder, Mesh, Obstacle, Sphere, World, save_world, world_from_dict


def _families() -> tuple[str, ...]:
    return tuple(_REGISTERED)


FAMILIES = _families()
"""World families :func:`generate_world` knows (read from :mod:`navstack.registry`)."""

GENERATOR_VERSION = 1
"""Stored in ``extra.generator.version``; bumped when the same arguments give different worlds."""

MAX_ATTEMPTS = 60
"""Sub-seeds tried before :func:`generate_world` gives up (RuntimeError)."""

BASE_POSITION = (0.0, 0.0, 0.3)
"""Robot base of the demo placement [m] (rpy :data:`navstack.truss.PAPER_BASE_RPY`)."""

TOLERANCE = 0.02
"""Goal tolerance written into generated worlds [m]."""

FloatArray = NDArray[np.float64]


# --------------------------------------------------------------------------- configuration / results


@dataclass(frozen=True)
class CheckConfig:
    """Thresholds of :func:`check_world` (metres unless noted)."""

    goal_clearance: float = 0.06
    """Every goal at least this far from every obstacle surface."""
    path_margin: float = 0.015
    """Reference tip path at least ``serpentine_radius + path_margin`` from every obstacle surface."""
    body_margin: float = 0.01
    """Surface clearance of the slithering chord chain's link capsules."""
    arm_margin: float = 0.03
    """Surface clearance of the arm capsules swept with the flange (J6)."""
    start_clearance: float = 0.05
    """PyBullet ``Scene.clearance`` of the robot at ``q0``."""
    min_turn_radius: float = 0.25
    """Smallest radius of curvature of the reference path."""
    max_inside_length: float = 1.1
    """Longest reference path from entering the structure's box to the last goal."""
    goal_reach: float = 0.9
    """The reference must pass within this fraction of each goal's tolerance."""
    structure_pad: float = 0.05
    """The structure's bounding box is grown by this much for the length rule."""
    path_sample: float = 0.002
    """Spacing of the reference path samples."""
    body_step: float = 0.01
    """Tip travel between evaluated chord chains, and spacing of samples on a capsule axis."""
    arm_sample: float = 0.02
    """Spacing of samples on the arm's capsule axes."""
    horizon: float = 0.5
    """Distances beyond this are reported as this value."""

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"CheckConfig.{name} must be a finite number, got {value!r}")
            if value < 0 or (value == 0 and name not in ("path_margin", "body_margin", "arm_margin")):
                raise ValueError(f"CheckConfig.{name} must be positive, got {value!r}")
        if self.goal_reach > 1.0:
            raise ValueError(f"CheckConfig.goal_reach must be at most 1, got {self.goal_reach!r}")


ReferencePath = GuidePath
"""A reference tip path: the goal spline through the via points (:class:`navstack.guide.GuidePath`)."""


@dataclass(frozen=True)
class CheckReport:
    """Outcome of :func:`check_world`: the measured quantities (metres) and the failed checks."""

    problems: tuple[str, ...]
    goal_clearance: float
    path_clearance: float
    body_clearance: float
    arm_clearance: float
    start_clearance: float | None
    min_turn_radius: float
    goal_miss: float
    inside_length: float
    insertion: float
    path_length: float

    @property
    def ok(self) -> bool:
        """True when every check passed."""
        return not self.problems

    def to_dict(self) -> dict[str, Any]:
        """The measured quantities, rounded to 0.1 mm, for ``extra.generator.checks``."""
        out: dict[str, Any] = {}
        for name in ("goal_clearance", "path_clearance", "body_clearance", "arm_clearance", "start_clearance",
                     "min_turn_radius", "goal_miss", "inside_length", "insertion", "path_length"):
            v = getattr(self, name)
            out[name] = None if v is None else round(float(v), 4)
        return out


# --------------------------------------------------------------------------- geometry


def reference_path(start: ArrayLike, heading: ArrayLike, via: ArrayLike,
                   sample: float = 0.002) -> ReferencePath:
    """The scripted planner's curve from ``start`` through ``via`` (k, 3) [m]: :func:`navstack.guide.goal_spline`.

    Raises:
        ValueError: wrong shapes, non-finite values, or a zero heading.
    """
    return goal_spline(start, heading, via, sample)


def _bounding_sphere(o: Obstacle) -> tuple[FloatArray, float]:
    if isinstance(o, Sphere):
        return o.center, o.radius
    if isinstance(o, Cylinder):
        return (o.p0 + o.p1) / 2.0, math.hypot(o.length / 2.0, o.radius)
    if isinstance(o, Box):
        return o.center, float(np.linalg.norm(o.half_extents))
    raise TypeError(type(o).__name__)


@numba.njit(cache=True)
def _cylinders_min(P, p0, u, L, r, out):  # pragma: no cover - jitted
    """out[i] = min(out[i], signed distance of P[i] to flat cylinders (p0, unit axis u, length L, r))."""
    for i in range(P.shape[0]):
        best = out[i]
        for m in range(p0.shape[0]):
            vx = P[i, 0] - p0[m, 0]
            vy = P[i, 1] - p0[m, 1]
            vz = P[i, 2] - p0[m, 2]
            t = vx * u[m, 0] + vy * u[m, 1] + vz * u[m, 2]
            rad = math.sqrt(max(vx * vx + vy * vy + vz * vz - t * t, 0.0))
            dr = rad - r[m]
            da = abs(t - 0.5 * L[m]) - 0.5 * L[m]
            if dr > 0.0 and da > 0.0:
                d = math.sqrt(dr * dr + da * da)
            else:
                d = max(dr, da)
            if d < best:
                best = d
        out[i] = best


@numba.njit(cache=True)
def _boxes_min(P, c, R, he, out):  # pragma: no cover - jitted
    """out[i] = min(out[i], signed distance of P[i] to boxes (centre c, rotation R (world <- box), he))."""
    for i in range(P.shape[0]):
        best = out[i]
        for m in range(c.shape[0]):
            vx = P[i, 0] - c[m, 0]
            vy = P[i, 1] - c[m, 1]
            vz = P[i, 2] - c[m, 2]
            outside = 0.0
            inside = -1e300
            for k in range(3):
                q = abs(vx * R[m, 0, k] + vy * R[m, 1, k] + vz * R[m, 2, k]) - he[m, k]
                if q > 0.0:
                    outside += q * q
                if q > inside:
                    inside = q
            d = math.sqrt(outside) if outside > 0.0 else inside
            if d < best:
                best = d
        out[i] = best


@numba.njit(cache=True)
def _spheres_min(P, c, r, out):  # pragma: no cover - jitted
    """out[i] = min(out[i], signed distance of P[i] to spheres (centre c, radius r))."""
    for i in range(P.shape[0]):
        best = out[i]
        for m in range(c.shape[0]):
            dx = P[i, 0] - c[m, 0]
            dy = P[i, 1] - c[m, 1]
            dz = P[i, 2] - c[m, 2]
            d = math.sqrt(dx * dx + dy * dy + dz * dz) - r[m]
            if d < best:
                best = d
        out[i] = best


def obstacle_distance(obstacles: tuple[Obstacle, ...] | list[Obstacle], points: ArrayLike,
                      horizon: float = 1.0) -> FloatArray:
    """Signed distance [m] from each of ``points`` (N, 3) to the nearest obstacle surface.

    Negative inside an obstacle; values beyond ``horizon`` are returned as ``horizon``.  Exact for
    spheres, boxes (with ``rpy``) and flat-ended cylinders.

    Raises:
        ValueError: a mesh obstacle (named by its index), or points not of shape (N, 3).
    """
    P = np.ascontiguousarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"obstacle_distance: points must have shape (N, 3), got {P.shape}")
    out = np.full(len(P), float(horizon))
    if len(P) == 0 or not obstacles:
        return out
    lo, hi = P.min(axis=0), P.max(axis=0)
    cyl, box, sph = [], [], []
    for i, o in enumerate(obstacles):
        if isinstance(o, Mesh):
            raise ValueError(f"obstacle_distance: obstacles[{i}] is a mesh; the generator's checks support "
                             f"cylinder, box and sphere obstacles only")
        c, r = _bounding_sphere(o)
        gap = float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - c, c - hi)))) - r
        if gap > horizon:
            continue
        (cyl if isinstance(o, Cylinder) else box if isinstance(o, Box) else sph).append(o)
    if cyl:
        p0 = np.array([o.p0 for o in cyl])
        ax = np.array([o.p1 for o in cyl]) - p0
        L = np.linalg.norm(ax, axis=1)
        _cylinders_min(P, p0, ax / L[:, None], L, np.array([o.radius for o in cyl]), out)
    if box:
        R = Rotation.from_euler("xyz", np.array([o.rpy for o in box])).as_matrix()
        _boxes_min(P, np.array([o.center for o in box]), np.ascontiguousarray(R),
                   np.array([o.half_extents for o in box]), out)
    if sph:
        _spheres_min(P, np.array([o.center for o in sph]), np.array([o.radius for o in sph]), out)
    return out


def _segment_samples(a: FloatArray, b: FloatArray, spacing: float) -> FloatArray:
    """Points every <= ``spacing`` on segments a[i] -> b[i] (both ends included), stacked (M, 3)."""
    out = []
    for p, q in zip(a, b, strict=True):
        n = max(int(np.ceil(np.linalg.norm(q - p) / spacing)), 1)
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        out.append(p + t * (q - p))
    return np.concatenate(out) if out else np.zeros((0, 3))


@dataclass(frozen=True)
class _Robot:
    """The robot of a world at ``q0``, in world coordinates."""

    tip: FloatArray
    heading: FloatArray
    backbone: FloatArray  # (7, 3) tip, J1..J6
    arm_frames: FloatArray  # (9, 3) origins of frames 1..9
    lathe_axis: FloatArray
    lathe_room: float
    serpentine_radius: float
    arm_radius: float


def _robot(world: World) -> _Robot:
    chain = jpl_serpentine()
    q0 = world.robot.q0
    T0 = world.robot.base.transform()
    F = T0 @ chain.frames(q0)
    return _Robot(
        tip=F[21, :3, 3].copy(),
        heading=F[20, :3, 0].copy(),
        backbone=F[list(BACKBONE_FRAMES), :3, 3].copy(),
        arm_frames=F[1:10, :3, 3].copy(),
        lathe_axis=T0[:3, 2].copy(),
        lathe_room=float(chain.upper[0] - q0[0]),
        serpentine_radius=world.robot.serpentine_radius,
        arm_radius=world.robot.arm_radius,
    )


def _slither(robot: _Robot, path: ReferencePath, step: float) -> FloatArray:
    """Chord chains (K, 7, 3) (tip, J1..J6) every ``step`` of tip travel along ``path``."""
    from navstack.path import PathMemory

    mem = PathMemory(robot.backbone, link_length=LINK_LENGTH)
    zero = np.zeros(3)
    chains = [robot.backbone.copy()]
    next_s = step
    for x, s in zip(path.points[1:], path.arc[1:], strict=True):
        mem.record(x)
        if s >= next_s or s == path.arc[-1]:
            pts, _ = mem.chain(x, zero)
            chains.append(np.vstack([x[None], pts]))
            next_s = s + step
    return np.array(chains)


def _structure_box(obstacles: tuple[Obstacle, ...]) -> tuple[FloatArray, FloatArray] | None:
    if not obstacles:
        return None
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for o in obstacles:
        if isinstance(o, Cylinder):
            pts = np.array([o.p0 - o.radius, o.p0 + o.radius, o.p1 - o.radius, o.p1 + o.radius])
        elif isinstance(o, Sphere):
            pts = np.array([o.center - o.radius, o.center + o.radius])
        elif isinstance(o, Box):
            R = Rotation.from_euler("xyz", o.rpy).as_matrix()
            ext = np.abs(R) @ o.half_extents
            pts = np.array([o.center - ext, o.center + ext])
        else:
            continue
        lo, hi = np.minimum(lo, pts.min(axis=0)), np.maximum(hi, pts.max(axis=0))
    return (lo, hi) if np.isfinite(lo).all() else None


@dataclass
class _Samples:
    """Everything the checks and the clutter placement measure against."""

    path: ReferencePath
    chains: FloatArray
    body: FloatArray  # capsule axis samples of every chain
    start_body: FloatArray  # capsule axis samples of the start chain
    arm: FloatArray  # swept arm axis samples
    arm_static: FloatArray  # arm axis samples at q0
    insertion: float


def _samples(robot: _Robot, via: FloatArray, cfg: CheckConfig) -> _Samples:
    path = reference_path(robot.tip, robot.heading, via, cfg.path_sample)
    chains = _slither(robot, path, cfg.body_step)
    a = chains[:, :-1].reshape(-1, 3)
    b = chains[:, 1:].reshape(-1, 3)
    n = max(int(np.ceil(LINK_LENGTH / cfg.body_step)), 1)
    t = np.linspace(0.0, 1.0, n + 1)[None, :, None]
    body = (a[:, None] + t * (b - a)[:, None]).reshape(-1, 3)
    start_body = body[: 6 * (n + 1)]
    af = robot.arm_frames
    keep = np.linalg.norm(np.diff(af, axis=0), axis=1) > 1e-9
    arm_static = _segment_samples(af[:-1][keep], af[1:][keep], cfg.arm_sample)
    disp = chains[:, -1] - chains[0, -1]
    # keep displacements at least arm_sample apart (the sweep is smooth)
    picked = [disp[0]]
    for d in disp[1:]:
        if np.linalg.norm(d - picked[-1]) >= cfg.arm_sample:
            picked.append(d)
    picked.append(disp[-1])
    arm = (arm_static[None] + np.array(picked)[:, None]).reshape(-1, 3)
    insertion = float(max(0.0, (disp @ robot.lathe_axis).max()))
    return _Samples(path, chains, body, start_body, arm, arm_static, insertion)


def start_clearance(world: World, max_distance: float = 0.5) -> float:
    """PyBullet clearance [m] of the robot at ``q0`` to the obstacles (``Scene.clearance``)."""
    from navstack.sim._bullet import direct_client
    from navstack.sim.body import RobotBody
    from navstack.sim.scene import Scene

    client = direct_client()
    try:
        body = RobotBody.build(client, jpl_serpentine(), world.robot.base.transform(),
                               serpentine_radius=world.robot.serpentine_radius,
                               arm_radius=world.robot.arm_radius)
        body.reset(world.robot.q0)
        scene = Scene.build(client, world)
        client.performCollisionDetection()
        return float(scene.clearance(body.body_id, max_distance))
    finally:
        client.disconnect()


def _check(world: World, via: FloatArray, structure: int, cfg: CheckConfig, robot: _Robot,
           samples: _Samples | None = None, pybullet_start: bool = True) -> CheckReport:
    obstacles = world.obstacles
    S = samples if samples is not None else _samples(robot, via, cfg)
    hz = cfg.horizon
    problems: list[str] = []
    goals = world.goal_positions
    gd = obstacle_distance(obstacles, goals, hz)
    goal_cl = float(gd.min())
    if goal_cl < cfg.goal_clearance:
        i = int(np.argmin(gd))
        problems.append(f"goals[{i}] is {goal_cl:.4f} m from an obstacle (< {cfg.goal_clearance} m)")
    pd = obstacle_distance(obstacles, S.path.points, hz)
    path_cl = float(pd.min())
    need = robot.serpentine_radius + cfg.path_margin
    if path_cl < need:
        i = int(np.argmin(pd))
        problems.append(f"reference path at s={S.path.arc[i]:.3f} m is {path_cl:.4f} m from an obstacle "
                        f"(< serpentine radius + margin = {need:.3f} m)")
    if S.path.min_turn_radius < cfg.min_turn_radius:
        problems.append(f"reference path turns with radius {S.path.min_turn_radius:.3f} m "
                        f"(< {cfg.min_turn_radius} m)")
    # goals reached in order within the tolerance
    miss = 0.0
    k = 0
    for i, g in enumerate(world.goals):
        d = np.linalg.norm(S.path.points[k:] - g.position, axis=1)
        inside = np.flatnonzero(d <= cfg.goal_reach * g.tolerance)
        if inside.size == 0:
            problems.append(f"reference path misses goals[{i}] by {d.min():.4f} m "
                            f"(> {cfg.goal_reach} x tolerance {g.tolerance} m)")
            miss = max(miss, float(d.min()))
            continue
        j = k + int(inside[0])
        miss = max(miss, float(d[inside].min()))
        k = j
    bd = obstacle_distance(obstacles, S.body, hz) - robot.serpentine_radius
    body_cl = float(bd.min())
    if body_cl < cfg.body_margin:
        problems.append(f"slithering body comes within {body_cl:.4f} m of an obstacle "
                        f"(< {cfg.body_margin} m)")
    ad = obstacle_distance(obstacles, S.arm, hz) - robot.arm_radius
    arm_cl = float(ad.min())
    if arm_cl < cfg.arm_margin:
        problems.append(f"arm swept along the insertion comes within {arm_cl:.4f} m of an obstacle "
                        f"(< {cfg.arm_margin} m)")
    inside_len = 0.0
    box = _structure_box(obstacles[:structure])
    if box is not None:
        lo, hi = box[0] - cfg.structure_pad, box[1] + cfg.structure_pad
        inb = np.flatnonzero(np.all((S.path.points >= lo) & (S.path.points <= hi), axis=1))
        if inb.size:
            inside_len = float(S.path.arc[-1] - S.path.arc[inb[0]])
    if inside_len > cfg.max_inside_length:
        problems.append(f"reference path runs {inside_len:.3f} m inside the structure "
                        f"(> {cfg.max_inside_length} m)")
    if S.insertion > robot.lathe_room:
        problems.append(f"the flange travels {S.insertion:.3f} m along the lathe bed, which has "
                        f"{robot.lathe_room:.3f} m left")
    start_cl = None
    if pybullet_start and not problems:
        start_cl = start_clearance(world)
        if start_cl < cfg.start_clearance:
            problems.append(f"robot at q0 is {start_cl:.4f} m from an obstacle (< {cfg.start_clearance} m)")
    return CheckReport(tuple(problems), goal_cl, path_cl, body_cl, arm_cl, start_cl, S.path.min_turn_radius,
                       miss, inside_len, S.insertion, S.path.length)


def check_world(world: World, via: ArrayLike | None = None, structure: int | None = None,
                config: CheckConfig | None = None) -> CheckReport:
    """Check that ``world`` is solvable in principle along its reference path (module docstring).

    Args:
        world: a world of cylinder, box and sphere obstacles.
        via: reference via points (k, 3) [m]; default ``extra.generator.reference_via`` if present,
            else the goals.
        structure: how many leading obstacles form the structure for the length rule; default
            ``extra.generator.structure_obstacles`` if present, else all.
        config: thresholds.

    The PyBullet start check runs only when every other check passed (it is the slowest).

    Raises:
        ValueError: a mesh obstacle, or malformed ``via`` / ``structure``.
    """
    cfg = config or CheckConfig()
    gen = world.extra.get("generator", {}) if isinstance(world.extra.get("generator"), dict) else {}
    if via is None:
        via = gen.get("reference_via", world.goal_positions)
    v = np.atleast_2d(np.asarray(via, dtype=np.float64))
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0 or not np.isfinite(v).all():
        raise ValueError(f"check_world: via must be finite points of shape (k, 3), got shape {v.shape}")
    if structure is None:
        structure = gen.get("structure_obstacles", len(world.obstacles))
    if isinstance(structure, bool) or not isinstance(structure, (int, np.integer)) or not (
            0 <= structure <= len(world.obstacles)):
        raise ValueError(f"check_world: structure must be an obstacle count in 0..{len(world.obstacles)}, "
                         f"got {structure!r}")
    for i, o in enumerate(world.obstacles):
        if isinstance(o, Mesh):
            raise ValueError(f"check_world: obstacles[{i}] is a mesh; only cylinder, box and sphere "
                             f"obstacles are supported")
    return _check(world, v, int(structure), cfg, _robot(world))


def with_reference_goals(world: World) -> World:
    """``world`` with its goals replaced by its reference via points (tolerance 0.02 m), name + ``-ref``.

    Running the scripted planner on it follows the reference path the checks proved feasible: a
    closed-loop demonstration that the world is solvable in principle (e.g. the way round a trap).
    """
    gen = world.extra.get("generator")
    via = gen.get("reference_via") if isinstance(gen, dict) else None
    if via is None:
        raise ValueError(f"with_reference_goals: world {world.name!r} has no extra.generator.reference_via")
    d = world.to_dict()
    d["name"] = world.name + "-ref"
    d["goals"] = [{"position": list(map(float, v)), "tolerance": TOLERANCE} for v in via]
    return world_from_dict(d)


# --------------------------------------------------------------------------- building blocks


def _r(v: ArrayLike) -> list[float]:
    """Round to 0.1 micrometre (as navstack.truss writes)."""
    return [round(float(x), 7) for x in np.asarray(v, dtype=np.float64).ravel()]


def _cyl(p0: ArrayLike, p1: ArrayLike, radius: float) -> dict[str, Any]:
    return {"type": "cylinder", "p0": _r(p0), "p1": _r(p1), "radius": round(float(radius), 7)}


def _box(center: ArrayLike, half: ArrayLike, rpy: ArrayLike = (0.0, 0.0, 0.0)) -> dict[str, Any]:
    return {"type": "box", "center": _r(center), "half_extents": _r(half), "rpy": _r(rpy)}


def _sphere(center: ArrayLike, radius: float) -> dict[str, Any]:
    return {"type": "sphere", "center": _r(center), "radius": round(float(radius), 7)}


def _robot_dict() -> dict[str, Any]:
    return {
        "base": {"position": _r(BASE_POSITION), "rpy": _r(PAPER_BASE_RPY)},
        "q0": _r(Q_DEFAULT),
        "serpentine_radius": 0.025,
        "arm_radius": 0.06,
    }


def _unit(rng: np.random.Generator) -> FloatArray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _perpendicular(rng: np.random.Generator, t: FloatArray) -> FloatArray:
    """A random unit vector perpendicular to the unit vector ``t``."""
    while True:
        v = rng.normal(size=3)
        v -= (v @ t) * t
        n = np.linalg.norm(v)
        if n > 1e-6:
            return v / n


@dataclass
class _Candidate:
    """One drawn world before the checks."""

    obstacles: list[dict[str, Any]]
    goals: FloatArray
    via: FloatArray
    structure: int
    params: dict[str, Any]
    description: str
    drawn: list[dict[str, Any]] | None = None  # truss as drawn (truss families)
    extra_checks: dict[str, Any] = field(default_factory=dict)


def _world(name: str, family: str | None, cand: _Candidate, extra: dict[str, Any],
           time_limit: float = 60.0) -> World:
    return world_from_dict({
        "format": "navstack-world/1",
        "name": name,
        "description": cand.description,
        **({"family": family} if family is not None else {}),
        "robot": _robot_dict(),
        "obstacles": cand.obstacles,
        "goals": [{"position": _r(g), "tolerance": TOLERANCE} for g in cand.goals],
        "time_limit": time_limit,
        "extra": extra,
    })


_TIP, _HEADING = robot_tip_start(BASE_POSITION, PAPER_BASE_RPY)


# --------------------------------------------------------------------------- truss


@dataclass(frozen=True)
class TrussLayout:
    """A truss world as drawn and as built.

    Attributes:
        side: bay side [m]; member_radius [m]; bays (nx, ny, nz).
        standoff: distance [m] from the start tip to the entry opening's centre.
        entry: ``"br"`` (bottom-right triangle of the front face) or ``"tl"`` (top-left).
        manoeuvre: ``"climb"``, ``"through"`` or ``"side"``.
        goals_local: (k, 3) goals [m] in the entry bay's frame (front face x = 0, bay [0, side]^3).
        offset: displacement [m] of the actual truss from its drawing.
        rpy: rotation [rad] of the actual truss about the entry opening's centre (roll X, pitch Y, yaw Z).
    """

    side: float
    member_radius: float
    bays: tuple[int, int, int]
    standoff: float
    entry: str
    manoeuvre: str
    goals_local: FloatArray
    offset: FloatArray
    rpy: FloatArray

    def entry_point(self) -> FloatArray:
        """Centre of the entry opening in the entry bay's frame [m]."""
        c = incircle_offset(self.side)
        s = self.side
        return np.array([0.0, s - c, c]) if self.entry == "br" else np.array([0.0, c, s - c])

    def build(self) -> tuple[list[dict[str, Any]], list[dict[str, Any]], FloatArray, FloatArray]:
        """Actual members, drawn members, goals (drawn, world) and the goals carried with the actual truss."""
        nx, ny, nz = self.bays
        entry_bay = np.array([0, ny // 2, nz - 1], dtype=float) * self.side
        entry_local = entry_bay + self.entry_point()
        origin = _TIP + self.standoff * _HEADING - entry_local
        pivot = origin + entry_local
        R = Rotation.from_euler("xyz", self.rpy).as_matrix()
        goals = self.goals_local + entry_bay + origin
        moved = (goals - pivot) @ R.T + pivot + self.offset
        actual, drawn = [], []
        for p0, p1 in truss_members(self.bays, self.side):
            a, b = origin + p0, origin + p1
            drawn.append(_cyl(a, b, self.member_radius))
            actual.append(_cyl(R @ (a - pivot) + pivot + self.offset, R @ (b - pivot) + pivot + self.offset,
                               self.member_radius))
        return actual, drawn, goals, moved


def _truss_goals(rng: np.random.Generator, side: float, entry: str, manoeuvre: str, nx: int) -> FloatArray:
    """Goals in the entry bay's frame for one manoeuvre (see the module docstring)."""
    c = incircle_offset(side)
    y_e, z_e = (side - c, c) if entry == "br" else (c, side - c)
    approach = np.array([-rng.uniform(0.1, 0.2), y_e, z_e])
    if manoeuvre == "through":
        mid = np.array([side / 2 + rng.uniform(-0.05, 0.05), y_e + rng.uniform(-0.02, 0.02),
                        z_e + rng.uniform(-0.02, 0.02)])
        depth = side + rng.uniform(0.12, 0.25) if nx == 1 else side + rng.uniform(0.2, 0.3)
        end = np.array([depth, y_e + rng.uniform(-0.03, 0.03), z_e + rng.uniform(-0.03, 0.03)])
        return np.array([approach, mid, end])
    # arc radius R from x = a; the turn must end >= ~0.09 m before the back face x = side
    room = side - 0.09
    R = rng.uniform(0.28, min(0.36, room)) if manoeuvre == "climb" else rng.uniform(0.3, min(0.38, room))
    a = rng.uniform(0.0, max(0.0, min(0.06, room - R)))
    phi1 = np.radians(rng.uniform(18.0, 32.0))
    phi2 = np.radians(rng.uniform(55.0, 72.0))
    if manoeuvre == "climb":
        arc = [np.array([a + R * np.sin(p), y_e, z_e + R * (1 - np.cos(p))]) for p in (phi1, phi2)]
        top = max(side + rng.uniform(0.12, 0.25), z_e + R + 0.03)
        # the second arc goal only where it is well inside the bay or well above it
        keep = arc if abs(arc[1][2] - side) > 0.08 else arc[:1]
        return np.array([approach, *keep, [a + R, y_e, top]])
    # side: a horizontal arc towards the near side face (y = side for "br", y = 0 for "tl"), crossing it
    # between two goals placed ~0.09 m before and after the face
    sign = 1.0 if entry == "br" else -1.0
    to_face = side - y_e if sign > 0 else y_e
    phis = [np.radians(rng.uniform(15.0, 25.0))]
    for rise in (to_face - rng.uniform(0.095, 0.11), to_face + rng.uniform(0.095, 0.12)):
        if 0.0 < rise < R:
            phi = float(np.arccos(1.0 - rise / R))
            if phi - phis[-1] < np.radians(8.0):
                phis.pop()
            phis.append(phi)
    arc = [np.array([a + R * np.sin(p), y_e + sign * R * (1 - np.cos(p)), z_e]) for p in phis]
    end = np.array([a + R, y_e + sign * (R + rng.uniform(0.08, 0.15)), z_e])
    return np.array([approach, *arc, end])


def _draw_truss(rng: np.random.Generator, difficulty: float) -> TrussLayout:
    side = round(0.5 - 0.08 * difficulty, 4)
    member = round(0.02 + 0.005 * difficulty, 4)
    nx = 2 if rng.random() < 0.3 else 1
    manoeuvre = str(rng.choice(["climb", "through", "side"], p=[0.45, 0.2, 0.35]))
    # the top-left opening leaves too little room for a climb or a side turn of radius >= 0.25 m
    entry = "tl" if manoeuvre == "through" and rng.random() < 0.5 else "br"
    goals = _truss_goals(rng, side, entry, manoeuvre, nx)
    offset = _unit(rng) * 0.06 * difficulty * rng.uniform(0.6, 1.0)
    angle = np.radians(3.0) * difficulty * rng.uniform(0.6, 1.0)
    rpy = Rotation.from_rotvec(_unit(rng) * angle).as_euler("xyz")
    return TrussLayout(side=side, member_radius=member, bays=(nx, 3, 2),
                       standoff=round(rng.uniform(0.45, 0.6), 4),
                       entry=entry, manoeuvre=manoeuvre, goals_local=goals, offset=offset, rpy=rpy)


def _reachable_via(goals: FloatArray, moved: FloatArray, reach: float) -> FloatArray:
    """Goals moved towards where the actual truss carries them, by at most ``reach`` [m]."""
    d = moved - goals
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return goals + d * np.minimum(1.0, reach / np.maximum(n, 1e-12))


def _truss_candidate(layout: TrussLayout, cfg: CheckConfig) -> _Candidate:
    actual, drawn, goals, moved = layout.build()
    via = _reachable_via(goals, moved, cfg.goal_reach * TOLERANCE - 1e-3)
    params = {
        "side": layout.side, "member_radius": layout.member_radius, "bays": list(layout.bays),
        "standoff": layout.standoff, "entry": layout.entry, "manoeuvre": layout.manoeuvre,
        "truss_offset": _r(layout.offset), "truss_rpy": _r(layout.rpy),
        "offset_norm": round(float(np.linalg.norm(layout.offset)), 5),
        "rotation_deg": round(float(np.degrees(Rotation.from_euler("xyz", layout.rpy).magnitude())), 4),
    }
    nx, ny, nz = layout.bays
    desc = (f"Box-bay truss ({nx}x{ny}x{nz} bays of {layout.side} m, members "
            f"of radius {layout.member_radius} m); manoeuvre '{layout.manoeuvre}' through the "
            f"{'bottom-right' if layout.entry == 'br' else 'top-left'} opening.  Goals are drawn positions; "
            f"the actual truss is displaced {params['offset_norm']:.3f} m and rotated "
            f"{params['rotation_deg']:.2f} deg "
            f"from its drawing.")
    return _Candidate(obstacles=actual, goals=goals, via=via, structure=len(actual), params=params,
                      description=desc, drawn=drawn)


# --------------------------------------------------------------------------- clutter placement


@dataclass
class _Guard:
    """Point sets an added obstacle must keep away from, with the distance each needs [m]."""

    sets: list[tuple[FloatArray, float]]

    def clear(self, obstacle: dict[str, Any]) -> bool:
        o = world_from_dict({"format": "navstack-world/1", "name": "probe", "robot": {},
                             "obstacles": [obstacle], "goals": [{"position": [0, 0, 0]}]}).obstacles
        return all(float(obstacle_distance(o, pts, need + 1.0).min()) >= need for pts, need in self.sets)


def _guard(samples: list[_Samples], goals: FloatArray, robot: _Robot, cfg: CheckConfig,
           extra: float = 0.005) -> _Guard:
    sets: list[tuple[FloatArray, float]] = [(goals, cfg.goal_clearance + extra)]
    for S in samples:
        sets += [
            (S.path.points, robot.serpentine_radius + cfg.path_margin + extra),
            (S.body, robot.serpentine_radius + cfg.body_margin + extra),
            (S.start_body, robot.serpentine_radius + cfg.start_clearance + extra),
            (S.arm, robot.arm_radius + cfg.arm_margin + extra),
            (S.arm_static, robot.arm_radius + cfg.start_clearance + extra),
        ]
    return _Guard(sets)


def _near_path(rng: np.random.Generator, path: ReferencePath, s_from: float) -> tuple[FloatArray, FloatArray]:
    """A random point of ``path`` beyond arc length ``s_from`` and a random unit normal there."""
    idx = np.flatnonzero(path.arc >= min(s_from, path.arc[-1] * 0.5))
    i = int(rng.choice(idx))
    j = min(i + 1, len(path.points) - 1)
    k = max(j - 2, 0)
    t = path.points[j] - path.points[k]
    t /= np.linalg.norm(t)
    return path.points[i], _perpendicular(rng, t)


def _cable(rng: np.random.Generator, path: ReferencePath, dist: float, s_from: float) -> dict[str, Any]:
    p, n = _near_path(rng, path, s_from)
    r = rng.uniform(0.005, 0.01)
    axis = _perpendicular(rng, n)
    length = rng.uniform(0.4, 1.0)
    centre = p + (dist + r) * n + axis * rng.uniform(-0.25, 0.25) * length
    return _cyl(centre - axis * length / 2, centre + axis * length / 2, r)


def _equipment(rng: np.random.Generator, path: ReferencePath, dist: float, s_from: float) -> dict[str, Any]:
    p, n = _near_path(rng, path, s_from)
    half = rng.uniform(0.03, 0.1, size=3)
    rpy = np.array([0.0, 0.0, rng.uniform(-np.pi, np.pi)])
    R = Rotation.from_euler("xyz", rpy).as_matrix()
    support = float(np.abs(R.T @ n) @ half)
    return _box(p + (dist + support) * n, half, rpy)


def _ball(rng: np.random.Generator, path: ReferencePath, dist: float, s_from: float) -> dict[str, Any]:
    p, n = _near_path(rng, path, s_from)
    r = rng.uniform(0.04, 0.12)
    return _sphere(p + (dist + r) * n, r)


def _place(rng: np.random.Generator, make, count: int, guard: _Guard,
           tries: int = 25) -> list[dict[str, Any]]:
    out = []
    for _ in range(count):
        for _ in range(tries):
            o = make()
            if guard.clear(o):
                out.append(o)
                guard.sets.append((_surface_probe(o), 0.0))  # no overlap with what was already placed
                break
    return out


def _surface_probe(o: dict[str, Any]) -> FloatArray:
    """A few points inside an obstacle so later ones do not overlap it (cheap, approximate)."""
    if o["type"] == "cylinder":
        return _segment_samples(np.array([o["p0"]]), np.array([o["p1"]]), 0.05)
    return np.array([o["center"]])


# --------------------------------------------------------------------------- families


def _gen_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig, robot: _Robot,
               clutter: bool) -> _Candidate:
    cand = _truss_candidate(_draw_truss(rng, difficulty), cfg)
    if not clutter:
        return cand
    s_ref = _samples(robot, cand.via, cfg)
    s_drawn = _samples(robot, cand.goals, cfg)
    guard = _guard([s_ref, s_drawn], cand.goals, robot, cfg)
    s_from = 0.25
    spread = 0.02 + 0.12 * (1.0 - difficulty)
    need = robot.serpentine_radius + cfg.body_margin + 0.01

    def dist() -> float:
        return need + rng.uniform(0.0, spread)

    paths = [s_ref.path, s_drawn.path]
    n_cables = 1 + int(round(3 * difficulty)) + int(rng.integers(0, 2))
    n_boxes = 1 + int(round(2 * difficulty))
    def pick() -> ReferencePath:
        return paths[int(rng.integers(0, 2))]

    cables = _place(rng, lambda: _cable(rng, pick(), dist(), s_from), n_cables, guard)
    boxes = _place(rng, lambda: _equipment(rng, pick(), dist(), s_from), n_boxes, guard)
    cand.obstacles = cand.obstacles + cables + boxes
    cand.params.update({"cables": len(cables), "boxes": len(boxes)})
    cand.description += (f"  Unmodelled clutter near the path: {len(cables)} cable(s) and {len(boxes)} "
                         f"equipment box(es).")
    return cand


def _smooth_goals(draw, cfg: CheckConfig, tries: int = 30) -> FloatArray:
    """Call ``draw()`` until its goals give a reference path with turn radius >= the minimum (or give up
    and return the last draw; the full check then rejects it)."""
    for _ in range(tries):
        goals = draw()
        if reference_path(_TIP, _HEADING, goals, 4 * cfg.path_sample).min_turn_radius >= cfg.min_turn_radius:
            break
    return goals


def _gen_pipe_rack(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                   robot: _Robot) -> _Candidate:
    n_layers = 3 if rng.random() < 0.3 + 0.6 * difficulty else 2
    spacing = rng.uniform(0.3, 0.35) if n_layers == 3 else rng.uniform(0.3, 0.4)
    x1 = _TIP[0] + rng.uniform(0.35, 0.45)
    # alternating crossings +-amp; a turn radius >= 0.25 m allows about amp <= 0.3 spacing^2
    amp = min(0.3 * spacing**2, 0.025 + 0.03 * difficulty) * rng.uniform(0.6, 1.0)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    gap = 0.13 + 0.12 * (1.0 - difficulty) + rng.uniform(-0.01, 0.01)

    def draw() -> FloatArray:
        crossings = []
        for k in range(n_layers):
            z = _TIP[2] + sign * amp * (1.0 if k % 2 == 0 else -1.0) + rng.uniform(-0.01, 0.01)
            crossings.append([x1 + k * spacing, _TIP[1] + rng.uniform(-0.03, 0.03), z])
        final = [crossings[-1][0] + rng.uniform(0.12, 0.2), _TIP[1] + rng.uniform(-0.03, 0.03),
                 _TIP[2] + rng.uniform(-0.03, 0.03)]
        return np.array([*crossings, final])

    goals = _smooth_goals(draw, cfg)
    crossings = goals[:-1]
    obstacles = []
    half_len = 0.6
    for x, y, z in crossings:
        rp = rng.uniform(0.025, 0.045)
        yaw = np.radians(rng.uniform(-10.0, 10.0))
        axis = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        levels = []
        for direction in (1.0, -1.0):
            zc = z + direction * (gap / 2 + rp)
            while abs(zc - _TIP[2]) <= 0.38:
                levels.append(zc)
                zc += direction * (2 * rp + rng.uniform(0.04, 0.12))
        for zc in sorted(levels):
            c = np.array([x, y, zc])
            obstacles.append(_cyl(c - half_len * axis, c + half_len * axis, rp))
    params = {"layers": n_layers, "layer_spacing": round(spacing, 4), "amplitude": round(amp, 4),
              "gap": round(gap, 4), "first_layer_x": round(x1, 4)}
    desc = (f"Pipe rack: {n_layers} layers of horizontal pipes {spacing:.2f} m apart; the free gap "
            f"({gap:.3f} m) "
            f"around the path alternates up and down by about {amp:.3f} m so the tip weaves; goals between "
            f"the pipes and behind the rack.")
    return _Candidate(obstacles=obstacles, goals=goals, via=goals, structure=len(obstacles), params=params,
                      description=desc)


def _gen_sphere_field(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                      robot: _Robot) -> _Candidate:
    n_via = int(rng.integers(2, 4))
    total = rng.uniform(0.9, 1.15)
    # a smooth bump of height amp (in a random direction across the heading) that the spheres on the
    # straight line start -> final goal force the tip through; a bump amp (1 - cos)/2 over `total` turns
    # with radius total^2 / (2 pi^2 amp) >= 0.29 m for amp <= 0.14 m
    amp = rng.uniform(0.11, 0.12 + 0.02 * difficulty)
    ang = rng.uniform(0.0, 2.0 * np.pi)
    across = np.array([0.0, np.cos(ang), np.sin(ang)])
    end_off = np.array([0.0, *rng.uniform(-0.04, 0.04, size=2)])

    def draw() -> FloatArray:
        base = np.linspace(0.0, 1.0, n_via + 2)[1:-1]
        fr = np.append(base + rng.uniform(-0.04, 0.04, size=n_via), 1.0)
        bump = amp * (1 - np.cos(2 * np.pi * fr)) / 2
        return np.array([_TIP + np.array([total * f, 0.0, 0.0]) + b * across + f * f * end_off
                         for f, b in zip(fr, bump, strict=True)])

    goals = _smooth_goals(draw, cfg)
    S = _samples(robot, goals, cfg)
    guard = _guard([S], goals, robot, cfg)
    need = robot.serpentine_radius + cfg.body_margin + 0.01
    spread = 0.03 + 0.12 * (1.0 - difficulty)
    n_near = 4 + int(round(8 * difficulty))
    near = _place(rng, lambda: _ball(rng, S.path, need + rng.uniform(0.0, spread), 0.3), n_near, guard)
    n_block = 1 + int(round(2 * difficulty))
    line0, line1 = _TIP, goals[-1]

    def blocker() -> dict[str, Any]:
        f = rng.uniform(0.35, 0.65)
        return _sphere(line0 + f * (line1 - line0), rng.uniform(0.025, 0.06))

    block = _place(rng, blocker, n_block, guard)
    obstacles = block + near
    params = {"via_goals": n_via, "length": round(total, 4), "amplitude": round(amp, 4),
              "spheres": len(obstacles), "blockers": len(block)}
    desc = (f"Sphere field: {len(obstacles)} spheres around a random goal path ({n_via} via goals on a "
            f"{amp:.2f} m bump, final goal {total:.2f} m ahead), {len(block)} of them on the straight line "
            f"to "
            f"the final goal.")
    return _Candidate(obstacles=obstacles, goals=goals, via=goals, structure=len(obstacles), params=params,
                      description=desc)


# --------------------------------------------------------------------------- entry point


def _check_args(family: Any, seed: Any, difficulty: Any) -> tuple[str, int, float]:
    if not isinstance(family, str) or family not in _REGISTERED:
        raise ValueError(f"family must be one of {', '.join(_REGISTERED)}; got {family!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    real = (int, float, np.integer, np.floating)
    number = isinstance(difficulty, real) and not isinstance(difficulty, bool)
    if not (number and math.isfinite(float(difficulty)) and 0.0 <= float(difficulty) <= 1.0):
        raise ValueError(f"difficulty must be a number in [0, 1], got {difficulty!r}")
    return family, int(seed), float(difficulty)


def world_name(family: str, seed: int, difficulty: float) -> str:
    """``family-sNNNN-dD.DD`` (more digits when the difficulty needs them)."""
    d = f"{difficulty:.2f}"
    if abs(float(d) - difficulty) > 1e-12:
        d = f"{difficulty:.6f}".rstrip("0")
    return f"{family}-s{seed:04d}-d{d}"


def family_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig, robot: _Robot) -> _Candidate:
    return _gen_truss(rng, difficulty, cfg, robot, clutter=False)


def family_cluttered_truss(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                           robot: _Robot) -> _Candidate:
    return _gen_truss(rng, difficulty, cfg, robot, clutter=True)


def family_pipe_rack(rng: np.random.Generator, difficulty: float, cfg: CheckConfig, robot: _Robot) -> _Candidate:
    return _gen_pipe_rack(rng, difficulty, cfg, robot)


def family_sphere_field(rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
                        robot: _Robot) -> _Candidate:
    return _gen_sphere_field(rng, difficulty, cfg, robot)


def _candidate(family: str, rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
               robot: _Robot) -> _Candidate:
    from navstack.registry import load

    return load(_REGISTERED[family].factory)(rng, difficulty, cfg, robot)


def _finish(cand: _Candidate, name: str, family: str | None, cfg: CheckConfig, robot: _Robot,
            generator: dict[str, Any]) -> tuple[World | None, CheckReport | None, str]:
    """Check a candidate; the world (or None) and why it failed."""
    extra = {"generator": {**generator, **cand.params, "reference_via": [_r(v) for v in cand.via],
                           "structure_obstacles": cand.structure}}
    world = _world(name, family, cand, extra)
    via = np.array(extra["generator"]["reference_via"])
    drawn_clearance = None
    if cand.drawn is not None:
        as_drawn = _Candidate(cand.drawn, cand.goals, cand.goals, len(cand.drawn), {}, "")
        drawn = _world(name, family, as_drawn, {})
        drawn_samples = _samples(robot, cand.goals, cfg)
        rep = _check(drawn, cand.goals, len(cand.drawn), cfg, robot, drawn_samples, pybullet_start=False)
        if not rep.ok:
            return None, rep, "drawing: " + "; ".join(rep.problems)
        # the slithering body along the path through the drawn goals, against the actual obstacles
        drawn_clearance = float(obstacle_distance(world.obstacles, drawn_samples.body, cfg.horizon).min()
                                - robot.serpentine_radius)
    rep = _check(world, via, cand.structure, cfg, robot)
    if not rep.ok:
        return None, rep, "; ".join(rep.problems)
    extra["generator"]["checks"] = rep.to_dict()
    if drawn_clearance is not None:
        extra["generator"]["drawn_path_clearance"] = round(drawn_clearance, 4)
    time_limit = float(max(60.0, math.ceil(3.0 * rep.path_length / 0.06)))
    return _world(name, family, cand, extra, time_limit), rep, ""


def generate_world(family: str, seed: int, difficulty: float = 0.5) -> World:
    """A random world of ``family`` (one of :data:`FAMILIES`), deterministic in its arguments.

    Args:
        family: ``truss``, ``cluttered-truss``, ``pipe-rack`` or ``sphere-field``.
        seed: non-negative integer.
        difficulty: 0 (easy) .. 1 (hard): truss displacement and narrower openings, more and closer
            clutter, narrower pipe gaps, denser spheres.

    The world's ``name`` is ``family-sNNNN-dD.DD``, ``family`` is set, and ``extra.generator`` holds
    the arguments, ``version``, the sub-seed ``attempt`` that passed, the drawn parameters, the
    reference via points, the structure's obstacle count and the measured check values.

    Raises:
        ValueError: unknown family, negative or non-integer seed, difficulty outside [0, 1].
        RuntimeError: no sub-seed passed the checks within :data:`MAX_ATTEMPTS` (a generator bug).
    """
    family, seed, difficulty = _check_args(family, seed, difficulty)
    cfg = CheckConfig()
    robot = _robot(world_from_dict({"format": "navstack-world/1", "name": "robot", "robot": _robot_dict(),
                                    "obstacles": [], "goals": [{"position": _r(_TIP)}]}))
    name = world_name(family, seed, difficulty)
    last = ""
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng([GENERATOR_VERSION, _REGISTERED[family].seed_id, seed, attempt])
        cand = _candidate(family, rng, difficulty, cfg, robot)
        generator = {"family": family, "seed": seed, "difficulty": difficulty, "version": GENERATOR_VERSION,
                     "attempt": attempt}
        world, _, why = _finish(cand, name, family, cfg, robot, generator)
        if world is not None:
            return world
        last = why
    raise RuntimeError(f"generate_world({family!r}, {seed}, {difficulty}): no candidate passed the checks in "
                       f"{MAX_ATTEMPTS} attempts; last failure: {last}")


# --------------------------------------------------------------------------- fixed worlds for the issue


def _fixed(cand: _Candidate, name: str, family: str | None, note: str) -> World:
    cfg = CheckConfig()
    robot = _robot(world_from_dict({"format": "navstack-world/1", "name": "robot", "robot": _robot_dict(),
                                    "obstacles": [], "goals": [{"position": _r(_TIP)}]}))
    world, _, why = _finish(cand, name, family, cfg, robot, {"fixed": name, "version": GENERATOR_VERSION,
                                                             "note": note})
    if world is None:
        raise RuntimeError(f"fixed world {name} fails its checks: {why}")
    return world


def truss_displaced_world() -> World:
    """The paper's truss displaced 0.046 m and rotated 3 deg from its drawing; goals at drawn positions.

    Of the 26 x 13 grid directions of a 0.046 m offset and a 3 deg rotation, this one (offset along -y,
    rotation about (1, 0, -1)) brings the actual truss closest to the path through the drawn goals
    (0.029 m surface clearance of the serpentine) while a path through the actual opening stays feasible.
    """
    offset = np.array([0.0, -0.046, 0.0])
    rpy = Rotation.from_rotvec(np.radians(3.0) * np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)).as_euler("xyz")
    drawn = paper_truss_world()
    actual = paper_truss_world(truss_offset=offset, truss_rpy=rpy)
    goals = np.array([g["position"] for g in drawn["goals"]])
    # the goals carried with the actual truss: the same rigid motion about the entry opening's centre
    pivot = _TIP + 0.55 * _HEADING
    R = Rotation.from_euler("xyz", rpy).as_matrix()
    moved = (goals - pivot) @ R.T + pivot + offset
    via = _reachable_via(goals, moved, CheckConfig().goal_reach * TOLERANCE - 1e-3)
    angle = np.degrees(Rotation.from_euler("xyz", rpy).magnitude())
    desc = (f"The paper's truss, actually displaced {np.linalg.norm(offset):.3f} m and rotated "
            f"{angle:.1f} deg from its drawing; the goals are where the drawing puts them (issue: uncertain "
            f"workspace).")
    cand = _Candidate(obstacles=actual["obstacles"], goals=goals, via=via, structure=len(actual["obstacles"]),
                      params={"truss_offset": _r(offset), "truss_rpy": _r(rpy)}, description=desc,
                      drawn=drawn["obstacles"])
    return _fixed(cand, "truss-displaced", "truss", "paper truss displaced from its drawing")


def truss_clutter_world() -> World:
    """The paper's truss with an unmodelled cable in front of it and an equipment box inside the bay."""
    paper = paper_truss_world()
    goals = np.array([g["position"] for g in paper["goals"]])
    side, c = 0.5, incircle_offset(0.5)
    entry = _TIP + 0.55 * _HEADING  # centre of the entry opening
    bay0 = entry - np.array([0.0, side - c, c])  # entry bay's (0, 0, 0) corner
    cable = _cyl(entry + np.array([-0.32, -0.085, -0.45]), entry + np.array([-0.22, -0.075, 0.45]), 0.008)
    box = _box(bay0 + np.array([0.43, side - c + 0.02, 0.26]), (0.05, 0.07, 0.06), (0.0, 0.0, 0.3))
    cand = _Candidate(obstacles=paper["obstacles"] + [cable, box], goals=goals, via=goals,
                      structure=len(paper["obstacles"]), params={},
                      description=("The paper's truss with unmodelled clutter near the path: a cable hanging "
                                   "beside the approach and an equipment box on the entry bay's back face, "
                                   "beside the climb."))
    return _fixed(cand, "truss-clutter", "cluttered-truss", "paper truss + unmodelled cable and box")


def u_trap_world() -> World:
    """A U of boxes opening towards the robot, the goal behind it; the way round is over the top."""
    x0, y0, z0 = _TIP
    mouth, depth, half_w, wall = x0 + 0.5, 0.3, 0.16, 0.04
    z_lo, z_hi = z0 - 0.22, z0 + 0.12
    zc, hz = (z_lo + z_hi) / 2, (z_hi - z_lo) / 2
    back = _box((mouth + depth + wall / 2, y0, zc), (wall / 2, half_w + wall, hz))
    left = _box((mouth + depth / 2, y0 - half_w - wall / 2, zc), (depth / 2, wall / 2, hz))
    right = _box((mouth + depth / 2, y0 + half_w + wall / 2, zc), (depth / 2, wall / 2, hz))
    goal = np.array([mouth + depth + wall + 0.22, y0, z0 + 0.08])
    via = np.array([[mouth - 0.02, y0, z0 + 0.2], [mouth + depth + wall / 2, y0, z0 + 0.2], goal])
    desc = ("A U-shaped trap of three boxes (back wall and two side walls, open upwards, downwards and "
            "towards the robot) straight ahead of the tip; the goal is behind the back wall.  Heading "
            "straight for the goal leads into the U; the way round is over the top (reference via points in "
            "extra.generator.reference_via).")
    cand = _Candidate(obstacles=[back, left, right], goals=goal[None], via=via, structure=3, params={},
                      description=desc)
    return _fixed(cand, "u-trap", "u-trap", "local-minimum trap for a potential-field planner")


ISSUE_PIPE_RACK = ("pipe-rack", 7, 0.6)
"""(family, seed, difficulty) of ``worlds/pipe_rack.json``."""


def pipe_rack_world() -> World:
    """The generated pipe rack of :data:`ISSUE_PIPE_RACK`, renamed ``pipe-rack``."""
    w = generate_world(*ISSUE_PIPE_RACK)
    d = w.to_dict()
    d["name"] = "pipe-rack"
    d["extra"]["generator"]["fixed"] = "pipe-rack"
    return world_from_dict(d)


def write_issue_worlds(folder: str | Path) -> list[Path]:
    """Write the fixed worlds of the sensor-planner issue into ``folder`` (created if missing).

    ``truss_displaced.json``, ``truss_clutter.json``, ``u_trap.json`` and ``pipe_rack.json``; each passes
    :func:`check_world`.  Returns the written paths.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for fname, make in (("truss_displaced.json", truss_displaced_world),
                        ("truss_clutter.json", truss_clutter_world),
                        ("u_trap.json", u_trap_world), ("pipe_rack.json", pipe_rack_world)):
        path = out / fname
        save_world(make(), path)
        written.append(path)
    return written


__all__ = [
    "FAMILIES",
    "GENERATOR_VERSION",
    "CheckConfig",
    "CheckReport",
    "ReferencePath",
    "TrussLayout",
    "check_world",
    "generate_world",
    "obstacle_distance",
    "pipe_rack_world",
    "reference_path",
    "start_clearance",
    "truss_clutter_world",
    "truss_displaced_world",
    "u_trap_world",
    "world_name",
    "with_reference_goals",
    "write_issue_worlds",
]
