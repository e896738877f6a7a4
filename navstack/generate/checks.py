"""The feasibility checks of generated worlds (see :mod:`navstack.generate` for the list).

:func:`check_world` re-checks a world (also a saved one) along its reference tip path: the cubic spline
through the reference via points that :func:`reference_path` builds, slithered by the chord chain of
:class:`navstack.path.PathMemory`.  Thresholds are in :class:`CheckConfig`, measured values in
:class:`CheckReport`.  Units: metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from navstack.generate.geometry import FloatArray, obstacle_distance, segment_samples
from navstack.guide import GuidePath, goal_spline
from navstack.jpl import BACKBONE_FRAMES, LINK_LENGTH, jpl_serpentine
from navstack.validate import in_range, non_negative, positive
from navstack.world import Box, Cylinder, LinearMotion, Mesh, Obstacle, Sphere, World

__all__ = [
    "CheckConfig",
    "CheckReport",
    "ReferencePath",
    "RobotStart",
    "Samples",
    "check_world",
    "path_samples",
    "reference_path",
    "robot_start",
    "run_checks",
    "settled",
    "slither_chains",
    "start_clearance",
    "structure_box",
]


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
        positive(self, "goal_clearance", "start_clearance", "min_turn_radius", "max_inside_length", "structure_pad",
                 "path_sample", "body_step", "arm_sample", "horizon")
        non_negative(self, "path_margin", "body_margin", "arm_margin")
        in_range(self, "goal_reach", lo=0.0, hi=1.0, lo_open=True)


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



def reference_path(start: ArrayLike, heading: ArrayLike, via: ArrayLike,
                   sample: float = 0.002) -> ReferencePath:
    """The scripted planner's curve from ``start`` through ``via`` (k, 3) [m]: :func:`navstack.guide.goal_spline`.

    Raises:
        ValueError: wrong shapes, non-finite values, or a zero heading.
    """
    return goal_spline(start, heading, via, sample)


@dataclass(frozen=True)
class RobotStart:
    """The robot of a world at ``q0``, in world coordinates."""

    tip: FloatArray
    heading: FloatArray
    backbone: FloatArray  # (7, 3) tip, J1..J6
    arm_frames: FloatArray  # (9, 3) origins of frames 1..9
    lathe_axis: FloatArray
    lathe_room: float
    serpentine_radius: float
    arm_radius: float


def robot_start(world: World) -> RobotStart:
    """The robot of ``world`` at ``q0`` in world coordinates (forward kinematics of the base and ``q0``)."""
    chain = jpl_serpentine()
    q0 = world.robot.q0
    T0 = world.robot.base.transform()
    F = T0 @ chain.frames(q0)
    return RobotStart(
        tip=F[21, :3, 3].copy(),
        heading=F[20, :3, 0].copy(),
        backbone=F[list(BACKBONE_FRAMES), :3, 3].copy(),
        arm_frames=F[1:10, :3, 3].copy(),
        lathe_axis=T0[:3, 2].copy(),
        lathe_room=float(chain.upper[0] - q0[0]),
        serpentine_radius=world.robot.serpentine_radius,
        arm_radius=world.robot.arm_radius,
    )


def slither_chains(robot: RobotStart, path: ReferencePath, step: float) -> FloatArray:
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


def structure_box(obstacles: tuple[Obstacle, ...]) -> tuple[FloatArray, FloatArray] | None:
    """Axis-aligned bounding box (lo, hi) [m] of ``obstacles`` (None when there are none)."""
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
class Samples:
    """Everything the checks and the clutter placement measure against."""

    path: ReferencePath
    chains: FloatArray
    body: FloatArray  # capsule axis samples of every chain
    start_body: FloatArray  # capsule axis samples of the start chain
    arm: FloatArray  # swept arm axis samples
    arm_static: FloatArray  # arm axis samples at q0
    insertion: float


def path_samples(robot: RobotStart, via: FloatArray, cfg: CheckConfig) -> Samples:
    """Reference path through ``via``, its chord chains, and the capsule and arm axis samples [m]."""
    path = reference_path(robot.tip, robot.heading, via, cfg.path_sample)
    chains = slither_chains(robot, path, cfg.body_step)
    a = chains[:, :-1].reshape(-1, 3)
    b = chains[:, 1:].reshape(-1, 3)
    n = max(int(np.ceil(LINK_LENGTH / cfg.body_step)), 1)
    t = np.linspace(0.0, 1.0, n + 1)[None, :, None]
    body = (a[:, None] + t * (b - a)[:, None]).reshape(-1, 3)
    start_body = body[: 6 * (n + 1)]
    af = robot.arm_frames
    keep = np.linalg.norm(np.diff(af, axis=0), axis=1) > 1e-9
    arm_static = segment_samples(af[:-1][keep], af[1:][keep], cfg.arm_sample)
    disp = chains[:, -1] - chains[0, -1]
    # keep displacements at least arm_sample apart (the sweep is smooth)
    picked = [disp[0]]
    for d in disp[1:]:
        if np.linalg.norm(d - picked[-1]) >= cfg.arm_sample:
            picked.append(d)
    picked.append(disp[-1])
    arm = (arm_static[None] + np.array(picked)[:, None]).reshape(-1, 3)
    insertion = float(max(0.0, (disp @ robot.lathe_axis).max()))
    return Samples(path, chains, body, start_body, arm, arm_static, insertion)


def start_clearance(world: World, max_distance: float = 0.5) -> float:
    """PyBullet clearance [m] of the robot at ``q0`` to the obstacles (``Scene.clearance``)."""
    from navstack.sim.probe import start_scene

    with start_scene(world) as (body, scene):
        return float(scene.clearance(body.body_id, max_distance))


def settled(obstacles: tuple[Obstacle, ...]) -> tuple[Obstacle, ...]:
    """Every obstacle where its motion ends: a ``linear`` motion's obstacle translated by its displacement at
    ``stop``, without the motion (a door that has slid away); the others as they are.

    Raises:
        ValueError: an obstacle whose motion never ends (``oscillate``, or ``linear`` without ``stop``),
            naming it.
    """
    out = []
    for i, o in enumerate(obstacles):
        m = getattr(o, "motion", None)
        if m is None:
            out.append(o)
            continue
        if not isinstance(m, LinearMotion) or not math.isfinite(m.stop):
            raise ValueError(f"check_world: obstacles[{i}] moves without end ({m.type} motion); the checks take "
                             f"only motions that stop (linear with a stop)")
        d = m.displacement(m.stop)
        if isinstance(o, Cylinder):
            out.append(replace(o, p0=o.p0 + d, p1=o.p1 + d, motion=None))
        else:
            out.append(replace(o, center=o.center + d, motion=None))
    return tuple(out)


def run_checks(world: World, via: FloatArray, structure: int, cfg: CheckConfig, robot: RobotStart,
               samples: Samples | None = None, pybullet_start: bool = True) -> CheckReport:
    """Checks 1-6 of :mod:`navstack.generate` along the path through ``via`` (given ``samples`` reused):
    1-5 against the obstacles where their motions end (:func:`settled`), 6 (the start) at t = 0."""
    obstacles = settled(world.obstacles)
    S = samples if samples is not None else path_samples(robot, via, cfg)
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
    box = structure_box(obstacles[:structure])
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


def _stored_config(overrides: Any) -> CheckConfig:
    """:class:`CheckConfig` with the fields in ``overrides`` (a dict from ``extra.generator.check_config``)."""
    if not isinstance(overrides, dict):
        raise ValueError(f"check_world: extra.generator.check_config must be an object, got {overrides!r}")
    try:
        return CheckConfig(**overrides)
    except TypeError as e:
        raise ValueError(f"check_world: extra.generator.check_config: {e}") from e


def check_world(world: World, via: ArrayLike | None = None, structure: int | None = None,
                config: CheckConfig | None = None) -> CheckReport:
    """Check that ``world`` is solvable in principle along its reference path (module docstring).

    Args:
        world: a world of cylinder, box and sphere obstacles.
        via: reference via points (k, 3) [m]; default ``extra.generator.reference_via`` if present,
            else the goals.
        structure: how many leading obstacles form the structure for the length rule; default
            ``extra.generator.structure_obstacles`` if present, else all.
        config: thresholds; default :class:`CheckConfig` with the stricter values a family stored in
            ``extra.generator.check_config`` (e.g. ``body_margin`` 0.012 m for the sparse-goal families).

    The PyBullet start check runs only when every other check passed (it is the slowest).  A
    ``retract`` world's way back passes through the same configurations in reverse order (the tip
    retraces the path, every joint point stays on it), so the same checks cover it.

    Moving obstacles are checked where their motions end (:func:`settled`: a door once it has slid away); the
    start at t = 0.

    Raises:
        ValueError: a mesh obstacle, an obstacle whose motion never ends, or malformed ``via`` / ``structure``
            / ``check_config``.
    """
    gen = world.extra.get("generator", {}) if isinstance(world.extra.get("generator"), dict) else {}
    cfg = config or _stored_config(gen.get("check_config", {}))
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
    return run_checks(world, v, int(structure), cfg, robot_start(world))
