"""Moving obstacles in generated worlds: the checks take obstacles where their motions end
(navstack.generate.checks.settled), and the ``sliding-door`` family shuts its window at the start."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from navstack.generate import check_world, generate_world, reference_path
from navstack.generate.base import HEADING, TIP
from navstack.generate.checks import settled
from navstack.generate.geometry import obstacle_distance
from navstack.world import Box, Cylinder, LinearMotion, OscillateMotion, Sphere


def test_settled_moves_a_linear_mover_to_where_it_stops_and_leaves_the_others():
    v = np.array([0.1, -0.2, 0.05])
    moving = [Sphere(center=[1.0, 2.0, 3.0], radius=0.1, motion=LinearMotion(velocity=v, start=1.0, stop=3.5)),
              Cylinder(p0=[0, 0, 0], p1=[0, 0, 1], radius=0.02, motion=LinearMotion(velocity=v, stop=2.0)),
              Box(center=[0.5, 0.5, 0.5], half_extents=[0.1, 0.2, 0.3])]
    out = settled(tuple(moving))
    np.testing.assert_allclose(out[0].center, [1.25, 1.5, 3.125])  # 2.5 s of motion
    np.testing.assert_allclose(out[1].p0, 2.0 * v)
    np.testing.assert_allclose(out[1].p1, [0.2, -0.4, 1.1])
    assert out[0].motion is None and out[1].motion is None and out[0].radius == 0.1
    assert out[2] is moving[2]


@pytest.mark.parametrize("motion", [OscillateMotion(axis=[1, 0, 0], amplitude=0.1, period=4.0),
                                    LinearMotion(velocity=[0.1, 0, 0], start=2.0)], ids=["oscillate", "endless"])
def test_settled_refuses_a_motion_without_end_naming_the_obstacle(motion):
    obstacles = (Box(center=[0, 0, 0], half_extents=[0.1] * 3), Sphere(center=[1, 0, 0], radius=0.1, motion=motion))
    with pytest.raises(ValueError, match=r"obstacles\[1\] moves without end"):
        settled(obstacles)


@pytest.mark.parametrize("seed, difficulty", [(0, 0.0), (1, 0.5), (2, 1.0)])
def test_the_sliding_door_shuts_the_window_at_the_start_and_is_clear_of_the_way_once_open(seed, difficulty):
    world = generate_world("sliding-door", seed, difficulty)
    gen = world.extra["generator"]
    door = world.obstacles[-1]
    assert isinstance(door.motion, LinearMotion) and door.motion.stop > door.motion.start > 0.0
    path = reference_path(TIP, HEADING, np.array(gen["reference_via"]), 0.002).points
    shut = obstacle_distance((door,), path, 1.0)
    assert shut.min() < 0.0  # the way passes through the shut door
    open_ = obstacle_distance(settled((door,)), path, 1.0)
    assert open_.min() >= 0.025 + 0.015  # the serpentine's radius and the path margin
    report = check_world(world)
    assert report.ok, report.problems
    assert world.time_limit >= door.motion.stop + 60.0
    assert world.goals[0].position.tolist() == pytest.approx(gen["reference_via"][-1])


def _disc(centre: np.ndarray, normal: np.ndarray, radius: float, n: int = 72) -> np.ndarray:
    """``n`` points on the circle of ``radius`` [m] about ``centre`` across the unit ``normal``."""
    a = np.cross(normal, [0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.cross(normal, [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(normal, a)
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return centre + radius * (np.cos(t)[:, None] * a + np.sin(t)[:, None] * b)


@pytest.mark.parametrize("seed, difficulty", [(0, 0.0), (1, 0.5), (2, 1.0)])
def test_the_shut_door_overlaps_the_window_and_the_open_one_stops_past_it(seed, difficulty):
    """The door covers the window by OVERLAP (3 cm) round its edge when shut, and stops CLEAR (8 cm) past it:
    a circle 2 cm beyond the window's half width (in the door's plane) lies inside the shut door; one 7 cm
    beyond it clears the open door."""
    world = generate_world("sliding-door", seed, difficulty)
    gen = world.extra["generator"]
    half, axis = gen["window_half_width"], np.array(gen["axis"])
    door = world.obstacles[-1]
    assert obstacle_distance((door,), _disc(door.center, axis, half + 0.02), 1.0).max() < 0.0
    assert obstacle_distance(settled((door,)), _disc(door.center, axis, half + 0.07), 1.0).min() > 0.0


def test_the_start_is_checked_with_the_obstacles_at_t0():
    """A small sphere next to the tip that moves away in the first second: the world is refused at the start."""
    world = generate_world("sliding-door", 0, 0.0)
    blocker = Sphere(center=TIP - 0.05 * HEADING, radius=0.01,
                     motion=LinearMotion(velocity=[0.0, 0.0, 1.0], start=0.0, stop=1.0))
    report = check_world(dataclasses.replace(world, obstacles=(*world.obstacles, blocker)))
    assert not report.ok and any("robot at q0" in p for p in report.problems), report.problems
