"""Inner walls (navstack.sim.mesh_walls): a face two glued solids share is not the solid's surface, so a depth
inside does not count it; against the union box's closed-form depth."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from test_mesh_inside import _cube, _glued

from navstack.sim import mesh_walls
from navstack.sim.mesh_depth import MeshDepth
from navstack.sim.mesh_inside import nesting, solids
from navstack.world import Mesh


def _walls(vertices, faces) -> np.ndarray:
    parts = solids(vertices, faces)
    tri = np.ascontiguousarray(np.asarray(vertices, dtype=float)[np.asarray(faces)])
    return mesh_walls.inner_walls(tri, [np.ascontiguousarray(v[f]) for v, f in parts], nesting(parts))


def _depth(tmp_path, mesh: trimesh.Trimesh) -> MeshDepth:
    m = Mesh(path=tmp_path / "m.obj", position=np.zeros(3), rpy=np.zeros(3), scale=1.0)
    mesh.export(m.path)
    return MeshDepth(m)


def _box_depth(a, b, lo, hi) -> float:
    """Closed form: the greatest distance to the faces of the box lo..hi along segment a-b wholly inside it (the
    distance to the faces is concave inside a box; sampled finely, it is exact at a breakpoint or an end)."""
    t = np.linspace(0.0, 1.0, 40001)[:, None]
    p = np.asarray(a) + t * (np.asarray(b) - np.asarray(a))
    return float(np.minimum(p - lo, hi - p).min(axis=1).max())


@pytest.mark.parametrize("other_diagonal", [False, True])
def test_the_face_two_glued_cubes_share_is_an_inner_wall(tmp_path, other_diagonal):
    """Two unit cubes glued at x = 1, each facing out: the shared face's four triangles (two per cube, whatever
    their diagonals) are the only inner walls, and a link across or beside it is as deep as in the 2 x 1 x 1 box
    (it read -0.25 m across the wall, measured to it)."""
    glued = _glued(False, other_diagonal)
    walls = _walls(glued.vertices, glued.faces)
    centres = glued.vertices[glued.faces].mean(axis=1)
    np.testing.assert_array_equal(walls, np.abs(centres[:, 0] - 1.0) < 1e-9)
    assert walls.sum() == 4
    depth = _depth(tmp_path, glued)
    lo, hi = np.zeros(3), np.array([2.0, 1.0, 1.0])
    for a, b in (([0.8, 0.5, 0.5], [1.2, 0.5, 0.5]), ([1.02, 0.4, 0.6], [1.1, 0.45, 0.5]),
                 ([0.7, 0.2, 0.3], [1.6, 0.8, 0.7])):
        expected = -_box_depth(a, b, lo, hi) - 0.05
        assert depth.capsule_clearance(a, b, 0.05, 0.0) == pytest.approx(expected, abs=1e-6)


def test_a_face_shared_in_part_keeps_the_triangles_not_covered():
    """A small box glued to the middle of a unit cube's face: the small box's face there has solid on both sides
    (an inner wall), the cube's face is partly the surface (kept)."""
    va, fa = _cube([0, 0, 0], [1, 1, 1])
    vb, fb = _cube([1, 0.25, 0.25], [1.5, 0.75, 0.75])
    walls = _walls(np.vstack([va, vb]), np.vstack([fa, fb + 8]))
    assert np.flatnonzero(walls).tolist() == [12 + k for k in range(12)
                                              if np.allclose(vb[fb[k]][:, 0], 1.0)]


