"""Behaviours of navstack.trial that surviving mutants showed no test pinned (session 47's seeded mutation sample
of navstack/trial.py, ``SAMPLE=35 SEED=47``), each against an independent reference: the lathe bed's closed form
(a prismatic joint along frame 0's z axis, its travel the joint's limits), the DH frames themselves, and PyBullet's
own closest-point query."""

from __future__ import annotations

import numpy as np
import pytest
from _worlds import TIP, world_data
from test_trial_accounting import _PinController

import navstack.trial
from navstack.jpl import jpl_serpentine
from navstack.planner import TipCommand
from navstack.sim.probe import build_scene
from navstack.trial import check_reach, run_trial
from navstack.world import RobotSpec, world_from_dict

BASE = {"position": [0.3, -0.2, 0.5], "rpy": [0.2, -0.1, 0.7]}
"""A base placed off the origin and turned about every axis: world and base frames differ in every component."""
LATHE_Q0 = 0.5
"""m: the lathe bed's start, inside its limits (-1, 2) and off their middle: the travel left differs each way."""


def _world(base=BASE, lathe=LATHE_Q0, goal_offset=(0.3, 0.0, 0.0)):
    """An obstacle-free world with the robot at ``base``, the lathe at ``lathe``, one goal off the start tip."""
    q0 = list(RobotSpec().q0)
    q0[0] = lathe
    data = {"format": "navstack-world/1", "name": "trial-mutants", "robot": {"base": base, "q0": q0},
            "obstacles": [], "goals": [{"position": [0.0, 0.0, 0.0]}], "time_limit": 1.0}
    world = world_from_dict(data)
    T0 = world.robot.base.transform()
    tip = T0[:3, :3] @ jpl_serpentine().frames(world.robot.q0)[21, :3, 3] + T0[:3, 3]
    data["goals"][0]["position"] = (tip + np.asarray(goal_offset)).tolist()
    return world_from_dict(data)


class _Stall:
    """A planner that holds the start tip and gives up at once: a trial of one control step."""

    def __init__(self, start):
        self.start = np.array(start, dtype=np.float64)

    def step(self, dt, tip, heading, reading, goal_index):
        return TipCommand(self.start.copy(), np.zeros(3), True)


class _Hold(_Stall):
    """A planner that holds the start tip and never gives up: the trial runs to its time limit."""

    def __init__(self, ctx):
        super().__init__(ctx.start)

    def step(self, dt, tip, heading, reading, goal_index):
        return TipCommand(self.start.copy(), np.zeros(3), False)


@pytest.fixture
def contexts(monkeypatch):
    """The :class:`PlannerContext` each ``planner="scripted"`` trial builds its planner from."""
    seen = []

    def make(ctx):
        seen.append(ctx)
        return _Stall(ctx.start)

    monkeypatch.setattr(navstack.trial, "make_scripted_planner", make)
    return seen


def test_the_planner_is_told_the_lathe_bed_axis_and_travel_and_the_flange(contexts):
    """The lathe bed (joint 1) is prismatic along frame 0's z axis: its unit axis in the world is the base's
    rotation of z, and from q0 it may still move ``lower - q0[0]`` back and ``upper - q0[0]`` on (metres, the
    joint's own limits).  The flange is DH frame 9's origin.  Pinned with a base off the origin and turned, so
    no component of the world and base frames agrees."""
    world = _world()
    r = run_trial(world, planner="scripted")
    assert r.reason == "stalled" and len(contexts) == 1
    ctx = contexts[0]
    chain = jpl_serpentine()
    T0 = world.robot.base.transform()
    np.testing.assert_allclose(ctx.lathe_axis, T0[:3, :3] @ [0.0, 0.0, 1.0], atol=1e-12)
    assert np.linalg.norm(ctx.lathe_axis) == pytest.approx(1.0, abs=1e-12)
    assert (chain.lower[0], chain.upper[0]) == (-1.0, 2.0)
    np.testing.assert_allclose(ctx.lathe_travel, (-1.0 - LATHE_Q0, 2.0 - LATHE_Q0), atol=1e-9)
    F = chain.frames(world.robot.q0)
    np.testing.assert_allclose(ctx.flange, T0[:3, :3] @ F[9, :3, 3] + T0[:3, 3], atol=1e-12)


