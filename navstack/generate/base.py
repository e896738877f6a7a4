"""Shared building blocks of the families: the robot placement, candidates, worlds and clutter placement.

Every family draws a :class:`Candidate` (obstacle dicts, goals, reference via points, parameters)
around the robot of the paper's demo placement (:data:`BASE_POSITION`, rpy
:data:`navstack.truss.PAPER_BASE_RPY`; tip at :data:`TIP` heading :data:`HEADING`).  Clutter is placed
with :func:`place`: a random obstacle is kept only when a :class:`Guard` says it keeps the clearances
the checks need around one or more reference paths.  Units: metres, radians.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from navstack.generate.checks import CheckConfig, ReferencePath, RobotStart, Samples, reference_path, robot_start
from navstack.generate.geometry import (
    FloatArray,
    box_dict,
    cylinder_dict,
    obstacle_distance,
    perpendicular,
    rounded,
    segment_samples,
    sphere_dict,
)
from navstack.jpl import Q_DEFAULT
from navstack.truss import PAPER_BASE_RPY, robot_tip_start
from navstack.world import World, world_from_dict

__all__ = [
    "BASE_POSITION",
    "GENERATOR_VERSION",
    "HEADING",
    "SERPENTINE_RADIUS",
    "TIP",
    "TOLERANCE",
    "Candidate",
    "Guard",
    "ball",
    "build_world",
    "cable",
    "default_robot",
    "equipment",
    "make_guard",
    "near_path",
    "place",
    "robot_dict",
    "smooth_goals",
    "surface_probe",
    "with_reference_goals",
]

GENERATOR_VERSION = 1
"""Stored in ``extra.generator.version``; bumped when the same arguments give different worlds."""

BASE_POSITION = (0.0, 0.0, 0.3)
"""Robot base of the demo placement [m] (rpy :data:`navstack.truss.PAPER_BASE_RPY`)."""

TOLERANCE = 0.02
"""Goal tolerance written into generated worlds [m]."""

TIP, HEADING = robot_tip_start(BASE_POSITION, PAPER_BASE_RPY)
"""Start tip position [m] and unit heading of the demo placement (tip at (1.8085, 0.1079, 1.1668), +x)."""


SERPENTINE_RADIUS = 0.025
"""The serpentine's capsule radius [m] of every family but those that draw their own
(``Candidate.serpentine_radius``)."""


def robot_dict(serpentine_radius: float | None = None) -> dict[str, Any]:
    """The ``robot`` object of every generated world (the demo placement, default posture and radii; the
    serpentine's radius ``serpentine_radius`` [m] when given)."""
    return {
        "base": {"position": rounded(BASE_POSITION), "rpy": rounded(PAPER_BASE_RPY)},
        "q0": rounded(Q_DEFAULT),
        "serpentine_radius": SERPENTINE_RADIUS if serpentine_radius is None else float(serpentine_radius),
        "arm_radius": 0.06,
    }


def default_robot() -> RobotStart:
    """The robot of :func:`robot_dict` at ``q0`` (what the families build around)."""
    return robot_start(world_from_dict({"format": "navstack-world/1", "name": "robot", "robot": robot_dict(),
                                        "obstacles": [], "goals": [{"position": rounded(TIP)}]}))


@dataclass
class Candidate:
    """One drawn world before the checks.

    Attributes:
        obstacles: obstacle dicts (``navstack-world/1``), the structure's first.
        goals: (k, 3) goals [m]; via: (m, 3) reference via points [m].
        structure: how many leading obstacles form the structure (length rule).
        params: drawn parameters, stored in ``extra.generator``.
        description: the world's description.
        drawn: the truss as drawn (truss families): the path through the goals is also checked against it.
        checks: :class:`CheckConfig` fields this family makes stricter (stored in
            ``extra.generator.check_config``; :func:`check_world` re-applies them).
        blocked_depth: when set [m], the goals must not mark the way: the body slithering along the
            spline through the goals alone must penetrate an obstacle by at least this much
            (``extra.generator.goal_path_clearance <= -blocked_depth``), else the candidate is discarded.
        retract: the family's default for the world's ``retract`` key.
        serpentine_radius: the robot's serpentine radius [m] this candidate was drawn for (written into the
            world's ``robot`` and used by the checks), ``None``: :data:`SERPENTINE_RADIUS`.
    """

    obstacles: list[dict[str, Any]]
    goals: FloatArray
    via: FloatArray
    structure: int
    params: dict[str, Any]
    description: str
    drawn: list[dict[str, Any]] | None = None
    checks: dict[str, float] = field(default_factory=dict)
    blocked_depth: float | None = None
    retract: bool = False
    serpentine_radius: float | None = None


def build_world(name: str, family: str | None, cand: Candidate, extra: dict[str, Any],
                time_limit: float = 60.0, retract: bool = False) -> World:
    """The world of a candidate (goals with tolerance :data:`TOLERANCE`)."""
    return world_from_dict({
        "format": "navstack-world/1",
        "name": name,
        "description": cand.description,
        **({"family": family} if family is not None else {}),
        **({"retract": True} if retract else {}),
        "robot": robot_dict(cand.serpentine_radius),
        "obstacles": cand.obstacles,
        "goals": [{"position": rounded(g), "tolerance": TOLERANCE} for g in cand.goals],
        "time_limit": time_limit,
        "extra": extra,
    })


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


# --------------------------------------------------------------------------- clutter placement


@dataclass
class Guard:
    """Point sets an added obstacle must keep away from, with the distance each needs [m]."""

    sets: list[tuple[FloatArray, float]]

    def clear(self, obstacle: dict[str, Any]) -> bool:
        o = world_from_dict({"format": "navstack-world/1", "name": "probe", "robot": {},
                             "obstacles": [obstacle], "goals": [{"position": [0, 0, 0]}]}).obstacles
        return all(float(obstacle_distance(o, pts, need + 1.0).min()) >= need for pts, need in self.sets)


def make_guard(samples: list[Samples], goals: FloatArray, robot: RobotStart, cfg: CheckConfig,
               extra: float = 0.005) -> Guard:
    """A guard keeping the clearances of checks 1-3, 5 and 6 (plus ``extra`` [m]) around ``samples``."""
    sets: list[tuple[FloatArray, float]] = [(goals, cfg.goal_clearance + extra)]
    for S in samples:
        sets += [
            (S.path.points, robot.serpentine_radius + cfg.path_margin + extra),
            (S.body, robot.serpentine_radius + cfg.body_margin + extra),
            (S.start_body, robot.serpentine_radius + cfg.start_clearance + extra),
            (S.arm, robot.arm_radius + cfg.arm_margin + extra),
            (S.arm_static, robot.arm_radius + cfg.start_clearance + extra),
        ]
    return Guard(sets)


def near_path(rng: np.random.Generator, path: ReferencePath, s_from: float) -> tuple[FloatArray, FloatArray]:
    """A random point of ``path`` beyond arc length ``s_from`` and a random unit normal there."""
    idx = np.flatnonzero(path.arc >= min(s_from, path.arc[-1] * 0.5))
    i = int(rng.choice(idx))
    j = min(i + 1, len(path.points) - 1)
    k = max(j - 2, 0)
    t = path.points[j] - path.points[k]
    t /= np.linalg.norm(t)
    return path.points[i], perpendicular(rng, t)


def cable(rng: np.random.Generator, path: ReferencePath, dist: float, s_from: float) -> dict[str, Any]:
    """An unmodelled cable (radius 5-10 mm, 0.4-1 m long) whose surface is ``dist`` [m] from a path point."""
    p, n = near_path(rng, path, s_from)
    r = rng.uniform(0.005, 0.01)
    axis = perpendicular(rng, n)
    length = rng.uniform(0.4, 1.0)
    centre = p + (dist + r) * n + axis * rng.uniform(-0.25, 0.25) * length
    return cylinder_dict(centre - axis * length / 2, centre + axis * length / 2, r)


def equipment(rng: np.random.Generator, path: ReferencePath, dist: float, s_from: float) -> dict[str, Any]:
    """An equipment box (half extents 3-10 cm, random yaw) whose face is ``dist`` [m] from a path point."""
    p, n = near_path(rng, path, s_from)
    half = rng.uniform(0.03, 0.1, size=3)
    rpy = np.array([0.0, 0.0, rng.uniform(-np.pi, np.pi)])
    R = Rotation.from_euler("xyz", rpy).as_matrix()
    support = float(np.abs(R.T @ n) @ half)
    return box_dict(p + (dist + support) * n, half, rpy)


def ball(rng: np.random.Generator, path: ReferencePath, dist: float, s_from: float) -> dict[str, Any]:
    """A sphere (radius 4-12 cm) whose surface is ``dist`` [m] from a path point."""
    p, n = near_path(rng, path, s_from)
    r = rng.uniform(0.04, 0.12)
    return sphere_dict(p + (dist + r) * n, r)


def place(rng: np.random.Generator, make: Callable[[], dict[str, Any]], count: int, guard: Guard,
          tries: int = 25, ok: Callable[[dict[str, Any]], bool] | None = None) -> list[dict[str, Any]]:
    """Up to ``count`` obstacles from ``make()`` that ``guard`` accepts, and ``ok`` if given (``tries`` draws
    each)."""
    out = []
    for _ in range(count):
        for _ in range(tries):
            o = make()
            if guard.clear(o) and (ok is None or ok(o)):
                out.append(o)
                guard.sets.append((surface_probe(o), 0.0))  # no overlap with what was already placed
                break
    return out


def surface_probe(o: dict[str, Any]) -> FloatArray:
    """A few points inside an obstacle so later ones do not overlap it (cheap, approximate)."""
    if o["type"] == "cylinder":
        return segment_samples(np.array([o["p0"]]), np.array([o["p1"]]), 0.05)
    return np.array([o["center"]])


def smooth_goals(draw: Callable[[], FloatArray], cfg: CheckConfig, tries: int = 30) -> FloatArray:
    """Call ``draw()`` until its goals give a reference path with turn radius >= the minimum (or give up
    and return the last draw; the full check then rejects it)."""
    for _ in range(tries):
        goals = draw()
        if reference_path(TIP, HEADING, goals, 4 * cfg.path_sample).min_turn_radius >= cfg.min_turn_radius:
            break
    return goals


