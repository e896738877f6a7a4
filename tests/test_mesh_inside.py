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
from navstack.sim.mesh_inside import WELD, held, is_closed, nesting, points_inside, solids, welded, winding_numbers
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


def _inside(vertices, faces, points) -> list[bool]:
    """points_inside's rule on the triangles as given (no file, no placement)."""
    parts = solids(vertices, faces)
    triangles, depths = [np.ascontiguousarray(v[f]) for v, f in parts], nesting(parts)
    return [held(triangles, depths, np.asarray(p, dtype=float)) for p in points]


def _outward(vertices, faces, centre) -> np.ndarray:
    """``faces`` each turned to face away from ``centre`` (a convex solid's)."""
    t = vertices[faces]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    turn = np.einsum("ij,ij->i", n, t.mean(axis=1) - centre) < 0
    faces = faces.copy()
    faces[turn] = faces[turn][:, ::-1]
    return faces


def _cad_box(lo, hi, rng) -> tuple[np.ndarray, np.ndarray]:
    """The box lo..hi [m] as a CAD export writes it: each face triangulated on its own (Delaunay of its corners,
    random points on its edges and inside), so T-junctions run along every edge; faces outward."""
    from scipy.spatial import Delaunay

    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    vertices, faces = [], []
    for axis in range(3):
        u, w = [k for k in range(3) if k != axis]
        for side in (lo, hi):
            square = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
            on_edges = [(1 - t) * square[i] + t * square[(i + 1) % 4] for i in range(4)
                        for t in rng.uniform(0.05, 0.95, rng.integers(0, 5))]
            uv = np.vstack([square, *([np.array(on_edges)] if on_edges else []),
                            rng.uniform(0.1, 0.9, (rng.integers(0, 6), 2))])
            points = np.empty((len(uv), 3))
            points[:, axis], points[:, u], points[:, w] = side[axis], lo[u] + uv[:, 0] * (hi[u] - lo[u]), \
                lo[w] + uv[:, 1] * (hi[w] - lo[w])
            faces.append(Delaunay(uv).simplices + sum(len(x) for x in vertices))
            vertices.append(points)
    v = np.vstack(vertices)
    return v, _outward(v, np.vstack(faces), 0.5 * (lo + hi))


def test_cad_boxes_with_t_junctions_on_every_edge_alone_and_glued():
    """Boxes whose faces a CAD export triangulated each on its own, alone and two glued face to face (the second
    turned inward half the time), against the box's closed form at random points (a review found 8 of 150
    single boxes and 7 of 60 glued pairs wrong, before slivers split at their own corner were dropped)."""
    rng = np.random.default_rng(39)
    for k in range(30):
        lo = rng.uniform(-1, 0, 3)
        hi = lo + rng.uniform(0.05, 2.0, 3)
        v, f = _cad_box(lo, hi, rng)
        if k % 2:  # a second box glued to the first's +x face
            v2, f2 = _cad_box([hi[0], lo[1], lo[2]], [hi[0] + 1.0, hi[1], hi[2]], rng)
            v, f = np.vstack([v, v2]), np.vstack([f, (f2[:, ::-1] if k % 4 == 1 else f2) + len(v)])
            hi = hi + [1.0, 0, 0]
        points = rng.uniform(lo - 0.3, hi + 0.3, (60, 3))
        inside = np.all((points > lo + 1e-3) & (points < hi - 1e-3), axis=1)
        known = inside | np.any((points < lo - 1e-3) | (points > hi + 1e-3), axis=1)
        assert is_closed(v, f)
        np.testing.assert_array_equal(np.array(_inside(v, f, points))[known], inside[known], err_msg=f"box {k}")


