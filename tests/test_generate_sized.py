"""``sized-slot-rack``: the slot rack for a serpentine of its own radius, drawn per world.

The family must write the drawn radius into the world, size the slots to it (the same room each side as the
default robot's slot rack), keep the straight line blocked for that body, and pass every check *with that
radius*: a thicker body than the world's fails them.  Its default-robot sibling ``slot-rack`` is unchanged
(the shift is exactly 0.0).  Distances in metres.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from navstack.generate import check_world, generate_world, obstacle_distance
from navstack.generate.base import default_robot
from navstack.generate.checks import CheckConfig
from navstack.generate.sized import RADII
from navstack.generate.slot_rack import family_slot_rack
from navstack.registry import FAMILIES
from navstack.world import world_from_dict

CASES = [(s, d) for s in range(6) for d in (0.0, 1.0)]


def test_registered_with_its_own_seed_id():
    entry = FAMILIES["sized-slot-rack"]
    assert entry.seed_id not in {e.seed_id for n, e in FAMILIES.items() if n != "sized-slot-rack"}


def test_radii_are_drawn_per_world_within_the_range():
    radii = [generate_world("sized-slot-rack", s, 0.5).robot.serpentine_radius for s in range(10)]
    assert all(RADII[0] <= r <= RADII[1] for r in radii)
    assert len(set(radii)) >= 8
    assert min(radii) < 0.02 and max(radii) > 0.035  # thin and thick bodies both drawn
    # the radius is drawn first from the sub-seed: one seed and sub-seed, one body, at every difficulty
    for seed in range(4):
        worlds = [generate_world("sized-slot-rack", seed, d) for d in (0.0, 0.5, 1.0)]
        by_attempt = {}
        for w in worlds:
            by_attempt.setdefault(w.extra["generator"]["attempt"], set()).add(w.robot.serpentine_radius)
        assert all(len(r) == 1 for r in by_attempt.values()), by_attempt
        assert worlds[1].robot.serpentine_radius == radii[seed]


@pytest.mark.parametrize(("seed", "difficulty"), CASES)
def test_slots_are_sized_to_the_body_and_the_line_is_blocked(seed, difficulty):
    w = generate_world("sized-slot-rack", seed, difficulty)
    gen = w.extra["generator"]
    r = w.robot.serpentine_radius
    assert gen["serpentine_radius"] == r and w.robot.arm_radius == 0.06
    assert f"radius {r:.4f} m" in w.description
    # the room each side of the body is the default robot's: slot 0.12-0.15 m for a 0.025 m body
    room = np.array(gen["slot_widths"]) - 2.0 * r
    assert np.all((room >= 0.07 - 1e-4) & (room <= 0.10 + 1e-4)), (r, gen["slot_widths"])
    # the straight segment entry -> final comes within the body's radius of the rack, slots alternate
    entry, final = w.goal_positions
    line = entry + np.linspace(0.0, 1.0, 800)[:, None] * (final - entry)
    assert obstacle_distance(w.obstacles, line).min() < r
    offsets = np.array(gen["slot_offsets"])
    assert np.all(np.sign(offsets[1:]) == -np.sign(offsets[:-1]))
    assert gen["goal_path_clearance"] <= -0.005


@pytest.mark.parametrize("seed", [0, 2, 3])
def test_the_checks_use_the_worlds_radius(seed):
    w = generate_world("sized-slot-rack", seed, 0.5)
    report = check_world(w)
    assert report.ok, report.problems
    # the same obstacles for a body 13 mm thicker: the 12 mm each link keeps is gone
    d = w.to_dict()
    d["robot"]["serpentine_radius"] = w.robot.serpentine_radius + 0.013
    thick = check_world(world_from_dict(d))
    assert not thick.ok
    assert thick.body_clearance == pytest.approx(report.body_clearance - 0.013, abs=1e-9)


@pytest.mark.parametrize(("seed", "difficulty", "widths", "slots", "offsets"), [
    (7, 0.5, [0.1359, 0.1374], [0.049, -0.0614], [0.0313, -0.0688]),
    (2, 1.0, [0.12, 0.1203, 0.12], [-0.0422, 0.0411, -0.0463], [-0.0267, 0.0281, -0.0304]),
])
def test_slot_rack_is_what_it_was_before_the_sizing(seed, difficulty, widths, slots, offsets):
    # numbers written by the slot rack before it could size its slots (session 49, at 20dc48d): the shift is
    # exactly 0.0 for the default body, so every default-robot world, and every sweep over them, is unchanged
    gen = generate_world("slot-rack", seed, difficulty).extra["generator"]
    assert (gen["slot_widths"], gen["slot_offsets"], gen["path_offsets"], gen["attempt"]) == (widths, slots, offsets, 1)


def test_a_thicker_body_gets_wider_slots_from_the_same_draw():
    robot = default_robot()
    assert robot.serpentine_radius == 0.025
    draw = [1, 4, 7, 1]
    a = family_slot_rack(np.random.default_rng(draw), 0.5, CheckConfig(), robot)
    c = family_slot_rack(np.random.default_rng(draw), 0.5, CheckConfig(), replace(robot, serpentine_radius=0.035))
    assert np.allclose(np.array(c.params["slot_widths"]) - a.params["slot_widths"], 0.02, atol=2e-4)
