"""The exact signed distance between capsules and a mesh (navstack.sim.mesh_depth), judged by the exact distance
to the box a closed mesh is (navstack.sim.exact_distance, itself checked against closed forms), by closed forms
for an open sheet, and by an outside checker's number for a trial that drove through a closed icosphere.

Before: a capsule pushed into a closed mesh read PyBullet's depth below the facets it touched (the icosphere
trial: -26.2 mm where its deepest ball lay 33.3 mm in), and a link wholly inside read a positive distance."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import trimesh
from pybullet_utils import bullet_client
from scipy.spatial.transform import Rotation

from navstack.sim.exact_distance import capsule_distance
from navstack.sim.mesh_depth import TOLERANCE, MeshDepth
from navstack.sim.scene import Scene
from navstack.world import Box, Goal, Mesh, RobotSpec, World

ROOT = Path(__file__).resolve().parents[1]
POSITION, RPY, SCALE = np.array([0.5, -0.2, 0.8]), np.array([0.3, 0.2, -0.6]), 1.5
HALF = SCALE * np.array([0.4, 0.3, 0.2]) / 2
BOX = Box(center=POSITION, half_extents=HALF, rpy=RPY)


@pytest.fixture
def cube(tmp_path) -> Mesh:
    """A closed box mesh (0.4 x 0.3 x 0.2, scaled 1.5), turned and placed: the same solid as :data:`BOX`."""
    trimesh.creation.box(extents=[0.4, 0.3, 0.2]).export(tmp_path / "cube.stl")
    return Mesh(path=tmp_path / "cube.stl", position=POSITION, rpy=RPY, scale=SCALE)


def _true(a, b, r) -> float:
    return float(capsule_distance(BOX, np.asarray(a)[None], np.asarray(b)[None], np.array([r]))[0])


def _random_capsules(rng, n: int, spread: float) -> list[tuple[np.ndarray, np.ndarray, float]]:
    out = []
    for _ in range(n):
        a = POSITION + rng.uniform(-spread, spread, size=3)
        d = rng.normal(size=3)
        out.append((a, a + rng.uniform(0.0, 0.3) * d / np.linalg.norm(d), float(rng.uniform(0.0, 0.06))))
    return out


def test_capsules_in_through_and_beside_a_closed_box_mesh_read_the_boxes_exact_distance(cube):
    depth = MeshDepth(cube)
    assert depth.closed
    rng = np.random.default_rng(3)
    cases = _random_capsules(rng, 150, 0.45)
    inside = [(POSITION + d, POSITION - d, 0.02) for d in (np.zeros(3), np.array([0.1, 0.05, -0.03]))]
    truths = []
    for a, b, r in cases + inside:  # floor +inf: exact everywhere
        true = _true(a, b, r)
        truths.append(true)
        assert depth.capsule_clearance(a, b, r, math.inf) == pytest.approx(true, abs=2 * TOLERANCE), (a, b, r)
    truths = np.array(truths)
    assert (truths < -0.05).sum() >= 20 and (truths > 0.0).sum() >= 20  # deep penetrations and clear passes


def test_below_the_floor_exact_above_it_not_below_it_and_a_contact_never_hidden_nor_made_up(cube):
    depth = MeshDepth(cube)
    rng = np.random.default_rng(4)
    for a, b, r in _random_capsules(rng, 120, 0.4):
        true = _true(a, b, r)
        for floor in (-0.08, -0.01, 0.0, 0.02):
            got = depth.capsule_clearance(a, b, r, floor)
            if true < floor:
                assert got == pytest.approx(true, abs=2 * TOLERANCE)
            else:
                assert got >= floor - 2 * TOLERANCE
            assert (got <= 0.0) == (true <= 0.0), (a, b, r, floor, true, got)


def test_an_open_sheet_has_no_inside_a_capsule_through_it_reads_minus_its_radius(tmp_path):
    sheet = trimesh.Trimesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    sheet.export(tmp_path / "sheet.stl")
    depth = MeshDepth(Mesh(path=tmp_path / "sheet.stl", position=[0.0, 0.0, 1.0], rpy=[0.0, 0.0, 0.0]))
    assert not depth.closed
    through = depth.capsule_clearance([0.2, 0.1, 0.8], [0.3, -0.1, 1.3], 0.03, math.inf)
    above = depth.capsule_clearance([-0.5, 0.0, 1.07], [0.5, 0.2, 1.07], 0.03, math.inf)
    off_edge = depth.capsule_clearance([1.2, 0.0, 0.9], [1.2, 0.0, 1.1], 0.03, math.inf)  # 0.2 m beyond the x edge
    assert through == pytest.approx(-0.03, abs=2 * TOLERANCE)
    assert above == pytest.approx(0.04, abs=2 * TOLERANCE)
    assert off_edge == pytest.approx(0.17, abs=2 * TOLERANCE)


def test_a_triangle_of_no_area_and_a_crack_narrower_than_the_weld_are_measured_right(tmp_path):
    """A review's cases.  A triangle with two equal corners (exporters write them) made Ericson's closest point
    divide 0 by 0 (ZeroDivisionError, a trial's error); a box whose +x face is shifted 2 um off its edges is closed
    for mesh_inside (welded), but an axis entering through that crack was not cut there, so its depth read 212 mm
    short (and +0.35 um, clear, with r = 0)."""
    box = trimesh.creation.box(extents=[2.0, 2.0, 2.0])
    sliver = trimesh.Trimesh(np.vstack([box.vertices, [[0.2, 0.1, 1.0], [0.6, -0.3, 1.0]]]),
                             np.vstack([box.faces, [[8, 8, 9]]]), process=False)
    sliver.export(tmp_path / "sliver.stl")
    depth = MeshDepth(Mesh(path=tmp_path / "sliver.stl", position=[0.0, 0.0, 0.0], rpy=[0.0, 0.0, 0.0]))
    plain = Box(center=[0.0, 0.0, 0.0], half_extents=[1.0, 1.0, 1.0], rpy=[0.0, 0.0, 0.0])
    for a, b in (([0.0, 0.0, 0.5], [0.3, 0.0, 0.5]), ([0.0, 0.0, 1.3], [0.3, 0.0, 1.3])):
        true = float(capsule_distance(plain, np.array([a]), np.array([b]), np.array([0.025]))[0])
        for floor in (math.inf, 0.0):
            got = depth.capsule_clearance(a, b, 0.025, floor)
            assert got == pytest.approx(true, abs=2 * TOLERANCE) if floor == math.inf else (got <= 0) == (true <= 0)
    soup = box.vertices[box.faces].copy()
    on_x = np.all(np.isclose(soup[:, :, 0], 1.0), axis=1)
    soup[on_x, :, 0] += 2e-6
    trimesh.Trimesh(soup.reshape(-1, 3), np.arange(len(soup) * 3).reshape(-1, 3), process=False).export(
        tmp_path / "crack.stl")
    depth = MeshDepth(Mesh(path=tmp_path / "crack.stl", position=[0.0, 0.0, 0.0], rpy=[0.0, 0.0, 0.0]))
    assert depth.closed
    P, d = np.array([1.0 + 1e-6, 0.0, 1.0 + 0.5e-6]), np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)
    a, b = P + 2.0 * d, P - 0.3 * d
    for r in (0.025, 0.0):
        true = float(capsule_distance(plain, a[None], b[None], np.array([r]))[0])
        assert depth.capsule_clearance(a, b, r, math.inf) == pytest.approx(true, abs=1e-5), r


@pytest.fixture
def client():
    c = bullet_client.BulletClient(connection_mode=p.DIRECT)
    yield c
    c.disconnect()


def _capsule_probe(c, a, b, radius: float) -> int:
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    rot, _ = Rotation.align_vectors([(b - a) / np.linalg.norm(b - a)], [[0.0, 0.0, 1.0]])
    cs = c.createCollisionShape(p.GEOM_CAPSULE, radius=radius, height=float(np.linalg.norm(b - a)))
    return c.createMultiBody(0.0, cs, -1, ((a + b) / 2).tolist(), rot.as_quat().tolist())


def _move(c, body: int, a, b) -> None:
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    rot, _ = Rotation.align_vectors([(b - a) / np.linalg.norm(b - a)], [[0.0, 0.0, 1.0]])
    c.resetBasePositionAndOrientation(body, ((a + b) / 2).tolist(), rot.as_quat().tolist())
    c.performCollisionDetection()


def test_the_scene_reads_a_penetrations_true_depth_and_a_link_wholly_inside_a_mesh_it_entered(client, cube):
    """A capsule of radius 25 mm pushed 20-110 mm into the closed box mesh, along its +x face's normal: the scene's
    clearance is the box's exact one; moved on to lie wholly inside, it stays a contact at the true depth (PyBullet
    reads the distance to the nearest facet, positive); moved out again, the true positive distance."""
    scene = Scene.build(client, World(name="t", robot=RobotSpec(), obstacles=(cube,), goals=(Goal([0.0, 0.0, 3.0]),)))
    rot = Rotation.from_euler("xyz", RPY)
    along = rot.apply([0.0, 0.1, 0.0])
    r = 0.025
    probe = None
    for inward in (0.02, 0.05, 0.08, 0.11):  # the segment's middle from outside the +x face to deep inside
        c = POSITION + rot.apply([HALF[0] + r - inward, 0.0, 0.0])
        if probe is None:
            probe = _capsule_probe(client, c - along, c + along, r)
        _move(client, probe, c - along, c + along)
        assert scene.clearance(probe, exact_below=0.5) == pytest.approx(_true(c - along, c + along, r), abs=1e-6)
    deep = POSITION + rot.apply([0.05, 0.0, 0.0])
    _move(client, probe, deep - along, deep + along)
    true = _true(deep - along, deep + along, r)
    assert true < -0.1
    assert scene.clearance(probe, exact_below=0.5) == pytest.approx(true, abs=1e-6)
    out = POSITION + rot.apply([HALF[0] + r + 0.03, 0.0, 0.0])
    _move(client, probe, out - along, out + along)
    assert scene.clearance(probe, exact_below=0.5) == pytest.approx(0.03, abs=1e-6)


def test_a_robot_with_shapes_the_exact_measure_does_not_know_keeps_pybullets_contact_with_a_mesh(client, cube):
    """A robot part that is no capsule (a box) pushed 10 mm into the closed box mesh: the exact measure knows only
    capsules, so PyBullet's reading of the contact stands (it must not be hidden)."""
    scene = Scene.build(client, World(name="t", robot=RobotSpec(), obstacles=(cube,), goals=(Goal([0.0, 0.0, 3.0]),)))
    rot = Rotation.from_euler("xyz", RPY)
    shape = client.createCollisionShape(p.GEOM_BOX, halfExtents=[0.03, 0.03, 0.03])
    centre = POSITION + rot.apply([HALF[0] + 0.03 - 0.01, 0.0, 0.0])
    probe = client.createMultiBody(0.0, shape, -1, centre.tolist(), rot.as_quat().tolist())
    client.performCollisionDetection()
    assert scene.clearance(probe) == pytest.approx(-0.01, abs=1e-3)


def test_the_icosphere_trial_reads_the_depth_and_contacts_an_outside_checker_computes():
    """``worlds/hard5/mesh_ico.json`` (5,120 triangles), scripted planner: the tip drives through the closed
    icosphere.  hard5's own checker (``verify.py``: its own kinematics, exact point-triangle distances, a sign
    inside the convex hull) reads the least clearance -33.328 mm and 205 contact steps; navstack read -26.2 mm."""
    from navstack.trial import run_trial

    result = run_trial(ROOT / "worlds" / "hard5" / "mesh_ico.json", planner="scripted")
    assert result.reason == "collision"
    assert result.metrics["contacts"] == 205
    assert result.metrics["min_clearance"] * 1e3 == pytest.approx(-33.328, abs=1e-3)
