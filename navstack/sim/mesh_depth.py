"""The exact signed distance between the robot's capsules and a mesh obstacle: a penetration's true depth.

PyBullet treats a triangle mesh as a surface (:mod:`navstack.sim.scene`).  A capsule pushed into a *closed*
mesh reads the depth below the facets it collides with, not below the mesh's surface: in ``worlds/hard5``'s
icosphere a link whose axis lay 33.3 mm inside read -26.2 mm (an outside checker's number, and this module's),
and a capsule wholly inside reads a positive distance, no contact at all.  So a trial's ``min_clearance``
understated a mesh penetration, and a step with a link wholly inside a mesh it had already entered was not
counted as a contact.

A capsule (segment ``a``-``b``, radius ``r``) against a mesh: the least of ``s(a + t (b - a)) - r`` over ``t`` in
[0, 1], where ``s`` is the distance to the nearest triangle, negative inside a closed mesh (the signed distance of
the solid; an open surface has no inside).  The segment is cut where it crosses a triangle (Moller and Trumbore's
test); each piece lies wholly inside or wholly outside, told by the winding number at its middle
(:mod:`navstack.sim.mesh_inside`'s rule, nesting and cavities included).  Outside, the least distance is the
least exact segment-triangle distance (closed form).  Inside, the depth is the *greatest* distance to the
surface along the piece, a max-min: each triangle's distance is convex along a segment, so on an interval it is
at most the larger of its two ends, and the least of those over the triangles bounds the distance to the surface
from above; branch and bound splits the interval with the highest bound in half until the bound is within
:data:`TOLERANCE` of the best found (a piece parallel to a face, where the distance is flat, is done at once;
Lipschitz bounds alone needed millions of splits there).  The surface inside is the mesh's triangles less the
faces two glued solids share (:mod:`navstack.sim.mesh_walls`).  Pure numpy and numba, no simulator.
"""

from __future__ import annotations

import heapq
import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from navstack.self_contact import _segment_distance
from navstack.sim.mesh_inside import held, nesting, solids
from navstack.sim.mesh_walls import inner_walls
from navstack.world import Mesh

__all__ = ["TOLERANCE", "MeshContacts", "MeshDepth"]

TOLERANCE = 1e-7
"""m: the depth inside a closed mesh is found to within this (the branch and bound's stop); outside, the distance is
exact (closed form)."""


@numba.njit(cache=True)
def _point_triangle(px, py, pz, a, b, c):  # pragma: no cover - jitted
    """Squared distance from point p to triangle abc (Ericson, Real-Time Collision Detection, 5.1.5)."""
    abx, aby, abz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    acx, acy, acz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    apx, apy, apz = px - a[0], py - a[1], pz - a[2]
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = px - b[0], py - b[1], pz - b[2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        qx, qy, qz = apx - v * abx, apy - v * aby, apz - v * abz
        return qx * qx + qy * qy + qz * qz
    cpx, cpy, cpz = px - c[0], py - c[1], pz - c[2]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        qx, qy, qz = apx - w * acx, apy - w * acy, apz - w * acz
        return qx * qx + qy * qy + qz * qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx = bpx - w * (c[0] - b[0])
        qy = bpy - w * (c[1] - b[1])
        qz = bpz - w * (c[2] - b[2])
        return qx * qx + qy * qy + qz * qz
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    qx, qy, qz = apx - v * abx - w * acx, apy - v * aby - w * acy, apz - v * abz - w * acz
    return qx * qx + qy * qy + qz * qz


@numba.njit(cache=True)
def _distances_to(px, py, pz, tri, out):  # pragma: no cover - jitted
    """Distance [m] from p to each of the triangles ``tri`` (F, 3, 3), into ``out`` (F,); returns the least."""
    least = np.inf
    for f in range(tri.shape[0]):
        out[f] = math.sqrt(_point_triangle(px, py, pz, tri[f, 0], tri[f, 1], tri[f, 2]))
        least = min(least, out[f])
    return least


@numba.njit(cache=True)
def _segment_mesh(p0, p1, tri, centre, radius, hit):  # pragma: no cover - jitted
    """The least distance [m] between segment p0-p1 and the triangles ``tri`` (F, 3, 3): 0 if it crosses one
    (``hit``, a (1,) scratch array), else the least of its ends against each triangle and of it against each
    triangle's edges (Ericson 5.1.9); a triangle whose bounding ball lies farther than the best so far is skipped."""
    best = np.inf
    dx, dy, dz = p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]
    dd = dx * dx + dy * dy + dz * dz
    for f in range(tri.shape[0]):
        cx, cy, cz = centre[f, 0] - p0[0], centre[f, 1] - p0[1], centre[f, 2] - p0[2]
        t = 0.0 if dd <= 0.0 else min(max((cx * dx + cy * dy + cz * dz) / dd, 0.0), 1.0)
        ex, ey, ez = cx - t * dx, cy - t * dy, cz - t * dz
        if math.sqrt(ex * ex + ey * ey + ez * ez) - radius[f] >= best:
            continue
        if _crossings(p0, p1, tri[f : f + 1], hit):
            return 0.0
        v0, v1, v2 = tri[f, 0], tri[f, 1], tri[f, 2]
        d = min(_segment_distance(p0, p1, v0, v1), _segment_distance(p0, p1, v1, v2),
                _segment_distance(p0, p1, v2, v0),
                math.sqrt(_point_triangle(p0[0], p0[1], p0[2], v0, v1, v2)),
                math.sqrt(_point_triangle(p1[0], p1[1], p1[2], v0, v1, v2)))
        best = min(best, d)
    return best


