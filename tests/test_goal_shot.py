"""Goals smaller than the search's sample spacing: the goal shot and the command landing on it.

A goal's tolerance may be far below the 1 cm between the samples of a motion primitive (and the 2 mm a
command moves per control step): before the shot, a 1-2 mm goal was never passed by any sample and the
planner stalled.  References: the circle through the state and the goal (centre, radius, chord and
central angle in closed form), brute-force clearances (k-d tree) of every densified sample, discrete
curvature from consecutive tangents, and the tip from the recorded joints for the trial.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from navstack import jpl_serpentine, load_world
from navstack.planner.map import SensedMap
from navstack.planner.potential import Repulsion, navigation_function
from navstack.planner.search import REACHED, SearchConfig, _arc, goal_shot, navigation_region, search
from navstack.planner.steering import PlanFollower, SteeringConfig
from navstack.trial import run_trial
from navstack.world import world_from_dict

CFG = SearchConfig()
REP = Repulsion()
KMAX = 1.0 / CFG.min_turn_radius
X = np.array([1.0, 0.0, 0.0])
WORLDS = Path(__file__).resolve().parents[1] / "worlds"


def _open_map() -> SensedMap:
    smap = SensedMap([0, 0, 0], [1.0, 0.0, 0.0])
    smap.mark_free(smap.origin + 0.5 * smap.free_dims * smap.config.free_cell, 10.0)
    return smap


def _slotted_wall(slot_y: float = 0.1, width: float = 0.1, x: float = 0.5) -> np.ndarray:
    y, z = (v.ravel() for v in np.meshgrid(np.arange(-0.6, 0.6 + 1e-9, 0.01), np.arange(-0.4, 0.4 + 1e-9, 0.01),
                                           indexing="ij"))
    keep = np.abs(y - slot_y) >= 0.5 * width - 1e-9
    return np.column_stack([np.full(keep.sum(), x), y[keep], z[keep]])


def _plan(smap, goals, tol):
    goals = np.asarray(goals, dtype=float).reshape(-1, 3)
    return search(smap, np.zeros(3), X, goals, np.full(len(goals), tol), 0, CFG, REP)


# ---------------------------------------------------------------------------- the arc
def test_the_shot_is_the_circle_tangent_to_the_heading_through_the_goal():
    rng = np.random.default_rng(3)
    tried = 0
    for _ in range(400):
        p = rng.uniform(-1, 1, 3)
        h = rng.normal(size=3)
        h /= np.linalg.norm(h)
        g = p + rng.uniform(0.005, 0.12) * (h + rng.uniform(-0.15, 0.15, 3))
        kap, nx, ny, nz, length = goal_shot(*p, *h, *g, KMAX)
        v = g - p
        needed = 2 * np.linalg.norm(v - (v @ h) * h) / (v @ v)  # the circle's curvature: 2 sin(angle) / |v|
        if length < 0:
            assert v @ h <= 0 or needed > KMAX
            continue
        assert kap == pytest.approx(needed, rel=1e-12, abs=1e-15)
        tried += 1
        n = np.array([nx, ny, nz])
        end = np.array(_arc(*p, *h, *n, kap, length))
        np.testing.assert_allclose(end[:3], g, rtol=0, atol=1e-12)
        assert kap <= KMAX
        if kap > 0:
            assert abs(n @ h) < 1e-12 and abs(np.linalg.norm(n) - 1) < 1e-12
            centre = p + n / kap  # both ends on the circle, the chord 2 R sin(angle / 2)
            assert np.linalg.norm(g - centre) == pytest.approx(1 / kap, rel=1e-9)
            assert np.linalg.norm(g - p) == pytest.approx(2 / kap * math.sin(kap * length / 2), rel=1e-9)
    assert tried > 150


def test_no_shot_behind_the_heading_or_tighter_than_the_turning_limit():
    p = np.zeros(3)
    assert goal_shot(*p, *X, -0.05, 0.01, 0.0, KMAX)[4] == -1.0  # behind
    assert goal_shot(*p, *X, -2.0, 0.01, 0.0, KMAX)[4] == -1.0  # far behind: a gentle arc, but not ahead
    assert goal_shot(*p, *X, 0.0, 0.05, 0.0, KMAX)[4] == -1.0  # beside: a half circle of radius 2.5 cm
    assert goal_shot(*p, *X, 0.05, 0.02, 0.0, KMAX)[4] == -1.0  # curvature 13.8 / m > 4 / m
    kap, *_, length = goal_shot(*p, *X, 0.08, 0.0, 0.0, KMAX)
    assert kap == 0.0 and length == pytest.approx(0.08, abs=1e-15)  # straight ahead


# ---------------------------------------------------------------------------- the search
def test_the_wave_of_a_goal_smaller_than_a_cell_starts_in_the_goals_cell():
    """A 1 mm ball near a corner of the 2 cm cells holds no cell's centre: the navigation function was
    ``inf`` everywhere (the search then found no state nearer than its start).  Its own cell is the seed."""
    smap = _open_map()
    cell = smap.config.free_cell
    corner = smap.origin + np.floor((np.array([0.6, 0.1, 0.0]) - smap.origin) / cell) * cell
    goal = corner + 0.001  # a millimetre inside the cell, 16 mm from its centre
    nav = navigation_function(smap, goal, 0.0007, *navigation_region(np.zeros(3), goal, CFG), REP)
    assert nav.lookup(goal) == 0.0
    assert nav.lookup(goal - [0.002, 0, 0]) == pytest.approx(cell, rel=1e-9)  # the next cell in x
    assert nav.lookup(goal - 0.002) == pytest.approx(math.sqrt(3) * cell, rel=1e-9)  # across the corner
    assert math.isfinite(nav.lookup(np.zeros(3)))


@pytest.mark.parametrize("tol", [0.002, 0.001, 0.0002])
def test_a_goal_smaller_than_the_samples_spacing_is_reached_exactly(tol):
    """Behind a slot in a wall: the plan ends on the goal, clear of the wall, with its curvature bounded."""
    goal = np.array([0.8, 0.13, 0.02])
    wall = _slotted_wall()
    smap = SensedMap([0, 0, 0], [1.0, 0.0, 0.0])
    smap.add_points(wall)
    smap.mark_free(smap.origin + 0.5 * smap.free_dims * smap.config.free_cell, 10.0)
    plan = _plan(smap, goal, tol)
    assert plan.status == REACHED
    np.testing.assert_allclose(plan.points[-1], goal, rtol=0, atol=1e-12)
    assert plan.stops.tolist() == [plan.arc[-1]]
    d, _ = cKDTree(wall).query(plan.points)
    assert d.min() >= REP.r_block - 1e-9
    ds = np.diff(plan.arc)
    turn = np.arccos(np.clip(np.sum(plan.tangents[1:] * plan.tangents[:-1], axis=1), -1, 1))
    assert np.all(turn <= KMAX * ds * (1 + 1e-4) + 1e-9)  # no kink where the shot starts (chords: 2e-5 short)


def test_an_intermediate_small_goal_is_a_stop_on_the_way():
    goals = np.array([[0.35, 0.03, -0.01], [0.8, 0.0, 0.05]])
    plan = _plan(_open_map(), goals, 0.001)
    assert plan.status == REACHED
    assert len(plan.stops) == 2
    i = int(np.flatnonzero(plan.arc == plan.stops[0])[0])
    np.testing.assert_allclose(plan.points[i], goals[0], rtol=0, atol=1e-12)
    assert plan.goal_index[i - 1] == 0 and plan.goal_index[i] == 1
    np.testing.assert_allclose(plan.points[-1], goals[1], rtol=0, atol=1e-12)


def test_a_goal_the_samples_can_pass_gets_no_shot():
    plan = _plan(_open_map(), [0.8, 0.13, 0.02], 0.02)  # reach 14 mm > 10 mm between samples
    assert plan.status == REACHED and len(plan.stops) == 0
    assert np.linalg.norm(plan.points[-1] - [0.8, 0.13, 0.02]) > 1e-6  # ends where a sample first passed


# ---------------------------------------------------------------------------- the command
def _follow(plan, lag=lambda step, p: 0.0, dt=1.0 / 30.0):
    f = PlanFollower(plan, SteeringConfig())
    pts, vels = [], []
    while f.remaining > 0 and len(pts) < 10_000:
        p, v = f.advance(dt, clearance=1.0, lag=lag(len(pts), pts[-1] if pts else None))
        pts.append(p)
        vels.append(v)
    return np.array(pts), np.array(vels)


def test_the_command_lands_on_each_stop_within_the_acceleration_limit():
    """Every stop is a commanded position (to 1e-12 m), and the commanded speed changes by no more than
    accel dt between steps around them (a review: cutting one step short made it drop to 4.7 um per step
    and jump back, 18 times the limit)."""
    goals = np.array([[0.35, 0.03, -0.01], [0.8, 0.0, 0.05]])
    plan = _plan(_open_map(), goals, 0.001)
    cfg = SteeringConfig()
    pts, vels = _follow(plan)
    dt = 1.0 / 30.0
    for g in goals:
        assert np.linalg.norm(pts - g, axis=1).min() < 1e-12
    speed = np.linalg.norm(vels, axis=1)
    assert np.abs(np.diff(speed[:-1])).max() <= cfg.accel * dt * (1 + 1e-9)  # (the last lands on the end)
    assert speed.max() <= cfg.v_max * (1 + 1e-12)
    k = int(np.argmin(np.linalg.norm(pts - goals[0], axis=1)))
    assert speed[k] < cfg.v_max and speed[k + 1] == pytest.approx(cfg.v_max)  # slowed a little, then on


def test_the_command_waits_on_a_stop_while_the_tip_lags():
    """On a stop with the tip 1 mm behind, the command stays (at rest) until the tip is within stop_lag, or
    stop_hold has passed; with the tip on it, it does not wait."""
    goals = np.array([[0.35, 0.03, -0.01], [0.8, 0.0, 0.05]])
    plan = _plan(_open_map(), goals, 0.001)
    cfg = SteeringConfig()
    base, _ = _follow(plan)
    arrive = int(np.argmin(np.linalg.norm(base - goals[0], axis=1)))
    lagging = {"until": arrive + 10}
    pts, vels = _follow(plan, lag=lambda step, p: 1e-3 if arrive < step <= lagging["until"] else 0.0)
    waited = np.flatnonzero(np.linalg.norm(pts - goals[0], axis=1) < 1e-12)
    assert waited.tolist() == list(range(arrive, arrive + 11))  # landed, then 10 steps at rest
    assert np.all(vels[arrive + 1 : arrive + 11] == 0.0)
    lagging["until"] = 10**6  # the tip never catches up: the command goes on after stop_hold
    pts, _ = _follow(plan, lag=lambda step, p: 1e-3 if step > arrive else 0.0)
    waited = np.flatnonzero(np.linalg.norm(pts - goals[0], axis=1) < 1e-12)
    assert len(waited) == 1 + round(cfg.stop_hold * 30) and len(pts) > waited[-1] + 10


# ---------------------------------------------------------------------------- a trial
def test_the_paper_demo_with_one_millimetre_goals_reaches_all_four(tmp_path):
    """The field planner through the paper truss with every goal's tolerance 1 mm (it stalled at the
    first one before): all four reached, each within 1 mm of the tip computed from the recorded joints."""
    d = load_world(WORLDS / "paper_truss.json").to_dict()
    for g in d["goals"]:
        g["tolerance"] = 0.001
    world = world_from_dict(d)
    r = run_trial(world, planner="field", out_dir=tmp_path)
    assert r.success and r.reason == "reached" and r.goals_reached == 4 and r.metrics["contacts"] == 0
    q = np.load(tmp_path / "trajectory.npz")["q"]
    chain = jpl_serpentine()
    T0 = world.robot.base.transform()
    tips = np.array([(T0 @ chain.frames(qi)[21])[:3, 3] for qi in q])
    i = 0
    for g in world.goals:
        near = np.flatnonzero(np.linalg.norm(tips[i:] - g.position, axis=1) <= g.tolerance)
        assert len(near), f"goal {g.position} never within {g.tolerance} m"
        i += int(near[0])
