"""Mesh files read as their authors mean them (``navstack.mesh_file``, ``navstack.ply_faces``).

trimesh misreads relative OBJ indices (it counts back from the file's end, not from the face) and cuts every
polygon into a fan from its first corner (wrong for a concave one), and refuses binary PLY faces of mixed
sizes.  Each case is checked against geometry known in closed form: the triangles' total area and where they
lie.  Lengths in the files' units.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh
from _worlds import world_data

from navstack.mesh_file import MeshFileError, ear_clip, is_convex, load_triangles, obj_text
from navstack.trial import run_trial
from navstack.world import WorldError, load_world

# an L-shaped hexagon in the plane z = 1 (area 3), listed from a corner whose fan covers the notch (area 4)
L_SHAPE = np.array([(2, 0), (2, 1), (1, 1), (1, 2), (0, 2), (0, 0)], dtype=float)


def _area(v: np.ndarray, f: np.ndarray) -> float:
    return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


def _in_l_shape(p: np.ndarray) -> np.ndarray:
    return (p[:, 0] >= -1e-9) & (p[:, 1] >= -1e-9) & ((p[:, 0] <= 1 + 1e-9) | (p[:, 1] <= 1 + 1e-9))


def _l_obj(tmp_path, name="l.obj"):
    text = "".join(f"v {x} {y} 1\n" for x, y in L_SHAPE) + "f 1 2 3 4 5 6\n"
    path = tmp_path / name
    path.write_text(text)
    return path


def test_trimesh_alone_fills_the_notch_and_navstack_does_not(tmp_path):
    path = _l_obj(tmp_path)
    plain = trimesh.load(path, force="mesh")
    assert plain.area == pytest.approx(4.0)  # the misreading this module exists for (if trimesh is fixed: fine)
    v, f = load_triangles(str(path))
    assert _area(v, f) == pytest.approx(3.0) and len(f) == 4
    centroids = v[f].mean(axis=1)
    assert _in_l_shape(centroids[:, :2]).all()


def test_relative_indices_count_back_from_the_face_not_from_the_file_end(tmp_path):
    blocks = [[(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(5, 0, 0), (7, 0, 0), (5, 2, 0)]]  # areas 0.5 and 2
    rel = "".join("".join(f"v {x} {y} {z}\n" for x, y, z in b) + f"o part{k}\nf -3 -2 -1\n"
                  for k, b in enumerate(blocks))
    absolute = "".join("".join(f"v {x} {y} {z}\n" for x, y, z in b) + f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}\n"
                       for k, b in enumerate(blocks))
    (tmp_path / "rel.obj").write_text(rel)
    (tmp_path / "abs.obj").write_text(absolute)
    v, f = load_triangles(str(tmp_path / "rel.obj"))
    assert _area(v, f) == pytest.approx(2.5)
    assert sorted(map(tuple, np.round(v[f].reshape(-1, 3), 9))) == sorted(map(tuple, np.round(
        np.array(blocks, dtype=float).reshape(-1, 3), 9)))
    va, fa = load_triangles(str(tmp_path / "abs.obj"))
    assert np.array_equal(v, va) and np.array_equal(f, fa)
    # texture and normal indices count back in their own lists
    assert obj_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf -3/-1/-1 -2/-1/-1 -1/-1/-1\n").splitlines()[-1] \
        == "f 1/1/1 2/1/1 3/1/1"


def test_files_without_relative_indices_or_concave_faces_are_left_to_trimesh(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"  # a convex quad: trimesh's fan is right
    assert obj_text(text) is text
    (tmp_path / "q.obj").write_text(text)
    v, f = load_triangles(str(tmp_path / "q.obj"))
    plain = trimesh.load(tmp_path / "q.obj", force="mesh")
    assert np.array_equal(v, plain.vertices) and np.array_equal(f, plain.faces)


def test_bad_faces_are_refused_naming_the_line(tmp_path):
    with pytest.raises(MeshFileError, match="line 4: face index -4 counts back past the first v"):
        obj_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n")
    bowtie = "v 0 0 0\nv 2 0 0\nv 0 2 0\nv 2 2 0\nv 1 3 0\nf 1 2 3 4 5\n"  # its outline crosses itself
    with pytest.raises(MeshFileError, match="line 6: a face of 5 corners is not a simple polygon"):
        obj_text(bowtie)
    (tmp_path / "bow.obj").write_text(bowtie)
    data = world_data({"type": "mesh", "path": "bow.obj", "position": [5.0, 5.0, 5.0]})
    (tmp_path / "w.json").write_text(json.dumps(data))
    with pytest.raises(WorldError, match=r"obstacles\[1\]\.path: .*not a simple polygon"):
        load_world(tmp_path / "w.json")


def _star_polygon(rng: np.random.Generator, n: int) -> np.ndarray:
    """A simple polygon: corners at increasing angles round the origin, no gap of pi or more (so it holds the
    origin and no edge can cross another), at random radii (concave corners)."""
    steps = rng.uniform(0.5, 1.0, n)
    angles = rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.cumsum(steps) / steps.sum()
    radii = rng.uniform(0.2, 1.0, n)
    return np.column_stack([radii * np.cos(angles), radii * np.sin(angles)])


def test_ear_clipping_covers_random_simple_polygons_exactly():
    rng = np.random.default_rng(49)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]  # any plane in space
    for _ in range(200):
        n = int(rng.integers(4, 14))
        p2 = _star_polygon(rng, n)
        if rng.random() < 0.5:
            p2 = p2[::-1]  # either orientation
        pts = np.column_stack([p2, np.zeros(n)]) @ R.T + rng.normal(size=3)
        tris = ear_clip(pts)
        assert len(tris) == n - 2 and sorted({i for t in tris for i in t}) == list(range(n))
        shoelace = 0.5 * abs(np.dot(p2[:, 0], np.roll(p2[:, 1], -1)) - np.dot(p2[:, 1], np.roll(p2[:, 0], -1)))
        f = np.array(tris)
        assert _area(pts, f) == pytest.approx(shoelace, rel=1e-9)
        # every triangle turns the polygon's way (normals agree with the outline's)
        normal = np.cross(pts[f[:, 1]] - pts[f[:, 0]], pts[f[:, 2]] - pts[f[:, 0]])
        outline = np.cross(pts[1] - pts[0], pts[2] - pts[0]) if is_convex(pts) else normal.sum(axis=0)
        assert (normal @ outline >= -1e-12).all()


def test_newells_normal_is_the_plane_normal_times_twice_the_area():
    from navstack.mesh_file import _newell

    rng = np.random.default_rng(7)
    for _ in range(50):
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        p2 = _star_polygon(rng, int(rng.integers(3, 12)))
        pts = np.column_stack([p2, np.zeros(len(p2))]) @ R.T + rng.normal(size=3)
        shoelace = 0.5 * (np.dot(p2[:, 0], np.roll(p2[:, 1], -1)) - np.dot(p2[:, 1], np.roll(p2[:, 0], -1)))
        # the plane's normal is R's third column (the polygon's own z axis); signed by the corner order
        assert np.allclose(_newell(pts[None])[0], 2.0 * shoelace * R[:, 2], atol=1e-12)


def test_convexity():
    square = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], dtype=float)
    assert is_convex(square) and is_convex(square[::-1])
    assert not is_convex(np.column_stack([L_SHAPE, np.ones(6)]))
    pentagram = np.array([(np.cos(a), np.sin(a), 0.0) for a in np.arange(5) * 4 * np.pi / 5])
    assert not is_convex(pentagram)  # every corner turns left, but it goes round twice
    assert not is_convex(np.zeros((4, 3))) and not is_convex(np.array([(0, 0, 0), (1, 0, 0), (1, 0, 0), (0, 0, 0.0)]))


def _ply_header(fmt: str, n_v: int, n_f: int) -> bytes:
    return (f"ply\nformat {fmt} 1.0\nelement vertex {n_v}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {n_f}\nproperty list uchar int vertex_indices\nend_header\n").encode()


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_polygons_concave_and_of_mixed_sizes(tmp_path, fmt):
    # the L hexagon at z = 1 and a triangle below it: faces of 6 and 3 corners in one file
    verts = [(x, y, 1.0) for x, y in L_SHAPE] + [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    faces = [list(range(6)), [6, 7, 8]]
    if fmt == "ascii":
        body = "".join(f"{x} {y} {z}\n" for x, y, z in verts) + "".join(f"{len(f)} {' '.join(map(str, f))}\n"
                                                                        for f in faces)
        data = _ply_header(fmt, len(verts), len(faces)) + body.encode()
    else:
        e = "<" if fmt.endswith("little_endian") else ">"
        data = _ply_header(fmt, len(verts), len(faces)) + b"".join(struct.pack(e + "3f", *v) for v in verts) + \
            b"".join(struct.pack(e + "B", len(f)) + struct.pack(e + f"{len(f)}i", *f) for f in faces)
    path = tmp_path / "m.ply"
    path.write_bytes(data)
    v, f = load_triangles(str(path))
    assert _area(v, f) == pytest.approx(3.5) and len(f) == 5
    top = v[f].mean(axis=1)
    top = top[top[:, 2] > 0.5]
    assert len(top) == 4 and _in_l_shape(top[:, :2]).all()


def test_ply_of_triangles_only_is_left_to_trimesh(tmp_path):
    from navstack.ply_faces import concave_ply

    verts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 1)]
    data = _ply_header("binary_little_endian", 4, 2) + b"".join(struct.pack("<3f", *v) for v in verts) + \
        b"".join(struct.pack("<B3i", 3, *f) for f in ([0, 1, 2], [1, 3, 2]))
    path = tmp_path / "t.ply"
    path.write_bytes(data)
    assert concave_ply(str(path)) is None
    v, f = load_triangles(str(path))
    plain = trimesh.load(path, force="mesh")
    assert np.array_equal(v, plain.vertices) and np.array_equal(f, plain.faces)


HARD13 = Path(__file__).resolve().parents[1] / "worlds" / "hard13"


@pytest.mark.slow
@pytest.mark.parametrize(("name", "reason", "clearance_mm", "contacts"), [
    ("obj_window", "collision", -29.864, 141),  # a jamb written with relative indices: trimesh alone lost it
    ("obj_concave_slot", "reached", 20.0, 0),  # a plate whose outline is one concave polygon: its slot was filled
])
def test_scripted_trials_read_as_the_independent_checker_reads_the_files(name, reason, clearance_mm, contacts):
    """The numbers are hard13's checker's (``worlds/hard13/verify_mesh.py``: the geometry each file means, kept in
    memory by the generator that wrote it, never loaded through trimesh)."""
    r = run_trial(load_world(HARD13 / f"{name}.json"), planner="scripted")
    assert r.reason == reason
    assert r.metrics["min_clearance"] * 1e3 == pytest.approx(clearance_mm, abs=0.01)
    assert r.metrics["contacts"] == contacts


def _obj(tmp_path, points, faces, name="m.obj"):
    path = tmp_path / name
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in points) + "".join(f"f {f}\n" for f in faces))
    return str(path)


def test_a_corner_written_twice_counts_once(tmp_path):
    # a review's cases: the repeated reflex corner hid the notch (fanned: area 4); repeated corners of convex
    # faces, and a closing corner written again, were refused as crossing themselves
    L3 = [(x, y, 0.0) for x, y in L_SHAPE]
    v, f = load_triangles(_obj(tmp_path, L3, ["1 2 3 3 4 5 6"]))
    assert _area(v, f) == pytest.approx(3.0) and _in_l_shape(v[f].mean(axis=1)[:, :2]).all()
    square = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    assert _area(*load_triangles(_obj(tmp_path, square, ["1 2 3 4 1"], "s.obj"))) == pytest.approx(1.0)
    pentagon = [(np.cos(a), np.sin(a), 0.0) for a in np.arange(5) * 2 * np.pi / 5]
    v, f = load_triangles(_obj(tmp_path, pentagon, ["1 2 3 4 4 5"], "p.obj"))
    assert _area(v, f) == pytest.approx(2.5 * np.sin(2 * np.pi / 5))


def test_concave_faces_with_texture_and_normal_indices(tmp_path):
    # as Blender writes them: v/vt/vn corners; the vertex is the first index of each (a mutation run's survivor)
    text = "".join(f"v {x} {y} 1\n" for x, y in L_SHAPE) + "vt 0 0\nvn 0 0 1\n" + \
        "f " + " ".join(f"{k}/1/1" for k in range(1, 7)) + "\n"
    (tmp_path / "l.obj").write_text(text)
    v, f = load_triangles(str(tmp_path / "l.obj"))
    assert _area(v, f) == pytest.approx(3.0) and _in_l_shape(v[f].mean(axis=1)[:, :2]).all()


def test_faces_without_area_are_left_as_trimesh_reads_them(tmp_path):
    points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0), (0, 1, 0)]  # four corners on a line: no area
    v, f = load_triangles(_obj(tmp_path, points, ["1 2 3 4", "1 2 5"]))
    assert _area(v, f) == pytest.approx(0.5)
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (3, 3, 3)]
    data = _ply_header("ascii", 5, 2) + "".join(f"{x} {y} {z}\n" for x, y, z in verts).encode() + \
        b"4 0 1 2 3\n2 0 4\n"  # a face of two corners beside a polygon: no surface, skipped
    (tmp_path / "two.ply").write_bytes(data)
    assert _area(*load_triangles(str(tmp_path / "two.ply"))) == pytest.approx(1.0)


def test_a_hole_bridged_into_the_outline_and_huge_concave_faces_are_refused_saying_why(tmp_path):
    outer = [(0, 0, 0), (4, 0, 0), (4, 4, 0), (0, 4, 0)]
    hole = [(1, 1, 0), (1, 3, 0), (3, 3, 0), (3, 1, 0)]
    path = _obj(tmp_path, outer + hole, ["1 2 3 4 1 5 6 7 8 5"])
    with pytest.raises(MeshFileError, match="line 9: .*crosses or touches itself \\(a hole joined by a bridge"):
        load_triangles(path)
    n = 1026  # a comb: concave, and more corners than are cut here
    comb = [(k / n, (k % 2) * 0.5, 0.0) for k in range(n - 2)] + [(1.0, -1.0, 0.0), (0.0, -1.0, 0.0)]
    with pytest.raises(MeshFileError, match="a concave face of 1026 corners; at most 1024"):
        load_triangles(_obj(tmp_path, comb, [" ".join(str(k + 1) for k in range(n))], "comb.obj"))


DART = [(0.0, 0.0), (2.0, 1.0), (0.0, 2.0), (0.8, 1.0)]  # a concave quad (area 1.2): its fan from (0, 0), beside
# the inward corner, covers the notch too (area 2.8)


def _ply_bytes(fmt: str, verts, faces) -> bytes:
    if fmt == "ascii":
        return _ply_header(fmt, len(verts), len(faces)) + "".join(f"{x} {y} {z}\n" for x, y, z in verts).encode() + \
            "".join(f"{len(f)} {' '.join(map(str, f))}\n" for f in faces).encode()
    e = "<" if fmt.endswith("little_endian") else ">"
    return _ply_header(fmt, len(verts), len(faces)) + b"".join(struct.pack(e + "3f", *v) for v in verts) + \
        b"".join(struct.pack(e + "B", len(f)) + struct.pack(e + f"{len(f)}i", *f) for f in faces)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_faces_all_of_one_size_concave_and_the_smallest_first(tmp_path, fmt):
    # two darts whose fans from their first corners cover their notches: the faces, all of one size, take the
    # one-pass reading
    verts = [(x, y, 0.0) for x, y in DART] + [(x + 5, y, 1.0) for x, y in DART]
    faces = [[0, 1, 2, 3], [4, 5, 6, 7]]
    (tmp_path / "d.ply").write_bytes(_ply_bytes(fmt, verts, faces))
    v, f = load_triangles(str(tmp_path / "d.ply"))
    assert _area(v, f) == pytest.approx(2.4) and len(f) == 4
    # a triangle first, then polygons of more corners: a reading that took every face to be a triangle would
    # read garbage
    tri = [(0.0, 5.0, 0.0), (1.0, 5.0, 0.0), (0.0, 6.0, 0.0)]
    verts2 = verts + tri
    faces2 = [[8, 9, 10], [0, 1, 2, 3], [4, 5, 6, 7]]
    (tmp_path / "t.ply").write_bytes(_ply_bytes(fmt, verts2, faces2))
    v, f = load_triangles(str(tmp_path / "t.ply"))
    assert _area(v, f) == pytest.approx(2.9) and len(f) == 5


def test_a_ply_this_reader_cannot_parse_is_left_to_trimesh(tmp_path):
    from navstack.ply_faces import concave_ply

    (tmp_path / "x.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex many\nend_header\n")
    assert concave_ply(str(tmp_path / "x.ply")) is None  # trimesh then reads it, or says why not


@pytest.mark.parametrize("bad", [4, -1])
def test_a_ply_face_naming_a_vertex_the_file_lacks_is_refused(tmp_path, bad):
    # 4 vertices: a quad naming vertex 4 (one past the last) or -1 must be refused, naming the index, not read
    # out of bounds (ply_faces mutation run: an index past the end alone went unnoticed)
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    (tmp_path / "q.ply").write_bytes(_ply_bytes("ascii", verts, [[0, 1, 2, bad]]))
    with pytest.raises(MeshFileError, match=f"a face names vertex {bad}; the file has 4"):
        load_triangles(str(tmp_path / "q.ply"))


def test_a_file_not_starting_with_ply_is_not_read_as_one(tmp_path):
    from navstack.ply_faces import concave_ply

    # a valid file's body with its first line changed: not a PLY file, whatever follows (left to trimesh)
    data = _ply_bytes("ascii", [(x, y, 0.0) for x, y in DART], [[0, 1, 2, 3]])
    assert concave_ply(str(_write(tmp_path / "ok.ply", data))) is not None
    assert concave_ply(str(_write(tmp_path / "no.ply", b"plx" + data[3:]))) is None


def _write(path, data: bytes):
    path.write_bytes(data)
    return path
