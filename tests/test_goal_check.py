"""Goals that cannot be reached without contact (navstack.goal_check): closed forms at the boundary, PyBullet
as the independent judge of the claim, meshes, moving obstacles, and the warning of ``check-world`` and ``run``."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pybullet
import pytest
import trimesh
from _worlds import TIP, world_data
from pybullet_utils.bullet_client import BulletClient
from scipy.spatial.transform import Rotation

from navstack.cli import main
from navstack.goal_check import _mesh_signed_distance, blocked_goals
from navstack.world import world_from_dict

R_S = 0.025  # the paper robot's serpentine radius (m)
TOL = 0.02  # the default goal tolerance (m)
GOAL = TIP + [0.6, 0.0, 0.0]  # world (m): ahead of the tip, clear of the robot at q0


def world_with(obstacle: dict, goal=GOAL, tolerance: float = TOL):
    data = world_data(obstacle)
    data["goals"] = [{"position": (TIP + [0.3, 0, 0.5]).tolist()},
                     {"position": np.asarray(goal, dtype=float).tolist(), "tolerance": tolerance}]
    return data


def box_at(depth: float) -> dict:
    """A box whose +x face lies ``depth`` m beyond GOAL (the goal ``depth`` m inside it, for depth <= 0.1 m),
    0.2 m deep along x: clear of the first goal."""
    return {"type": "box", "center": (GOAL + [depth - 0.1, 0, 0]).tolist(), "half_extents": [0.1, 0.2, 0.2]}


@pytest.mark.parametrize("depth, blocked", [(0.1, True), (0.0, True), (TOL - R_S + 1e-6, True),
                                            (TOL - R_S - 1e-6, False), (-0.1, False)])
def test_a_goal_is_blocked_exactly_when_its_tolerance_ball_has_no_point_a_tip_radius_clear(depth, blocked):
    """Blocked when the signed distance d = -depth satisfies d + TOL <= R_S: up to 5 mm outside the box."""
    world = world_from_dict(world_with(box_at(depth)))
    found = blocked_goals(world)
    assert [(b.goal, b.obstacle) for b in found] == ([(1, 1)] if blocked else [])
    if blocked:
        assert found[0].distance == pytest.approx(-depth, abs=1e-12)


def test_the_bound_itself_is_blocked_and_a_world_with_one_goal_is_checked():
    """d + tolerance == serpentine radius, exactly (the goal on the box's face, tolerance = R_S): blocked, the
    bound being attained; and a world whose only goal is buried is warned of too."""
    goal = np.round(GOAL * 64.0) / 64.0  # binary fractions: the face and the distance come out exact
    box = {"type": "box", "center": (goal - [0.125, 0.0, 0.0]).tolist(), "half_extents": [0.125, 0.25, 0.25]}
    data = world_with(box, goal=goal, tolerance=R_S)
    found = blocked_goals(world_from_dict(data))
    assert [(b.goal, b.obstacle) for b in found] == [(1, 1)] and found[0].distance == 0.0  # exactly on the face
    assert "lies 0.000 m from obstacles[1] (a box)" in found[0].message(world_from_dict(data))  # not "inside"
    with pytest.raises(dataclasses.FrozenInstanceError):
        found[0].distance = -1.0
    data["goals"] = data["goals"][1:]  # the buried goal alone
    assert [(b.goal, b.obstacle, b.distance) for b in blocked_goals(world_from_dict(data))] == [(0, 1, 0.0)]


def test_a_moving_obstacle_listed_first_does_not_hide_a_static_one_after_it():
    moving = dict(box_at(0.1), motion={"type": "linear", "velocity": [0.0, 0.0, 0.1]})
    data = world_with(moving)
    data["obstacles"] += [box_at(0.05)]
    found = blocked_goals(world_from_dict(data))
    assert [(b.goal, b.obstacle) for b in found] == [(1, 2)]
    assert found[0].distance == pytest.approx(-0.05, abs=1e-12)


def test_the_warning_names_the_goal_where_it_is_and_how_far_inside_or_outside():
    goal = GOAL + [0.00012, 0.0, 0.0]  # a position with more than 3 decimals
    for depth, where in ((0.1, "lies 0.100 m inside obstacles[1] (a box)"),
                         (-0.004, "lies 0.004 m from obstacles[1] (a box)")):
        obstacle = {"type": "box", "center": (goal + [depth - 0.1, 0, 0]).tolist(), "half_extents": [0.1, 0.2, 0.2]}
        world = world_from_dict(world_with(obstacle, goal=goal))
        (b,) = blocked_goals(world)
        text = b.message(world)
        assert text.startswith(f"goals[1] at {np.round(goal, 3).tolist()} {where}: "), text
        assert "with a tolerance of 0.02 m and a serpentine radius of 0.025 m" in text


@pytest.mark.parametrize("obstacle, depth", [
    ({"type": "sphere", "center": GOAL.tolist(), "radius": 0.05}, 0.05),
    ({"type": "cylinder", "p0": (GOAL - [0, 0, 0.3]).tolist(), "p1": (GOAL + [0, 0, 0.3]).tolist(), "radius": 0.05},
     0.05),
    ({"type": "cylinder", "p0": (GOAL - [0.1, 0, 0]).tolist(), "p1": (GOAL + [0.0461, 0, 0]).tolist(),
      "radius": 0.3}, 0.0461),
])
def test_sphere_and_cylinder_depths_against_closed_forms(obstacle, depth):
    """The ball's radius, the side's radius, the distance to a flat end."""
    found = blocked_goals(world_from_dict(world_with(obstacle)))
    assert len(found) == 1 and found[0].distance == pytest.approx(-depth, abs=1e-12)
    if obstacle["type"] == "sphere":  # a small ball: the goal 4.9 mm outside it is blocked, 5.1 mm is not
        center = (GOAL + [0.0, 0.0, 0.01 + 0.0049]).tolist()
        assert blocked_goals(world_from_dict(world_with(dict(obstacle, center=center, radius=0.01))))
        center = (GOAL + [0.0, 0.0, 0.01 + 0.0051]).tolist()
        assert not blocked_goals(world_from_dict(world_with(dict(obstacle, center=center, radius=0.01))))


def _pybullet_distance(obstacle: dict, point: np.ndarray, radius: float) -> float:
    """PyBullet's distance from a ball of ``radius`` at ``point`` to the box ``obstacle`` (independent of navstack)."""
    c = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        box = c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=obstacle["half_extents"]),
                                basePosition=obstacle["center"])
        ball = c.createMultiBody(0, c.createCollisionShape(pybullet.GEOM_SPHERE, radius=radius), basePosition=point)
        c.performCollisionDetection()
        return min(p[8] for p in c.getClosestPoints(box, ball, 1.0))
    finally:
        c.disconnect()


