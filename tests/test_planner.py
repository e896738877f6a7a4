"""Potential-field tip planner: limits, approach, gap centring, local minima.

The closed-loop cases fly a free point "robot" (a sphere of the tip's radius)
in PyBullet with perfect tracking of the command; the RaySensor casts from
the point along its heading.  Obstacles are known to PyBullet only: the
planner receives sensor readings, nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pybullet as p
import pytest
from pybullet_utils.bullet_client import BulletClient

from navstack.estimate import RangeEstimator
from navstack.planner.reactive import PlannerConfig, PotentialFieldPlanner, TipCommand, TipPlanner
from navstack.planner.reactive.terms import reach_length
from navstack.sensing import SensorConfig, frame_from_direction
from navstack.sim.rays import RaySensor

R_TIP = 0.025


# ---------------------------------------------------------------------------- helpers
def _quat_z_to(axis: np.ndarray) -> list[float]:
    z = axis / np.linalg.norm(axis)
    v = np.cross([0.0, 0.0, 1.0], z)
    s, c = np.linalg.norm(v), z[2]
    if s < 1e-12:
        return [0.0, 0.0, 0.0, 1.0] if c > 0 else [1.0, 0.0, 0.0, 0.0]
    k = v / s
    ang = np.arctan2(s, c)
    return [*(k * np.sin(ang / 2)), float(np.cos(ang / 2))]


def _build(client, boxes=(), cylinders=()) -> list[int]:
    ids = []
    for center, half in boxes:
        shape = client.createCollisionShape(p.GEOM_BOX, halfExtents=list(half))
        ids.append(client.createMultiBody(0, shape, -1, list(center)))
    for p0, p1, radius in cylinders:
        p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
        length = float(np.linalg.norm(p1 - p0))
        shape = client.createCollisionShape(p.GEOM_CYLINDER, radius=radius, height=length)
        ids.append(client.createMultiBody(0, shape, -1, list((p0 + p1) / 2), _quat_z_to(p1 - p0)))
    return ids


@dataclass
class Flight:
    reached: bool
    stalled: bool
    time: float
    positions: np.ndarray
    velocities: np.ndarray
    clearance: float
    modes: list[str] = field(default_factory=list)
    planner: PotentialFieldPlanner | None = None


def _fly(boxes=(), cylinders=(), start=(0.0, 0.0, 0.0), heading=(1.0, 0.0, 0.0), goal=(1.0, 0.0, 0.0),
         tol=0.02, t_max=60.0, dt=0.04, sense_every=2, seed=0, config=None, approach=True) -> Flight:
    client = BulletClient(connection_mode=p.DIRECT)
    try:
        obstacles = _build(client, boxes, cylinders)
        ball = client.createCollisionShape(p.GEOM_SPHERE, radius=R_TIP)
        robot = client.createMultiBody(0, ball, -1, list(start))
        sensor = RaySensor(client, SensorConfig(), robot, np.random.default_rng(seed))
        planner = PotentialFieldPlanner(config or PlannerConfig(), start=start, heading=heading)
        x = np.array(start, float)
        h = np.asarray(heading, float) / np.linalg.norm(heading)
        g = np.asarray(goal, float)
        pos, vel, modes = [x.copy()], [], []
        clearance = np.inf
        for k in range(int(round(t_max / dt))):
            reading = sensor.read(frame_from_direction(x, h)) if k % sense_every == 0 else None
            cmd = planner.step(dt, x, h, reading, g, tol, approach=approach)
            x = cmd.position.copy()
            if np.linalg.norm(cmd.velocity) > 0:
                h = cmd.velocity / np.linalg.norm(cmd.velocity)
            client.resetBasePositionAndOrientation(robot, x.tolist(), [0, 0, 0, 1])
            for o in obstacles:
                for c in client.getClosestPoints(robot, o, 1.0):
                    clearance = min(clearance, c[8])
            pos.append(x.copy())
            vel.append(cmd.velocity.copy())
            modes.append(cmd.mode)
            reached = bool(np.linalg.norm(x - g) <= tol)
            if reached or cmd.stalled:
                return Flight(reached, cmd.stalled, (k + 1) * dt, np.array(pos), np.array(vel), clearance,
                              modes, planner)
        return Flight(False, False, t_max, np.array(pos), np.array(vel), clearance, modes, planner)
    finally:
        client.disconnect()


def _free_flight(goal, heading=(1.0, 0.0, 0.0), approach=False, dt=0.02, t_max=60.0, tol=0.02, config=None):
    """No obstacles, no sensor: (positions, velocities, commands)."""
    planner = PotentialFieldPlanner(config or PlannerConfig(), start=np.zeros(3), heading=heading)
    x = np.zeros(3)
    h = np.asarray(heading, float)
    cmds: list[TipCommand] = []
    for _ in range(int(t_max / dt)):
        cmd = planner.step(dt, x, h, None, np.asarray(goal, float), tol, approach=approach)
        cmds.append(cmd)
        x = cmd.position
        if np.linalg.norm(cmd.velocity) > 0:
            h = cmd.velocity / np.linalg.norm(cmd.velocity)
        if cmd.stalled or (not approach and np.linalg.norm(x - goal) <= tol):
            break
    pos = np.array([np.zeros(3)] + [c.position for c in cmds])
    vel = np.array([c.velocity for c in cmds])
    return pos, vel, cmds


def _assert_curvature_limited(velocities: np.ndarray, dt: float, radius: float) -> None:
    """Heading change per step <= arc length / radius (the body's bend limit)."""
    speed = np.linalg.norm(velocities, axis=1)
    moving = np.flatnonzero(speed > 1e-9)
    for i, j in zip(moving[:-1], moving[1:], strict=True):
        if j != i + 1:
            continue
        c = np.clip(velocities[i] @ velocities[j] / (speed[i] * speed[j]), -1, 1)
        assert np.arccos(c) <= speed[j] * dt / radius + 1e-9, f"step {j}: too sharp a turn"


def _wall_boxes():
    return [([0.5, 0.0, 0.0], [0.02, 0.3, 0.3])]


def _u_trap(height: float = 0.4):
    """Back wall at x = 0.9 with two side walls reaching back to x = 0.3, open towards -x."""
    return [([0.9, 0.0, 0.0], [0.02, 0.6, height]),
            ([0.6, 0.6, 0.0], [0.3, 0.02, height]),
            ([0.6, -0.6, 0.0], [0.3, 0.02, height])]


def _triangle(center, side=0.5, radius=0.02, overhang=0.15, rot=0.0):
    """A triangular truss opening in the plane x = center[0]: three members of radius 0.02 m."""
    rc = side / np.sqrt(3)
    v = [np.array([center[0], center[1] + rc * np.cos(rot + k * 2 * np.pi / 3),
                   center[2] + rc * np.sin(rot + k * 2 * np.pi / 3)]) for k in range(3)]
    out = []
    for i in range(3):
        a, b = v[i], v[(i + 1) % 3]
        u = (b - a) / np.linalg.norm(b - a)
        out.append((a - overhang * u, b + overhang * u, radius))
    return out


# ---------------------------------------------------------------------------- config and interface
@pytest.mark.parametrize(
    ("name", "value"),
    [("v_max", 0.0), ("v_min", -0.01), ("min_turn_radius", -1.0), ("influence_distance", np.nan),
     ("stall_window", 0.0), ("memory_voxel", 0.0), ("max_escapes", -1), ("memory_capacity", 0),
     ("gap_centering", "yes"), ("estimator", {}), ("v_max", True), ("repulsion_gain", np.inf)],
)
def test_config_rejects_bad_values_naming_the_field(name, value):
    with pytest.raises(ValueError, match=name):
        PlannerConfig(**{name: value})


def test_config_rejects_inconsistent_pairs():
    with pytest.raises(ValueError, match="v_min"):
        PlannerConfig(v_min=0.1, v_max=0.05)
    with pytest.raises(ValueError, match="safety_distance"):
        PlannerConfig(safety_distance=0.2, slow_distance=0.15)


def test_step_rejects_bad_inputs():
    pl = PotentialFieldPlanner(start=[0, 0, 0], heading=[1, 0, 0])
    ok = dict(dt=0.02, tip_position_measured=np.zeros(3), tip_direction=np.array([1.0, 0, 0]), reading=None,
              goal=np.ones(3), goal_tolerance=0.02)
    for key, bad, err in [("dt", 0.0, ValueError), ("dt", np.nan, ValueError), ("goal", [1, 2], ValueError),
                          ("goal", [np.nan, 0, 0], ValueError), ("goal_tolerance", -0.1, ValueError),
                          ("tip_position_measured", "here", TypeError), ("reading", [0.3, 0.2], TypeError)]:
        with pytest.raises(err, match=key.split("_")[0] if key != "reading" else "reading"):
            pl.step(**{**ok, key: bad})
    with pytest.raises(ValueError, match="heading"):
        PotentialFieldPlanner(start=[0, 0, 0])
    with pytest.raises(ValueError, match="non-zero"):
        PotentialFieldPlanner(start=[0, 0, 0], heading=[0, 0, 0])


def test_satisfies_the_common_planner_interface():
    assert isinstance(PotentialFieldPlanner(), TipPlanner)
    pl = PotentialFieldPlanner()  # starts from the first measured tip state
    tip, direction, goal = np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 2.0]), np.array([1.0, 2.0, 4.0])
    cmd = pl.step(0.02, tip, direction, None, goal, 0.02)
    assert isinstance(cmd, TipCommand) and not cmd.stalled
    np.testing.assert_allclose(cmd.velocity / np.linalg.norm(cmd.velocity), [0, 0, 1])
    np.testing.assert_allclose(cmd.position, [1.0, 2.0, 3.0 + 0.02 * np.linalg.norm(cmd.velocity)])