def _beam(xs, length: float = 10.0, width: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """A closed beam ``length`` x ``width`` x ``width`` [m] whose top is a fan from one corner over points at
    ``xs`` [m] along its far edge; its far side is two triangles, so every point inside that edge is a T-junction;
    faces outward."""
    v = np.array([[0, 0, width], [length, 0, width]] + [[x, width, width] for x in xs]
                 + [[0, 0, 0], [length, 0, 0], [length, width, 0], [0, width, 0]], dtype=float)
    q, (b0, b1, b2, b3) = list(range(2, 2 + len(xs))), range(2 + len(xs), 6 + len(xs))
    f = ([[0, 1, q[-1]]] + [[0, q[k + 1], q[k]] for k in range(len(q) - 1)]
         + [[b0, b2, b1], [b0, b3, b2], [b0, b1, 1], [b0, 1, 0], [b3, q[-1], b2], [b3, q[0], q[-1]], [b0, 0, q[0]],
            [b0, q[0], b3], [b1, b2, q[-1]], [b1, q[-1], 1]])
    return v, _outward(v, np.array(f), [length / 2, width / 2, width / 2])


def test_mending_sliver_fans_stray_fins_touching_cavities_and_two_sided_t_junction_boxes():
    """A review's cases (session 39).  A 10 m beam whose top is a fan of slivers from one corner over 2,001
    points (a T-junction at every one): its slivers lie within WELD of a line and were split at their own
    corners, round after round (30 s, and wrong; 4,000 of them ran out of memory).  A stray fin touching a
    T-junction box at a corner made the box open.  A cavity with T-junctions touching its tank's wall at a point
    was read as solid.  A triangle of no area filling a T-junction kept it open.  A T-junction box written
    two-sided had no inside (a watertight one written so has)."""
    for xs in ([0.0, 9.99, 10.0], np.linspace(0.0, 10.0, 2001)):  # one sliver, 50 um high; 2,000 of them
        v, f = _beam(xs)
        assert is_closed(v, f) and _inside(v, f, [[5.0, 0.025, 0.025], [5.0, 0.08, 0.025]]) == [True, False]

    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    v, f = trimesh.remesh.subdivide(box.vertices, box.faces, face_index=np.flatnonzero(box.face_normals[:, 2] > 0.5))
    corner = int(np.argmin(np.linalg.norm(v - [1, 0.5, 0.25], axis=1)))
    fin = (np.vstack([v, [[1.5, 0.5, 0.25], [1.5, 0.5, 1.0]]]), np.vstack([f, [[corner, len(v), len(v) + 1]]]))
    assert _inside(*fin, [[0.0, 0, 0]]) == [True] and not is_closed(*fin)
    a, m, b = (int(np.argmin(np.linalg.norm(v - x, axis=1))) for x in ([1, -0.5, 0.25], [1, 0, 0.25], [1, 0.5, 0.25]))
    for filler in ([[a, m, b]], [[a, m, b], [b, m, a]]):  # a triangle of no area over the T-junction, as exporters add
        assert is_closed(v, np.vstack([f, filler])) and _inside(v, np.vstack([f, filler]), [[0.0, 0, 0]]) == [True]
    two_sided = np.vstack([f, f[:, ::-1]])
    assert is_closed(v, two_sided) and _inside(v, two_sided, [[0.0, 0, 0], [1.5, 0, 0]]) == [True, False]

    tank = trimesh.creation.box(bounds=[[0, 0, 0], [4, 4, 4]])
    top = np.flatnonzero(tank.face_normals[:, 2] > 0.5)
    vo, fo = trimesh.remesh.subdivide(tank.vertices, tank.faces, face_index=top)
    tv = np.array([[2, 0, 0], [1, 2, 1], [3, 2, 1], [2, 1.5, 3]], dtype=float)  # touches the tank's wall at (2, 0, 0)
    tv, tf = trimesh.remesh.subdivide(tv, _outward(tv, np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]),
                                                   tv.mean(axis=0)), face_index=[1])
    v, f = np.vstack([vo, tv]), np.vstack([fo, tf + len(vo)])
    assert _inside(v, f, [[2, 1.5, 1.5], [0.5, 3.5, 3.5], [5, 2, 2]]) == [False, True, False]  # cavity, wall, out


def test_solids_are_kept_for_the_same_arrays_only(monkeypatch):
    """A mesh's solids are computed once for the goal check, the start check and the exact depth; other arrays
    (another mesh, or the same one changed in place) are computed again, and what is kept cannot be changed."""
    import navstack.sim.mesh_inside as mesh_inside

    computed = []
    original = mesh_inside._solids_of
    monkeypatch.setattr(mesh_inside, "_solids_of", lambda v, f: computed.append(len(f)) or original(v, f))
    monkeypatch.setattr(mesh_inside, "_SOLIDS", {})
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    v, f = np.array(box.vertices), np.array(box.faces)
    first = solids(v, f)
    assert solids(v.copy(), f.copy()) == first and is_closed(v, f) and computed == [12]
    v[0] += 1.0  # the same array, another mesh
    assert (solids(v, f)[0][0] == v[0]).all(axis=1).any() and computed == [12, 12]  # its solid has the new corner
    with pytest.raises(ValueError):
        first[0][0][0, 0] = 5.0
    for k in range(1, mesh_inside.SOLIDS_KEPT + 1):
        solids(v + k, f)
    solids(box.vertices, box.faces)  # the first mesh again, forgotten since
    assert len(computed) == 2 + mesh_inside.SOLIDS_KEPT + 1


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
