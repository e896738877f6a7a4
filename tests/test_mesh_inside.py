"""Inside a closed mesh (navstack.sim.mesh_inside): winding numbers against closed-form shapes, and the start
check that refuses a robot wholly inside a closed mesh, which PyBullet's distances cannot see (a wrong success
before: the trial ran inside a solid block and reached its goal)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from _worlds import BASE_POSITION, TIP, world_data
from scipy.spatial.transform import Rotation

from navstack.cli import main
from navstack.sim.mesh_depth import MeshDepth
from navstack.sim.mesh_inside import WELD, is_closed, points_inside, solids, welded, winding_numbers
from navstack.trial import check_start
from navstack.world import Mesh, WorldError, load_world

RNG = np.random.default_rng(7)


def test_winding_numbers_of_a_box_and_a_sphere_against_their_closed_forms():
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    ball = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    pts = RNG.uniform(-1.5, 1.5, size=(400, 3))
    in_box = np.all(np.abs(pts) < [1.0, 0.5, 0.25], axis=1)
    r = np.linalg.norm(pts, axis=1)
    keep = np.abs(r - 1.0) > 0.01  # the icosphere is within 0.3 % of the unit sphere
    w_box = winding_numbers(box.vertices, box.faces, pts)
    w_ball = winding_numbers(ball.vertices, ball.faces, pts[keep])
    np.testing.assert_allclose(np.abs(w_box), in_box.astype(float), atol=1e-9)
    np.testing.assert_allclose(np.abs(w_ball), (r[keep] < 1.0).astype(float), atol=1e-9)
    flipped = winding_numbers(box.vertices, box.faces[:, ::-1], pts)  # the faces' orientation gives the sign
    np.testing.assert_allclose(flipped, -w_box, atol=1e-9)


def test_points_inside_follows_the_placement_and_ignores_open_meshes(tmp_path):
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    box.export(tmp_path / "box.stl")
    rpy, position = np.array([0.3, -0.2, 1.1]), np.array([4.0, -1.0, 2.0])
    mesh = Mesh(path=tmp_path / "box.stl", position=position, rpy=rpy, scale=2.0)
    local = RNG.uniform(-2.5, 2.5, size=(300, 3))  # in the mesh's own frame, scaled box half-extents 2, 1, 0.5
    world = local @ Rotation.from_euler("xyz", rpy).as_matrix().T + position
    np.testing.assert_array_equal(points_inside(mesh, world), np.all(np.abs(local) < [2.0, 1.0, 0.5], axis=1))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1])
    open_box.export(tmp_path / "open.stl")
    assert is_closed(box.vertices, box.faces) and not is_closed(open_box.vertices, open_box.faces)
    assert not points_inside(Mesh(path=tmp_path / "open.stl", position=position, rpy=rpy, scale=2.0), world).any()


def _l_block() -> trimesh.Trimesh:
    """A concave L: the outline (0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2) extruded from z = 0 to 1, away
    from the origin (a point and its mirror image are not alike); closed, faces outward."""
    outline = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]  # counter-clockwise, star-shaped from (0, 0)
    n = len(outline)
    vertices = [(x, y, 0.0) for x, y in outline] + [(x, y, 1.0) for x, y in outline]
    faces = []
    for i in range(1, n - 1):  # a fan from corner 0: the bottom facing -z, the top +z
        faces += [(0, i + 1, i), (n, n + i, n + i + 1)]
    for i in range(n):  # the sides: each edge's quad, its normal to the right of the edge (outwards)
        j = (i + 1) % n
        faces += [(i, j, n + j), (i, n + j, n + i)]
    return trimesh.Trimesh(np.array(vertices, dtype=float), np.array(faces), process=False)


def _in_l(p: np.ndarray) -> np.ndarray:
    x, y, z = p.T
    return (0 < x) & (x < 2) & (0 < y) & (y < 2) & (0 < z) & (z < 1) & ~((x > 1) & (y > 1))


def test_winding_numbers_and_points_inside_a_concave_mesh_off_the_origin(tmp_path, monkeypatch):
    """An L-shaped block off the origin: a point of its box outside the L (its missing corner) is outside; the
    winding number is the point's own (not its mirror image's); only points in the mesh's box are asked."""
    import navstack.sim.mesh_inside as mesh_inside

    block = _l_block()
    assert block.is_watertight and block.volume > 0  # outward faces
    pts = RNG.uniform(-0.5, 2.5, size=(600, 3))
    pts = pts[np.min(np.abs(np.concatenate([pts, pts - 1.0, pts - 2.0], axis=1)), axis=1) > 0.01]  # off the faces
    np.testing.assert_allclose(winding_numbers(block.vertices, block.faces, pts), _in_l(pts).astype(float),
                               atol=1e-9)
    block.export(tmp_path / "l.stl")
    mesh = Mesh(path=tmp_path / "l.stl", position=np.zeros(3), rpy=np.zeros(3), scale=1.0)
    asked = []
    original = mesh_inside.held
    monkeypatch.setattr(mesh_inside, "held", lambda parts, depths, p: asked.append(p) or original(parts, depths, p))
    inside = points_inside(mesh, pts)
    np.testing.assert_array_equal(inside, _in_l(pts))
    corner = (pts[:, 0] > 1) & (pts[:, 1] > 1) & np.all((pts > 0) & (pts < [2, 2, 1]), axis=1)
    assert corner.sum() > 20 and not inside[corner].any()  # in the box, outside the L
    in_box = np.all((pts >= 0) & (pts <= [2, 2, 1]), axis=1)
    assert len(asked) == in_box.sum() < len(pts)  # the rest never reach the winding numbers