@pytest.mark.parametrize("depth", [0.05, 0.0, -0.004])
def test_pybullet_agrees_no_tip_within_tolerance_is_clear_of_a_blocked_goals_box(depth):
    """The tip's ball (radius R_S) at the tolerance ball's most favourable point, GOAL + TOL along +x,
    still touches the box when the goal is blocked; for a goal 6 mm outside it is clear."""
    obstacle = box_at(depth)
    assert blocked_goals(world_from_dict(world_with(obstacle)))
    assert _pybullet_distance(obstacle, GOAL + [TOL, 0, 0], R_S) <= 0.0
    clear = box_at(-0.006)
    assert not blocked_goals(world_from_dict(world_with(clear)))
    assert _pybullet_distance(clear, GOAL + [TOL, 0, 0], R_S) > 0.0


def test_moving_obstacles_are_skipped_and_every_blocked_pair_is_named():
    moving = dict(box_at(0.1), motion={"type": "linear", "velocity": [0.0, 0.0, 0.1]})
    assert blocked_goals(world_from_dict(world_with(moving))) == []
    data = world_with(box_at(0.1))
    data["obstacles"] += [{"type": "sphere", "center": GOAL.tolist(), "radius": 0.2}]
    data["goals"][0] = {"position": GOAL.tolist()}
    found = blocked_goals(world_from_dict(data))
    assert [(b.goal, b.obstacle) for b in found] == [(0, 1), (0, 2), (1, 1), (1, 2)]