@pytest.mark.parametrize("lathe", [-1.0, 2.0], ids=["at lower limit", "at upper limit"])
def test_no_lathe_travel_is_left_beyond_a_limit_it_starts_at(contexts, lathe):
    """A lathe bed starting at a limit can move only the other way: the travel that way is 0, not negative
    (the other way it is the whole 3 m of the joint's range)."""
    r = run_trial(_world(lathe=lathe), planner="scripted")
    assert r.reason == "stalled"
    lo, hi = contexts[0].lathe_travel
    assert (lo, hi) == pytest.approx((0.0, 3.0) if lathe == -1.0 else (-3.0, 0.0), abs=1e-9)


def test_reach_is_measured_from_the_whole_lathe_travel_including_its_far_end():
    """A goal beyond the lathe bed's far end (the joint at its upper limit, 2 m) by a little less than the reach
    bound is within reach; a little more is not.  (The bound's value, 2.77 m, is tests/test_trial_accounting.py's
    ``test_reach_bound_is_the_sum_of_the_figure_2_link_offsets``; a travel cut short at any other joint's limit
    refused the first goal.)"""
    chain = jpl_serpentine()
    world = _world()
    T0 = world.robot.base.transform()
    origins = chain.frames(np.zeros(chain.n))[1:, :3, 3]
    reach = float(np.linalg.norm(np.diff(origins, axis=0), axis=1).sum())
    q = np.array(world.robot.q0, dtype=np.float64)
    ends = []
    for lathe in (chain.lower[0], chain.upper[0]):
        q[0] = lathe
        ends.append(T0[:3, :3] @ chain.frames(q)[1, :3, 3] + T0[:3, 3])
    axis = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    data = world.to_dict()
    for end, out in ((ends[1], axis), (ends[0], -axis)):
        for distance, ok in ((reach - 0.01, True), (reach + 0.03, False)):
            data["goals"] = [{"position": (end + distance * out).tolist(), "tolerance": 0.01}]
            w = world_from_dict(data)
            if ok:
                check_reach(w)
            else:
                with pytest.raises(ValueError, match="beyond the robot's reach"):
                    check_reach(w)


def test_an_obstacle_beyond_the_clearance_horizon_is_measured_exactly_after_a_normal_end(monkeypatch):
    """Nothing within the 0.5 m horizon all trial: the reported ``min_clearance`` is still the robot's true least
    distance to the far sphere (the trial's end replays it, ``navstack.sim.far_clearance``), as PyBullet measures
    it between the robot at q0 and the sphere; the robot is held still, so only the servo's droop (about a
    millimetre) separates the two.  And it is reported for a trial that ended normally, not only after an error."""
    monkeypatch.setattr(navstack.trial, "make_scripted_planner", _Hold)
    world = world_from_dict(world_data(time_limit=0.2))
    client, body, scene = build_scene(world)
    try:
        client.performCollisionDetection()
        expected = min(pt[8] for pt in client.getClosestPoints(body.body_id, scene.body_ids[0], 5.0))
    finally:
        client.disconnect()
    assert expected > navstack.trial.TrialConfig().clearance_horizon + 0.3  # far beyond the horizon
    r = run_trial(world, planner="scripted")
    assert r.reason == "timeout" and r.metrics["contacts"] == 0
    assert r.metrics["min_clearance"] is not None
    assert r.metrics["min_clearance"] == pytest.approx(expected, abs=0.003)


class _LatheController(_PinController):
    """A controller that holds the start posture but drives the lathe bed (joint 1) through ``schedule(k)`` at
    its k-th call: the whole robot translates along the bed's axis, no link turning."""

    def __init__(self, q0, schedule):
        super().__init__(q0)
        self.schedule, self.calls = schedule, 0

    def step(self, x_d, xdot_d):
        self.calls += 1
        self.theta_d[0] = self.schedule(self.calls)
        return self.theta_d.copy()