def test_faces_that_only_face_each_other_are_not_walls(tmp_path):
    """Not glued: two cubes 5 mm apart, a two-sided sheet beside a solid cube (a triangle of it in the plane
    of the cube's face, facing the other way, boxes meeting, but with nothing on its other side), and a sheet
    lying on the cube's face facing in (solid on its front, nothing behind)."""
    va, fa = _cube([0, 0, 0], [1, 1, 1])
    vb, fb = _cube([1.005, 0, 0], [2, 1, 1])
    assert not _walls(np.vstack([va, vb]), np.vstack([fa, fb + 8])).any()
    sheet = np.array([[1.0, 1.0, 0.0], [1.0, 2.0, 0.0], [1.0, 1.0, 1.0]])  # x = 1, touching the cube's edge
    v = np.vstack([va, sheet])
    f = np.vstack([fa, [[8, 9, 10], [8, 10, 9]]])
    assert not _walls(v, f).any()
    inward = np.array([[0.0, 0.2, 0.2], [0.0, 0.8, 0.2], [0.0, 0.2, 0.8]])  # x = 0, facing +x: into the cube
    assert np.cross(inward[1] - inward[0], inward[2] - inward[0])[0] > 0
    assert not _walls(np.vstack([va, inward]), np.vstack([fa, [[8, 9, 10]]])).any()


def test_wall_tests_past_the_budget_keep_every_triangle(tmp_path, monkeypatch):
    """Past :data:`WALL_TESTS` nothing is tested: the depth is measured to the nearest triangle, as before."""
    monkeypatch.setattr(mesh_walls, "WALL_TESTS", 0)
    glued = _glued(False, False)
    assert not _walls(glued.vertices, glued.faces).any()
    assert _depth(tmp_path, glued).capsule_clearance([0.8, 0.5, 0.5], [1.2, 0.5, 0.5], 0.05, 0.0) == \
        pytest.approx(-0.25, abs=1e-6)


def test_candidates_are_coplanar_opposite_triangles_whose_boxes_meet():
    """Only triangles with another of the file in their plane, facing the other way, boxes meeting, are tested:
    none in a cube, the shared face's four in the glued pair, none between a cube and a far one whose face lies in
    the same plane facing it."""
    va, fa = _cube([0, 0, 0], [1, 1, 1])
    assert mesh_walls._opposite_pairs(va[fa]).tolist() == []
    glued = _glued(False, True)
    tri = glued.vertices[glued.faces]
    assert mesh_walls._opposite_pairs(tri).tolist() == np.flatnonzero(np.abs(tri[:, :, 0] - 1.0).max(axis=1) < 1e-12
                                                                      ).tolist()
    vb, fb = _cube([1, 2, 0], [2, 3, 1])  # its face x = 1 faces -x, the cube's +x: one plane, boxes 1 m apart
    assert mesh_walls._opposite_pairs(np.vstack([va[fa], vb[fb]])).tolist() == []


def test_samples_are_the_centroid_edge_midpoints_and_corners_pulled_in():
    t = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 6.0, 0.0]])
    c = np.array([1.0, 2.0, 0.0])
    raw = [c, (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[2] + t[0]) / 2, t[0], t[1], t[2]]
    expected = sorted(map(tuple, np.round([p + 0.01 * (c - p) for p in raw], 12)))
    assert sorted(map(tuple, np.round(mesh_walls._samples(t), 12))) == expected


def test_a_thin_plate_glued_on_is_walled_and_the_budget_counts_what_it_says(monkeypatch):
    """A 5 mm plate glued to a cube: solid on both sides of the shared face within :data:`OFFSET` (0.2 mm).  The
    budget is candidates x 14 samples x the solid's triangles: at that count the walls are tested, one below not."""
    va, fa = _cube([0, 0, 0], [1, 1, 1])
    vb, fb = _cube([1, 0, 0], [1.005, 1, 1])
    v, f = np.vstack([va, vb]), np.vstack([fa, fb + 8])
    walls = _walls(v, f)
    assert np.flatnonzero(walls).tolist() == [k for k in range(24) if np.allclose(v[f[k]][:, 0], 1.0)]
    parts = solids(v, f)
    cost = 4 * 14 * sum(len(pf) for _, pf in parts)
    monkeypatch.setattr(mesh_walls, "WALL_TESTS", cost)
    assert _walls(v, f).sum() == 4
    monkeypatch.setattr(mesh_walls, "WALL_TESTS", cost - 1)
    assert _walls(v, f).sum() == 0
