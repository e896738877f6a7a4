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

__all__ = ["MeshFileError", "ear_clip", "is_convex", "load_triangles", "obj_text"]

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
    out: list[str] = []
    changed = False
    for number, line in enumerate(lines, start=1):
        head = line.split(maxsplit=1)[0] if line.strip() else ""
        if head in counts:
            counts[head] += 1
        if head != "f":
            out.append(line)
            continue
        corners = [_absolute(token, counts, number) for token in line.split()[1:]]
        new = _face_lines(corners, positions, number)
        changed = changed or new != [line]
        out.extend(new)
    return "\n".join(out) + "\n" if changed else text


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


def _face_lines(corners: list[list[str]], positions: FloatArray, number: int) -> list[str]:
    """The ``f`` line(s) of one face: itself (absolute indices) when it is a triangle or convex, else its
    ear-clipped triangles."""
    def line(cs: list[list[str]]) -> str:
        return "f " + " ".join("/".join(c) for c in cs)

    if len(corners) <= 3:
        return [line(corners)]
    try:
        idx = np.array([int(c[0]) - 1 for c in corners])
        pts = positions[idx]
    except (ValueError, IndexError):
        return [line(corners)]  # an index trimesh will refuse with its own message
    if not np.isfinite(pts).all() or is_convex(pts):
        return [line(corners)]
    try:
        triangles = ear_clip(pts)
    except MeshFileError as exc:
        raise MeshFileError(f"line {number}: {exc}") from None
    return [line([corners[i] for i in tri]) for tri in triangles]


# --------------------------------------------------------------------------- polygons


def _plane_coordinates(pts: FloatArray) -> FloatArray:
    """(n, 2) coordinates of a polygon's corners in its plane (Newell's normal), orientation kept."""
    nxt = np.roll(pts, -1, axis=0)
    normal = np.array([np.sum((pts[:, 1] - nxt[:, 1]) * (pts[:, 2] + nxt[:, 2])),
                       np.sum((pts[:, 2] - nxt[:, 2]) * (pts[:, 0] + nxt[:, 0])),
                       np.sum((pts[:, 0] - nxt[:, 0]) * (pts[:, 1] + nxt[:, 1]))])
    size = np.linalg.norm(normal)
    if size == 0.0:
        raise MeshFileError(f"a face of {len(pts)} corners encloses no area")
    n = normal / size
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    return np.column_stack([pts @ u, pts @ v])  # (u, v, n) right-handed: the polygon turns counter-clockwise


def _turns(p: FloatArray) -> FloatArray:
    """z of the cross product of each corner's incoming and outgoing edge (positive: a left turn)."""
    a = p - np.roll(p, 1, axis=0)
    b = np.roll(p, -1, axis=0) - p
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def is_convex(pts: FloatArray) -> bool:
    """Whether a polygon (n, 3) is convex in its plane: every corner turns the same way and it goes round
    once (a fan of triangles from any corner then covers exactly it)."""
    try:
        p = _plane_coordinates(pts)
    except MeshFileError:
        return False
    scale = np.ptp(p, axis=0).max() ** 2
    turns = _turns(p)
    if np.any(turns < -1e-12 * scale):
        return False
    edges = np.roll(p, -1, axis=0) - p
    heading = np.unwrap(np.arctan2(edges[:, 1], edges[:, 0]))
    total = heading[-1] - heading[0] + (np.arctan2(np.sin(heading[0] - heading[-1]),
                                                   np.cos(heading[0] - heading[-1])))
    return bool(abs(total - 2.0 * np.pi) < 1e-6)


def ear_clip(pts: FloatArray) -> list[tuple[int, int, int]]:
    """Triangles (corner indices, the polygon's own orientation) covering the simple polygon ``pts`` (n, 3),
    by ear clipping in its plane; :class:`MeshFileError` when no ear is left (the outline crosses itself)."""
    p = _plane_coordinates(pts)
    scale = np.ptp(p, axis=0).max() ** 2
    eps = 1e-12 * scale
    if _crossing_edges(p, eps):
        raise MeshFileError(f"a face of {len(p)} corners is not a simple polygon (its outline crosses itself); "
                            "split it into simple polygons or triangles")
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
        else:
            raise MeshFileError(f"a face of {len(p)} corners is not a simple polygon (its outline crosses itself); "
                                "split it into simple polygons or triangles")
    out.append((ring[0], ring[1], ring[2]))
    return out


def _crossing_edges(p: FloatArray, eps: float) -> bool:
    """Whether two edges of the closed outline ``p`` (n, 2) that share no corner cross (or touch)."""
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