def test_is_closed_merges_the_vertices_an_stl_repeats_per_triangle():
    """STL files store each triangle's own three vertices: closed once coincident vertices are merged."""
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    soup = box.vertices[box.faces].reshape(-1, 3)
    assert is_closed(soup, np.arange(len(soup)).reshape(-1, 3))


def _block_world(tmp_path, mesh: trimesh.Trimesh, center) -> str:
    mesh.export(tmp_path / "block.stl")
    data = world_data({"type": "mesh", "path": "block.stl", "position": list(map(float, center))})
    path = tmp_path / "world.json"
    path.write_text(json.dumps(data))
    return str(path)


def test_a_robot_inside_a_closed_mesh_is_refused(tmp_path, capsys):
    world = _block_world(tmp_path, trimesh.creation.box(extents=[6.0, 6.0, 6.0]), BASE_POSITION)
    with pytest.raises(WorldError) as ei:
        check_start(load_world(world))
    assert ei.value.json_path == "obstacles[1]" and "is inside this mesh" in str(ei.value)
    out = tmp_path / "out"
    assert main(["run", world, "--out", str(out), "--planner", "scripted"]) == 2
    assert "world.json: obstacles[1]: the robot at q0 is inside this mesh" in capsys.readouterr().err
    assert not (out / "result.json").exists()


def _turned(mesh: trimesh.Trimesh, which: slice) -> trimesh.Trimesh:
    faces = mesh.faces.copy()
    faces[which] = faces[which, ::-1]
    return trimesh.Trimesh(mesh.vertices, faces, process=False)


@pytest.mark.parametrize("case", ["every-other-face-turned", "one-face-turned", "all-turned", "duplicated"])
def test_a_robot_inside_a_closed_mesh_is_refused_whatever_its_faces_orientation(tmp_path, case):
    """Every other face turned: the winding numbers cancel (0 inside) and the trial inside the block was a
    SUCCESS; each triangle twice: not watertight (each edge in four faces), the same."""
    block = trimesh.creation.box(extents=[6.0, 6.0, 6.0])
    mesh = {"every-other-face-turned": lambda: _turned(block, slice(None, None, 2)),
            "one-face-turned": lambda: _turned(block, slice(0, 1)),
            "all-turned": lambda: _turned(block, slice(None)),
            "duplicated": lambda: trimesh.Trimesh(block.vertices, np.vstack([block.faces, block.faces]),
                                                  process=False)}[case]()
    world = _block_world(tmp_path, mesh, BASE_POSITION)
    with pytest.raises(WorldError, match="is inside this mesh"):
        check_start(load_world(world))
    inside = points_inside(load_world(world).obstacles[1], np.array([BASE_POSITION, BASE_POSITION + [3.5, 0, 0]]))
    assert inside.tolist() == [True, False]


