"""Exact signed distances between the robot's capsules and primitive obstacles, in numpy.

PyBullet gives boxes and cylinders a collision margin of 1 mm (:data:`MARGIN`) that rounds their corners,
edges and rims: its shape is the primitive shrunk by the margin, then grown by a ball of that radius.  That
rounded shape lies inside the true one, so PyBullet's distance exceeds the true distance by at most
(sqrt 3 - 1) x 1 mm = 0.73 mm at a box corner, 0.41 mm at an edge or a rim (faces, spheres and capsules are
exact), and is never less, except for a box or cylinder thinner than the margin, which reads up to 1.9 mm
less (:data:`navstack.sim.scene.THIN_SLACK`).  A link that far into a corner touches the obstacle unseen.  Setting the
margin to zero is not an option: PyBullet's rays then miss boxes altogether.

So :class:`navstack.sim.scene.Scene` measures again whenever PyBullet's distance is within :data:`MARGIN` of
0 (a contact could hide there) or of the trial's smallest clearance so far (which makes ``min_clearance``
exact): a capsule (segment ``a``-``b`` swept by radius ``r``) is at signed distance
``min over t in [0, 1] of sdf(a + t (b - a)) - r`` from a convex obstacle, where ``sdf`` is the obstacle's
signed distance function (negative inside).  ``sdf`` of a convex set is convex along any line, so a golden
section search finds that minimum; :data:`GOLDEN_STEPS` steps narrow ``t`` to below 1e-13 of the segment.
For a capsule that crosses the obstacle the value is negative (the deepest of its balls, less ``r``), which
is all a contact needs.

:func:`signed_distance` and :func:`capsule_distance` are the numpy reference (tests check them against closed
forms, dense sampling and PyBullet's exact faces); :func:`member_distances` is the
same arithmetic compiled, which the scene runs (about 2 us for five capsules against 1 ms in numpy).

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

from navstack.jit import kernel
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


# ---- compiled: the same distances for the scene's per-step checks ----------------------------------------

SPHERE, BOX, CYLINDER = 0, 1, 2
"""Kinds in :func:`primitive_row`'s rows."""

ROW = 17
"""A primitive's row: kind, centre (3), rotation R (3 x 3, row-major; world = R local), sizes (3)."""


def primitive_row(o: Obstacle) -> NDArray[np.float64]:
    """``o`` (box, cylinder or sphere) as one (:data:`ROW`,) row for :func:`member_distances`: a sphere's
    sizes are (radius, 0, 0), a box's its half extents, a cylinder's (radius, 0, half length) about its
    local z axis (the axis from ``p0`` to ``p1``)."""
    row = np.zeros(ROW)
    if isinstance(o, Sphere):
        row[0], row[1:4], row[4:13], row[13] = SPHERE, o.center, np.eye(3).ravel(), o.radius
    elif isinstance(o, Box):
        row[0], row[1:4], row[13:16] = BOX, o.center, o.half_extents
        row[4:13] = Rotation.from_euler("xyz", o.rpy).as_matrix().ravel()
    elif isinstance(o, Cylinder):
        z = (o.p1 - o.p0) / o.length
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
        x /= np.linalg.norm(x)
        row[0], row[1:4], row[13], row[15] = CYLINDER, (o.p0 + o.p1) / 2.0, o.radius, o.length / 2.0
        row[4:13] = np.column_stack([x, np.cross(z, x), z]).ravel()
    else:
        raise TypeError(f"primitive_row: not a primitive obstacle: {type(o).__name__}")
    return row


@kernel(inline="always")
def _sdf_row(row, sx, sy, sz, x, y, z):  # pragma: no cover - jitted
    """Signed distance (m) from the point (x, y, z) to the primitive ``row`` moved by (sx, sy, sz)."""
    dx, dy, dz = x - row[1] - sx, y - row[2] - sy, z - row[3] - sz
    kind = row[0]
    if kind == SPHERE:
        return math.sqrt(dx * dx + dy * dy + dz * dz) - row[13]
    lx = row[4] * dx + row[7] * dy + row[10] * dz  # R^T d
    ly = row[5] * dx + row[8] * dy + row[11] * dz
    lz = row[6] * dx + row[9] * dy + row[12] * dz
    if kind == BOX:
        qx, qy, qz = abs(lx) - row[13], abs(ly) - row[14], abs(lz) - row[15]
        ox, oy, oz = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
        return math.sqrt(ox * ox + oy * oy + oz * oz) + min(max(qx, max(qy, qz)), 0.0)
    qr, qa = math.sqrt(lx * lx + ly * ly) - row[13], abs(lz) - row[15]
    o_r, o_a = max(qr, 0.0), max(qa, 0.0)
    return math.sqrt(o_r * o_r + o_a * o_a) + min(max(qr, qa), 0.0)


@kernel(inline="always")
def _capsule_row(row, sx, sy, sz, ax, ay, az, dx, dy, dz):  # pragma: no cover - jitted
    """min over t in [0, 1] of the signed distance (m) from a + t d to the primitive ``row`` moved by s: the
    golden section of :func:`capsule_distance`, on one segment."""
    lo, hi = 0.0, 1.0
    x1, x2 = hi - _INV_PHI, lo + _INV_PHI
    f1 = _sdf_row(row, sx, sy, sz, ax + x1 * dx, ay + x1 * dy, az + x1 * dz)
    f2 = _sdf_row(row, sx, sy, sz, ax + x2 * dx, ay + x2 * dy, az + x2 * dz)
    for _ in range(GOLDEN_STEPS):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - _INV_PHI * (hi - lo)
            f1 = _sdf_row(row, sx, sy, sz, ax + x1 * dx, ay + x1 * dy, az + x1 * dz)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + _INV_PHI * (hi - lo)
            f2 = _sdf_row(row, sx, sy, sz, ax + x2 * dx, ay + x2 * dy, az + x2 * dz)
    best = min(f1, f2)
    best = min(best, _sdf_row(row, sx, sy, sz, ax, ay, az))
    return min(best, _sdf_row(row, sx, sy, sz, ax + dx, ay + dy, az + dz))


@kernel
def member_distances(rows, members, shifts, lo, hi, a, b, r, within, out):  # pragma: no cover - jitted
    """``out[j]`` = the smallest signed distance (m) between primitive ``members[j]`` (a row of ``rows``
    (N, ROW), moved by ``shifts[members[j]]`` (N, 3) [m], held in the world box ``lo[.]``-``hi[.]`` (N, 3) [m])
    and the capsules ``a[k]``-``b[k]`` (K, 3) [m] of radii ``r[k]`` whose boxes are within ``within`` (m) of
    its box on every axis; ``inf`` if none is.  The distance to a capsule whose box is farther is more than
    ``within``, so the minimum is exact wherever it is below ``within``."""
    for j in range(members.shape[0]):
        i = members[j]
        best = np.inf
        for k in range(a.shape[0]):
            rk = r[k]
            far = False
            for ax in range(3):
                far = far or (min(a[k, ax], b[k, ax]) - rk - hi[i, ax] > within
                              or lo[i, ax] - max(a[k, ax], b[k, ax]) - rk > within)
            if far:
                continue
            d = _capsule_row(rows[i], shifts[i, 0], shifts[i, 1], shifts[i, 2], a[k, 0], a[k, 1], a[k, 2],
                             b[k, 0] - a[k, 0], b[k, 1] - a[k, 1], b[k, 2] - a[k, 2]) - rk
            best = min(best, d)
        out[j] = best
