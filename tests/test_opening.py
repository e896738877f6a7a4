"""Seen openings (navstack.planner.opening): a gap ringed by sensed points that a far ray went through."""

import numpy as np
import pytest

from navstack.generate.build import generate_world
from navstack.planner.opening import FarRays, OpeningConfig, far_rays, find_opening
from navstack.trial import run_trial


def _square_rim(centre, half, x, n=12):
    """Points on a square rim of half width ``half`` [m] in the plane x = ``x``, about (y, z) = ``centre``."""
    s = np.linspace(-half, half, n)
    ones = np.ones(n)
    sides = [np.column_stack([x * ones, s + centre[0], (centre[1] + o) * ones]) for o in (-half, half)]
    sides += [np.column_stack([x * ones, (centre[0] + o) * ones, s + centre[1]]) for o in (-half, half)]
    return np.vstack(sides)


def _rays(origin, directions, length=0.4):
    d = np.asarray(directions, dtype=float)
    d /= np.linalg.norm(d, axis=1)[:, None]
    return FarRays(np.tile(origin, (len(d), 1)), d, np.full(len(d), length))


def test_a_ray_through_a_square_rim_finds_its_centre():
    rim = _square_rim((0.02, -0.01), 0.075, 0.3)
    tip, goal = np.zeros(3), np.array([1.0, 0.3, 0.0])
    found = find_opening(rim, _rays(tip, [[1.0, 0.0, 0.0]]), tip, goal, OpeningConfig())
    assert found is not None
    assert found[0] == pytest.approx(0.3, abs=0.031)  # within the slab's half
    assert found[1:] == pytest.approx([0.02, -0.01], abs=0.003)


def test_no_opening_beside_a_single_wall_or_away_from_the_goal():
    rim = _square_rim((0.0, 0.0), 0.075, 0.3)
    wall = rim[rim[:, 2] > 0.07]  # one side only
    tip = np.zeros(3)
    rays = _rays(tip, [[1.0, 0.0, 0.0]])
    assert find_opening(wall, rays, tip, np.array([1.0, 0.0, 0.0]), OpeningConfig()) is None
    assert find_opening(rim, rays, tip, np.array([-1.0, 0.0, 0.0]), OpeningConfig()) is None  # goal behind
    assert find_opening(rim, None, tip, np.array([1.0, 0.0, 0.0]), OpeningConfig()) is None


def test_too_narrow_a_gap_is_no_opening():
    rim = _square_rim((0.0, 0.0), 0.03, 0.3)  # the nearest points within min_clearance of the ray
    tip = np.zeros(3)
    assert find_opening(rim, _rays(tip, [[1.0, 0.0, 0.0]]), tip, np.array([1.0, 0.0, 0.0]), OpeningConfig()) is None


def test_far_rays_are_the_informative_rays_that_went_far():
    """Only rays that told the map something (a hit, or free space to the maximum range) and went at least
    ``far_range``: a near hit, a far ray that was not informative (a dropout) and a ray just short are left out."""
    origins = np.zeros((5, 3))
    dirs = np.eye(3)[[0, 1, 2, 0, 1]]
    ranges = np.array([0.4, 0.3, 0.1, 0.4, 0.2499])
    informative = np.array([True, True, True, False, True])
    far = far_rays(origins, dirs, ranges, informative, 0.25)
    np.testing.assert_array_equal(far.lengths, [0.4, 0.3])
    np.testing.assert_array_equal(far.directions, dirs[:2])
    assert far_rays(origins, dirs, ranges, np.zeros(5, dtype=bool), 0.25) is None


@pytest.mark.slow
def test_the_tip_enters_a_duct_through_its_seen_mouth():
    """A duct-elbow world at difficulty 1 (seed 3838's world 01) where the plans went round the duct's unseen
    outside and the planner stalled after 59.5 s: with seen openings the tip goes in through the mouth and
    reaches the goal without contact."""
    world = generate_world("duct-elbow", 1017244650, 1.0)
    r = run_trial(world, planner="field", seed=2028959830)
    assert r.reason == "reached" and r.metrics["contacts"] == 0
    assert r.sim_time < 40.0


def test_an_opening_inside_the_tips_turning_circle_is_not_returned():
    """A rim 8 cm ahead of the tip and 6 cm to its side: with the heading along the ray it lies inside the circle
    of radius 0.25 m the tip could turn on (8^2 + 6^2 < 2 x 25 x 6), so no path of that curvature goes through it;
    with the heading pointing at it, or without a heading, it is returned."""
    tip, goal = np.zeros(3), np.array([1.0, 0.3, 0.0])
    rim = _square_rim((0.06, 0.0), 0.05, 0.08)
    d = np.array([0.08, 0.06, 0.0])
    rays = _rays(tip, [d], length=0.4)
    cfg = OpeningConfig(passed=0.05, near=0.02)
    assert find_opening(rim, rays, tip, goal, cfg) is not None
    assert find_opening(rim, rays, tip, goal, cfg, heading=np.array([1.0, 0.0, 0.0]), min_turn_radius=0.25) is None
    assert find_opening(rim, rays, tip, goal, cfg, heading=d, min_turn_radius=0.25) is not None
