"""Shared by the families whose goals do not mark the way (``slot-rack``, ``sparse-truss``,
``bend-clutter``, ``dead-end``, ``fin-bank``, ``rod-forest``).

Their worlds give only an entry point and a destination (or an inspection point and an exit); the way
between them is proven by a hidden reference path through reference via points that each family
constructs (samples of a curvature-bounded curve).  They check with the user's clearance for every link
(:data:`SPARSE_CHECKS`: ``body_margin`` 12 mm), and :data:`BLOCKED_DEPTH` makes
:func:`navstack.generate.build.finish` discard a candidate whose goals alone would lead the scripted
planner through; :func:`block_goal_path` places a blocker where the structure alone does not.  Units: metres, radians.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from navstack.generate.base import HEADING, TIP, Guard, place
from navstack.generate.checks import CheckConfig, ReferencePath, RobotStart, Samples, reference_path
from navstack.generate.geometry import FloatArray, cylinder_dict, perpendicular, rounded, sphere_dict
from navstack.world import Obstacle, world_from_dict

__all__ = [
    "BLOCKED_DEPTH",
    "SPARSE_CHECKS",
    "arc_at",
    "ball_between",
    "block_goal_path",
    "box_on_axes",
    "cable_between",
    "cross_axes",
    "obstacles_of",
    "point_between",
    "sparse_config",
]

SPARSE_CHECKS: dict[str, float] = {"body_margin": 0.012}
"""Stricter :class:`CheckConfig` fields: every link keeps 12 mm, as in the user's worlds."""

BLOCKED_DEPTH = 0.005
"""The body slithering along the spline through the goals alone must cut this deep [m] into an obstacle."""


def sparse_config(cfg: CheckConfig) -> CheckConfig:
    """``cfg`` with :data:`SPARSE_CHECKS` applied."""
    return replace(cfg, **SPARSE_CHECKS)


def obstacles_of(dicts: list[dict[str, Any]]) -> tuple[Obstacle, ...]:
    """Obstacle dicts as validated obstacles (for :func:`obstacle_distance`)."""
    return world_from_dict({"format": "navstack-world/1", "name": "probe", "robot": {}, "obstacles": dicts,
                            "goals": [{"position": [0.0, 0.0, 0.0]}]}).obstacles


def cross_axes(u: FloatArray, roll: float) -> tuple[FloatArray, FloatArray]:
    """Unit vectors ``a`` (at angle ``roll`` [rad] about ``u`` from the horizontal) and ``n = u x a``.

    For ``u`` along +x, ``roll`` 0 gives ``a`` = +y (horizontal) and ``n`` = +z; pi/2 gives ``a`` = +z.
    """
    up = np.array([0.0, 0.0, 1.0])
    e1 = np.cross(up, u)
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.cross(np.array([0.0, 1.0, 0.0]), u)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    a = np.cos(roll) * e1 + np.sin(roll) * e2
    return a, np.cross(u, a)


def box_on_axes(center: ArrayLike, axes: FloatArray, half: ArrayLike) -> dict[str, Any]:
    """A box whose local x, y, z axes are the columns of the rotation ``axes`` (3, 3)."""
    rpy = Rotation.from_matrix(axes).as_euler("xyz")
    return {"type": "box", "center": rounded(center), "half_extents": rounded(half), "rpy": rounded(rpy)}


def arc_at(path: ReferencePath, origin: FloatArray, u: FloatArray, x: float) -> float:
    """Arc length [m] where ``path`` first passes the plane ``(p - origin) . u = x``."""
    along = (path.points - origin) @ u
    i = int(np.argmax(along >= x)) if (along >= x).any() else len(along) - 1
    return float(path.arc[i])


def point_between(rng: np.random.Generator, path: ReferencePath, s_lo: float,
                  s_hi: float) -> tuple[FloatArray, FloatArray]:
    """A random point of ``path`` between arc lengths ``s_lo`` and ``s_hi`` [m] (the nearest to their
    middle if none), and a random unit vector across the path there."""
    idx = np.flatnonzero((path.arc >= s_lo) & (path.arc <= s_hi))
    if idx.size == 0:
        idx = np.array([int(np.searchsorted(path.arc, 0.5 * (s_lo + s_hi)).clip(0, len(path.arc) - 1))])
    i = int(rng.choice(idx))
    j, k = min(i + 1, len(path.points) - 1), max(i - 1, 0)
    t = path.points[j] - path.points[k]
    return path.points[i], perpendicular(rng, t / np.linalg.norm(t))


def ball_between(rng: np.random.Generator, path: ReferencePath, s_lo: float, s_hi: float, dist: float,
                 radius: tuple[float, float]) -> dict[str, Any]:
    """A sphere (radius drawn from ``radius`` [m]) whose surface is ``dist`` [m] from a random point of
    ``path`` between arc lengths ``s_lo`` and ``s_hi``, in a random direction across the path."""
    p, n = point_between(rng, path, s_lo, s_hi)
    r = rng.uniform(*radius)
    return sphere_dict(p + (dist + r) * n, r)


def cable_between(rng: np.random.Generator, path: ReferencePath, s_lo: float, s_hi: float,
                  dist: float) -> dict[str, Any]:
    """A cable (radius 5-10 mm, 0.4-1 m long, across the path) whose surface is ``dist`` [m] from a random
    point of ``path`` between arc lengths ``s_lo`` and ``s_hi``."""
    p, n = point_between(rng, path, s_lo, s_hi)
    r = rng.uniform(0.005, 0.01)
    axis = perpendicular(rng, n)
    length = rng.uniform(0.4, 1.0)
    centre = p + (dist + r) * n + axis * rng.uniform(-0.25, 0.25) * length
    return cylinder_dict(centre - axis * length / 2, centre + axis * length / 2, r)


def block_goal_path(rng: np.random.Generator, goals: FloatArray, reference: Samples, guard: Guard,
                    robot: RobotStart, s_from: float = 0.25, tries: int = 40) -> list[dict[str, Any]]:
    """A sphere (radius 0.02-0.05 m, "unmodelled equipment") that the tip on the spline through ``goals``
    alone would cut :data:`BLOCKED_DEPTH` + 5 mm to 20 mm into, placed where that spline is far enough from
    the reference path for ``guard`` to accept it; ``[]`` when no such place is found in ``tries`` draws."""
    goal_path = reference_path(TIP, HEADING, goals, 0.01)
    near_ref = np.array([np.linalg.norm(reference.path.points[::5] - q, axis=1).min() for q in goal_path.points])
    far = np.flatnonzero((goal_path.arc >= s_from) & (near_ref >= 0.06))
    if far.size == 0:
        return []
    ref_pts = reference.path.points[::5]

    def blocker() -> dict[str, Any]:
        q = goal_path.points[int(rng.choice(far))]
        v = q - ref_pts[int(np.argmin(np.linalg.norm(ref_pts - q, axis=1)))]
        v /= np.linalg.norm(v)
        r = rng.uniform(0.02, 0.05)
        cut = robot.serpentine_radius - BLOCKED_DEPTH - rng.uniform(0.005, 0.02)  # surface this far from q
        return sphere_dict(q + (r + cut) * v, r)

    return place(rng, blocker, 1, guard, tries=tries)