def test_the_far_clearance_replay_finds_the_closest_step_after_the_robot_first_backed_away(monkeypatch, tmp_path):
    """The lathe bed first backs the robot 0.1 m away from a sphere 1 m ahead of its tip, then carries it 0.3 m
    towards it, never within the 0.5 m horizon.  The reported ``min_clearance`` is the least over every recorded
    step, as PyBullet measures the robot placed at each recorded joint vector in a scene of its own (brute force; the
    trial's replay skips the steps its bound on the robot's motion rules out: a bound that ignored translation
    skipped all of them after the robot backed away, and reported the start's distance)."""
    monkeypatch.setattr(navstack.trial, "make_scripted_planner", _Hold)

    def schedule(k):  # m: 0 -> -0.1 over 10 steps, then up to +0.3 by step 40, then held
        return -0.01 * k if k <= 10 else min(-0.1 + 0.4 * (k - 10) / 30, 0.3)

    monkeypatch.setattr(navstack.trial, "make_slither_controller",
                        lambda chain, q0, dt, cfg: _LatheController(q0, schedule))
    data = world_data(time_limit=1.5)
    data["obstacles"] = [{"type": "sphere", "center": (TIP + [1.0, 0.0, 0.0]).tolist(), "radius": 0.05}]
    data["goals"] = [{"position": (TIP + [0.0, 0.3, 0.0]).tolist()}]  # off the bed's way: never reached
    world = world_from_dict(data)
    assert world.robot.q0[0] == 0.0
    np.testing.assert_allclose(world.robot.base.transform()[:3, 2], [1.0, 0.0, 0.0], atol=1e-6)  # bed along +x
    r = run_trial(world, planner="scripted", out_dir=tmp_path)
    assert r.reason == "timeout" and r.metrics["contacts"] == 0
    qs = np.load(tmp_path / "trajectory.npz")["q"]
    assert qs[:, 0].min() < -0.08 and qs[:, 0].max() > 0.25  # the bed did back away, then rise
    client, body, scene = build_scene(world)
    try:
        distances = []
        for q in qs:
            body.reset(q)
            client.performCollisionDetection()
            distances.append(min(pt[8] for pt in client.getClosestPoints(body.body_id, scene.body_ids[0], 5.0)))
    finally:
        client.disconnect()
    assert min(distances) > 0.5 and distances[0] - min(distances) > 0.2  # beyond the horizon; the end is closest
    assert r.metrics["min_clearance"] == pytest.approx(min(distances), abs=1e-4)


def test_a_robot_starting_through_an_obstacle_is_refused_with_the_depth(monkeypatch):
    """A sphere centred on serpentine frame 15's origin, on the axis of its capsules: the robot penetrates it by
    the sphere's radius plus the capsule's (closed form), which the refusal names ("penetrates ... m into"), not
    "touches" nor "is inside" (the wording of a contact at zero depth and of a robot inside a closed mesh)."""
    world = _world(base={}, lathe=0.0)
    F = jpl_serpentine().frames(world.robot.q0)
    centre = F[15, :3, 3]  # default base: DH frame 0 is the world frame
    data = world.to_dict()
    data["obstacles"] = [{"type": "sphere", "center": centre.tolist(), "radius": 0.08}]
    with pytest.raises(ValueError) as ei:
        run_trial(world_from_dict(data), planner="scripted")
    message = str(ei.value)
    assert "obstacles[0]" in message and "touches" not in message and "is inside" not in message, message
    depth = 0.08 + world.robot.serpentine_radius
    found = [float(w) for w in message.split("penetrates ")[1:2] for w in [w.split(" m into this sphere")[0]]]
    assert found and found[0] == pytest.approx(depth, abs=1e-3), message


def test_the_self_clearance_summary_is_the_named_capsules_distance_in_millimetres(contexts):
    """``TrialResult.self_clearance`` (printed by ``navstack run`` with a self-contact) names two capsules and
    their least distance in millimetres: PyBullet's closest distance between those two links of the robot (the
    capsule of DH frame k is link k - 1), the robot at q0 (a trial of one step: only the servo's droop moves it)."""
    import re

    world = world_from_dict(world_data())
    r = run_trial(world, planner="scripted")
    assert r.reason == "stalled" and r.self_contacts == 0
    m = re.fullmatch(r"(-?\d+\.\d) mm between the capsules of DH frames (\d+) and (\d+)", r.self_clearance)
    assert m, r.self_clearance
    client, body, _ = build_scene(world)
    try:
        client.performCollisionDetection()
        points = client.getClosestPoints(body.body_id, body.body_id, 1.0, int(m[2]) - 1, int(m[3]) - 1)
    finally:
        client.disconnect()
    assert points and float(m[1]) == pytest.approx(min(pt[8] for pt in points) * 1e3, abs=0.3)
    assert float(m[1]) > 10.0  # the robot's own parts stand centimetres apart at its start
