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
from navstack.sim.mesh_inside import is_closed, points_inside, winding_numbers
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


@pytest.mark.parametrize("case", ["open", "elsewhere"])
def test_an_open_mesh_around_the_robot_or_a_closed_one_elsewhere_is_accepted(tmp_path, case):
    block = trimesh.creation.box(extents=[6.0, 6.0, 6.0])
    if case == "open":  # a surface with a hole has no inside: the robot in it is not in any solid
        world = _block_world(tmp_path, trimesh.Trimesh(block.vertices, block.faces[:-1]), BASE_POSITION)
    else:
        world = _block_world(tmp_path, block, TIP + [0.0, 0.0, 5.0])
    check_start(load_world(world))
