"""The field planner boxed in: it holds still and waits (EscapeConfig.patience) for the map to change.

A planner at the origin heading +x, its goal 1 m ahead, inside a sensed closed box of half side 0.2 m (points
1 cm apart, put into its own map): no way on from the command, nor from any point behind it.  It holds the
command and its map begins to forget (``SensedMap.begin_forgetting``); while nothing is forgotten it does not
search, and gives up after the patience; once rays see through the box's front face and the map drops it, it
searches again and goes on.  No simulator: the map is filled by hand.
"""

from __future__ import annotations

import numpy as np
import pytest
from _clouds import box_surface

import navstack.planner.field as field_module
from navstack.planner.escape import EscapeConfig
from navstack.planner.field import FieldPlanner, FieldPlannerConfig
from navstack.planner.map import MapConfig

DT = 1.0 / 30.0
X = np.array([1.0, 0.0, 0.0])


def _boxed_in(config: FieldPlannerConfig) -> FieldPlanner:
    planner = FieldPlanner(np.zeros(3), X, [(1.0, 0.0, 0.0)], [0.02], config)
    planner.map.add_points(box_surface([0.0, 0.0, 0.0], 0.2))
    return planner


def _step_until(planner: FieldPlanner, done, t_max: float = 60.0) -> float:
    """Step with no reading until ``done(planner)``; the planner's time then [s]."""
    while planner.time < t_max:
        planner.step(DT, planner.path.head, X, None, 0)
        if done(planner):
            return planner.time
    raise AssertionError(f"not done in {t_max} s (mode {planner.mode})")


def test_boxed_in_in_a_static_map_it_waits_without_searching_then_gives_up(monkeypatch):
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=5.0)))
    assert not planner.map.forgetting
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    assert planner.map.forgetting and planner.map.n_points > 0  # forgetting, nothing forgotten: no pass yet
    head = planner.path.head.copy()
    calls = []
    real = field_module.search
    monkeypatch.setattr(field_module, "search", lambda *a, **k: calls.append(1) or real(*a, **k))
    t_stall = _step_until(planner, lambda p: p.stalled)
    assert t_stall - t_wait == pytest.approx(5.0, abs=1.5 * DT)
    np.testing.assert_array_equal(planner.path.head, head)  # held still
    # no search while waiting (the map dropped nothing); at the stall, the arm check (no arm: none)
    assert calls == []
    assert planner.stall_reason == (
        "goals[0] (of 1): no way on from here (boxed in), nor from any point up to 1.5 m back along the path; no "
        "way either after waiting 5 s (EscapeConfig.patience) for the map to change")


def test_with_no_patience_it_gives_up_at_once():
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=0.0)))
    _step_until(planner, lambda p: p.stalled or p.mode == "wait")
    assert planner.stalled and planner.stall_reason.endswith("up to 1.5 m back along the path")
    assert not planner.map.forgetting


def test_a_map_told_never_to_forget_is_not_made_to_by_waiting():
    planner = _boxed_in(FieldPlannerConfig(map=MapConfig(detect_motion=False), escape=EscapeConfig(patience=2.0)))
    _step_until(planner, lambda p: p.stalled)
    assert not planner.map.forgetting


@pytest.mark.parametrize("map_config", [MapConfig(), MapConfig(forget_moved=True)], ids=["sensing", "forget_moved"])
def test_once_the_map_forgets_the_face_it_was_stopped_by_it_goes_on(map_config):
    cfg = FieldPlannerConfig(map=map_config, escape=EscapeConfig(patience=30.0))
    planner = _boxed_in(cfg)
    _step_until(planner, lambda p: p.mode == "wait")
    face = box_surface([0.0, 0.0, 0.0], 0.2)
    face = face[np.isclose(face[:, 0], 0.2)]
    n = len(face)
    rays = (face - 0.15 * X, np.tile(X, (n, 1)), np.full(n, 0.0), np.full(n, 0.4), np.zeros(n, bool), np.ones(n, bool))
    for _ in range(cfg.map.initial_evidence):  # a clean pass through each of its points takes one evidence
        planner.map.update(*rays)
    assert planner.mode == "wait" and not planner.stalled
    _step_until(planner, lambda p: p.mode != "wait", t_max=planner.time + 2.0)  # within a second of it
    assert not planner.stalled and planner.mode in ("plan", "explore")
    _step_until(planner, lambda p: p.path.head[0] > 0.25, t_max=planner.time + 20.0)  # out through the face
    assert not planner.stalled


@pytest.mark.parametrize("value", [-1.0, float("nan"), True, "5 s"])
def test_a_bad_patience_is_refused_naming_the_field(value):
    with pytest.raises(ValueError, match="EscapeConfig.patience"):
        EscapeConfig(patience=value)