_EDGE = 1e-9
"""A crossing within this (barycentric) of a triangle's edge counts for it: a segment through an edge shared by
two triangles is cut there even if rounding puts it just outside both (a cut too many only splits a piece)."""


@numba.njit(cache=True)
def _crossings(a, b, tri, out):  # pragma: no cover - jitted
    """Where (t in [0, 1]) segment a-b crosses the triangles (Moller-Trumbore); their count, into ``out``."""
    n = 0
    dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    for f in range(tri.shape[0]):
        v0, v1, v2 = tri[f, 0], tri[f, 1], tri[f, 2]
        e1x, e1y, e1z = v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]
        e2x, e2y, e2z = v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]
        hx, hy, hz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
        det = e1x * hx + e1y * hy + e1z * hz
        if abs(det) < 1e-300:
            continue  # parallel to the triangle's plane
        inv = 1.0 / det
        sx, sy, sz = a[0] - v0[0], a[1] - v0[1], a[2] - v0[2]
        u = (sx * hx + sy * hy + sz * hz) * inv
        if u < -_EDGE or u > 1.0 + _EDGE:
            continue
        qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
        v = (dx * qx + dy * qy + dz * qz) * inv
        if v < -_EDGE or u + v > 1.0 + _EDGE:
            continue
        t = (e2x * qx + e2y * qy + e2z * qz) * inv
        if 0.0 <= t <= 1.0:
            out[n] = t
            n += 1
    return n


