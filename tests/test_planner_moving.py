"""The sensing planner with a moving obstacle (interfaces.md section 2b): it learns of it by its sensors
only, senses that it moved when its rays pass through where it was, and then forgets it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from navstack.jpl import jpl_serpentine
from navstack.planner.map import MapConfig
from navstack.trial import TrialConfig, run_trial
from navstack.world import world_from_dict


def _door_world() -> dict:
    """A wall with a square door (0.16 m) on the straight way to the goal; a sphere sits in the door and
    moves out of it sideways between t = 5 s and t = 8 s (0.3 m at 0.1 m/s), when the tip, 0.15 m from the
    wall, has seen it there for seconds."""
    robot = {"base": {"position": [0.0, 0.0, 0.3], "rpy": [0.0, -np.pi / 2, np.pi]}}  # the tip heads along +x
    base = {"format": "navstack-world/1", "name": "door", "robot": robot, "obstacles": [],
            "goals": [{"position": [0.0, 0.0, 0.0]}], "time_limit": 40.0}
    w = world_from_dict(base)
    F = jpl_serpentine().frames(w.robot.q0)
    T0 = w.robot.base.transform()
    tip = T0[:3, :3] @ F[21, :3, 3] + T0[:3, 3]
    assert np.allclose(T0[:3, :3] @ F[20, :3, 0], [1.0, 0.0, 0.0], atol=1e-6)
    x, y, z = tip
    wx, half, t, big = x + 0.45, 0.08, 0.02, 0.5
    walls = [
        {"type": "box", "center": [wx, y, z + half + big / 2], "half_extents": [t, big, big / 2]},
        {"type": "box", "center": [wx, y, z - half - big / 2], "half_extents": [t, big, big / 2]},
        {"type": "box", "center": [wx, y + half + big / 2, z], "half_extents": [t, big / 2, half]},
        {"type": "box", "center": [wx, y - half - big / 2, z], "half_extents": [t, big / 2, half]},
    ]
    sphere = {"type": "sphere", "center": [wx, y, z], "radius": 0.07,
              "motion": {"type": "linear", "velocity": [0.0, 0.1, 0.0], "start": 5.0, "stop": 8.0}}
    base["obstacles"] = [*walls, sphere]
    base["goals"] = [{"position": [x + 0.9, y, z]}]
    return base


DOOR_CONFIGS = {
    "forget_moved": MapConfig(forget_moved=True),  # forgetting from the start, as once for worlds with movers
    "sensed": MapConfig(),  # the default: forgetting once motion is sensed
    "never": MapConfig(detect_motion=False),  # the static map
}


@pytest.mark.slow
def test_a_door_that_clears_is_taken_once_the_rays_see_through_it():
    """With forgetting the door is taken; without it the sphere's surface stays in the door in the map.  A map
    that senses the motion itself, and then counts the passes before as forgetting would have, takes it as one
    told from the start that obstacles move does (it ended step for step the same until it began clearing with
    the wider ``sensed_clear_radius`` once motion is sensed: now 26.0 s against 25.9 s, seed 0)."""
    base = TrialConfig()
    results = {}
    for name, map_config in DOOR_CONFIGS.items():
        cfg = dataclasses.replace(base, field_planner=dataclasses.replace(base.field_planner, map=map_config))
        r = run_trial(world_from_dict(_door_world()), planner="field", config=cfg)
        print(f"\n{name}: {r.reason}, goals {r.goals_reached}, {r.sim_time:.1f} s, clearance "
              f"{r.metrics['min_clearance'] * 1e3:.1f} mm")
        assert r.metrics["contacts"] == 0
        assert r.success == (name != "never")
        results[name] = dataclasses.replace(r, wall_time=0.0)


def test_forgetting_needs_repeated_passes_and_the_planner_is_not_told_whether_obstacles_move():
    """Spec 2b: no one tells the planner whether the world holds moving obstacles; its map starts
    without forgetting and senses motion itself (``MapConfig.detect_motion``)."""
    from navstack.registry import PlannerContext
    from navstack.trial import make_field_planner

    cfg = MapConfig()
    assert not cfg.forget_moved and cfg.detect_motion and cfg.initial_evidence >= 2
    with pytest.raises(ValueError, match="initial_evidence"):
        dataclasses.replace(cfg, initial_evidence=0)
    assert not any("dynamic" in f.name or "mov" in f.name for f in dataclasses.fields(PlannerContext))
    assert not any("mov" in f.name for f in dataclasses.fields(TrialConfig))
    ctx = PlannerContext(start=np.zeros(3), heading=np.array([1.0, 0, 0]), goals=np.array([[1.0, 0, 0]]),
                         tolerances=np.array([0.02]), dt=1 / 30, config=TrialConfig())
    smap = make_field_planner(ctx).map
    assert not smap.forgetting and smap.motion_sensed_at is None


def test_the_planner_is_built_the_same_for_a_world_with_and_without_movers(monkeypatch):
    """The planner a trial builds for the door world is built from the same context as for the door world
    with its sphere fixed: whether obstacles move reaches the planner through its sensors only."""
    import navstack.trial as trial

    contexts = []
    build = trial.make_field_planner
    monkeypatch.setattr(trial, "make_field_planner", lambda ctx: contexts.append(ctx) or build(ctx))
    for moving in (True, False):
        w = _door_world()
        if not moving:
            del w["obstacles"][-1]["motion"]
        trial._Simulation(world_from_dict(w), "slither", "field", 0, TrialConfig()).close()
    a, b = (dataclasses.asdict(c) for c in contexts)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray) else a[k] == b[k]
                                        for k in a)
