"""The sensing planner with a moving obstacle (interfaces.md section 2b): it learns of it by its sensors
only, and forgets where it was once its rays pass through that space again."""

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


@pytest.mark.slow
@pytest.mark.parametrize("forget", [True, False])
def test_a_door_that_clears_is_taken_once_the_rays_see_through_it(forget):
    """The trial's default turns forgetting on because the world declares a moving obstacle;
    ``forget_when_moving=False`` keeps the static map (the same planner config)."""
    cfg = TrialConfig(forget_when_moving=forget)
    r = run_trial(world_from_dict(_door_world()), planner="field", config=cfg)
    print(f"\nforget={forget}: {r.reason}, goals {r.goals_reached}, {r.sim_time:.1f} s, clearance "
          f"{r.metrics['min_clearance'] * 1e3:.1f} mm")
    assert r.metrics["contacts"] == 0
    if forget:
        assert r.success
    else:  # the sphere's surface stays in the door in the map: no way through is planned
        assert not r.success


def test_forgetting_is_for_moving_worlds_and_needs_repeated_passes():
    from navstack.registry import PlannerContext
    from navstack.trial import make_field_planner

    cfg = MapConfig()
    assert not cfg.forget_moved and cfg.initial_evidence >= 2
    with pytest.raises(ValueError, match="initial_evidence"):
        dataclasses.replace(cfg, initial_evidence=0)
    ctx = dict(start=np.zeros(3), heading=np.array([1.0, 0, 0]), goals=np.array([[1.0, 0, 0]]),
               tolerances=np.array([0.02]), dt=1 / 30, config=TrialConfig())
    assert make_field_planner(PlannerContext(**ctx, dynamic=True)).map.config.forget_moved
    assert not make_field_planner(PlannerContext(**ctx, dynamic=False)).map.config.forget_moved
    off = dataclasses.replace(TrialConfig(), forget_when_moving=False)
    assert not make_field_planner(PlannerContext(**{**ctx, "config": off}, dynamic=True)).map.config.forget_moved
