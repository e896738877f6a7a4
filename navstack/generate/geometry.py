"""Exact distances to obstacle primitives, and the obstacle dicts the families write.

:func:`obstacle_distance` is the one distance the checks and the clutter placement use: the signed
distance from points to flat-ended cylinders, boxes (with ``rpy``) and spheres, in numba kernels.
The ``*_dict`` builders write obstacles in the ``navstack-world/1`` form, rounded to 0.1 micrometre
(as :mod:`navstack.truss` writes).  Units: metres, radians.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from navstack.world import Box, Cylinder, Mesh, Obstacle, Sphere

FloatArray = NDArray[np.float64]

__all__ = [
    "FloatArray",
    "box_dict",
    "cylinder_dict",
    "obstacle_distance",
    "perpendicular",
    "rounded",
    "segment_samples",
    "sphere_dict",
    "unit_vector",
]


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


def segment_samples(a: FloatArray, b: FloatArray, spacing: float) -> FloatArray:
    """Points every <= ``spacing`` on segments a[i] -> b[i] (both ends included), stacked (M, 3)."""
    out = []
    for p, q in zip(a, b, strict=True):
        n = max(int(np.ceil(np.linalg.norm(q - p) / spacing)), 1)
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        out.append(p + t * (q - p))
    return np.concatenate(out) if out else np.zeros((0, 3))


# --------------------------------------------------------------------------- obstacle dicts


def rounded(v: ArrayLike) -> list[float]:
    """Round to 0.1 micrometre (as navstack.truss writes)."""
    return [round(float(x), 7) for x in np.asarray(v, dtype=np.float64).ravel()]


def cylinder_dict(p0: ArrayLike, p1: ArrayLike, radius: float) -> dict[str, Any]:
    """A flat-ended cylinder from ``p0`` to ``p1`` [m] of ``radius`` [m]."""
    return {"type": "cylinder", "p0": rounded(p0), "p1": rounded(p1), "radius": round(float(radius), 7)}


def box_dict(center: ArrayLike, half: ArrayLike, rpy: ArrayLike = (0.0, 0.0, 0.0)) -> dict[str, Any]:
    """A box: ``center`` [m], half extents ``half`` [m], orientation ``rpy`` [rad]."""
    return {"type": "box", "center": rounded(center), "half_extents": rounded(half), "rpy": rounded(rpy)}


def sphere_dict(center: ArrayLike, radius: float) -> dict[str, Any]:
    """A sphere: ``center`` [m], ``radius`` [m]."""
    return {"type": "sphere", "center": rounded(center), "radius": round(float(radius), 7)}


def unit_vector(rng: np.random.Generator) -> FloatArray:
    """A random unit vector (uniform on the sphere)."""
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def perpendicular(rng: np.random.Generator, t: FloatArray) -> FloatArray:
    """A random unit vector perpendicular to the unit vector ``t``."""
    while True:
        v = rng.normal(size=3)
        v -= (v @ t) * t
        n = np.linalg.norm(v)
        if n > 1e-6:
            return v / n
