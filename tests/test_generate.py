"""Randomized world families, their feasibility checks, the fixed issue worlds and `navstack generate`.

Distances in metres.  The checks are tested in both directions: generated worlds pass them (also
after a save/load round trip) and worlds broken on purpose fail the right one.  The analytic
distances behind the checks are compared with PyBullet's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as p
import pytest
from pybullet_utils import bullet_client

from navstack.cli import main
from navstack.generate import (
    FAMILIES,
    CheckConfig,
    check_world,
    generate_world,
    obstacle_distance,
    reference_path,
    start_clearance,
    u_trap_world,
    with_reference_goals,
    world_name,
    write_issue_worlds,
)
from navstack.jpl import jpl_serpentine
from navstack.scripted import ScriptedPlanner
from navstack.sim.body import RobotBody
from navstack.sim.scene import Scene
from navstack.trial import run_trial
from navstack.truss import PAPER_BASE_RPY, robot_tip_start
from navstack.world import (
    Box,
    Cylinder,
    Goal,
    RobotSpec,
    Sphere,
    World,
    load_world,
    save_world,
    world_from_dict,
)

WORLDS = Path(__file__).resolve().parents[1] / "worlds"
ISSUE_FILES = ("truss_displaced.json", "truss_clutter.json", "u_trap.json", "pipe_rack.json", "blind_pocket.json")
TIP, HEADING = robot_tip_start((0.0, 0.0, 0.3), PAPER_BASE_RPY)


def with_obstacles(world: World, *extra, goals=None) -> World:
    """A copy of ``world`` with obstacles appended (and optionally other goals)."""
    d = world.to_dict()
    d["obstacles"] = d["obstacles"] + [o.to_dict() for o in extra]
    if goals is not None:
        d["goals"] = [{"position": list(map(float, g)), "tolerance": 0.02} for g in goals]
    return world_from_dict(d)


@pytest.fixture(scope="module")
def rack() -> World:
    return generate_world("pipe-rack", 3, 0.5)


# --------------------------------------------------------------------------- arguments, names, determinism


@pytest.mark.parametrize(
    ("args", "word"),
    [
        (("forest", 0, 0.5), "family"),
        ((None, 0, 0.5), "family"),
        (("truss", -1, 0.5), "seed"),
        (("truss", 1.5, 0.5), "seed"),
        (("truss", True, 0.5), "seed"),
        (("truss", 0, -0.01), "difficulty"),
        (("truss", 0, 1.01), "difficulty"),
        (("truss", 0, float("nan")), "difficulty"),
        (("truss", 0, "0.5"), "difficulty"),
        (("truss", 0, True), "difficulty"),
    ],
)
def test_bad_arguments_raise_value_error_naming_the_argument(args, word):
    with pytest.raises(ValueError, match=word):
        generate_world(*args)


def test_negative_zero_difficulty_is_zero():
    """``--difficulty -0.0`` wrote the world of 0 named ``...-d-0.00`` (an audit)."""
    w = generate_world("truss", 1, -0.0)
    assert w.name == "truss-s0001-d0.00" and w.to_dict() == generate_world("truss", 1, 0.0).to_dict()


def test_names():
    assert world_name("truss", 12, 0.5) == "truss-s0012-d0.50"
    assert world_name("pipe-rack", 3, 0.125) == "pipe-rack-s0003-d0.125"
    assert world_name("truss", 1, 0.333) != world_name("truss", 1, 0.33)


@pytest.mark.parametrize("family", FAMILIES)
def test_deterministic_and_seed_dependent(family):
    a = generate_world(family, 5, 0.4)
    assert a.to_dict() == generate_world(family, 5, 0.4).to_dict()
    b = generate_world(family, 6, 0.4)
    assert a.name != b.name
    assert [o.to_dict() for o in a.obstacles] != [o.to_dict() for o in b.obstacles]
    assert a.to_dict()["goals"] != b.to_dict()["goals"]


# --------------------------------------------------------------------------- every family passes its checks

CASES = [(f, s, d) for f in FAMILIES for s, d in ((0, 0.0), (1, 0.5), (2, 0.5), (3, 1.0))]


@pytest.mark.parametrize(("family", "seed", "difficulty"), CASES)
def test_generated_world_passes_checks_after_round_trip(family, seed, difficulty, tmp_path):
    w = generate_world(family, seed, difficulty)
    gen = w.extra["generator"]
    assert w.name == world_name(family, seed, difficulty) and w.family == family
    assert (gen["family"], gen["seed"], gen["difficulty"], gen["version"]) == (family, seed, difficulty, 1)
    assert all(g.tolerance == 0.02 for g in w.goals) and w.time_limit >= 60.0
    save_world(w, tmp_path / "w.json")
    back = load_world(tmp_path / "w.json")
    assert back == w
    report = check_world(back)
    assert report.ok, report.problems
    cfg = CheckConfig()
    assert report.goal_clearance >= cfg.goal_clearance
    assert report.path_clearance >= back.robot.serpentine_radius + cfg.path_margin
    assert report.min_turn_radius >= cfg.min_turn_radius
    assert report.inside_length <= cfg.max_inside_length
    assert report.start_clearance is not None and report.start_clearance >= cfg.start_clearance
    # goals really are clear of every obstacle (brute force over the obstacles, one at a time)
    for g in back.goals:
        assert min(obstacle_distance([o], g.position[None])[0] for o in back.obstacles) >= cfg.goal_clearance


@pytest.mark.parametrize("family", FAMILIES)
def test_start_posture_is_collision_free_in_pybullet(family):
    w = generate_world(family, 4, 1.0)
    c = bullet_client.BulletClient(connection_mode=p.DIRECT)
    try:
        body = RobotBody.build(c, jpl_serpentine(), w.robot.base.transform())
        body.reset(w.robot.q0)
        scene = Scene.build(c, w)
        c.performCollisionDetection()
        assert not scene.in_contact(body.body_id)
        assert scene.clearance(body.body_id) >= 0.05
    finally:
        c.disconnect()


def test_difficulty_moves_the_truss_and_narrows_the_bays():
    easy, hard = generate_world("truss", 7, 0.0), generate_world("truss", 7, 1.0)
    ge, gh = easy.extra["generator"], hard.extra["generator"]
    assert ge["offset_norm"] == 0.0 and ge["rotation_deg"] == 0.0
    assert 0.036 - 1e-9 <= gh["offset_norm"] <= 0.06 + 1e-9 and 1.8 - 1e-6 <= gh["rotation_deg"] <= 3.0 + 1e-6
    assert gh["side"] < ge["side"] and gh["member_radius"] > ge["member_radius"]
    # undisplaced: the reference is the path through the goals themselves
    assert np.allclose(ge["reference_via"], easy.goal_positions)
    # displaced: the reference stays within 90 % of the tolerance of every drawn goal, but not on it
    shift = np.linalg.norm(np.array(gh["reference_via"]) - hard.goal_positions, axis=1)
    assert shift.max() <= 0.018 and shift.max() > 0.01


def test_clutter_keeps_clear_of_the_drawn_path():
    for seed in (0, 1, 2):
        w = generate_world("cluttered-truss", seed, 1.0)
        n = w.extra["generator"]["structure_obstacles"]
        clutter = w.obstacles[n:]
        cables = [o for o in clutter if isinstance(o, Cylinder)]
        assert len(clutter) >= 3 and cables and any(isinstance(o, Box) for o in clutter)
        assert all(0.005 <= o.radius <= 0.01 for o in cables)
        drawn = reference_path(TIP, HEADING, w.goal_positions)
        assert obstacle_distance(clutter, drawn.points).min() >= 0.025 + CheckConfig().path_margin


def test_sphere_field_blocks_the_straight_line():
    for seed in (0, 1):
        w = generate_world("sphere-field", seed, 0.8)
        assert w.extra["generator"]["blockers"] >= 1
        line = TIP + np.linspace(0.0, 1.0, 200)[:, None] * (w.goal_positions[-1] - TIP)
        assert obstacle_distance(w.obstacles, line).min() < 0.025  # the serpentine cannot go straight


# --------------------------------------------------------------------------- the checks themselves


def test_obstacle_distance_matches_pybullet():
    rng = np.random.default_rng(0)
    obstacles = [
        Cylinder(p0=[0.1, -0.2, 0.3], p1=[0.5, 0.3, 0.6], radius=0.04),
        Box(center=[-0.4, 0.2, 0.1], half_extents=[0.1, 0.05, 0.2], rpy=[0.3, -0.2, 0.9]),
        Sphere(center=[0.0, 0.5, -0.3], radius=0.12),
    ]
    w = World(name="t", robot=RobotSpec(), obstacles=tuple(obstacles), goals=(Goal([0.0, 0.0, 3.0]),))
    c = bullet_client.BulletClient(connection_mode=p.DIRECT)
    try:
        scene = Scene.build(c, w)
        probe = c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=c.createCollisionShape(
            p.GEOM_SPHERE, radius=1e-3), basePosition=[9.0, 9.0, 9.0])
        pts = rng.uniform(-0.8, 0.8, size=(300, 3))
        ours = obstacle_distance(obstacles, pts, horizon=2.0)
        checked = 0
        for x, d in zip(pts, ours, strict=True):
            if d < 0.005:
                continue  # inside or touching: PyBullet reports penetration differently
            c.resetBasePositionAndOrientation(probe, x.tolist(), [0, 0, 0, 1])
            c.performCollisionDetection()
            assert scene.clearance(probe, 2.0) + 1e-3 == pytest.approx(d, abs=2e-3)
            checked += 1
        assert checked > 200
    finally:
        c.disconnect()
    # inside is negative
    assert obstacle_distance(obstacles, [[0.0, 0.5, -0.3]])[0] == pytest.approx(-0.12)
    with pytest.raises(ValueError, match="shape"):
        obstacle_distance(obstacles, [1.0, 2.0, 3.0])


def test_reference_path_is_the_scripted_planners_curve(rack):
    goals = rack.goal_positions
    ref = reference_path(TIP, HEADING, goals)
    planner = ScriptedPlanner(TIP, HEADING, goals)
    assert ref.min_turn_radius == pytest.approx(planner.min_turn_radius, rel=0.02)
    assert ref.length == pytest.approx(planner.length, abs=1e-3)
    worst = 0.0
    while not planner.done:
        x = planner.step(1 / 60).position
        worst = max(worst, float(np.linalg.norm(ref.points - x, axis=1).min()))
    assert worst < 2e-3


def test_check_fails_for_an_obstacle_on_the_path(rack):
    via = np.array(rack.extra["generator"]["reference_via"])
    mid = reference_path(TIP, HEADING, via).points[150]
    report = check_world(with_obstacles(rack, Sphere(center=mid + [0.0, 0.0, 0.05], radius=0.03)))
    assert not report.ok and any("reference path" in m for m in report.problems)
    assert report.path_clearance < 0.04
    assert report.start_clearance is None  # PyBullet runs only when everything else passed


def test_check_fails_for_a_goal_next_to_an_obstacle(rack):
    g = rack.goal_positions[-1]
    report = check_world(with_obstacles(rack, Sphere(center=g + [0.0, 0.12, 0.0], radius=0.07)))
    assert not report.ok and any("goals[" in m for m in report.problems)
    assert 0.04 < report.goal_clearance < 0.06


def test_check_fails_for_a_sharp_turn_and_a_missed_goal(rack):
    sharp = [TIP + [0.3, 0.0, 0.0], TIP + [0.35, 0.15, 0.0]]
    report = check_world(rack, via=sharp)
    assert any("turns with radius" in m for m in report.problems)
    assert any("misses goals[" in m for m in report.problems)


def test_check_fails_when_the_path_runs_too_long_inside_the_structure(rack):
    far = TIP + [1.25, 0.0, 0.0]
    posts = (Sphere(center=TIP + [0.05, 0.0, -0.4], radius=0.05),
             Sphere(center=far + [0.3, 0.0, 0.4], radius=0.05))
    w = World(name="long", robot=rack.robot, obstacles=posts, goals=(Goal(far),))
    report = check_world(w)
    assert any("inside the structure" in m for m in report.problems) and report.inside_length > 1.1
    assert check_world(w, structure=0).ok  # without a structure the same path is fine


def test_check_fails_for_the_arm_and_for_the_start_posture(rack):
    # beside the wrist, 0.2 m ahead of it: the insertion carries the arm into it
    wrist = np.array([0.609, 0.108, 1.167])
    arm_hit = check_world(with_obstacles(rack, Sphere(center=wrist + [0.2, 0.0, 0.1], radius=0.03)))
    assert any("arm swept" in m for m in arm_hit.problems)
    # 0.03 m above the straight serpentine at J1: fine for the slithering body (0.01 m) and beyond the
    # arm's reach (insertion 0.85 m), not for the start (0.05 m), which only PyBullet measures
    j1 = np.array([1.609, 0.1079, 1.1668])
    near = Sphere(center=j1 + [0.0, 0.0, 0.025 + 0.03 + 0.02], radius=0.02)
    report = check_world(with_obstacles(rack, near))
    assert report.problems and all("q0" in m for m in report.problems)
    assert report.start_clearance == pytest.approx(0.03, abs=2e-3)
    assert start_clearance(rack) > 0.05


def test_check_rejects_meshes_and_bad_arguments(rack, tmp_path):
    with pytest.raises(ValueError, match="structure"):
        check_world(rack, structure=10_000)
    with pytest.raises(ValueError, match="via"):
        check_world(rack, via=[[np.nan, 0.0, 0.0]])
    with pytest.raises(ValueError, match="CheckConfig.goal_clearance"):
        CheckConfig(goal_clearance=-1.0)


# --------------------------------------------------------------------------- CLI and the issue worlds


def test_cli_generate_writes_the_same_world(tmp_path, capsys):
    out = tmp_path / "g.json"
    assert main(["generate", "cluttered-truss", "--seed", "3", "--difficulty", "0.4", "--out", str(out)]) == 0
    assert load_world(out) == generate_world("cluttered-truss", 3, 0.4)
    assert "cluttered-truss-s0003-d0.40" in capsys.readouterr().out
    assert main(["generate", "forest", "--seed", "3", "--out", str(out)]) == 2
    assert "family" in capsys.readouterr().err
    assert main(["generate", "truss", "--seed", "3", "--difficulty", "2", "--out", str(out)]) == 2


def test_issue_worlds_are_regenerated_identically_and_pass_the_checks(tmp_path):
    written = write_issue_worlds(tmp_path)
    assert [f.name for f in written] == list(ISSUE_FILES)
    for f in ISSUE_FILES:
        w = load_world(tmp_path / f)
        assert w == load_world(WORLDS / f), f"worlds/{f} is stale: rerun write_issue_worlds('worlds')"
        assert check_world(w).ok
    displaced = load_world(WORLDS / "truss_displaced.json").extra["generator"]
    assert np.linalg.norm(displaced["truss_offset"]) == pytest.approx(0.046, abs=1e-6)


# --------------------------------------------------------------------------- closed loop


def test_scripted_slither_solves_a_generated_truss():
    r = run_trial(generate_world("truss", 1, 0.3), planner="scripted")
    assert r.success and r.reason == "reached", r
    assert r.metrics["contacts"] == 0 and r.metrics["min_clearance"] > 0.0


def test_u_trap_is_a_trap_for_the_straight_path_but_solvable_round_it():
    trap = u_trap_world()
    straight = run_trial(trap, planner="scripted")
    assert not straight.success and straight.metrics["contacts"] > 0
    around = run_trial(with_reference_goals(trap), planner="scripted")
    assert around.success and around.metrics["contacts"] == 0, around