@pytest.mark.parametrize("case", ["open", "elsewhere"])
def test_an_open_mesh_around_the_robot_or_a_closed_one_elsewhere_is_accepted(tmp_path, case):
    block = trimesh.creation.box(extents=[6.0, 6.0, 6.0])
    if case == "open":  # a surface with a hole has no inside: the robot in it is not in any solid
        world = _block_world(tmp_path, trimesh.Trimesh(block.vertices, block.faces[:-1]), BASE_POSITION)
    else:
        world = _block_world(tmp_path, block, TIP + [0.0, 0.0, 5.0])
    check_start(load_world(world))


@pytest.mark.parametrize("second_turned", [False, True])
def test_overlapping_closed_parts_each_hold_their_inside_whatever_their_orientation(tmp_path, second_turned):
    """Two overlapping closed boxes in one file, the second with its faces turned inward: their winding
    numbers cancel where they overlap (+1 - 1 = 0), and a robot there was a SUCCESS (a review's case).  Each
    part is now taken on its own."""
    a = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    b = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    b.apply_translation([0.5, 0.0, 0.0])
    if second_turned:
        b.invert()
    both = trimesh.util.concatenate([a, b])
    both.export(tmp_path / "two.stl")
    assert len(solids(both.vertices, both.faces)) == 2 and is_closed(both.vertices, both.faces)
    mesh = Mesh(path=tmp_path / "two.stl", position=np.zeros(3), rpy=np.zeros(3), scale=1.0)
    points = np.array([[0.25, 0, 0], [-0.3, 0, 0], [0.8, 0, 0], [1.2, 0, 0]])  # both, only a, only b, neither
    assert points_inside(mesh, points).tolist() == [True, True, True, False]
    big = trimesh.util.concatenate([trimesh.creation.box(extents=[6.0, 6.0, 6.0]),
                                    trimesh.creation.box(extents=[6.0, 6.0, 6.0]).apply_translation([1.0, 0, 0])])
    if second_turned:
        big = trimesh.Trimesh(big.vertices, np.vstack([big.faces[:12], big.faces[12:, ::-1]]), process=False)
    world = _block_world(tmp_path, big, BASE_POSITION)  # the robot inside both
    with pytest.raises(WorldError, match="is inside this mesh"):
        check_start(load_world(world))


@pytest.mark.parametrize("inner_turned", [True, False])
def test_a_part_wholly_inside_another_is_a_cavity_and_one_inside_that_a_solid(tmp_path, inner_turned):
    """A room (a 6 m box) with 0.5 m thick walls, written as its outer and inner surfaces in one mesh, and a
    pillar standing in it: a point in the wall or the pillar is inside, one in the room is not, whatever
    way the inner surface's faces turn (it was refused: the robot standing in the room was "inside" the
    outer surface).  The pillar stands on the floor and holds up the ceiling (its ends on the inner surface)."""
    inner = trimesh.creation.box(extents=[5.0, 5.0, 5.0])
    if inner_turned:
        inner.invert()
    pillar = trimesh.creation.box(extents=[0.4, 0.4, 5.0]).apply_translation([1.5, 1.5, 0.0])
    room = trimesh.util.concatenate([trimesh.creation.box(extents=[6.0, 6.0, 6.0]), inner, pillar])
    room.export(tmp_path / "room.stl")
    mesh = Mesh(path=tmp_path / "room.stl", position=np.zeros(3), rpy=np.zeros(3), scale=1.0)
    points = np.array([[0.0, 0, 0], [2.75, 0, 0], [1.5, 1.5, 0.0], [3.5, 0, 0], [0.0, -2.9, 1.0]])
    # in the room, in the wall, in the pillar, outside, in the wall
    assert points_inside(mesh, points).tolist() == [False, True, True, False, True]
    world = _block_world(tmp_path, room, BASE_POSITION)  # the robot stands in the room
    check_start(load_world(world))


