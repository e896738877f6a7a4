"""Which points lie inside a closed mesh obstacle: what PyBullet's distance queries cannot tell.

PyBullet treats a mesh as a surface (:mod:`navstack.sim.scene`), so a robot wholly inside a closed mesh
reports a positive distance to its nearest triangle and no contact: a trial could run inside a solid block and
call itself a success.  The start check (:func:`navstack.trial.check_start`) asks this module instead.

A point's winding number with respect to a closed triangle mesh is the sum of the solid angles its triangles
subtend at the point over 4 pi: +-1 inside (the sign is the faces' orientation), 0 outside, whatever the mesh's
shape (Jacobson, Kavan and Sorkine-Hornung, "Robust inside-outside segmentation using generalized winding
numbers", SIGGRAPH 2013). Each triangle's solid angle is Van Oosterom and Strackee's closed form (IEEE Trans.
Biomed. Eng. 1983). Only *closed* meshes (every edge shared by exactly two faces, trimesh's ``is_watertight``,
once vertices nearer than :data:`WELD` are welded and repeated triangles dropped; or, failing that, every edge
run as often one way as the other once T-junctions are split: :func:`mended`) have an inside; an open surface
has none and is never said to contain a point. Each connected part is taken on its own, its faces' orientations
made consistent first (:func:`solids`). Parts that overlap are one solid (their union), whatever their faces'
orientation; a part wholly inside another is a cavity in it (a tank's or a room's inner wall: the robot stands
in the cavity, not in the wall), a part inside that a solid again, and so on (:func:`nesting`): a point is
inside if the innermost closed part holding it lies inside an even number of others. Points on the surface
itself are not meaningful here: the caller has already refused any contact with it.
"""

from __future__ import annotations

import math

import numba
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


@numba.njit(cache=True)
def _winding(px, py, pz, tri):  # pragma: no cover - jitted
    """The winding number of p with respect to the triangles ``tri`` (F, 3, 3): the sum of their signed solid
    angles over 4 pi (Van Oosterom and Strackee)."""
    total = 0.0
    for f in range(tri.shape[0]):
        ax, ay, az = tri[f, 0, 0] - px, tri[f, 0, 1] - py, tri[f, 0, 2] - pz
        bx, by, bz = tri[f, 1, 0] - px, tri[f, 1, 1] - py, tri[f, 1, 2] - pz
        cx, cy, cz = tri[f, 2, 0] - px, tri[f, 2, 1] - py, tri[f, 2, 2] - pz
        la = math.sqrt(ax * ax + ay * ay + az * az)
        lb = math.sqrt(bx * bx + by * by + bz * bz)
        lc = math.sqrt(cx * cx + cy * cy + cz * cz)
        det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
        den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (ax * cx + ay * cy + az * cz) * lb
               + (bx * cx + by * cy + bz * cz) * la)
        total += 2.0 * math.atan2(det, den)
    return total / (4.0 * math.pi)


def winding_numbers(vertices: ArrayLike, faces: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """The winding number (P,) of each of ``points`` (P, 3) [m] with respect to the triangles ``faces`` (F, 3,
    vertex indices) of ``vertices`` (V, 3) [m]: about +-1 inside a closed mesh, about 0 outside."""
    tri = np.ascontiguousarray(np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)])
    return np.array([_winding(p[0], p[1], p[2], tri) for p in np.atleast_2d(np.asarray(points, dtype=np.float64))])


def held(parts: list[NDArray[np.float64]], depths: list[int], point: NDArray[np.float64]) -> bool:
    """Whether ``point`` (3,) [m] lies inside the solid made of the closed ``parts`` (their triangles (F, 3, 3), in
    the point's frame) nested ``depths`` deep (:func:`nesting`): the innermost part holding it is a solid (inside
    an even number of others), not a cavity."""
    innermost = -1
    for tri, depth in zip(parts, depths, strict=True):
        if depth > innermost and abs(_winding(point[0], point[1], point[2], tri)) > 0.5:
            innermost = depth
    return innermost >= 0 and innermost % 2 == 0