class MeshDepth:
    """A mesh obstacle's exact signed distance to capsules (module docstring), its triangles and solids read once.

    Attributes:
        closed: whether the mesh has an inside (some part of it closed, :func:`navstack.sim.mesh_inside.solids`).
        lo, hi: the mesh's box in its own frame [m].
    """

    def __init__(self, mesh: Mesh) -> None:
        vertices, faces = mesh.triangles()
        self._R = Rotation.from_euler("xyz", mesh.rpy).as_matrix()  # as the scene places it
        self._position = np.asarray(mesh.position, dtype=np.float64)
        tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
        twice_area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        scale = max(float(np.ptp(vertices, axis=0).max()), 1e-300)
        # a triangle of no area (corners that coincide or lie on a line) is a segment on its neighbours' edges:
        # left out (Ericson's closest point divides by its edge terms, 0/0 for two equal corners)
        self._tri = np.ascontiguousarray(tri[twice_area > 1e-12 * scale * scale])
        self._centre = self._tri.mean(axis=1)
        self._radius = np.linalg.norm(self._tri - self._centre[:, None, :], axis=2).max(axis=1)
        self.lo, self.hi = vertices.min(axis=0), vertices.max(axis=0)
        self._parts = solids(vertices, faces)
        self._depths = nesting(self._parts)
        self._part_tri = [np.ascontiguousarray(v[f]) for v, f in self._parts]
        self.closed = bool(self._parts)
        # the axis is cut where it crosses the file's triangles and the welded ones (mesh_inside.solids decides
        # inside on welded vertices: a crack narrower than WELD is closed there, and a piece entering through it
        # must be cut too); a cut too many only splits a piece
        self._cut_tri = np.ascontiguousarray(np.concatenate([self._tri] + [v[f] for v, f in self._parts]))
        # a depth inside is measured to the solid's surface: not to a face two glued solids share
        self._surface = np.ascontiguousarray(self._tri[~inner_walls(self._tri, self._part_tri, self._depths)])
        self._hits = np.empty(len(self._cut_tri))
        self._hit = np.empty(1)

    def local(self, points: ArrayLike) -> NDArray[np.float64]:
        """World points (P, 3) [m] in the mesh's own frame."""
        return (np.asarray(points, dtype=np.float64) - self._position) @ self._R

    def inside(self, local_point: NDArray[np.float64]) -> bool:
        """Whether a point of the mesh's frame lies inside it (the innermost closed part holding it is a solid)."""
        return held(self._part_tri, self._depths, local_point)

    def box_gap(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
        """A lower bound [m] of the distance between segment a-b (mesh frame) and the mesh: to its box."""
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        return float(np.linalg.norm(np.maximum(self.lo - hi, 0.0) + np.maximum(lo - self.hi, 0.0)))

    def capsule_clearance(self, a: ArrayLike, b: ArrayLike, r: float, floor: float = -math.inf,
                          apart: bool = False) -> float:
        """The signed distance [m] between the capsule ``a``-``b`` (world [m]), radius ``r`` [m], and the mesh.

        Exact (to :data:`TOLERANCE`) when it is below ``floor`` [m]; otherwise not below ``floor``, and at most 0
        exactly when the true one is (a contact is never hidden nor made up): the depth inside is searched only
        while it could go below ``floor``.  A capsule whose segment lies outside the mesh's box gets a lower bound
        (its distance to the box less ``r``) when that is above both ``floor`` and 0.  ``apart``: the capsule is
        known not to touch the surface (PyBullet reads it clear), so it lies wholly inside or wholly outside:
        inside, its depth as above; outside, +inf (nothing to add to PyBullet's own reading)."""
        A, B = self.local(a), self.local(b)
        bound = self.box_gap(A, B) - r
        if bound > max(floor, 0.0):
            return bound  # the segment is outside the box: no inside to reach, farther than both
        if apart:
            if not (self.closed and self.inside(0.5 * (A + B))):
                return math.inf
            return -self._deepest(A, B, -(floor + r)) - r
        cuts = [0.0, 1.0]
        if self.closed:
            cuts = sorted(cuts + self._hits[: _crossings(A, B, self._cut_tri, self._hits)].tolist())
        best = math.inf
        for t0, t1 in zip(cuts[:-1], cuts[1:], strict=True):
            if t1 - t0 <= 1e-12 and len(cuts) > 2:
                continue  # two cuts at one place (an edge shared by two triangles)
            p0, p1 = A + t0 * (B - A), A + t1 * (B - A)
            if self.closed and self.inside(0.5 * (p0 + p1)):
                best = min(best, -self._deepest(p0, p1, -(min(floor, best - TOLERANCE) + r)) - r)
            else:
                best = min(best, _segment_mesh(p0, p1, self._tri, self._centre, self._radius, self._hit) - r)
        return best

    def _deepest(self, p0: NDArray[np.float64], p1: NDArray[np.float64], beyond: float) -> float:
        """The greatest distance [m] to the surface along segment p0-p1 (mesh frame), to :data:`TOLERANCE` if it
        is greater than ``beyond`` [m]; otherwise a distance reached there (no more is asked for).

        Branch and bound on the segment's parameter: each triangle's distance is convex along the segment, so
        within an interval it is at most the larger of its values at the ends; the least of those over the
        triangles bounds the distance to the surface there.  The interval with the highest bound is halved."""
        def at(t: float) -> tuple[float, NDArray[np.float64]]:
            out = np.empty(len(self._surface))
            q = p0 + t * (p1 - p0)
            return _distances_to(q[0], q[1], q[2], self._surface, out), out

        (ua, da), (ub, db) = at(0.0), at(1.0)
        best = max(ua, ub)
        heap = [(-float(np.minimum.reduce(np.maximum(da, db))), 0.0, da, 1.0, db)]
        while heap:
            neg, t0, d0, t1, d1 = heapq.heappop(heap)
            if -neg <= max(best + TOLERANCE, beyond) or t1 - t0 < 1e-12:
                break  # the highest bound left is no better than what was found, or than what is asked
            tm = 0.5 * (t0 + t1)
            um, dm = at(tm)
            best = max(best, um)
            for u, du, v, dv in ((t0, d0, tm, dm), (tm, dm, t1, d1)):
                heapq.heappush(heap, (-float(np.minimum.reduce(np.maximum(du, dv))), u, du, v, dv))
        return best


class MeshContacts:
    """A scene's mesh obstacles measured exactly where PyBullet cannot be trusted (:meth:`Scene.clearance`).

    A mesh body PyBullet reads within :data:`navstack.sim.exact_distance.MARGIN` of a contact is measured again
    exactly against every capsule of the robot (its :class:`MeshDepth` built on first need), and a closed mesh
    the robot has penetrated is *entered*: from then on it is measured exactly at every query, whatever PyBullet
    reads, since a link wholly inside it reads a positive distance there.  (A link cannot get wholly inside a
    static closed mesh without crossing its surface first, which is read: meshes do not move.)

    Attributes:
        entered: the mesh bodies the robot has been inside.
    """

    def __init__(self, meshes: dict[int, Mesh], margin: float) -> None:
        """``meshes``: body id -> the mesh obstacle it holds; ``margin`` [m]: PyBullet's reading at or below
        which a mesh is measured exactly."""
        self._meshes = meshes
        self._margin = margin
        self._depth: dict[int, MeshDepth] = {}
        self.entered: set[int] = set()

    def depth(self, body: int) -> MeshDepth:
        """The exact measure of mesh body ``body`` (built once)."""
        if body not in self._depth:
            self._depth[body] = MeshDepth(self._meshes[body])
        return self._depth[body]

    def clearance(self, near: dict[int, float], reached: float, exact_below: float,
                  capsules: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None,
                  all_capsules: bool = True) -> float:
        """The least signed distance [m] to the meshes: ``near`` holds PyBullet's reading of each mesh body it
        found closer than ``reached`` [m] (the threshold of that query; the others are at least that far).
        Exact when below ``exact_below`` [m], and a contact (at most 0) exactly when there is one.  ``capsules``:
        the robot's ``(a, b, r)`` now; None when no mesh needs it (then only PyBullet's readings are used).
        ``all_capsules``: whether they are every collision shape the robot has; if not, PyBullet's reading (which
        sees the other shapes too) is kept wherever it is lower, so no contact of theirs is hidden."""
        todo = [b for b, v in near.items() if v <= self._margin or b in self.entered]
        todo += [b for b in self.entered if b not in near]
        if not todo or capsules is None:
            return min(near.values(), default=reached)
        values = [v for b, v in near.items() if b not in todo]
        floor = max(exact_below, 0.0)
        for b in todo:
            measure = self.depth(b)
            v = near.get(b, reached)  # PyBullet's reading; above its margin, each capsule is inside or outside
            e = min((measure.capsule_clearance(a, c, float(r), exact_below, v > self._margin)
                     for a, c, r in zip(*capsules, strict=True)), default=math.inf)
            if e <= 0.0 and measure.closed:
                self.entered.add(b)
            if not all_capsules:  # clear and above the floor: PyBullet's reading stands, unless it is a contact
                values.append(min(e, v))
            else:
                values.append(e if e <= floor or v <= 0.0 else v)
        return min(values, default=reached)

    def needs_capsules(self, near: dict[int, float]) -> bool:
        """Whether :meth:`clearance` will measure exactly (and so needs the robot's capsules)."""
        return bool(self.entered) or any(v <= self._margin for v in near.values())
