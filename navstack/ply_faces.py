"""PLY files with faces of more than three corners, read as their author meant them (:mod:`navstack.mesh_file`).

trimesh cuts a PLY polygon into a fan of triangles from its first corner (wrong for a concave one) and refuses
a binary PLY whose faces have different numbers of corners (``PLY is unexpected length``, though the format
allows it).  :func:`concave_ply` reads the vertex and face elements with ``plyfile`` (ASCII and both binary
byte orders, lists of any lengths) and cuts the polygons itself; a file whose faces are all triangles (or that
plyfile cannot parse: trimesh then reads it, or says why not) is left to trimesh, unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.mesh_file import MeshFileError, cut_polygon, fan_is_right

__all__ = ["PlyData", "concave_ply", "read_ply"]

_FACE_NAMES = ("vertex_indices", "vertex_index")


@dataclass
class PlyData:
    """The vertices (n, 3) and the faces (lists of vertex indices) of a PLY file."""

    vertices: NDArray[np.float64]
    faces: list[NDArray[np.int64]]


def concave_ply(path: str) -> Any:
    """A ``trimesh.Trimesh`` of the PLY file ``path`` with its polygons cut right (convex ones as a fan from
    the first corner, as trimesh cuts them; concave ones by ear clipping), or ``None`` when every face is a
    triangle or the file cannot be parsed here (trimesh reads it then)."""
    try:
        data = read_ply(path)
    except (ValueError, IndexError, KeyError, OSError):  # not parsed here: trimesh reads it, or says why not
        return None
    if data is None or all(len(f) == 3 for f in data.faces):
        return None
    import trimesh

    n = len(data.vertices)
    faces = [f for f in data.faces if len(f) >= 3]  # a face of fewer corners has no surface (trimesh drops it too)
    for k, face in enumerate(faces):
        if face.min() < 0 or face.max() >= n:
            raise MeshFileError(f"a face names vertex {int(face.max() if face.max() >= n else face.min())}; the "
                                f"file has {n} (face {k} of those with 3 or more corners)")
    polygons = [f for f in faces if len(f) > 3]
    fan = iter(fan_is_right(polygons, data.vertices))
    triangles: list[NDArray[np.int64]] = []
    for k, face in enumerate(faces):
        if len(face) == 3:
            triangles.append(face[None])
        elif next(fan):  # convex: the fan from the first corner, as trimesh cuts it
            triangles.append(np.column_stack([np.full(len(face) - 2, face[0]), face[1:-1], face[2:]]))
        else:
            try:
                cut = cut_polygon(face, data.vertices)
            except MeshFileError as exc:
                raise MeshFileError(f"face {k}: {exc}") from None
            triangles.append(face[np.array(cut)])
    return trimesh.Trimesh(vertices=data.vertices, faces=np.concatenate(triangles))


def read_ply(path: str) -> PlyData | None:
    """The vertex positions and face lists of a PLY file (``None`` without a face list), read by ``plyfile``
    (ASCII and both binary byte orders, lists of any lengths); ``ValueError`` for a file it cannot parse."""
    import plyfile

    try:
        ply = plyfile.PlyData.read(path)
    except plyfile.PlyParseError as exc:
        raise ValueError(str(exc)) from None
    names = [el.name for el in ply.elements]
    if "vertex" not in names or "face" not in names:
        return None
    vertex, face = ply["vertex"], ply["face"]
    lists = [prop.name for prop in face.properties if isinstance(prop, plyfile.PlyListProperty)]
    name = next((n for n in _FACE_NAMES if n in lists), lists[0] if lists else None)
    if name is None:
        return None
    xyz = np.column_stack([np.asarray(vertex[c], dtype=np.float64) for c in ("x", "y", "z")])
    return PlyData(xyz, [np.asarray(f, dtype=np.int64) for f in face[name]])
