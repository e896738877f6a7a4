"""Exact signed distances between the robot's capsules and primitive obstacles, in numpy.

PyBullet gives boxes and cylinders a collision margin of 1 mm (:data:`MARGIN`) that rounds their corners,
edges and rims: its shape is the primitive shrunk by the margin, then grown by a ball of that radius.  That
rounded shape lies inside the true one, so PyBullet's distance is never less than the true distance and
exceeds it by at most (sqrt 3 - 1) x 1 mm = 0.73 mm at a box corner, 0.41 mm at an edge or a rim (faces,
spheres and capsules are exact).  A link that far into a corner touches the obstacle unseen.  Setting the
margin to zero is not an option: PyBullet's rays then miss boxes altogether.

So :class:`navstack.sim.scene.Scene` asks this module again whenever PyBullet reports a link within
:data:`MARGIN` of a primitive: a capsule (segment ``a``-``b`` swept by radius ``r``) is at signed distance
``min over t in [0, 1] of sdf(a + t (b - a)) - r`` from a convex obstacle, where ``sdf`` is the obstacle's
signed distance function (negative inside).  ``sdf`` of a convex set is convex along any line, so a golden
section search finds that minimum; :data:`GOLDEN_STEPS` steps narrow ``t`` to below 1e-12 of the segment.
For a capsule that crosses the obstacle the value is negative (the deepest of its balls, less ``r``), which
is all a contact needs.

Geometry as :mod:`navstack.sim.scene` builds it (metres): a box is ``center``, ``half_extents`` and the
rotation ``rpy`` (roll X, pitch Y, yaw Z about the world axes); a cylinder is flat-ended from ``p0`` to
``p1``; a sphere is ``center`` and ``radius``.  A moving obstacle is translated by ``shift``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from navstack.world import Box, Cylinder, Obstacle, Sphere

MARGIN = 1e-3
"""PyBullet's collision margin of boxes and cylinders (m): the most by which its distance to them can exceed
the true one is below this, so a reported distance above it is positive for certain."""

GOLDEN_STEPS = 64
"""Golden-section steps over the segment parameter: 0.618^64 < 1e-13 of the segment's length."""

_INV_PHI = (math.sqrt(5.0) - 1.0) / 2.0


def signed_distance(o: Obstacle, points: NDArray[np.float64], shift: NDArray[np.float64] | None = None,
                    ) -> NDArray[np.float64]:
    """Signed distance (m, negative inside) from each of ``points`` ((..., 3) [m]) to the primitive ``o``,
    translated by ``shift`` ((3,) [m]) if given.  Exact: boxes and cylinders with sharp corners and rims.

    Raises:
        TypeError: ``o`` is not a box, cylinder or sphere (a mesh has no closed form here).
    """
    return _sdf(o, shift)(np.asarray(points, dtype=np.float64))


def _sdf(o: Obstacle, shift: NDArray[np.float64] | None) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """:func:`signed_distance` to ``o`` as a function of the points, its constants computed once."""
    move = np.zeros(3) if shift is None else np.asarray(shift, dtype=np.float64)
    if isinstance(o, Sphere):
        centre = o.center + move
        return lambda x: np.linalg.norm(x - centre, axis=-1) - o.radius
    if isinstance(o, Box):
        centre, rot = o.center + move, Rotation.from_euler("xyz", o.rpy).as_matrix()
        return lambda x: _outside_inside(np.abs((x - centre) @ rot) - o.half_extents)  # rows: R^T (x - c)
    if isinstance(o, Cylinder):
        axis, mid, half = (o.p1 - o.p0) / o.length, (o.p0 + o.p1) / 2.0 + move, o.length / 2.0

        def cylinder(x: NDArray[np.float64]) -> NDArray[np.float64]:
            along = (x - mid) @ axis
            radial = np.linalg.norm(x - mid - along[..., None] * axis, axis=-1)
            return _outside_inside(np.stack([radial - o.radius, np.abs(along) - half], axis=-1))
        return cylinder
    raise TypeError(f"signed_distance: not a primitive obstacle: {type(o).__name__}")


def _outside_inside(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The signed distance of an intersection of slabs from its per-axis excesses ``q`` (..., k) [m]."""
    return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)


def capsule_distance(o: Obstacle, a: NDArray[np.float64], b: NDArray[np.float64], r: NDArray[np.float64],
                     shift: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Signed distance (m) between each capsule (segment ``a[k]``-``b[k]``, each (K, 3) [m], radius ``r[k]``
    (K,) [m]) and the primitive ``o`` (translated by ``shift``): negative when they overlap."""
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    d = np.atleast_2d(np.asarray(b, dtype=np.float64)) - a

    sdf = _sdf(o, shift)

    def f(t: NDArray[np.float64]) -> NDArray[np.float64]:
        return sdf(a + t[:, None] * d)

    lo, hi = np.zeros(len(a)), np.ones(len(a))
    x1, x2 = hi - _INV_PHI, lo + _INV_PHI  # lo < x1 < x2 < hi
    f1, f2 = f(x1), f(x2)
    for _ in range(GOLDEN_STEPS):  # keep the side whose inner point is lower (f convex: the minimum is there)
        left = f1 <= f2
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x_new = np.where(left, hi - _INV_PHI * (hi - lo), lo + _INV_PHI * (hi - lo))
        f_new = f(x_new)
        x1, x2 = np.where(left, x_new, x2), np.where(left, x1, x_new)
        f1, f2 = np.where(left, f_new, f2), np.where(left, f1, f_new)
    best = np.minimum(np.minimum(f1, f2), np.minimum(f(np.zeros(len(a))), f(np.ones(len(a)))))
    return best - np.asarray(r, dtype=np.float64)
