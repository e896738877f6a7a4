"""Which points lie inside a closed mesh obstacle: what PyBullet's distance queries cannot tell.

PyBullet treats a mesh as a surface (:mod:`navstack.sim.scene`), so a robot wholly inside a closed mesh
reports a positive distance to its nearest triangle and no contact: a trial could run inside a solid block and
call itself a success.  The start check (:func:`navstack.trial.check_start`) asks this module instead.

A point's winding number with respect to a closed triangle mesh is the sum of the solid angles its triangles
subtend at the point over 4 pi: +-1 inside (the sign is the faces' orientation), 0 outside, whatever the
mesh's shape (Jacobson, Kavan and Sorkine-Hornung, "Robust inside-outside segmentation using generalized
winding numbers", SIGGRAPH 2013).  Each triangle's solid angle is Van Oosterom and Strackee's closed form
(IEEE Trans. Biomed. Eng. 1983).  Only *closed* meshes (every edge shared by exactly two faces, trimesh's
``is_watertight``, once vertices nearer than :data:`WELD` are welded and repeated triangles dropped) have an
inside; an open surface has none and is never
said to contain a point.  Each connected part is taken on its own, its faces' orientations made
consistent first (:func:`solids`).  Parts that overlap are one solid (their union), whatever their faces'
orientation; a part wholly inside another is a cavity in it (a tank's or a room's inner wall: the robot
stands in the cavity, not in the wall), a part inside that a solid again, and so on (:func:`nesting`): a
point is inside if the innermost closed part holding it lies inside an even number of others.  Points on
the surface itself are not meaningful here: the caller has already refused any contact with it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from navstack.world import Mesh

WELD = 1e-4
"""Vertices nearer than this [m] are one vertex (:func:`welded`): a CAD export's unwelded corners, a float32
file's rounding (6e-5 m at 1 km), leave cracks that no part of the robot (25 mm radius) passes through, and
a block with such cracks is a solid to its user.  Without welding it had no inside, and a robot wholly
inside it ran and reached its goals: a wrong SUCCESS (an audit's case, cracks of 0.1-5 um)."""


def welded(vertices: ArrayLike, faces: ArrayLike, tol: float = WELD) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """``vertices`` (V, 3) [m] with every cluster of vertices chained within ``tol`` [m] of each other merged
    into its first one, and ``faces`` (F, 3) renumbered, those whose corners merged dropped (degenerate)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    pairs = cKDTree(v).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return v, f
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(v), len(v)))
    _, label = connected_components(graph, directed=False)
    first = np.full(label.max() + 1, len(v))
    np.minimum.at(first, label, np.arange(len(v)))
    g = first[label][f]
    keep = (g[:, 0] != g[:, 1]) & (g[:, 1] != g[:, 2]) & (g[:, 0] != g[:, 2])
    return v, g[keep]


def winding_numbers(vertices: ArrayLike, faces: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """The winding number (P,) of each of ``points`` (P, 3) [m] with respect to the triangles ``faces`` (F, 3,
    vertex indices) of ``vertices`` (V, 3) [m]: about +-1 inside a closed mesh, about 0 outside."""
    v = np.asarray(vertices, dtype=np.float64)
    tri = v[np.asarray(faces, dtype=np.int64)]  # (F, 3 corners, 3)
    out = np.empty(len(np.atleast_2d(points)))
    for k, p in enumerate(np.atleast_2d(np.asarray(points, dtype=np.float64))):
        a, b, c = (tri[:, i] - p for i in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        det = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", a, c) * lb
               + np.einsum("ij,ij->i", b, c) * la)
        out[k] = np.sum(2.0 * np.arctan2(det, den)) / (4.0 * np.pi)
    return out


def solids(vertices: ArrayLike, faces: ArrayLike) -> list[tuple[NDArray[np.float64], NDArray[np.int64]]]:
    """The closed, consistently oriented parts of the triangle mesh ``faces`` (F, 3) of ``vertices`` (V, 3).

    Vertices within :data:`WELD` are merged (:func:`welded`) and repeated triangles dropped (an STL's
    duplicates); the mesh is split into its connected parts, and each part that is closed (every edge shared
    by exactly two faces, trimesh's ``is_watertight``) is a solid, its faces turned to agree with their
    neighbours
    (``trimesh.repair.fix_winding``).  A winding number sums the faces' signed solid angles, so a closed box
    with every other face turned has 0 everywhere, and two overlapping closed parts turned opposite ways
    cancel where they overlap: a robot inside either looked outside.  Parts that are not closed have no
    inside and are left out."""
    import trimesh  # slow to import: only mesh worlds need it

    mesh = trimesh.Trimesh(*welded(vertices, faces), process=True)
    mesh.update_faces(mesh.unique_faces())
    out = []
    for part in mesh.split(only_watertight=False, repair=False):  # repair=True would fill holes
        if part.is_watertight:
            if not part.is_winding_consistent:
                trimesh.repair.fix_winding(part)
            out.append((np.asarray(part.vertices, dtype=np.float64), np.asarray(part.faces, dtype=np.int64)))
    return out


NEST_SAMPLES = 64
"""At most this many of a part's vertices (its six extreme ones among them) are tested to tell whether the
part lies wholly inside another (:func:`nesting`): each costs a winding number over the other part's faces
(2,000 of them took 22 s for two 82,000-triangle shells, 64 take under a second).  A part that crosses
another's surface by a sliver between the tested vertices would count as inside it."""


def nesting(parts: list[tuple[NDArray[np.float64], NDArray[np.int64]]]) -> list[int]:
    """Per closed part of :func:`solids`, how many other parts hold it wholly: each of its tested vertices
    (all of them, or :data:`NEST_SAMPLES` with the six extreme ones) inside the other part, once moved
    1e-4 of the way towards the part's centroid (a vertex on the other's surface, a pillar standing on a
    room's floor, has no meaningful winding number: 0 or 1/2 as rounding falls).  Parts whose surfaces cross
    (overlapping solids) hold neither the other: depth 0 both, a union."""
    tested = []
    for v, _ in parts:
        if len(v) > NEST_SAMPLES:
            extreme = np.concatenate([v.argmin(axis=0), v.argmax(axis=0)])
            rest = np.random.default_rng(0).choice(len(v), NEST_SAMPLES - 6, replace=False)
            v = v[np.unique(np.concatenate([extreme, rest]))]
        tested.append(v + 1e-4 * (v.mean(axis=0) - v))
    lo = [v.min(axis=0) for v, _ in parts]
    hi = [v.max(axis=0) for v, _ in parts]
    depth = [0] * len(parts)
    for b, pts in enumerate(tested):
        for a, part in enumerate(parts):
            if a == b or np.any(lo[b] < lo[a] - WELD) or np.any(hi[b] > hi[a] + WELD):
                continue
            if np.all(np.abs(winding_numbers(*part, pts)) > 0.5):
                depth[b] += 1
    return depth


def is_closed(vertices: ArrayLike, faces: ArrayLike) -> bool:
    """Whether the triangles ``faces`` (F, 3) of ``vertices`` (V, 3) close up: every part is closed
    (:func:`solids`)."""
    import trimesh

    mesh = trimesh.Trimesh(*welded(vertices, faces), process=True)
    mesh.update_faces(mesh.unique_faces())
    parts = mesh.split(only_watertight=False, repair=False)
    return len(parts) > 0 and all(part.is_watertight for part in parts)


def points_inside(mesh: Mesh, points: ArrayLike) -> NDArray[np.bool_]:
    """For each of ``points`` (P, 3), world [m], whether it lies inside the closed mesh obstacle ``mesh`` placed
    at its ``position`` and ``rpy`` (all False for a mesh that is not closed)."""
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    vertices, faces = mesh.triangles()
    R = Rotation.from_euler("xyz", mesh.rpy).as_matrix()  # as the scene places it (scene._quat_xyzw_from_rpy)
    local = (pts - mesh.position) @ R  # R.T @ (p - position), row by row
    inside = np.all((local >= vertices.min(axis=0)) & (local <= vertices.max(axis=0)), axis=1)  # in its box
    parts = solids(vertices, faces) if inside.any() else []  # a surface with a hole has no inside
    innermost = np.full(int(inside.sum()), -1)  # the depth of the innermost part holding each point
    for part, depth in zip(parts, nesting(parts), strict=True):
        holds = np.abs(winding_numbers(*part, local[inside])) > 0.5
        innermost[holds & (depth > innermost)] = depth
    inside[inside] = (innermost >= 0) & (innermost % 2 == 0)
    return inside
