"""A mesh's inner walls: triangles with solid on both sides, which a depth inside the solid must not count.

Two closed boxes glued face to face in one file (:func:`navstack.sim.mesh_inside.mended`) are one solid, but
the file still holds the face they share, twice (once per box, facing opposite ways).  A link inside the pair
near that face is no nearer the solid's surface for it: :class:`navstack.sim.mesh_depth.MeshDepth` measured its
depth to the nearest triangle, the shared face included, so a link across the wall between two glued unit cubes
read -0.25 m where the solid's own depth gives -0.55 m (``min_clearance`` understated; the contact itself was
always counted).

A triangle is an inner wall when a triangle of the file lies in its plane facing the other way, their boxes
meet, and the solid holds both sides of it (:func:`navstack.sim.mesh_inside.held`) at each of its samples: its
centroid, its edges' midpoints and its corners, each pulled 1 % of the way to the centroid, every one
:data:`OFFSET` off the face on either side.  Only such coplanar, opposite pairs are tested (glued faces,
whatever their triangulation); triangles of two closed parts that overlap, one inside the other's volume, are
not looked for and still count (a depth there is the distance to the nearest of them: shallower than the
union's, never a hidden contact), nor are faces shared the same way round (a solid whose faces were turned
inward, glued to one facing out).  A face shared only in part keeps the triangles that are not wholly covered.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from navstack.sim.mesh_inside import WELD, held

OFFSET = 2.0 * WELD
"""m: a wall's samples are tested this far off its face on either side.  Glued faces coincide to within
:data:`~navstack.sim.mesh_inside.WELD`; solids nearer each other than this across a gap count as glued there."""

PLANE_TOLERANCE = 10.0 * WELD
"""Two triangles lie in one plane, facing opposite ways, when the 4-vectors (unit normal, offset [m]: the normal's
dot product with the centroid) of one and of the other turned round are at most this far apart (Euclidean)."""

WALL_TESTS = 2e8
"""At most this many solid angles (candidate triangles x 14 samples x the solid's triangles, about 4 s) are
spent looking for inner walls; a mesh that would need more (every triangle of a large surface written twice,
facing both ways) keeps them all, and its depths are measured to the nearest triangle, as without this module."""


def _opposite_pairs(tri: NDArray[np.float64]) -> NDArray[np.intp]:
    """The triangles of ``tri`` (F, 3, 3) [m] with another in their plane facing the other way, boxes meeting."""
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    plane = np.hstack([normal, np.einsum("ij,ij->i", normal, tri.mean(axis=1))[:, None]])
    pairs = cKDTree(plane).sparse_distance_matrix(cKDTree(-plane), PLANE_TOLERANCE, output_type="ndarray")
    i, j = pairs["i"], pairs["j"]
    lo, hi = tri.min(axis=1) - WELD, tri.max(axis=1) + WELD
    meet = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
    return np.unique(i[meet])


def _samples(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Seven points of the triangle ``t`` (3, 3): its centroid, edge midpoints and corners, 1 % in from them."""
    c = t.mean(axis=0)
    points = np.vstack([c, 0.5 * (t + np.roll(t, -1, axis=0)), t])
    return points + 0.01 * (c - points)


def inner_walls(tri: NDArray[np.float64], parts: list[NDArray[np.float64]], depths: list[int]) -> NDArray[np.bool_]:
    """For each triangle of ``tri`` (F, 3, 3) [m], whether it is an inner wall of the solid made of the closed
    ``parts`` (their triangles, same frame) nested ``depths`` deep (module docstring)."""
    wall = np.zeros(len(tri), dtype=bool)
    if not parts:
        return wall
    candidates = _opposite_pairs(tri)
    if len(candidates) * 2 * len(_samples(tri[0])) * sum(len(p) for p in parts) > WALL_TESTS:
        return wall  # too many to test (a surface written two-sided): every triangle counts, as before
    for i in candidates:
        t = tri[i]
        n = np.cross(t[1] - t[0], t[2] - t[0])
        n *= OFFSET / np.linalg.norm(n)
        wall[i] = all(held(parts, depths, p + side) for p in _samples(t) for side in (n, -n))
    return wall