def test_mesh_distances_inside_a_closed_mesh_and_near_an_open_one(tmp_path):
    """A goal at a closed box mesh's centre is 0.2 m inside; in an open one (no inside) 0.2 m from the
    surface: clear.  Near a face (placed and turned by rpy) the same rule as a primitive's."""
    box = trimesh.creation.box(extents=[0.4, 0.4, 0.4])
    box.export(tmp_path / "box.stl")
    trimesh.Trimesh(box.vertices, box.faces[:-1]).export(tmp_path / "open.stl")
    rpy = np.array([0.3, -0.2, 0.5])
    for name, expected in (("box.stl", [-0.2]), ("open.stl", [])):
        for tolerance in (TOL, 0.05):  # a tolerance above the serpentine radius too (the ball reaches beyond it)
            data = world_with({"type": "mesh", "path": str(tmp_path / name), "position": GOAL.tolist(),
                               "rpy": rpy.tolist()}, tolerance=tolerance)
            found = blocked_goals(world_from_dict(data))
            assert [pytest.approx(b.distance, abs=1e-6) for b in found] == expected, (name, tolerance)
    R = Rotation.from_euler("xyz", rpy).as_matrix()
    for name in ("box.stl", "open.stl"):
        for gap, expected in ((0.0049, [0.0049]), (0.0051, []), (-0.03, [-0.03])):
            position = GOAL - R @ [-(0.2 + gap), 0.0, 0.0]  # the goal gap m off the -x face, outward
            data = world_with({"type": "mesh", "path": str(tmp_path / name), "position": position.tolist(),
                               "rpy": rpy.tolist()})
            found = blocked_goals(world_from_dict(data))
            want = expected if name == "box.stl" or gap > 0 else []  # no inside: 0.03 m from the surface
            assert [pytest.approx(b.distance, abs=1e-6) for b in found] == want, (name, gap)


def test_mesh_distances_of_a_mesh_off_its_own_origin(tmp_path):
    """A box mesh whose vertices lie off its frame's origin (so no symmetry of the frame hides a sign error),
    turned by rpy: a goal ``gap`` m off its -x face, or inside it, is at the signed distance the rule needs."""
    offset = np.array([0.5, -0.3, 0.2])  # the box's centre in the mesh's own frame
    box = trimesh.creation.box(extents=[0.4, 0.4, 0.4])
    box.apply_translation(offset)
    box.export(tmp_path / "off.stl")
    rpy = np.array([0.3, -0.2, 0.5])
    R = Rotation.from_euler("xyz", rpy).as_matrix()
    for gap, expected in ((0.0049, [0.0049]), (0.0051, []), (-0.03, [-0.03]), (-0.2, [-0.2])):
        position = GOAL - R @ (offset + [-(0.2 + gap), 0.0, 0.0])  # the goal gap m off the -x face, outward
        data = world_with({"type": "mesh", "path": str(tmp_path / "off.stl"), "position": position.tolist(),
                           "rpy": rpy.tolist()})
        found = blocked_goals(world_from_dict(data))
        assert [pytest.approx(b.distance, abs=1e-6) for b in found] == expected, gap
    # only points within `within` of the mesh's box are measured; the rest are +inf, unmeasured (the last
    # placement above: GOAL at the box's centre, 0.2 m inside)
    mesh = world_from_dict(data).obstacles[1]
    points = np.array([GOAL, GOAL + R @ [-0.7, 0.0, 0.0], GOAL + R @ [0.0, 0.0, 3.0]])  # 0.5 and 2.8 m off
    d = _mesh_signed_distance(mesh, points, np.array([0.01, 0.01, 1.0]))
    assert d[0] == pytest.approx(-0.2, abs=1e-6) and np.isinf(d[1:]).all() and (d[1:] > 0).all()


def test_check_world_and_run_warn_but_do_not_refuse(tmp_path: Path, capsys):
    path = tmp_path / "buried.json"
    path.write_text(json.dumps(dict(world_with(box_at(0.1)), time_limit=0.2)))
    assert main(["check-world", str(path)]) == 0
    out, err = capsys.readouterr()
    assert f"{path}: ok" in out
    assert "warning: goals[1]" in err and "0.100 m inside obstacles[1] (a box)" in err and "cannot reach" in err
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--planner", "scripted"]) == 0
    out, err = capsys.readouterr()
    assert "navstack run: warning: goals[1]" in err
    assert json.loads((tmp_path / "out" / "result.json").read_text())["success"] is False
    path.write_text(json.dumps(world_with(box_at(-0.006))))  # 1 mm of room: reachable, but not keeping 5 mm
    assert main(["check-world", str(path)]) == 0
    err = capsys.readouterr().err
    assert "cannot reach" not in err
    assert "warning: goals[1] at" in err and "at most 1.0000 mm from obstacles[1] (a box)" in err
    assert "the field planner is not expected to reach it" in err
    path.write_text(json.dumps(dict(world_with(box_at(-0.006)), time_limit=0.2)))
    assert main(["run", str(path), "--out", str(tmp_path / "out2"), "--planner", "scripted"]) == 0
    assert "warning" not in capsys.readouterr().err  # the scripted planner keeps no margin
    path.write_text(json.dumps(world_with(box_at(-0.0101))))  # 5.1 mm of room
    assert main(["check-world", str(path)]) == 0
    assert "warning" not in capsys.readouterr().err


