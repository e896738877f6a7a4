"""``min_clearance`` beyond the per-step horizon (navstack.sim.far_clearance): a closed form for a trial that
never comes near anything, the replay's skipping against measuring every step, and a world without obstacles."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _worlds import ROBOT, TIP

import navstack.sim.far_clearance as far
from navstack import jpl_serpentine
from navstack.cli import main
from navstack.trial import TrialConfig, _Simulation, run_trial
from navstack.world import world_from_dict

HORIZON = TrialConfig().clearance_horizon


def world(*obstacles: dict, time_limit: float = 3.0) -> dict:
    """The paper's robot with a goal 0.6 m ahead of and 0.3 m above its tip (the scripted planner heads
    there, so the robot moves), and ``obstacles``."""
    return {"format": "navstack-world/1", "name": "far", "robot": ROBOT, "obstacles": list(obstacles),
            "goals": [{"position": (TIP + [0.6, 0.0, 0.3]).tolist()}], "time_limit": time_limit}


def closed_form(q_rows: np.ndarray, w, center: np.ndarray, radius: float) -> float:
    """Smallest distance (m) over the steps from the robot's capsules (frames 1..21, arm radius on frames 1..8)
    to a sphere, by the segment-point formula (independent of navstack's geometry code)."""
    chain, T0 = jpl_serpentine(), w.robot.base.transform()
    radii = np.where(np.arange(20) < 8, w.robot.arm_radius, w.robot.serpentine_radius)
    best = np.inf
    for q in q_rows:
        O = chain.frames(q)[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3]
        for k in range(20):
            a, ab = O[k], O[k + 1] - O[k]
            if ab @ ab < 1e-18:
                continue
            t = np.clip((center - a) @ ab / (ab @ ab), 0.0, 1.0)
            best = min(best, float(np.linalg.norm(a + t * ab - center)) - radii[k] - radius)
    return best


@pytest.mark.parametrize("where, most", [([-5.0, -5.0, -5.0], 0.25), ([2.6, 0.9, 1.5], 1.0)])
def test_a_trial_that_never_comes_near_reports_the_true_clearance(tmp_path, monkeypatch, where, most):
    """8.7 m away, and 0.6-0.9 m from the moving serpentine: the spec's minimum, not the 0.5 m horizon.
    Far from everything, the replay measures at most ``most`` of the steps (measured: 18 of 301 over 10 s)."""
    w = world_from_dict(world({"type": "sphere", "center": where, "radius": 0.1}, time_limit=10.0))
    measured, original = [], far._measure
    monkeypatch.setattr(far, "_measure", lambda *a: measured.append(a[5]) or original(*a))
    result = run_trial(w, planner="scripted", out_dir=tmp_path / "out")
    assert 0 < len(measured) <= most * (result.steps + 1)
    q = np.load(tmp_path / "out" / "trajectory.npz")["q"]
    expected = closed_form(q, w, np.array(where), 0.1)
    assert expected > HORIZON
    assert result.metrics["min_clearance"] == pytest.approx(expected, abs=1e-6)
    saved = json.loads((tmp_path / "out" / "result.json").read_text())["metrics"]["min_clearance"]
    assert saved == result.metrics["min_clearance"]


def _every_step(sim: _Simulation) -> float:
    """The replay's answer with nothing skipped: every recorded step measured."""
    qs = np.asarray(sim.trajectory.q)
    origins = np.array([sim.chain.frames(q)[1:22, :3, 3] @ sim.R0.T + sim.p0 for q in qs])
    times = np.asarray(sim.trajectory.t)
    return min(far._measure(sim.scene, sim.body, qs[k], origins[k], origins[k - 1] if k else None, times, k, sim.dt,
                            np.inf)
               for k in range(len(qs)))


@pytest.mark.parametrize("moving", [False, True])
def test_skipping_steps_gives_the_minimum_of_measuring_every_step(moving, monkeypatch):
    """Three members 0.55-0.9 m from the robot's way (one oscillating at up to 0.2 m/s): the bound-driven
    replay finds the same minimum."""
    side = {"type": "box", "center": (TIP + [0.3, -0.75, 0.0]).tolist(), "half_extents": [0.3, 0.05, 0.3]}
    if moving:
        side["motion"] = {"type": "oscillate", "axis": [0, 1, 0], "amplitude": 0.1, "period": np.pi}
    obstacles = [side, {"type": "cylinder", "p0": (TIP + [0.9, 0.7, -0.5]).tolist(),
                        "p1": (TIP + [0.9, 0.7, 0.5]).tolist(), "radius": 0.05},
                 {"type": "sphere", "center": (TIP + [0.2, 0.0, -0.8]).tolist(), "radius": 0.1}]
    sim = _Simulation(world_from_dict(world(*obstacles)), "slither", "scripted", 0, TrialConfig())
    try:
        measured = []
        original = far._measure
        monkeypatch.setattr(far, "_measure", lambda *a: measured.append(a[5]) or original(*a))
        assert sim.run() == "timeout"
        assert sim.min_clearance > HORIZON  # the replay ran
        steps = len(sim.trajectory.q)
        assert 1 < len(measured) <= steps  # approaching its smallest clearance, every step must be measured
        q_last = np.asarray(sim.trajectory.q[-1])
        np.testing.assert_allclose(sim.body.joint_state()[0], q_last, atol=1e-12)  # left at the last step
        monkeypatch.setattr(far, "_measure", original)
        assert sim.min_clearance == pytest.approx(_every_step(sim), abs=1e-12)
    finally:
        sim.close()


def test_a_world_without_obstacles_has_no_clearance(tmp_path, capsys):
    path = tmp_path / "empty.json"
    path.write_text(json.dumps(world(time_limit=0.5)))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--planner", "scripted"]) == 0
    assert "min_clearance none" in capsys.readouterr().out
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert result["metrics"]["min_clearance"] is None and result["metrics"]["contacts"] == 0


def test_the_skip_bound_counts_the_robots_motion_and_the_movers_speed():
    """From a step measured at 1.0 m with 0.95 m the best so far, a later step is skipped while it cannot
    come below 0.95: an origin moving 11 mm per step (no movers) allows m steps with 0.011 m <= 0.05, m <= 4.5;
    a robot at rest next to a mover of 0.2 m/s at 30 Hz allows 0.2 (m + 1) / 30 <= 0.05, m <= 6.5."""
    n, dt = 40, 1.0 / 30.0
    times = np.arange(n) * dt
    moving = np.zeros((n, 21, 3))
    moving[:, 20, 0] = 0.011 * np.arange(n)  # the tip's origin only
    assert far._next_step(moving, times, 3, 1.0, 0.95, 0.0, dt) == 3 + 5
    still = np.zeros((n, 21, 3))
    assert far._next_step(still, times, 3, 1.0, 0.95, 0.2, dt) == 3 + 7
    assert far._next_step(still, times, 3, 1.0, 0.95, 0.0, dt) == n  # nothing moves: nothing to measure again
    assert far._next_step(moving, times, 3, 0.95, 0.95, 0.0, dt) == 4  # at the best: the next step


def test_a_box_corner_that_pybullet_reads_high_does_not_hide_the_minimum():
    """PyBullet's distance to a box corner reads up to 0.73 mm high where it is not sharpened.  A corner 0.6 m
    from the robot, the lathe moving 0.4 mm away then 0.6 mm closer: the replay must find the minimum at the
    third step, 0.6 mm below the first (a review's case: the bound without the margin skipped it)."""
    from scipy.spatial.transform import Rotation

    from navstack.sim.probe import build_scene

    base = world_from_dict(world())
    T0 = base.robot.base.transform()
    R0, p0 = T0[:3, :3], T0[:3, 3]
    chain, q0 = jpl_serpentine(), np.array(base.robot.q0, dtype=float)
    O = chain.frames(q0)[1:22, :3, 3] @ R0.T + p0
    r = np.where(np.arange(21) < 8, base.robot.arm_radius, base.robot.serpentine_radius)
    up = R0[:, 2]  # the lathe's axis in the world
    k = int(np.argmax(O @ up + r))
    turn, _ = Rotation.align_vectors([-up], [np.ones(3) / np.sqrt(3)])  # the (1, 1, 1) corner faces the robot
    box = {"type": "box", "center": (O[k] + (r[k] + 0.6 + 0.1 * np.sqrt(3)) * up).tolist(),
           "half_extents": [0.1] * 3, "rpy": turn.as_euler("xyz").tolist()}
    client, body, scene = build_scene(world_from_dict(world(box)))
    try:
        qs = np.array([q0, q0, q0])
        qs[1, 0] -= 0.0004
        qs[2, 0] += 0.0006
        origins = np.array([chain.frames(q)[1:22, :3, 3] @ R0.T + p0 for q in qs])
        times, dt = np.arange(3) / 30.0, 1.0 / 30.0
        every = [far._measure(scene, body, qs[i], origins[i], origins[i - 1] if i else None, times, i, dt, np.inf)
                 for i in range(3)]
        assert every[2] == pytest.approx(0.5994, abs=1e-6) and every[2] == min(every)
        assert far.replay_min_clearance(scene, body, qs, origins, times, dt) == pytest.approx(every[2], abs=1e-12)
    finally:
        client.disconnect()


def test_a_dense_mesh_just_beyond_the_horizon_is_measured_without_crashing_pybullet(tmp_path):
    """PyBullet returns a closest point per triangle within the query distance: one 10 km query around a
    5,120-triangle sphere 0.55 m away crashed it (a segmentation fault, no result.json).  The replay's queries
    grow from 1 m; the answer is PyBullet's own distance to the mesh at the closest step."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.3)
    sphere.export(tmp_path / "ico.stl")
    center = TIP + [0.3, -(0.3 + 0.55), 0.0]
    data = world({"type": "mesh", "path": "ico.stl", "position": center.tolist()}, time_limit=1.0)
    (tmp_path / "w.json").write_text(json.dumps(data))
    from navstack.world import load_world

    result = run_trial(load_world(tmp_path / "w.json"), planner="scripted", out_dir=tmp_path / "out")
    q = np.load(tmp_path / "out" / "trajectory.npz")["q"]
    w = load_world(tmp_path / "w.json")
    # the icosphere lies inside its 0.3 m circumscribed sphere, its faces less than 1 mm within it; PyBullet's
    # distance to its triangles reads up to 1 mm closer (measured 0.82 mm here)
    outer = closed_form(q, w, center, 0.3)
    assert outer - 1e-3 <= result.metrics["min_clearance"] <= outer + 1e-3
    assert result.metrics["min_clearance"] > HORIZON


def test_a_trial_that_fails_far_from_everything_reports_no_clearance(monkeypatch):
    """An ``error`` trial is not replayed: what it measured is only 'at least 0.5 m' (it reported 0.5)."""
    calls = []
    plan = _Simulation._plan

    def failing(self, *args):
        calls.append(1)
        if len(calls) > 3:
            raise RuntimeError("the planner failed")
        return plan(self, *args)

    monkeypatch.setattr(_Simulation, "_plan", failing)
    far_away = world_from_dict(world({"type": "sphere", "center": [-5.0, -5.0, -5.0], "radius": 0.1}))
    result = run_trial(far_away, planner="scripted")
    assert result.reason == "error" and result.metrics["min_clearance"] is None
    near = world_from_dict(world({"type": "sphere", "center": (TIP + [0.0, 0.0, 0.2]).tolist(), "radius": 0.1}))
    result = run_trial(near, planner="scripted")  # within the horizon: what it measured is exact
    assert result.reason == "error" and result.metrics["min_clearance"] == pytest.approx(0.2 - 0.1 - 0.025, abs=0.01)
