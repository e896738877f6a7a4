"""A mesh file's triangles, read as the file means them: trimesh, with what it misreads put right first.

trimesh reads every format navstack accepts, but it gets two things of the polygon formats wrong, and both
change the surface the robot can touch (found by session 49's held-out worlds, ``worlds/hard13``):

* **OBJ relative indices.**  A negative index in a face (``f -3 -2 -1``) counts back from the last vertex
  defined *before that face line* (likewise for ``vt`` and ``vn``).  trimesh 5.2 counts back from the end of
  the whole file, so in a file of several objects each written as ``v ... f -3 -2 -1`` every face but the
  last object's is built on the wrong vertices (trimesh issue #2364): a wall went missing from the simulator
  and a trial through it was scored a success.  The OBJ text is rewritten with absolute indices first.
* **Concave polygons.**  A face of more than three corners is cut into a fan of triangles from its first
  corner, right only for a convex polygon: a plate whose outline is one concave polygon (a slot cut into
  it) got its slot filled in.  Concave faces (OBJ ``f`` lines, PLY face lists) are cut by ear clipping in
  the polygon's plane instead; convex ones are left to trimesh (the same triangles as before).

Files that hold neither are read by trimesh exactly as before.  A face that is not a simple polygon (its
outline crosses itself) is refused: :class:`MeshFileError` names the line or face.  Units: the file's.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_CONCAVE_CORNERS", "MeshFileError", "cut_polygon", "ear_clip", "fan_is_right", "is_convex",
           "load_triangles", "obj_text"]

FloatArray = NDArray[np.float64]


class MeshFileError(ValueError):
    """A mesh file navstack cannot read as its author meant it (the message names the line or face)."""


def load_triangles(path: str) -> tuple[FloatArray, NDArray[np.int32]]:
    """Vertices (n, 3) and triangles (m, 3) of the mesh file ``path`` (STL, OBJ, PLY, GLB, ...), merged as
    ``trimesh.load(path, force="mesh")`` merges them, with the corrections of the module docstring."""
    import trimesh  # imported lazily: slow to import, and only mesh worlds need it

    suffix = Path(path).suffix.lower()
    mesh = None
    if suffix == ".obj":
        text = Path(path).read_bytes().decode("utf-8", errors="surrogateescape")
        fixed = obj_text(text)
        if fixed is not text:
            data = io.BytesIO(fixed.encode("utf-8", errors="surrogateescape"))
            mesh = trimesh.load(data, file_type="obj", force="mesh")
    elif suffix == ".ply":
        from navstack.ply_faces import concave_ply

        mesh = concave_ply(path)
    if mesh is None:
        mesh = trimesh.load(path, force="mesh")
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int32)


# --------------------------------------------------------------------------- OBJ


def obj_text(text: str) -> str:
    """``text`` (an OBJ file) with every relative (negative) face index made absolute and every concave face
    cut into triangles; ``text`` itself (the same object) when it holds neither."""
    lines = text.splitlines()
    if not any(_is_face(line) and ("-" in line or len(line.split()) > 4) for line in lines):
        return text
    positions = _obj_positions(lines)
    counts = {"v": 0, "vt": 0, "vn": 0}
    faces: dict[int, list[list[str]]] = {}  # line index -> its corners, indices absolute
    relative: list[int] = []  # lines with a relative index: rewritten
    for number, line in enumerate(lines):
        head = line.split(maxsplit=1)[0] if line.strip() else ""
        if head in counts:
            counts[head] += 1
        elif head == "f":
            tokens = line.split()[1:]
            faces[number] = [_absolute(token, counts, number + 1) for token in tokens]
            if any(part.startswith("-") for token in tokens for part in token.split("/")):
                relative.append(number)
    corner_indices = {k: _vertex_indices(c, len(positions)) for k, c in faces.items()}
    polygons = {k: idx for k, idx in corner_indices.items() if idx is not None and len(idx) > 3}
    keep = fan_is_right(list(polygons.values()), positions)
    out = list(lines)
    changed = False
    for (number, idx), fan in zip(polygons.items(), keep, strict=True):
        if not fan:
            try:
                triangles = cut_polygon(idx, positions)
            except MeshFileError as exc:
                raise MeshFileError(f"line {number + 1}: {exc}") from None
            out[number] = "\n".join(_face_line([faces[number][i] for i in tri]) for tri in triangles)
            changed = True
    for number in relative:
        if out[number] is lines[number]:  # not cut into triangles above
            out[number] = _face_line(faces[number])
        changed = True
    return "\n".join(out) + "\n" if changed else text


def _face_line(corners: list[list[str]]) -> str:
    return "f " + " ".join("/".join(c) for c in corners)


def _vertex_indices(corners: list[list[str]], n: int) -> NDArray[np.int64] | None:
    """The 0-based vertex indices of a face's corners, ``None`` when one is not a valid index (trimesh then says
    why)."""
    try:
        idx = np.array([int(c[0]) - 1 for c in corners], dtype=np.int64)
    except ValueError:
        return None
    return idx if len(idx) and idx.min() >= 0 and idx.max() < n else None


def _is_face(line: str) -> bool:
    s = line.lstrip()
    return s.startswith("f ") or s.startswith("f\t")


def _obj_positions(lines: list[str]) -> FloatArray:
    """Every ``v`` line's x, y, z, in file order (NaN where one cannot be read: trimesh will say so)."""
    pts = []
    for line in lines:
        parts = line.split()
        if parts and parts[0] == "v":
            try:
                pts.append([float(x) for x in parts[1:4]])
            except ValueError:
                pts.append([np.nan] * 3)
    return np.array(pts, dtype=np.float64).reshape(-1, 3)


