"""The optional top-level ``retract`` key of world files (interfaces.md section 2a): parse, default, round trip."""

from __future__ import annotations

import json

import pytest

from navstack.world import RobotSpec, World, WorldError, load_world, save_world, world_from_dict

BASE = {"format": "navstack-world/1", "name": "w", "robot": {}, "obstacles": [],
        "goals": [{"position": [2.0, 0.0, 1.0]}]}


def test_default_false_and_not_written():
    w = world_from_dict(BASE)
    assert w.retract is False
    assert "retract" not in w.to_dict()  # worlds without the key keep their bytes


def test_true_round_trips_through_a_file(tmp_path):
    w = world_from_dict({**BASE, "retract": True})
    assert w.retract is True and w.to_dict()["retract"] is True
    save_world(w, tmp_path / "w.json")
    assert json.loads((tmp_path / "w.json").read_text())["retract"] is True
    back = load_world(tmp_path / "w.json")
    assert back == w and back.retract is True
    assert back != world_from_dict(BASE)
    assert world_from_dict({**BASE, "retract": False}) == world_from_dict(BASE)


@pytest.mark.parametrize("bad", [1, 0, "true", None, [True]])
def test_non_boolean_is_an_error_naming_the_key(bad):
    with pytest.raises(WorldError, match="retract"):
        world_from_dict({**BASE, "retract": bad})
    with pytest.raises(WorldError, match="retract"):
        World(name="w", robot=RobotSpec(), obstacles=(), goals=world_from_dict(BASE).goals, retract=bad)