# ---------------------------------------------------------------------------- free space
@pytest.mark.parametrize("goal", [(0.8, 0.3, -0.2), (-0.5, 0.1, 0.0), (0.0, 0.0, 0.6)])
def test_free_space_respects_speed_and_turn_radius(goal):
    cfg = PlannerConfig()
    pos, vel, cmds = _free_flight(np.array(goal))
    assert np.linalg.norm(pos[-1] - goal) <= 0.02, "goal not reached"
    assert not any(c.stalled for c in cmds)
    assert np.linalg.norm(vel, axis=1).max() <= cfg.v_max + 1e-12
    _assert_curvature_limited(vel, 0.02, cfg.min_turn_radius)
    # the path is never much longer than the shortest curvature-bounded one
    length = np.linalg.norm(np.diff(pos, axis=0), axis=1).sum()
    bound = reach_length(cfg.min_turn_radius, np.zeros(3), np.array([1.0, 0, 0]), np.array(goal))
    assert length <= 1.1 * bound + 0.02


def test_goal_inside_the_turning_circle_is_reached_by_going_wide():
    cfg = PlannerConfig()
    goal = np.array([0.05, 0.15, 0.0])  # inside the left turning circle (radius 0.25)
    pos, vel, cmds = _free_flight(goal)
    assert np.linalg.norm(pos[-1] - goal) <= 0.02
    _assert_curvature_limited(vel, 0.02, cfg.min_turn_radius)