MARGIN = 0.005  # m: the field planner's least margin from sensed surfaces (FieldPlannerConfig.tight_margin)


@pytest.mark.parametrize("depth, tight", [(TOL - R_S + 1e-6, False), (TOL - R_S - 1e-6, True),
                                          (TOL - R_S - MARGIN + 1e-6, True), (TOL - R_S - MARGIN - 1e-6, False),
                                          (-0.1, False)])
def test_a_goal_is_tight_exactly_when_its_tolerance_ball_offers_less_room_than_the_margin(depth, tight):
    """Tight when 0 < room < MARGIN, room = d + TOL - R_S (d = -depth): up to 10 mm outside the box; a blocked
    goal (room <= 0) is not also tight."""
    from navstack.goal_check import tight_goals

    world = world_from_dict(world_with(box_at(depth)))
    found = tight_goals(world, MARGIN)
    assert [(t.goal, t.obstacle) for t in found] == ([(1, 1)] if tight else [])
    if tight:
        assert found[0].room == pytest.approx(-depth + TOL - R_S, abs=1e-12) and found[0].margin == MARGIN


def test_the_room_is_the_most_clearance_a_tip_in_the_tolerance_ball_can_have():
    """Brute force: tip points sampled in the goal's tolerance ball (and the ball's point straight away from the
    box's face), each one's clearance its distance to the box's +x face (closed form: the face reaches 0.2 m
    round the goal in y and z, the ball 0.02 m) less R_S; the largest is the room."""
    from navstack.goal_check import tight_goals

    depth = -0.008  # room 3 mm
    world = world_from_dict(world_with(box_at(depth)))
    (tight,) = tight_goals(world, MARGIN)
    rng = np.random.default_rng(0)
    u = rng.normal(size=(20000, 3))
    pts = GOAL + TOL * u / np.linalg.norm(u, axis=1)[:, None] * rng.random((20000, 1)) ** (1 / 3)
    pts = np.vstack([pts, GOAL + [TOL, 0.0, 0.0]])
    clearance = pts[:, 0] - (GOAL[0] + depth) - R_S
    assert clearance.max() == pytest.approx(tight.room, abs=1e-12)
    assert tight.room == pytest.approx(0.003, abs=1e-12)


@pytest.mark.parametrize("family", ["truss", "cluttered-truss", "pipe-rack", "sphere-field", "slot-rack",
                                    "sparse-truss", "bend-clutter", "dead-end", "fin-bank",
                                    "rod-forest"])
def test_no_generated_world_has_a_goal_that_cannot_be_reached_without_contact(family):
    """The generators' own checks should never let such a goal through (measured: 0 of 960 worlds, seeds
    0-39 at difficulty 0, 0.5 and 1); the hardest settings here, three seeds per family."""
    from navstack.generate import generate_world
    from navstack.registry import FAMILIES

    assert family in FAMILIES
    for seed in range(3):
        world = generate_world(family, seed=seed, difficulty=1.0)
        assert blocked_goals(world) == [], [b.message(world) for b in blocked_goals(world)]


def test_the_warnings_margin_is_the_field_planners_least():
    """MARGIN above is the default planner's least margin; without a tight margin, or with one above the
    repulsion's, it is the repulsion's."""
    from navstack.planner.field import FieldPlannerConfig

    assert FieldPlannerConfig().least_margin == MARGIN
    assert FieldPlannerConfig(tight_margin=None).least_margin == FieldPlannerConfig().repulsion.margin == 0.01
    assert FieldPlannerConfig(tight_margin=0.02).least_margin == 0.01