def solids(vertices: ArrayLike, faces: ArrayLike) -> list[tuple[NDArray[np.float64], NDArray[np.int64]]]:
    """The closed, consistently oriented parts of the triangle mesh ``faces`` (F, 3) of ``vertices`` (V, 3).

    Vertices within :data:`WELD` are merged (:func:`welded`) and repeated triangles dropped (an STL's
    duplicates); the mesh is split into its connected parts, and each part that is closed (every edge shared
    by exactly two faces, trimesh's ``is_watertight``) is a solid, its faces turned to agree with their
    neighbours
    (``trimesh.repair.fix_winding``).  A winding number sums the faces' signed solid angles, so a closed box
    with every other face turned has 0 everywhere, and two overlapping closed parts turned opposite ways
    cancel where they overlap: a robot inside either looked outside.  The parts left are mended where they
    can be (:func:`mended`: solids glued face to face, T-junctions); what stays open has no inside and is
    left out."""
    return _solids(vertices, faces)[0]


_SOLIDS: dict[bytes, tuple[list[tuple[NDArray[np.float64], NDArray[np.int64]]], bool]] = {}
"""The last few meshes' :func:`_solids`, by a digest of their arrays: a trial asks for a mesh's solids up to three
times (goal check, start check, exact depth), a sweep's worker once per trial, and a large CAD mesh takes seconds."""

SOLIDS_KEPT = 4
"""How many meshes' solids :data:`_SOLIDS` keeps."""


def _solids(vertices: ArrayLike, faces: ArrayLike) -> tuple[list[tuple[NDArray[np.float64], NDArray[np.int64]]],
                                                             bool]:
    """:func:`solids`, and whether some of the surface is left open (kept for the next call on the same arrays;
    the arrays returned are read-only)."""
    import hashlib

    v, f = np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64)
    key = hashlib.sha256(np.array(v.shape + f.shape).tobytes() + v.tobytes() + f.tobytes()).digest()
    if key not in _SOLIDS:
        parts, left_open = _solids_of(v, f)
        for pair in parts:
            for array in pair:
                array.flags.writeable = False
        if len(_SOLIDS) >= SOLIDS_KEPT:
            del _SOLIDS[next(iter(_SOLIDS))]  # the oldest
        _SOLIDS[key] = parts, left_open
    parts, left_open = _SOLIDS[key]
    return list(parts), left_open