def _absolute(token: str, counts: dict[str, int], number: int) -> list[str]:
    """A face corner ``v[/vt[/vn]]`` with negative indices resolved against the counts so far (1-based)."""
    parts = token.split("/")
    for k, key in enumerate(("v", "vt", "vn")[:len(parts)]):
        if parts[k].startswith("-"):
            try:
                value = int(parts[k])
            except ValueError:
                continue  # not a number: left for trimesh to refuse
            if -value > counts[key]:
                raise MeshFileError(f"line {number}: face index {value} counts back past the first {key} "
                                    f"({counts[key]} defined before this line)")
            parts[k] = str(counts[key] + value + 1)
    return parts


# --------------------------------------------------------------------------- polygons

MAX_CONCAVE_CORNERS = 1024
"""The most corners of a concave face navstack cuts into triangles (ear clipping takes quadratic time)."""


def fan_is_right(polygons: list[NDArray[np.int64]], positions: FloatArray) -> NDArray[np.bool_]:
    """For each polygon (vertex indices into ``positions``), whether trimesh's fan from its first corner covers
    it exactly: it is convex in its plane, or encloses no area (its triangles are then degenerate and harmless).
    Polygons of one corner count are tested together (a mesh of quads: one numpy pass)."""
    out = np.ones(len(polygons), dtype=np.bool_)
    by_size: dict[int, list[int]] = {}
    for k, idx in enumerate(polygons):
        by_size.setdefault(len(idx), []).append(k)
    for ks in by_size.values():
        out[np.array(ks)] = _fan_covers(positions[np.array([polygons[k] for k in ks])])  # (m, n, 3) at once
    return out


def is_convex(pts: FloatArray) -> bool:
    """Whether a polygon (n, 3) is convex in its plane: every corner turns the same way and it goes round once
    (a fan of triangles from any corner then covers exactly it); corners written twice in a row count once."""
    kept = _distinct(np.asarray(pts, dtype=np.float64))
    if len(kept) < 3:
        return False
    p = np.asarray(pts, dtype=np.float64)[kept][None]
    return bool(_fan_covers(p)[0]) and bool(np.linalg.norm(_newell(p)[0]) > 0.0)


def cut_polygon(idx: NDArray[np.int64], positions: FloatArray) -> list[tuple[int, int, int]]:
    """Triangles (positions into ``idx``) covering a concave polygon, by ear clipping; corners written twice in a
    row count once.  :class:`MeshFileError` for one of more than :data:`MAX_CONCAVE_CORNERS` corners or one whose
    outline crosses or touches itself."""
    kept = _distinct(positions[idx])
    if len(kept) > MAX_CONCAVE_CORNERS:
        raise MeshFileError(f"a concave face of {len(kept)} corners; at most {MAX_CONCAVE_CORNERS} are cut into "
                            "triangles here: split it into smaller polygons or triangles")
    return [(int(kept[a]), int(kept[b]), int(kept[c])) for a, b, c in ear_clip(positions[idx][kept])]


def _distinct(pts: FloatArray) -> NDArray[np.int64]:
    """Indices of a polygon's corners without those equal to the corner before them (cyclically)."""
    same = np.all(pts == np.roll(pts, 1, axis=0), axis=1)
    if same.all():
        return np.array([0], dtype=np.int64)
    return np.flatnonzero(~same)


def _newell(p: FloatArray) -> FloatArray:
    """Newell's normals (m, 3) of polygons (m, n, 3): along the right-hand rule of their corner order, its length
    twice the area."""
    q = np.roll(p, -1, axis=1)
    return np.stack([np.sum((p[..., 1] - q[..., 1]) * (p[..., 2] + q[..., 2]), axis=1),
                     np.sum((p[..., 2] - q[..., 2]) * (p[..., 0] + q[..., 0]), axis=1),
                     np.sum((p[..., 0] - q[..., 0]) * (p[..., 1] + q[..., 1]), axis=1)], axis=1)


