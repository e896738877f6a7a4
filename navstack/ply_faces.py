"""PLY files with faces of more than three corners, read as their author meant them (:mod:`navstack.mesh_file`).

trimesh cuts a PLY polygon into a fan of triangles from its first corner (wrong for a concave one) and refuses
a binary PLY whose faces have different numbers of corners (``PLY is unexpected length``, though the format
allows it).  :func:`concave_ply` reads the header and the vertex and face elements itself (ASCII and both
binary byte orders, any scalar property types, other elements skipped); a file whose faces are all triangles
(or that it cannot parse: trimesh then reads it, or says why not) is left to trimesh, unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.mesh_file import MeshFileError, cut_polygon, fan_is_right

__all__ = ["PlyData", "concave_ply", "read_ply"]

_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
          "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
          "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_FACE_NAMES = ("vertex_indices", "vertex_index")


@dataclass
class _Element:
    name: str
    count: int
    props: list[tuple[str, str, str | None]] = field(default_factory=list)  # (name, type, list count type)


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
    """The vertex positions and face lists of a PLY file (``None`` without a face list)."""
    with open(path, "rb") as fh:
        raw = fh.read()
    fmt, elements, start = _header(raw)
    if fmt == "ascii":
        values = _ascii_elements(raw[start:].decode("ascii", errors="replace").split(), elements)
    else:
        values = _binary_elements(raw[start:], elements, "<" if fmt == "binary_little_endian" else ">")
    vertex = values.get("vertex")
    face = values.get("face")
    if vertex is None or face is None:
        return None
    faces = next((face[name] for name in _FACE_NAMES if name in face), None)
    if faces is None:
        faces = next((v for v in face.values() if isinstance(v, list)), None)
    if faces is None:
        return None
    xyz = np.column_stack([np.asarray(vertex[c], dtype=np.float64) for c in ("x", "y", "z")])
    return PlyData(xyz, [np.asarray(f, dtype=np.int64) for f in faces])


def _header(raw: bytes) -> tuple[str, list[_Element], int]:
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise ValueError("not a PLY header")
    start = raw.index(b"\n", end) + 1
    fmt = ""
    elements: list[_Element] = []
    for line in raw[:end].decode("ascii", errors="replace").splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "format":
            fmt = words[1]
        elif words[0] == "element":
            elements.append(_Element(words[1], int(words[2])))
        elif words[0] == "property":
            if words[1] == "list":
                elements[-1].props.append((words[4], _TYPES[words[3]], _TYPES[words[2]]))
            else:
                elements[-1].props.append((words[2], _TYPES[words[1]], None))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"unknown PLY format {fmt!r}")
    return fmt, elements, start


def _ascii_elements(tokens: list[str], elements: list[_Element]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    pos = 0
    for el in elements:
        if len(el.props) == 1 and el.props[0][2] is not None and el.count:  # one list: all of one length?
            n = int(tokens[pos])
            block = np.array(tokens[pos:pos + el.count * (n + 1)]).reshape(-1, n + 1) \
                if len(tokens) >= pos + el.count * (n + 1) else None
            if block is not None and np.all(block[:, 0].astype(np.int64) == n):
                out[el.name] = {el.props[0][0]: list(block[:, 1:].astype(np.float64).astype(np.int64))}
                pos += el.count * (n + 1)
                continue
        cols: dict[str, Any] = {name: [] for name, _, _ in el.props}
        for _ in range(el.count):
            for name, _, count_type in el.props:
                if count_type is None:
                    cols[name].append(float(tokens[pos]))
                    pos += 1
                else:
                    n = int(tokens[pos])
                    cols[name].append([int(float(t)) for t in tokens[pos + 1:pos + 1 + n]])
                    pos += 1 + n
        out[el.name] = cols
    return out


def _binary_elements(buf: bytes, elements: list[_Element], order: str) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    pos = 0
    for el in elements:
        if all(count_type is None for _, _, count_type in el.props):
            dtype = np.dtype([(name, order + typ) for name, typ, _ in el.props])
            arr = np.frombuffer(buf, dtype=dtype, count=el.count, offset=pos)
            out[el.name] = {name: arr[name] for name, _, _ in el.props}
            pos += dtype.itemsize * el.count
            continue
        if len(el.props) == 1 and el.count:  # one list: all of one length (the usual case)?
            name, typ, count_type = el.props[0]
            ct, it = np.dtype(order + count_type), np.dtype(order + typ)  # type: ignore[operator]
            n = int(np.frombuffer(buf, dtype=ct, count=1, offset=pos)[0])
            dtype = np.dtype([("n", ct), ("i", it, (n,))])
            if len(buf) >= pos + dtype.itemsize * el.count:
                arr = np.frombuffer(buf, dtype=dtype, count=el.count, offset=pos)
                if np.all(arr["n"] == n):
                    out[el.name] = {name: list(arr["i"].astype(np.int64))}
                    pos += dtype.itemsize * el.count
                    continue
        cols: dict[str, Any] = {name: [] for name, _, _ in el.props}
        for _ in range(el.count):  # lists of any length: one item after another
            for name, typ, count_type in el.props:
                if count_type is None:
                    dt = np.dtype(order + typ)
                    cols[name].append(np.frombuffer(buf, dtype=dt, count=1, offset=pos)[0])
                    pos += dt.itemsize
                else:
                    ct, it = np.dtype(order + count_type), np.dtype(order + typ)
                    n = int(np.frombuffer(buf, dtype=ct, count=1, offset=pos)[0])
                    pos += ct.itemsize
                    cols[name].append(np.frombuffer(buf, dtype=it, count=n, offset=pos).astype(np.int64))
                    pos += it.itemsize * n
        out[el.name] = cols
    return out