def _solids_of(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> tuple[
        list[tuple[NDArray[np.float64], NDArray[np.int64]]], bool]:
    """:func:`_solids`, computed."""
    import trimesh  # slow to import: only mesh worlds need it

    v, f = welded(vertices, faces)
    mesh = trimesh.Trimesh(v, f, process=True)
    mesh.update_faces(mesh.unique_faces())
    out, rest = [], []
    for part in mesh.split(only_watertight=False, repair=False):  # repair=True would fill holes
        if part.is_watertight:
            if not part.is_winding_consistent:
                trimesh.repair.fix_winding(part)
            out.append((np.asarray(part.vertices, dtype=np.float64), np.asarray(part.faces, dtype=np.int64)))
        else:
            rest.append(part)
    if not rest:
        return out, False
    taken = np.isin(_keys(v, f), np.concatenate([_keys(part.vertices, part.faces) for part in rest]))
    more, left_open = mended(v, f[taken])
    return out + more, left_open


def _keys(vertices: ArrayLike, faces: ArrayLike) -> NDArray[np.void]:
    """Each triangle as its corners' coordinates, sorted (one key whatever its corners' order or numbering)."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]  # (F, 3, 3)
    tri = tri[np.arange(len(tri))[:, None], np.lexsort(tri.transpose(2, 0, 1)[::-1], axis=-1)]
    return np.ascontiguousarray(tri.reshape(len(tri), 9)).view(np.dtype((np.void, 72))).ravel()


def mended(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> tuple[
        list[tuple[NDArray[np.float64], NDArray[np.int64]]], bool]:
    """The solids in surface parts that are not closed as trimesh sees them (an edge in other than two faces), and
    whether some of it stays open.

    Two things close a surface to the winding number though not to trimesh: solids glued face to face (two
    boxes sharing a face: its edges are in four faces, the shared triangles twice, or in two triangulations),
    and T-junctions (a vertex on another triangle's edge: a CAD export's neighbouring faces tessellated apart).
    Triangles are split at the vertices lying on their edges (:func:`split_t_junctions`); then a connected part
    whose directed edges balance (each edge run as often one way as the other, the faces' own orientation
    trusted) is a sum of closed surfaces: its winding number is a whole number everywhere off the surface, +-1
    in each solid glued in.  Triangles repeated the same way round are tried once too (an STL's duplicates).
    Parts are joined by their edges, not corners (a stray fin touching a solid leaves it closed).  A triangle
    written both ways round is taken out, both copies (:func:`_without_opposite_pairs`); a part that is nothing
    else (a surface written two-sided) keeps one side of it (:func:`_one_side`), as trimesh's rule does for a
    watertight one."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = split_t_junctions(vertices, faces)
    if len(f) == 0:
        return [], True
    # parts joined by their edges (a stray triangle touching a solid at a corner is not part of it): a graph of
    # the faces and their edges, each face joined to its three
    _, edge = np.unique(_edge_keys(f.ravel(), np.roll(f, -1, axis=1).ravel()), return_inverse=True)
    n = len(f) + edge.max() + 1
    face = np.repeat(np.arange(len(f)), 3)
    label = connected_components(coo_matrix((np.ones(len(face)), (face, len(f) + edge)), shape=(n, n)),
                                 directed=False)[1][: len(f)]
    out, left_open = [], False
    for part in np.unique(label):
        tri = f[label == part]
        good = tri if _balanced(tri) else None
        if good is None:  # each triangle turned to start at its least corner, same way round, then taken once
            start = tri.argmin(axis=1)[:, None]
            once = np.unique(np.take_along_axis(tri, (start + np.arange(3)) % 3, axis=1), axis=0)
            good = once if _balanced(once) else None
        good = None if good is None else _without_opposite_pairs(good)
        if good is not None and len(good) == 0:  # a surface written both ways: one side of it, as a closed one's
            one = _one_side(tri)
            good = one if _balanced(one) else None
        if good is None:
            left_open = True
            continue
        used, compact = np.unique(good, return_inverse=True)
        out.append((np.asarray(vertices[used], dtype=np.float64), compact.reshape(-1, 3).astype(np.int64)))
    return out, left_open


def _without_opposite_pairs(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """``faces`` (F, 3) less each triangle written both ways round, both copies (their solid angles cancel: the
    wall between two solids glued face to face, or a surface written two-sided); the edges' balance is kept."""
    from collections import Counter

    def key(t: tuple[int, int, int]) -> tuple[int, int, int]:
        k = t.index(min(t))
        return t[k:] + t[:k]

    keys = [key(tuple(t)) for t in faces.tolist()]
    count = Counter(keys)
    left = {k: c - min(c, count.get(key(k[::-1]), 0)) for k, c in count.items()}
    keep = []
    for i, k in enumerate(keys):
        if left[k] > 0:
            left[k] -= 1
            keep.append(i)
    return faces[keep]


def _one_side(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """``faces`` (F, 3) with each triangle once, whichever way round it is first written (trimesh's rule)."""
    return faces[np.sort(np.unique(np.sort(faces, axis=1), axis=0, return_index=True)[1])]


def _unbalanced(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """The edges (:func:`_edge_keys`) of the triangles ``faces`` (F, 3) run more often one way than the other."""
    a, b = faces.ravel(), np.roll(faces, -1, axis=1).ravel()  # the directed edges a -> b
    key, edge = np.unique(_edge_keys(a, b), return_inverse=True)
    return key[np.bincount(edge, weights=np.where(a < b, 1.0, -1.0)) != 0.0]


def _balanced(faces: NDArray[np.int64]) -> bool:
    """Whether every edge of the triangles ``faces`` (F, 3) is run as often one way as the other."""
    return len(faces) > 0 and len(_unbalanced(faces)) == 0


def _edge_keys(a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.int64]:
    """One integer per undirected edge a-b (vertex indices below 2**31)."""
    return np.minimum(a, b) << 31 | np.maximum(a, b)


def split_t_junctions(vertices: NDArray[np.float64], faces: NDArray[np.int64], rounds: int = 8
                      ) -> NDArray[np.int64]:
    """``faces`` (F, 3) with each triangle that has vertices of ``faces`` lying on one of its edges (within
    :data:`WELD`, between its ends) split there: a fan from the opposite corner, the same way round. Only edges
    that do not balance, as written or with each triangle once (:func:`_unbalanced`, :func:`_one_side`), are
    split: splitting a balanced one cannot close anything, and long thin triangles (a fan of slivers) split each
    other round after round, into millions. A triangle split at its own corner (a sliver within :data:`WELD` of
    a line) is dropped. Each round splits one edge per triangle; ``rounds`` of them (a triangle has three edges;
    more only where splits make new junctions)."""
    from scipy.spatial import cKDTree

    f = np.asarray(faces, dtype=np.int64)
    corners = np.unique(f)
    tree = cKDTree(vertices[corners])
    for _ in range(rounds):
        on = _on_edges(vertices, corners, tree, f)
        if not on:
            break
        new, split = [], np.zeros(len(f), dtype=bool)
        edges = _edge_keys(f.ravel(), np.roll(f, -1, axis=1).ravel()).reshape(-1, 3)
        for k in np.flatnonzero(np.isin(edges, [a << 31 | b for a, b in on]).any(axis=1)):  # the faces to split
            tri = f[k].tolist()
            for i in range(3):
                a, b, c = tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]
                between = on.get((a, b)) or on.get((b, a), [])[::-1]
                if between:
                    fan = [a, *between, b]
                    new += [(fan[j], fan[j + 1], c) for j in range(len(fan) - 1)]
                    split[k] = True
                    break
        f = np.concatenate([f[~split], np.asarray(new, dtype=np.int64).reshape(-1, 3)])
        f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]  # a sliver split at its own corner
    return f


def _on_edges(vertices: NDArray[np.float64], corners: NDArray[np.int64], tree, faces: NDArray[np.int64]
              ) -> dict[tuple[int, int], list[int]]:
    """Per edge ``(a, b)`` of ``faces`` (a < b) with vertices of ``corners`` (indexed by ``tree``) within :data:`WELD`
    of it strictly between its ends, those vertices in order from a."""
    # a balanced edge needs no split; in the faces as written, or with each triangle once (a surface written
    # two-sided balances everywhere, T-junctions and all, but :func:`mended` may fall back to one side of it)
    key = np.union1d(_unbalanced(faces), _unbalanced(_one_side(faces)))
    edges = np.stack([key >> 31, key & (2**31 - 1)], axis=1)
    pa, pb = vertices[edges[:, 0]], vertices[edges[:, 1]]
    length = np.linalg.norm(pb - pa, axis=1)
    mid, radius = 0.5 * (pa + pb), 0.5 * length + WELD
    busy = np.flatnonzero(tree.query_ball_point(mid, radius, return_length=True) > 2)  # more than its two ends
    hits = tree.query_ball_point(mid[busy], radius[busy]) if len(busy) else []
    e = np.repeat(busy, [len(h) for h in hits])
    near = corners[np.concatenate(hits).astype(np.int64)] if len(e) else np.empty(0, dtype=np.int64)
    d = pb[e] - pa[e]
    t = np.einsum("ij,ij->i", vertices[near] - pa[e], d) / (length[e] * length[e])
    gap = np.linalg.norm(vertices[near] - (pa[e] + t[:, None] * d), axis=1)
    keep = ((near != edges[e, 0]) & (near != edges[e, 1]) & (gap <= WELD) & (t * length[e] > WELD)
            & ((1.0 - t) * length[e] > WELD))
    out: dict[tuple[int, int], list[int]] = {}
    for k in np.flatnonzero(keep)[np.lexsort((t[keep], e[keep]))]:  # by edge, then from a
        out.setdefault((int(edges[e[k], 0]), int(edges[e[k], 1])), []).append(int(near[k]))
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
    """Whether the triangles ``faces`` (F, 3) of ``vertices`` (V, 3) close up: every part is closed, or mended
    (:func:`solids`)."""
    parts, left_open = _solids(vertices, faces)
    return bool(parts) and not left_open


def points_inside(mesh: Mesh, points: ArrayLike) -> NDArray[np.bool_]:
    """For each of ``points`` (P, 3), world [m], whether it lies inside the closed mesh obstacle ``mesh`` placed
    at its ``position`` and ``rpy`` (all False for a mesh that is not closed)."""
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    vertices, faces = mesh.triangles()
    R = Rotation.from_euler("xyz", mesh.rpy).as_matrix()  # as the scene places it (scene._quat_xyzw_from_rpy)
    local = (pts - mesh.position) @ R  # R.T @ (p - position), row by row
    inside = np.all((local >= vertices.min(axis=0)) & (local <= vertices.max(axis=0)), axis=1)  # in its box
    parts = solids(vertices, faces) if inside.any() else []  # a surface with a hole has no inside
    triangles = [np.ascontiguousarray(v[f]) for v, f in parts]
    depths = nesting(parts)
    inside[inside] = [held(triangles, depths, p) for p in local[inside]]
    return inside