def _goal_sequence(goals, with_next: bool, dt=0.02, t_max=60.0):
    """Free flight through goals in order, advancing like the trial loop; returns (length, velocities)."""
    pl = PotentialFieldPlanner(start=np.zeros(3), heading=[1, 0, 0])
    x, h, k = np.zeros(3), np.array([1.0, 0, 0]), 0
    length, vel = 0.0, []
    for _ in range(int(t_max / dt)):
        nxt = goals[k + 1] if with_next and k + 1 < len(goals) else None
        cmd = pl.step(dt, x, h, None, goals[k], 0.02, next_goal=nxt, approach=k == len(goals) - 1)
        length += float(np.linalg.norm(cmd.position - x))
        x = cmd.position
        vel.append(cmd.velocity)
        if np.linalg.norm(cmd.velocity) > 0:
            h = cmd.velocity / np.linalg.norm(cmd.velocity)
        if np.linalg.norm(x - goals[k]) <= 0.02:
            k += 1
            if k == len(goals):
                return length, np.array(vel)
    return np.inf, np.array(vel)


def test_next_goal_lets_the_tip_take_a_sharp_corner_without_a_loop():
    # after the first goal the second is inside the turning circle of a tip arriving straight
    goals = np.array([[0.3, 0.0, 0.0], [0.5, 0.2, 0.0]])
    plain, _ = _goal_sequence(goals, with_next=False)
    ahead, vel = _goal_sequence(goals, with_next=True)
    print(f"\nsharp corner: path {plain:.3f} m heading straight for each goal, {ahead:.3f} m with next_goal")
    assert ahead < 0.75  # no loop (straight-line length 0.58 m)
    assert plain > ahead + 0.5  # without the look-ahead the tip has to loop back
    _assert_curvature_limited(vel, 0.02, PlannerConfig().min_turn_radius)


