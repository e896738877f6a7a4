"""The broken world files outside users wrote (``worlds/hard5/bad``, ``worlds/hard10/bad``), each through
``navstack check-world`` as a user runs it: exit status 2 and one message naming the file and the JSON path of
the bad field, never a traceback and never ``ok``.  Three files there are not broken and are pinned as such: a
goal inside an obstacle (a warning, exit 0), a UTF-8 byte order mark before a valid file (RFC 8259 lets a reader
ignore it: accepted, the same world as the file without it) and the 50,000-goal file that ``make_bad.py`` writes
only on demand (3.3 MB, not kept; it is tested here written to a temporary folder)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from navstack.cli import main
from navstack.world import load_world

ROOT = Path(__file__).resolve().parents[1]
BAD = sorted((ROOT / "worlds" / "hard5" / "bad").glob("*.json")) + sorted(
    (ROOT / "worlds" / "hard10" / "bad").glob("*.json"))
NOT_BROKEN = {"goal_inside_obstacle.json", "bom.json"}
PATH = r"(\(top level\)|[a-z_]+(\[\d+\])?(\.[a-z_0-9]+(\[\d+\])*)*): "
"""A JSON path as the messages write it, after the file's name: ``goals[1].tolerance``, ``obstacles[4].motion.axis[1]``,
``(top level)``."""


def _check_world(path: Path, capsys) -> tuple[int, str]:
    code = main(["check-world", str(path)])
    out = capsys.readouterr()
    return code, out.out + out.err


def test_both_folders_of_broken_files_are_found():
    names = {p.name for p in BAD}
    assert len(BAD) >= 31 and {"truncated.json", "q0_nan.json", "inf_nested.json", "bom.json"} <= names


@pytest.mark.parametrize("path", [p for p in BAD if p.name not in NOT_BROKEN], ids=lambda p: p.name)
def test_a_broken_world_is_refused_naming_the_file_and_the_field(path, capsys):
    code, text = _check_world(path, capsys)
    assert code == 2, text
    assert "Traceback" not in text and "ok (" not in text
    assert re.search(re.escape(path.name) + ": " + PATH, text), text


def test_a_goal_inside_an_obstacle_is_a_warning_not_an_error(capsys):
    code, text = _check_world(ROOT / "worlds" / "hard5" / "bad" / "goal_inside_obstacle.json", capsys)
    assert code == 0 and "warning: goals[1]" in text and "inside obstacles[5]" in text


def test_a_byte_order_mark_is_ignored_and_the_world_is_the_same(tmp_path, capsys):
    bom = ROOT / "worlds" / "hard10" / "bad" / "bom.json"
    raw = bom.read_bytes()
    assert raw.startswith(b"\xef\xbb\xbf")
    plain = tmp_path / "bom.json"
    plain.write_bytes(raw[3:])
    assert load_world(bom) == load_world(plain)
    code, text = _check_world(bom, capsys)
    assert code == 0 and "ok (bom:" in text


def test_fifty_thousand_goals_are_refused(tmp_path, capsys):
    world = json.loads((ROOT / "worlds" / "hard10" / "osc_slot.json").read_text())
    goal = world["goals"][0]
    world["goals"] = [goal] * 50_000
    path = tmp_path / "goals_50k.json"
    path.write_text(json.dumps(world))
    code, text = _check_world(path, capsys)
    assert code == 2 and "goals: expected at most 1000 goals, got 50000" in text