def test_a_closed_part_beside_an_open_one_still_has_its_inside(tmp_path):
    closed = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    plate = trimesh.creation.box(extents=[1.0, 1.0, 0.1]).apply_translation([3.0, 0, 0])
    plate = trimesh.Trimesh(plate.vertices, plate.faces[:-2])  # a box with a face missing: open
    both = trimesh.util.concatenate([closed, plate])
    both.export(tmp_path / "mixed.stl")
    assert not is_closed(both.vertices, both.faces) and len(solids(both.vertices, both.faces)) == 1
    mesh = Mesh(path=tmp_path / "mixed.stl", position=np.zeros(3), rpy=np.zeros(3), scale=1.0)
    assert points_inside(mesh, np.array([[0.0, 0, 0], [3.0, 0, 0]])).tolist() == [True, False]


def _cube(lo, hi, other_diagonal: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The box ``lo``..``hi`` [m] as 8 corners and 12 triangles facing out, each square face cut along the
    diagonal from its lowest corner (least x + y + z) or (``other_diagonal``) the other."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    corners = np.array([[(hi if i >> k & 1 else lo)[k] for k in range(3)] for i in range(8)])
    faces = []
    for axis in range(3):
        u, w = [k for k in range(3) if k != axis]
        for side in (0, 1):
            quad = [i for i in range(8) if (i >> axis & 1) == side]  # 4 corners, ordered round the square:
            quad = [quad[0], quad[1], quad[3], quad[2]] if u < w else quad
            c = corners[quad]
            if np.dot(np.cross(c[1] - c[0], c[2] - c[0]), c.mean(axis=0) - corners.mean(axis=0)) < 0:
                quad = quad[::-1]
            first = int(np.argmin(corners[quad].sum(axis=1))) + other_diagonal  # the cut: from the lowest corner
            a, b, cc, d = quad[first % 4:] + quad[: first % 4]
            faces += [(a, b, cc), (a, cc, d)]
    return corners, np.array(faces)


def _keys(vertices, faces) -> list[tuple]:
    """Each triangle as the set of its corners' coordinates."""
    return [tuple(map(tuple, np.asarray(vertices)[t])) for t in np.asarray(faces)]


def _glued(turned: bool, other_diagonal: bool) -> trimesh.Trimesh:
    """Two unit cubes sharing the face x = 1, in one file (their edges there are in four faces); the second's
    faces turned inward (``turned``), its shared face cut along the other diagonal (``other_diagonal``)."""
    va, fa = _cube([0, 0, 0], [1, 1, 1])
    vb, fb = _cube([1, 0, 0], [2, 1, 1], other_diagonal)
    return trimesh.Trimesh(np.vstack([va, vb]), np.vstack([fa, (fb[:, ::-1] if turned else fb) + 8]), process=False)


@pytest.mark.parametrize("turned", [False, True])
@pytest.mark.parametrize("other_diagonal", [False, True])
def test_solids_glued_face_to_face_have_their_inside(tmp_path, turned, other_diagonal):
    """Two closed boxes sharing a face in one file: no edge there is in exactly two faces, so trimesh calls it
    open, and a robot wholly inside had no contact and was not refused (a review's case, session 38)."""
    glued = _glued(turned, other_diagonal)
    va, fa = _cube([0, 0, 0], [1, 1, 1])
    assert trimesh.Trimesh(va, fa).is_watertight and trimesh.Trimesh(va, fa).is_volume  # the cube is right
    assert not trimesh.Trimesh(glued.vertices, glued.faces).is_watertight  # what trimesh alone says
    assert is_closed(glued.vertices, glued.faces)
    shared = {tuple(sorted(t)) for t in _keys(glued.vertices, glued.faces[:12])} & {
        tuple(sorted(t)) for t in _keys(glued.vertices, glued.faces[12:])}
    assert len(shared) == (0 if other_diagonal else 2)  # the shared face's triangles: twice, or cut apart
    if not (turned and shared):  # there the shared triangles repeat the same way round, as an STL's repeats do
        assert is_closed(glued.vertices, np.vstack([glued.faces, glued.faces[[3, 20]]]))  # an STL's repeats too
    mesh = Mesh(path=tmp_path / "glued.obj", position=np.zeros(3), rpy=np.zeros(3), scale=1.0)
    glued.export(mesh.path)
    points = RNG.uniform([-0.5, -0.5, -0.5], [2.5, 1.5, 1.5], size=(300, 3))
    points = points[np.abs(points[:, 0] - 1.0) > 1e-3]  # not on the shared face
    expected = np.all((points > [0, 0, 0]) & (points < [2, 1, 1]), axis=1)
    np.testing.assert_array_equal(points_inside(mesh, points), expected)
    assert expected.sum() > 30 and (~expected).sum() > 30
    depth = MeshDepth(mesh)  # a link wholly inside the second box: 0.5 m from its walls at its middle
    assert depth.closed and depth.capsule_clearance([1.3, 0.5, 0.5], [1.7, 0.5, 0.5], 0.05, 0.0, True) == \
        pytest.approx(-0.55, abs=1e-6)
    big = trimesh.Trimesh(8.0 * glued.vertices - [12.0, 4.0, 4.0], glued.faces, process=False)  # glued at x -4
    with pytest.raises(WorldError, match="is inside this mesh"):
        check_start(load_world(_block_world(tmp_path, big, BASE_POSITION)))


def test_a_closed_box_with_t_junctions_has_its_inside(tmp_path):
    """A box whose top is cut finer than its sides (a vertex on another triangle's edge: a CAD export's
    neighbouring faces tessellated apart), and an icosphere with every third triangle cut: open to trimesh,
    closed to the winding number.  A robot inside was not refused."""
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    v, f = trimesh.remesh.subdivide(box.vertices, box.faces, face_index=np.flatnonzero(box.face_normals[:, 2] > 0.5))
    ball = trimesh.creation.icosphere(subdivisions=3)
    bv, bf = trimesh.remesh.subdivide(ball.vertices, ball.faces, face_index=np.arange(0, len(ball.faces), 3))
    for vertices, faces in ((v, f), (bv, bf)):
        assert not trimesh.Trimesh(vertices, faces).is_watertight and is_closed(vertices, faces)
    points = RNG.uniform(-1.2, 1.2, size=(400, 3))
    in_box = np.all(np.abs(points) < [1.0, 0.5, 0.25], axis=1)
    w_box = sum(winding_numbers(*part, points) for part in solids(v, f))
    np.testing.assert_allclose(np.abs(w_box), in_box.astype(float), atol=1e-9)
    r = np.linalg.norm(points, axis=1)
    keep = np.abs(r - 1.0) > 0.02  # the icosphere is within 1.3 % of the unit sphere
    w_ball = sum(winding_numbers(*part, points[keep]) for part in solids(bv, bf))
    np.testing.assert_allclose(np.abs(w_ball), (r[keep] < 1.0).astype(float), atol=1e-9)
    block = trimesh.Trimesh(v * [3.0, 6.0, 12.0], f, process=False)  # 6 m each way
    with pytest.raises(WorldError, match="is inside this mesh"):
        check_start(load_world(_block_world(tmp_path, block, BASE_POSITION)))


def test_glued_or_t_junction_surfaces_with_a_hole_stay_open():
    """Mending closes only what is closed: with a triangle taken out of either glued box or of the T-junction
    box, or a stray triangle across the inside, the holed box holds nothing (the other glued box may)."""
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    v, f = trimesh.remesh.subdivide(box.vertices, box.faces, face_index=np.flatnonzero(box.face_normals[:, 2] > 0.5))
    cases = [(v, np.delete(f, k, axis=0), [0.0, 0.0, 0.0]) for k in (0, 7, len(f) - 1)]
    for other_diagonal in (False, True):
        glued = _glued(False, other_diagonal)
        cases += [(glued.vertices, np.delete(glued.faces, k, axis=0), [0.5 + k // 12, 0.5, 0.5])
                  for k in (0, 5, 13, 23)]
        cases.append((glued.vertices, np.vstack([glued.faces, [[0, 3, 7]]]), [0.5, 0.5, 0.5]))  # across a's inside
    for vertices, faces, centre in cases:
        assert not is_closed(vertices, faces)
        assert all(abs(winding_numbers(*part, [centre])[0]) < 0.5 for part in solids(vertices, faces))


def _cracked(mesh: trimesh.Trimesh, crack: float, seed: int = 3) -> trimesh.Trimesh:
    """``mesh`` as a triangle soup (each triangle its own corners, as CAD exports write them), every corner
    nudged by up to ``crack`` [m] along each axis: closed to its user, cracks of up to ``2 sqrt(3) crack``."""
    soup = mesh.vertices[mesh.faces].reshape(-1, 3)
    soup = soup + np.random.default_rng(seed).uniform(-crack, crack, soup.shape)
    return trimesh.Trimesh(soup, np.arange(len(soup)).reshape(-1, 3), process=False)


@pytest.mark.parametrize("crack", [1e-7, 5e-6, 2e-5])
def test_a_robot_inside_a_block_with_hairline_cracks_is_refused(tmp_path, crack):
    """A closed block written as a soup whose corners miss each other by micrometres (an audit's wrong
    SUCCESS: not watertight, so no inside, and the trial ran inside the solid and reached its goals)."""
    block = _cracked(trimesh.creation.box(extents=[6.0, 6.0, 6.0]), crack)
    assert not trimesh.Trimesh(block.vertices, block.faces).is_watertight  # what trimesh alone says
    block.export(tmp_path / "block.obj")
    data = world_data({"type": "mesh", "path": "block.obj", "position": list(map(float, BASE_POSITION))})
    (tmp_path / "world.json").write_text(json.dumps(data))
    with pytest.raises(WorldError, match="is inside this mesh"):
        check_start(load_world(str(tmp_path / "world.json")))


def test_cracks_wider_than_the_weld_leave_an_open_surface():
    """The weld is for rounding, not for gaps: cracks of a few WELD stay open (no inside, as before)."""
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    assert is_closed(*_unpack(_cracked(box, 0.2 * WELD)))
    assert not is_closed(*_unpack(_cracked(box, 5.0 * WELD)))


def _unpack(mesh: trimesh.Trimesh):
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_welded_merges_chains_of_near_vertices_and_drops_the_faces_they_collapse():
    v = np.array([[0.0, 0, 0], [0.6 * WELD, 0, 0], [1.2 * WELD, 0, 0], [1.0, 0, 0], [0.0, 1.0, 0], [5 * WELD, 0, 0]])
    f = np.array([[0, 3, 4], [2, 3, 4], [0, 1, 3], [5, 3, 4]])
    wv, wf = welded(v, f)
    np.testing.assert_array_equal(wv, v)  # the vertices are kept; the faces are renumbered
    # 0, 1, 2 chain within WELD of each other (0 and 2 are 1.2 WELD apart): one vertex, 0; 5 stays apart
    np.testing.assert_array_equal(wf, [[0, 3, 4], [0, 3, 4], [5, 3, 4]])
    assert welded(v[[0, 3, 4]], [[0, 1, 2]])[1].tolist() == [[0, 1, 2]]  # nothing near: unchanged