def test_approach_stops_on_the_goal_without_overshoot():
    goal = np.array([0.6, 0.0, 0.0])
    pos, vel, cmds = _free_flight(goal, approach=True, t_max=25.0)  # > stall_window of holding
    assert cmds[-1].mode == "hold" and np.all(cmds[-1].velocity == 0)  # holds as long as asked
    assert np.linalg.norm(pos[-1] - goal) <= 0.01
    assert pos[:, 0].max() <= goal[0] + 1e-9  # never beyond the goal
    d = np.linalg.norm(pos - goal, axis=1)
    assert np.all(np.diff(d) <= 1e-12)  # distance never grows
    speed = np.linalg.norm(vel, axis=1)
    near = d[:-1] < 0.04  # speed of the step that starts this close
    assert speed[near].max() <= 0.4 * PlannerConfig().v_max + 1e-12  # slows down near the goal
    # without approach the goal is passed at cruise speed
    _, vel2, _ = _free_flight(goal, approach=False)
    assert np.linalg.norm(vel2[-1]) == pytest.approx(PlannerConfig().v_max)


def test_gives_up_when_the_tip_cannot_follow():
    cfg = PlannerConfig(stall_window=3.0)
    pl = PotentialFieldPlanner(cfg, start=np.zeros(3), heading=[1, 0, 0])
    stuck_tip = np.zeros(3)  # the actual tip never moves (e.g. a joint at its limit)
    t, cmd = 0.0, None
    while t < 20.0:
        cmd = pl.step(0.02, stuck_tip, np.array([1.0, 0, 0]), None, np.array([1.0, 0, 0]), 0.02)
        t += 0.02
        if cmd.stalled:
            break
    assert cmd is not None and cmd.stalled and np.all(cmd.velocity == 0)
    assert np.linalg.norm(cmd.position) <= cfg.max_lead + 1e-9  # waited for the tip instead of running away
    assert t < 8.0  # stall_window after it came to a stop


# ---------------------------------------------------------------------------- with obstacles (PyBullet)
def test_wall_head_on_goes_around_without_touching():
    f = _fly(boxes=_wall_boxes(), goal=(1.0, 0.0, 0.0))
    print(f"\nwall head-on: reached {f.reached} in {f.time:.1f} s, min clearance {f.clearance * 1e3:.1f} mm")
    assert f.reached
    assert f.clearance > 0.02
    _assert_curvature_limited(f.velocities, 0.04, PlannerConfig().min_turn_radius)


