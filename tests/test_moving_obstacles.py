"""Moving obstacles (interfaces.md section 2b) in closed-loop trials: the simulator moves them, the planner
never hears of them, and a robot that starts touching one is refused."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from _worlds import TIP, world_data

from navstack.trial import check_start, run_trial
from navstack.world import WorldError, world_from_dict

# a sphere 0.4 m to the side of the point 0.2 m ahead of the tip, crossing the tip's path at 0.1 m/s
CROSSING = {"type": "sphere", "center": (TIP + [0.2, 0.4, 0.0]).tolist(), "radius": 0.05}


@pytest.fixture(scope="module")
def crossing_runs():
    """The scripted planner (no sensing) past the sphere, static and moving."""
    static = world_data(CROSSING, time_limit=20.0)
    moving = copy.deepcopy(static)
    moving["obstacles"][1]["motion"] = {"type": "linear", "velocity": [0.0, -0.1, 0.0]}
    return [run_trial(world_from_dict(d), planner="scripted") for d in (static, moving)]


def test_a_sphere_moving_across_the_path_ends_in_collision(crossing_runs):
    static, moving = crossing_runs
    assert static.reason == "reached" and static.metrics["contacts"] == 0
    assert static.metrics["min_clearance"] > 0.3  # left where it was, the sphere is never near the robot
    assert moving.reason == "collision" and not moving.success
    assert moving.metrics["contacts"] > 0 and moving.metrics["min_clearance"] < 0.0  # the clearance saw it move


def test_the_planner_never_hears_of_the_motion(tmp_path):
    """The scripted planner senses nothing: its commands are identical whether or not the sphere moves."""
    static = world_data(CROSSING, time_limit=8.0)
    moving = copy.deepcopy(static)
    moving["obstacles"][1]["motion"] = {"type": "linear", "velocity": [0.0, -0.1, 0.0]}
    tips = []
    for i, d in enumerate((static, moving)):
        run_trial(world_from_dict(d), planner="scripted", out_dir=tmp_path / str(i))
        tips.append(np.load(tmp_path / str(i) / "trajectory.npz")["tip_des"])
    np.testing.assert_array_equal(tips[0], tips[1])


def test_a_moving_obstacle_that_starts_in_contact_is_refused():
    # 0.1 m beside the tip, oscillating towards it: at t = 0 (phase pi/2) it sits on the tip
    osc = {"type": "sphere", "center": (TIP + [0.0, 0.1, 0.0]).tolist(), "radius": 0.03,
           "motion": {"type": "oscillate", "axis": [0, -1, 0], "amplitude": 0.1, "period": 10.0,
                      "phase": float(np.pi / 2)}}
    with pytest.raises(WorldError) as ei:
        check_start(world_from_dict(world_data(osc)))
    assert ei.value.json_path == "obstacles[1]" and "at t = 0" in str(ei.value)
    osc["motion"]["phase"] = 0.0  # at t = 0 it is 0.1 m away: accepted, it reaches the tip later
    check_start(world_from_dict(world_data(osc)))


def test_a_fast_mover_that_grazes_a_link_between_two_control_steps_is_a_collision():
    """A 1 mm sphere falling at 0.5 m/s (17 mm per control step) past a serpentine link, its path 0.7 mm
    inside the link's surface for 12 mm, between the looks at t = 1 s and 1.033 s: neither look sees it, so
    before the swept check this trial was a success."""
    R, r, dt = 0.025, 0.001, 1 / 30  # the paper robot's serpentine radius (m), the sphere's, the control period
    h = np.sqrt((R + r) ** 2 - 0.006 ** 2)  # its path's distance from the link's axis: a 12 mm chord
    t_cross = 1.0 + dt / 2
    graze = {"type": "sphere", "center": [TIP[0] - 0.3, TIP[1] + h, TIP[2] + 0.5 * t_cross], "radius": r,
             "motion": {"type": "linear", "velocity": [0.0, 0.0, -0.5], "stop": 2.0}}
    result = run_trial(world_from_dict(world_data(graze, time_limit=20.0)), planner="scripted")
    assert result.reason == "collision" and not result.success
    assert result.metrics["contacts"] == 1
    assert result.metrics["min_clearance"] == pytest.approx(h - R - r, abs=5e-5)  # -0.70 mm


def test_a_mover_at_the_speed_bound_flying_through_a_link_between_two_control_steps_is_a_collision():
    """A 1 cm sphere falling at 5 m/s (167 mm per control step) straight through a serpentine link: 83 mm above
    its axis at one look, 83 mm below at the next, clear both times; the swept check sees it pass through,
    as deep as the link's radius plus its own.  5.01 m/s is refused as input."""
    R, r, dt, v = 0.025, 0.01, 1 / 30, 5.0
    t_cross = 1.0 + dt / 2
    through = {"type": "sphere", "center": [TIP[0] - 0.3, TIP[1], TIP[2] + v * t_cross], "radius": r,
               "motion": {"type": "linear", "velocity": [0.0, 0.0, -v], "stop": 1.5}}
    result = run_trial(world_from_dict(world_data(through, time_limit=3.0)), planner="scripted")
    assert result.reason == "collision" and not result.success
    assert result.metrics["contacts"] == 1
    assert result.metrics["min_clearance"] == pytest.approx(-(R + r), abs=1e-3)
    through["motion"]["velocity"] = [0.0, 0.0, -5.01]
    with pytest.raises(WorldError, match=r"velocity\[2\]: expected a finite number in \[-5, 5\] m/s"):
        world_from_dict(world_data(through))