def _in_plane(p: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """(m, n, 2) coordinates of polygons (m, n, 3) in their planes, counter-clockwise (Newell's normal), and which
    enclose no area."""
    normal = _newell(p)
    size = np.linalg.norm(normal, axis=1)
    flat = size == 0.0
    n = normal / np.where(flat, 1.0, size)[:, None]
    n[flat] = (0.0, 0.0, 1.0)
    helper = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u, axis=1)[:, None]
    v = np.cross(n, u)  # (u, v, n) right-handed: the polygon turns counter-clockwise
    return np.stack([np.einsum("mnk,mk->mn", p, u), np.einsum("mnk,mk->mn", p, v)], axis=2), flat


def _fan_covers(p: FloatArray) -> NDArray[np.bool_]:
    """For polygons (m, n, 3): convex (no corner turning right, going round once), or enclosing no area.  A corner
    written twice in a row makes a zero-length edge whose two turns count 0, so the turn it makes is missed and
    the sum is not one round: such a face is cut instead (:func:`cut_polygon` counts the corner once)."""
    q, flat = _in_plane(p)
    e = np.roll(q, -1, axis=1) - q
    prev = np.roll(e, 1, axis=1)
    cross = prev[..., 0] * e[..., 1] - prev[..., 1] * e[..., 0]
    dot = np.sum(prev * e, axis=2)
    scale = np.ptp(q, axis=1).max(axis=1) ** 2
    left = np.all(cross >= -1e-12 * scale[:, None], axis=1)
    once = np.abs(np.arctan2(cross, dot).sum(axis=1) - 2.0 * np.pi) < 1e-6
    return flat | (left & once)


def _plane_coordinates(pts: FloatArray) -> FloatArray:
    """(n, 2) coordinates of one polygon's corners in its plane, counter-clockwise; :class:`MeshFileError` when it
    encloses no area."""
    q, flat = _in_plane(np.asarray(pts, dtype=np.float64)[None])
    if flat[0]:
        raise MeshFileError(f"a face of {len(pts)} corners encloses no area")
    return q[0]


def ear_clip(pts: FloatArray) -> list[tuple[int, int, int]]:
    """Triangles (corner indices, the polygon's own orientation) covering the simple polygon ``pts`` (n, 3),
    by ear clipping in its plane; :class:`MeshFileError` when its outline crosses or touches itself."""
    p = _plane_coordinates(pts)
    scale = np.ptp(p, axis=0).max() ** 2
    eps = 1e-12 * scale
    problem = ("its outline crosses or touches itself (a hole joined by a bridge edge, a spike of no width); "
               "split it into simple polygons or triangles")
    if _crossing_edges(p, eps):
        raise MeshFileError(f"a face of {len(p)} corners is not a simple polygon: {problem}")
    ring = list(range(len(p)))
    out: list[tuple[int, int, int]] = []
    while len(ring) > 3:
        for k in range(len(ring)):
            a, b, c = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
            if _cross(p[a], p[b], p[c]) <= eps:
                continue  # a reflex or straight corner is no ear
            if any(_inside(p[j], p[a], p[b], p[c], eps) for j in ring if j not in (a, b, c)):
                continue
            out.append((a, b, c))
            ring.pop(k)
            break
        else:  # a simple polygon always has an ear (Meisters' two ears theorem)
            raise MeshFileError(f"a face of {len(p)} corners is not a simple polygon: {problem}")
    out.append((ring[0], ring[1], ring[2]))
    return out


def _crossing_edges(p: FloatArray, eps: float) -> bool:
    """Whether two edges of the closed outline ``p`` (n, 2) that share no corner cross or touch."""
    a, b = p, np.roll(p, -1, axis=0)
    n = len(p)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))  # the last edge and the first share corner 0
    i, j = i[keep], j[keep]

    def orient(p0: FloatArray, p1: FloatArray, q: FloatArray) -> FloatArray:
        return (p1[:, 0] - p0[:, 0]) * (q[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (q[:, 0] - p0[:, 0])

    d1, d2 = orient(a[i], b[i], a[j]), orient(a[i], b[i], b[j])
    d3, d4 = orient(a[j], b[j], a[i]), orient(a[j], b[j], b[i])
    return bool(np.any((d1 * d2 <= eps * eps) & (d3 * d4 <= eps * eps)
                       & ~((np.abs(d1) <= eps) & (np.abs(d2) <= eps))))  # collinear edges: left to the ears


def _cross(a: FloatArray, b: FloatArray, c: FloatArray) -> float:
    return float((b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]))


def _inside(q: FloatArray, a: FloatArray, b: FloatArray, c: FloatArray, eps: float) -> bool:
    """Whether ``q`` lies in the counter-clockwise triangle a, b, c (its edges included, its corners not)."""
    if any(np.array_equal(q, x) for x in (a, b, c)):
        return False
    return (_cross(a, b, q) >= -eps and _cross(b, c, q) >= -eps and _cross(c, a, q) >= -eps)