def test_gap_centring_recovers_a_displaced_opening():
    """A triangular opening (side 0.5 m, members r = 0.02 m) displaced 3-7 cm from the goal line."""
    rows = []
    for delta in (0.03, 0.05, 0.07):
        center = np.array([0.6, 0.0, -delta])  # towards an edge member: the harder direction
        result = {}
        for centring in (False, True):
            f = _fly(cylinders=_triangle(center, rot=np.pi / 2), goal=(1.0, 0.0, 0.0), t_max=30.0,
                     config=PlannerConfig(gap_centering=centring))
            assert f.reached and f.clearance > 0.0
            xs = f.positions[:, 0]
            i = int(np.searchsorted(xs, center[0]))
            a = (center[0] - xs[i - 1]) / (xs[i] - xs[i - 1])
            crossing = f.positions[i - 1] + a * (f.positions[i] - f.positions[i - 1])
            result[centring] = (float(np.linalg.norm(crossing[1:] - center[1:])), f.clearance)
        rows.append((delta, *result[False], *result[True]))
    print("\n offset | plain field: residual, clearance | gap centring: residual, clearance  [mm]")
    for delta, r0, c0, r1, c1 in rows:
        print(f"  {delta * 1e3:4.0f}  |   {r0 * 1e3:5.1f} ({100 * (1 - r0 / delta):3.0f}% recovered), "
              f"{c0 * 1e3:5.1f}     |   {r1 * 1e3:5.1f} ({100 * (1 - r1 / delta):3.0f}% recovered), "
              f"{c1 * 1e3:5.1f}")
    for delta, r0, c0, r1, c1 in rows:
        assert r1 <= 0.3 * delta  # recovers at least 70 % of the misplacement
        assert r1 < r0 and c1 > c0  # better centred and more clearance than the plain field


def test_u_trap_escape_reaches_the_goal_behind_it_without_touching():
    goal = (1.4, 0.0, 0.0)
    plain = _fly(boxes=_u_trap(), start=(-0.3, 0.0, 0.0), goal=goal, t_max=120.0,
                 config=PlannerConfig(max_escapes=0))
    assert plain.stalled and not plain.reached  # it is a trap for the field alone
    f = _fly(boxes=_u_trap(), start=(-0.3, 0.0, 0.0), goal=goal, t_max=120.0)
    print(f"\nU-trap: plain field stalled after {plain.time:.1f} s; with boundary-following escape reached "
          f"{f.reached} in {f.time:.1f} s ({f.modes.count('follow')} follow steps), "
          f"min clearance {f.clearance * 1e3:.1f} mm")
    assert f.reached
    assert f.planner is not None and f.planner.n_escapes >= 1
    assert f.clearance > 0.02
    _assert_curvature_limited(f.velocities, 0.04, PlannerConfig().min_turn_radius)


def test_enclosed_goal_reports_stalled_without_touching():
    c, a, t = np.array([1.2, 0.0, 0.0]), 0.2, 0.01
    boxes = []
    for ax in range(3):
        for sgn in (-1, 1):
            center = c.copy()
            center[ax] += sgn * a
            half = [a + t] * 3
            half[ax] = t
            boxes.append((center, half))
    cfg = PlannerConfig(stall_window=5.0, escape_timeout=20.0, max_escapes=2)
    f = _fly(boxes=boxes, goal=c, t_max=200.0, config=cfg)
    assert f.stalled and not f.reached
    assert f.clearance > 0.005  # it stops short of the box (stop_distance), never touching


def test_same_seed_same_flight():
    a = _fly(boxes=_wall_boxes(), t_max=12.0, seed=4)
    b = _fly(boxes=_wall_boxes(), t_max=12.0, seed=4)
    c = _fly(boxes=_wall_boxes(), t_max=12.0, seed=5)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert not np.array_equal(a.positions, c.positions)


def test_accepts_readings_filtered_by_the_caller():
    client = BulletClient(connection_mode=p.DIRECT)
    try:
        _build(client, boxes=_wall_boxes())
        cfg = SensorConfig()
        sensor = RaySensor(client, cfg, None, np.random.default_rng(0))
        est = RangeEstimator(cfg)
        pl = PotentialFieldPlanner(start=[0.2, 0, 0], heading=[1, 0, 0])
        x, h = np.array([0.2, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
        for _ in range(10):
            filtered = est.update(sensor.read(frame_from_direction(x, h)), 0.04)
            cmd = pl.step(0.04, x, h, filtered, np.array([1.0, 0, 0]), 0.02)
            x, h = cmd.position, cmd.velocity / np.linalg.norm(cmd.velocity)
        assert pl.estimator is None  # the planner used the caller's estimate
        pts = pl.obstacle_points
        assert len(pts) > 10 and np.all(np.abs(pts[:, 0] - 0.48) < 0.02)
    finally:
        client.disconnect()
