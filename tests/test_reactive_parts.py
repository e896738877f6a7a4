"""The reactive planner's parts on their own, against closed-form answers (tests/test_planner.py flies them)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.planner.reactive import PlannerConfig, PointMemory
from navstack.planner.reactive.gap import GapCentering
from navstack.planner.reactive.lookahead import Lookahead
from navstack.planner.reactive.terms import aim_direction, goal_inside_turn_circle, reach_length, repulsion, speed
from navstack.planner.reactive.vectors import rotate_towards
from navstack.planner.reactive.wall_follow import WallFollower, boundary_normal, free_length

R = 0.25
X = np.array([1.0, 0.0, 0.0])
Y = np.array([0.0, 1.0, 0.0])
O = np.zeros(3)


@pytest.mark.parametrize(
    ("goal", "length"),
    [
        ((0.7, 0.0, 0.0), 0.7),  # straight ahead
        ((R, R, 0.0), R * math.pi / 2),  # a quarter of the turning circle
        ((0.0, 2 * R, 0.0), R * math.pi),  # half of it
        ((R, R + 0.3, 0.0), R * math.pi / 2 + 0.3),  # a quarter, then straight on
        # a goal 0.6 m to the side: D = 0.35 m from the turning centre; the tangent from it touches the circle
        # acos(R / D) before the top, so the arc is pi - acos(R / D), then the tangent sqrt(D^2 - R^2)
        ((0.0, 0.0, -0.6), R * (math.pi - math.acos(R / 0.35)) + math.sqrt(0.35**2 - R**2)),
    ],
)
def test_reach_length_is_the_turn_then_straight_path(goal, length):
    g = np.array(goal)
    assert reach_length(R, O, X, g) == pytest.approx(length, abs=1e-12)


def test_reach_length_of_a_goal_inside_the_turning_circle_decreases_as_it_leaves():
    # the goal (0.1, 0.1) lies 0.18-0.22 m from the turning centre (a, 0.25): a loop, shorter as it leaves
    lengths = [reach_length(R, np.array([a, 0.0, 0.0]), X, np.array([0.1, 0.1, 0.0])) for a in (0.0, -0.03, -0.06)]
    assert all(v > 2 * math.pi * R for v in lengths)
    assert lengths[0] > lengths[1] > lengths[2]


def test_goal_inside_turn_circle_and_its_margin():
    g = np.array([0.1, 0.1, 0.0])  # 0.17 m from the centre (0, 0.25, 0): inside
    assert goal_inside_turn_circle(R, O, X, g)
    assert not goal_inside_turn_circle(R, O, X, np.array([0.3, 0.1, 0.0]))  # 0.33 m: outside
    assert goal_inside_turn_circle(R, O, X, np.array([0.3, 0.1, 0.0]), margin=1.5)
    # a goal straight ahead within half the tolerance of the line is passed, not turned to
    assert not goal_inside_turn_circle(R, O, X, np.array([0.1, 0.005, 0.0]), tolerance=0.02)


@pytest.mark.parametrize("angle", [0.01, 0.1, 0.5])
def test_rotate_towards_turns_at_most_the_given_angle(angle):
    d = np.array([0.0, 1.0, 0.0])
    out = rotate_towards(X, d, angle, Y)
    assert np.linalg.norm(out) == pytest.approx(1.0, abs=1e-12)
    assert math.acos(np.clip(out @ X, -1, 1)) == pytest.approx(angle, abs=1e-9)
    assert out @ d > 0  # towards d
    assert np.array_equal(rotate_towards(X, X, angle, Y), X)  # already there


def test_rotate_towards_a_direction_behind_turns_to_the_preferred_side():
    out = rotate_towards(X, -X, 0.2, np.array([0.0, 0.0, 1.0]))
    assert out[2] == pytest.approx(math.sin(0.2), abs=1e-12)
    assert out[0] == pytest.approx(math.cos(0.2), abs=1e-12)


def test_free_length_is_the_nearest_point_in_the_tube():
    P = np.array([[0.3, 0.01, 0.0], [0.2, 0.2, 0.0], [-0.1, 0.0, 0.0], [0.5, 0.0, 0.0]])
    assert free_length(O, X, P, 0.6, 0.05) == pytest.approx(0.3)  # (0.2, 0.2) is outside, -0.1 behind
    assert free_length(O, X, P, 0.25, 0.05) == 0.25  # none within max_len
    assert free_length(O, X, np.empty((0, 3)), 0.6, 0.05) == 0.6


def test_repulsion_points_away_and_reports_clearances():
    cfg = PlannerConfig()
    P = np.array([[0.0, 0.05, 0.0]])  # 5 cm to the side: clearance 5 - 2.5 cm
    F, clear_min, clear_ahead = repulsion(cfg, O, X, P)
    assert clear_min == pytest.approx(0.025)
    assert clear_ahead == pytest.approx(0.025)  # beside the tip counts as ahead (within a body radius)
    assert F[1] < 0 and abs(F[0]) < 1e-15 and abs(F[2]) < 1e-15
    rho0 = cfg.influence_distance  # the Khatib magnitude
    expected = cfg.repulsion_gain * (1 / 0.025 - 1 / rho0) / (1 / cfg.safety_distance - 1 / rho0)
    assert np.linalg.norm(F) == pytest.approx(expected)
    F_far, _, _ = repulsion(cfg, O, X, np.array([[0.0, 0.5, 0.0]]))
    assert np.array_equal(F_far, np.zeros(3))  # beyond the influence distance
    _, _, ahead = repulsion(cfg, O, X, np.array([[-0.3, 0.0, 0.0]]))
    assert ahead == np.inf  # behind the tip


def test_speed_stops_when_blocked_and_waits_for_a_lagging_tip():
    cfg = PlannerConfig()
    assert speed(cfg, np.inf, np.inf, X, X, 1.0, False, 0.0) == cfg.v_max
    assert speed(cfg, np.inf, 0.5 * cfg.stop_distance, X, X, 1.0, False, 0.0) == 0.0
    assert speed(cfg, np.inf, np.inf, X, X, 1.0, False, cfg.max_lead) == 0.0
    assert speed(cfg, np.inf, np.inf, X, -X, 1.0, False, 0.0) == pytest.approx(0.5 * cfg.v_max)  # a turn: halved
    d = 0.5 * cfg.approach_distance
    assert speed(cfg, np.inf, np.inf, X, X, d, True, 0.0) == pytest.approx(cfg.v_max * d / cfg.approach_distance)


def test_point_memory_averages_a_voxel_and_drops_the_farthest():
    m = PointMemory(voxel=0.01, capacity=4, average=2)
    m.add(np.array([[0.001, 0.001, 0.001], [0.003, 0.003, 0.003]]))  # one voxel: the mean
    assert len(m) == 1 and np.allclose(m.points, 0.002)
    m.add(np.array([[0.009, 0.009, 0.009]]))  # a third sample: exponential, weight 1/2
    assert np.allclose(m.points, 0.0055)
    assert len(m.near(np.zeros(3), 0.5)) == 1  # (the query position: the origin)
    m.add(np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0], [0.1, 0, 0]]))  # the fifth voxel drops half
    pts = m.points
    assert len(m) == 3
    assert not np.any(np.isclose(pts[:, 0], 3.0)) and not np.any(np.isclose(pts[:, 0], 2.0))
    assert np.allclose(m.near(np.zeros(3), 0.2)[:, 0], [0.0055, 0.1])


def test_lookahead_turns_one_way_at_a_wall_and_keeps_that_sense():
    la = Lookahead(PlannerConfig())
    wall = np.array([[0.3, y, z] for y in np.linspace(-0.2, 0.2, 21) for z in np.linspace(-0.2, 0.2, 21)])
    e = np.array([1.0, 0.3, 0.0]) / np.linalg.norm([1.0, 0.3, 0.0])  # the goal a little to +y
    F, free = la.push(0.0, O, X, wall, e, 0.5)
    assert free == pytest.approx(0.3 - 0.025)
    assert F[1] > 0 and abs(F[0]) < 1e-12  # sideways, to the goal's side
    e_other = np.array([1.0, -0.3, 0.0]) / np.linalg.norm([1.0, -0.3, 0.0])
    F2, _ = la.push(0.1, O, X, wall, e_other, 0.5)
    assert F2[1] > 0  # committed: the goal's side flipping does not flip the turn
    F3, free3 = la.push(2.0, O, X, np.empty((0, 3)), e, 0.5)
    assert np.array_equal(F3, np.zeros(3)) and free3 == np.inf


def test_gap_centering_finds_a_displaced_opening():
    cfg = PlannerConfig(gap_time_constant=0.0)  # no smoothing: the raw offset at once
    gap = GapCentering(cfg)
    # a square ring of points 0.3 m ahead, inner half-width 0.09 m, centred 4 cm to +y of the goal line
    ring = [[0.3, 0.04 + a, b] for a in np.linspace(-0.2, 0.2, 41) for b in np.linspace(-0.2, 0.2, 41)
            if max(abs(a), abs(b)) >= 0.09]
    aim = gap.attraction(O, X, X, X, 1.0, np.array(ring), 0.05)
    assert gap.offset_raw[1] == pytest.approx(0.04, abs=0.011)  # the 1 cm grid
    assert aim[1] > 0 and np.linalg.norm(aim) == pytest.approx(1.0)


def test_wall_follower_commits_to_a_direction_along_the_surface():
    cfg = PlannerConfig()
    wf = WallFollower(cfg)
    wall = np.array([[0.05, y, z] for y in np.linspace(-0.3, 0.3, 31) for z in np.linspace(-0.3, 0.3, 31)])
    g = np.array([1.0, 0.1, 0.0])
    assert wf.start(3.0, O, X, g, wall)
    assert wf.start_time == 3.0
    d = wf.direction(O, wall, (g - O) / np.linalg.norm(g))
    assert abs(d[0]) < 0.9 and d[0] <= 0.0  # along the wall (or away from it), not into it
    assert not wf.start(3.0, O, X, g, np.empty((0, 3)))  # nothing near: nothing to follow


def test_speed_falls_from_cruise_to_v_min_between_the_slow_and_the_safety_distance():
    cfg = PlannerConfig()
    assert speed(cfg, cfg.safety_distance, np.inf, X, X, 1.0, False, 0.0) == pytest.approx(cfg.v_min)
    assert speed(cfg, cfg.slow_distance, np.inf, X, X, 1.0, False, 0.0) == pytest.approx(cfg.v_max)
    mid = 0.5 * (cfg.safety_distance + cfg.slow_distance)
    assert speed(cfg, mid, np.inf, X, X, 1.0, False, 0.0) == pytest.approx(0.5 * (cfg.v_min + cfg.v_max))
    # turning halves the speed, but never below v_min (turning needs motion)
    assert speed(cfg, cfg.safety_distance, np.inf, X, -X, 1.0, False, 0.0) == pytest.approx(cfg.v_min)


def test_repulsion_weights_each_point_by_the_khatib_term():
    """Two points, clearances 0.03 m on +y and 0.06 m on +z: the push's components are in the ratio of their
    weights (1/rho - 1/rho0)^2, away from each."""
    cfg = PlannerConfig()
    r = cfg.body_radius
    P = np.array([[0.0, r + 0.03, 0.0], [0.0, 0.0, r + 0.06]])
    F, clear_min, _ = repulsion(cfg, O, X, P)
    w1, w2 = ((1 / 0.03 - 1 / cfg.influence_distance) ** 2, (1 / 0.06 - 1 / cfg.influence_distance) ** 2)
    assert clear_min == pytest.approx(0.03)
    assert F[1] < 0 and F[2] < 0
    assert F[1] / F[2] == pytest.approx(w1 / w2, rel=1e-12)


def test_aim_direction_is_the_carrot_on_the_hermite_corner_curve():
    """With a next goal, the aim points at the cubic Hermite curve from x (tangent dist h) to the goal (tangent
    corner_tangent dist t, t the bisector of in and out) at parameter corner_lead: scipy's spline as the
    reference."""
    from scipy.interpolate import CubicHermiteSpline

    cfg = PlannerConfig()
    g, g_next = np.array([1.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.0])
    t = (X + Y) / np.linalg.norm(X + Y)
    curve = CubicHermiteSpline([0.0, 1.0], np.array([O, g]), np.array([1.0 * X, cfg.corner_tangent * 1.0 * t]))
    carrot = curve(cfg.corner_lead)
    expected = carrot / np.linalg.norm(carrot)
    assert aim_direction(cfg, O, X, g, X, 1.0, g_next) == pytest.approx(expected, abs=1e-12)
    assert np.array_equal(aim_direction(cfg, O, X, g, X, 1.0, None), X)  # no next goal: the goal itself


def test_free_length_is_blocked_by_a_point_just_inside_the_tube_radius():
    radius = 0.06
    inside = np.array([[0.2, 0.95 * radius, 0.0]])
    outside = np.array([[0.2, 1.05 * radius, 0.0]])
    assert free_length(O, X, inside, 0.6, radius) == pytest.approx(0.2)
    assert free_length(O, X, outside, 0.6, radius) == 0.6


def test_boundary_normal_weights_points_by_inverse_square_clearance():
    cfg = PlannerConfig()
    r = cfg.body_radius
    P = np.array([[0.0, -(r + 0.02), 0.0], [0.0, 0.0, -(r + 0.04)]])  # below in y (near) and in z (farther)
    n = boundary_normal(cfg, O, P)
    w1, w2 = 1 / 0.02**2, 1 / 0.04**2
    expected = np.array([0.0, w1, w2]) / np.hypot(w1, w2)
    assert n == pytest.approx(expected, abs=1e-12)
    assert boundary_normal(cfg, O, np.array([[0.0, 1.0, 0.0]])) is None  # beyond follow_range


def _wall(x: float = 0.05) -> np.ndarray:
    return np.array([[x, y, z] for y in np.linspace(-0.3, 0.3, 31) for z in np.linspace(-0.3, 0.3, 31)])


def test_wall_follower_picks_the_side_of_the_goal():
    """A symmetric wall head-on, 0.1 m ahead (beyond the tube's radius: every direction along it is free over the
    whole 0.3 m that counts, and as far from the heading): the goal, a little to +y or to -y, picks the side."""
    for side in (1.0, -1.0):
        wf = WallFollower(PlannerConfig())
        g = np.array([1.0, 0.1 * side, 0.0])
        assert wf.start(0.0, O, X, g, _wall(0.1))
        d = wf.direction(O, _wall(0.1), g / np.linalg.norm(g))
        assert d[1] * side > 0.5


def test_wall_follower_curls_back_round_a_lost_edge():
    """Once no point is within follow_range (the tip passed a convex edge), it turns back towards where the
    surface was (against the last normal), not out into the open."""
    cfg = PlannerConfig()
    wf = WallFollower(cfg)
    g = np.array([1.0, 0.1, 0.0])
    assert wf.start(0.0, O, X, g, _wall())
    n = np.array([-1.0, 0.0, 0.0])  # the normal away from the wall at x = 0.05
    d = wf.direction(O, np.empty((0, 3)), g / np.linalg.norm(g))
    assert d @ n < -0.3


def test_wall_follower_leaves_only_closer_than_at_the_stall_and_with_a_free_way():
    cfg = PlannerConfig()
    wf = WallFollower(cfg)
    g = np.array([1.0, 0.0, 0.0])
    assert wf.start(0.0, O, X, g, _wall())  # the stall 1 m from the goal
    blocker = np.array([[0.85, 0.0, 0.0]])
    x_near = np.array([0.7, 0.0, 0.0])  # 0.3 m from the goal (within memory_radius), much closer than at the stall
    assert wf.may_leave(x_near, g, 0.3, np.empty((0, 3)))
    assert not wf.may_leave(x_near, g, 0.3, blocker)  # something known on the way
    # not closer by stall_progress than at the stall, and the goal beyond memory_radius: stay on the wall
    x_back = np.array([1.0 - (1.0 - 0.5 * cfg.stall_progress), 0.0, 0.0])
    assert not wf.may_leave(x_back, g, 1.0 - 0.5 * cfg.stall_progress, np.empty((0, 3)))
    # closer by more than stall_progress, the way ahead free over the look-ahead: leave
    x_on = np.array([2.0 * cfg.stall_progress, 0.0, 0.0])
    assert wf.may_leave(x_on, g, 1.0 - 2.0 * cfg.stall_progress, np.empty((0, 3)))
    assert not wf.may_leave(x_on, g, 1.0 - 2.0 * cfg.stall_progress, np.array([[0.3, 0.0, 0.0]]))
