"""The field planner boxed in: it holds still and waits (EscapeConfig.patience) for the map to change.

A planner at the origin heading +x, its goal 1 m ahead, inside a sensed closed box of half side 0.2 m (points
1 cm apart, put into its own map): no way on from the command, nor from any point behind it.  It holds the
command and its map begins to forget (``SensedMap.begin_forgetting``); while nothing is forgotten it does not
search, and gives up after the patience; once rays see through the box's front face and the map drops it, it
searches again and goes on.  No simulator: the map is filled by hand.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from _clouds import box_surface

import navstack.planner.field as field_module
import navstack.planner.recovery as recovery_module
from navstack.planner.escape import WAIT_ESCAPE_PERIODS, EscapeConfig, Wait
from navstack.planner.field import FieldPlanner, FieldPlannerConfig
from navstack.planner.map import MapConfig
from navstack.planner.search import PARTIAL, REACHED

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
    # the forgetting the wait began ends with it (a map told that obstacles move forgets on)
    assert planner.map.forgetting == map_config.forget_moved and not planner.map.forgetting_for_a_while
    _step_until(planner, lambda p: p.path.head[0] > 0.25, t_max=planner.time + 20.0)  # out through the face
    assert not planner.stalled


@pytest.mark.parametrize("value", [-1.0, float("nan"), True, "5 s"])
def test_a_bad_patience_is_refused_naming_the_field(value):
    with pytest.raises(ValueError, match="EscapeConfig.patience"):
        EscapeConfig(patience=value)


@pytest.mark.parametrize(("name", "value"), [("look_back", 0.0), ("look_back", float("inf")), ("look_back", True),
                                             ("max_look_backs", -1), ("max_look_backs", 1.5), ("max_look_backs", True)])
def test_a_bad_look_back_is_refused_naming_the_field(name, value):
    with pytest.raises(ValueError, match=f"EscapeConfig.{name} must be"):
        EscapeConfig(**{name: value})


def test_the_wait_searches_once_the_map_forgot_and_escapes_every_fourth_period():
    """Closed cases of :meth:`Wait.next_search` (nav_period 1 s, the last plan at ``planned_at``)."""
    assert WAIT_ESCAPE_PERIODS == 4
    w = Wait.begin(0.0, 5)
    assert w.next_search(0.5, True, 6, 0.0, 1.0) is None  # within a period of the last plan
    assert w.next_search(1.0, False, 6, 0.0, 1.0) is None  # the map does not forget
    assert w.next_search(1.0, True, 5, 0.0, 1.0) is None  # nothing forgotten since
    assert w.forgotten == 5
    assert w.next_search(1.0, True, 6, 0.0, 1.0) == "here" and w.forgotten == 6 and w.escaped == 0.0
    assert w.next_search(2.0, True, 6, 1.0, 1.0) is None
    assert w.next_search(3.999, True, 7, 1.0, 1.0) == "here"
    assert w.next_search(4.0, True, 8, 3.0, 1.0) == "escape" and w.escaped == 4.0 and w.forgotten == 8
    assert w.next_search(5.0, True, 9, 4.0, 1.0) == "here"



def test_an_escape_owed_is_made_when_due_though_the_map_has_stopped_forgetting():
    """Points forgotten in the wait's first seconds owe an escape: made once one is due (4 periods after the
    last), though nothing was forgotten since the last search; then none until more is forgotten."""
    w = Wait.begin(0.0, 5)
    assert w.next_search(1.0, True, 6, 0.0, 1.0) == "here"  # forgotten since the last search: a search from here
    assert w.next_search(2.0, True, 6, 1.0, 1.0) is None
    assert w.next_search(3.9, True, 6, 1.0, 1.0) is None  # an escape not due yet
    assert w.next_search(4.0, True, 6, 1.0, 1.0) == "escape" and w.escaped == 4.0 and w.escape_forgotten == 6
    assert w.next_search(8.0, True, 6, 4.0, 1.0) is None  # nothing forgotten since that escape
    assert w.next_search(8.0, False, 7, 4.0, 1.0) is None  # the map does not forget
    assert w.next_search(8.0, True, 7, 4.0, 1.0) == "escape" and w.forgotten == 7

def _rays_through(points: np.ndarray):
    """One reading of rays along +x, each straight through one of ``points`` (from 0.15 m before it, free to
    0.4 m): a clean pass through each."""
    n = len(points)
    return (points - 0.15 * X, np.tile(X, (n, 1)), np.zeros(n), np.full(n, 0.4), np.zeros(n, bool), np.ones(n, bool))


def _front_face() -> np.ndarray:
    face = box_surface([0.0, 0.0, 0.0], 0.2)
    return face[np.isclose(face[:, 0], 0.2)]


def _step_each(planner: FieldPlanner, done, t_max: float, before) -> float:
    while planner.time < t_max:
        before(planner)
        planner.step(DT, planner.path.head, X, None, 0)
        if done(planner):
            return planner.time
    raise AssertionError(f"not done in {t_max} s (mode {planner.mode})")


def test_while_the_map_forgets_elsewhere_it_searches_once_a_second_and_escapes_every_fourth(monkeypatch):
    """Points far off the way are forgotten a few at every step (the map forgetting, the box still shut):
    searches at most once per ``nav_period``, escapes (back along the path) every 4 s of them, and the patience
    counted from the wait's start, not from each escape's."""
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=9.0)))
    y, z = np.meshgrid(np.arange(-0.3, 0.3, 0.01), np.arange(-0.3, 0.3, 0.01))
    far = np.column_stack([np.full(y.size, 1.3), y.ravel(), z.ravel()])  # beyond the goal, off the way
    planner.map.add_points(far)
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    searched, escaped = [], []
    real_search, real_branch = field_module.search, recovery_module.find_branch_point
    monkeypatch.setattr(field_module, "search", lambda *a, **k: searched.append(planner.time) or real_search(*a, **k))
    monkeypatch.setattr(recovery_module, "find_branch_point",
                        lambda *a, **k: escaped.append(planner.time) or real_branch(*a, **k))
    batches = iter(range(0, len(far), 5))

    def forget_some(p: FieldPlanner) -> None:
        i = next(batches)
        for _ in range(2):
            p.map.update(*_rays_through(far[i:i + 5]))

    t_stall = _step_each(planner, lambda p: p.stalled, t_wait + 20.0, forget_some)
    assert t_stall - t_wait == pytest.approx(9.0, abs=1.5 * DT)
    times = sorted({round(t - t_wait, 3) for t in searched if t < t_stall - 1e-9})
    assert len(times) >= 5 and all(b - a >= 1.0 - 1e-6 for a, b in zip(times, times[1:], strict=False))
    esc = sorted({round(t - t_wait, 3) for t in escaped})
    assert len(esc) == 2 and 4.0 <= esc[0] < 4.5 and esc[1] - esc[0] >= 4.0



def test_points_forgotten_early_in_the_wait_bring_an_escape_when_one_is_due(monkeypatch):
    """Points off the way forgotten in the first second of the wait only (a door that opened, seen from where the
    tip waits): the escape back along the path, where a way through may begin, is still made, once due (4 s),
    and only once; then the wait goes on to the patience."""
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=9.0)))
    y, z = np.meshgrid(np.arange(-0.3, 0.3, 0.01), np.arange(-0.3, 0.3, 0.01))
    far = np.column_stack([np.full(y.size, 1.3), y.ravel(), z.ravel()])
    planner.map.add_points(far)
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    escaped = []
    real_branch = recovery_module.find_branch_point
    monkeypatch.setattr(recovery_module, "find_branch_point",
                        lambda *a, **k: escaped.append(planner.time) or real_branch(*a, **k))
    batches = iter(range(0, 150, 5))

    def forget_early(p: FieldPlanner) -> None:
        i = next(batches, None)
        if i is not None:
            for _ in range(2):
                p.map.update(*_rays_through(far[i:i + 5]))

    t_stall = _step_each(planner, lambda p: p.stalled, t_wait + 20.0, forget_early)
    assert t_stall - t_wait == pytest.approx(9.0, abs=1.5 * DT)
    esc = sorted({round(t - t_wait, 3) for t in escaped})
    assert len(esc) == 1 and 4.0 <= esc[0] < 4.5


def _boxed_in_after_a_run(config: FieldPlannerConfig) -> FieldPlanner:
    """A planner that has come 0.25 m along +x (its goal 2 m on) and is then boxed in round where it is."""
    planner = FieldPlanner(np.zeros(3), X, [(2.0, 0.0, 0.0)], [0.02], config)
    _step_until(planner, lambda p: p.path.head[0] >= 0.25, t_max=20.0)
    planner.map.add_points(box_surface(planner.path.head, 0.2))
    return planner


@pytest.mark.parametrize("forget", [True, False], ids=["points-forgotten", "static"])
def test_once_the_map_has_forgotten_and_gone_quiet_it_looks_back_twice_a_goal(forget):
    """Points off the way forgotten in the wait's first second, then none: 4 s later the tip backs 0.15 m along
    its own path (the map still forgetting) and searches again; the map forgot nothing meanwhile, so it backs
    0.15 m more at once; at most twice for the goal; the patience counted from the wait's start.  With nothing
    forgotten (a static map), it never backs out."""
    planner = _boxed_in_after_a_run(FieldPlannerConfig(escape=EscapeConfig(patience=14.0)))
    y, z = np.meshgrid(np.arange(-0.3, 0.3, 0.01), np.arange(-0.3, 0.3, 0.01))
    far = np.column_stack([np.full(y.size, 2.3), y.ravel(), z.ravel()])  # beyond the goal, off the way
    planner.map.add_points(far)
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    end, start = planner.path.end_arc_length, planner.path.start_arc_length
    assert end - start > 0.2
    batches = iter(range(0, 150 if forget else 0, 5))
    looks: list[tuple[float, float, int]] = []  # (time since the wait began [s], path end [m], look-backs) as each
    # look-back begins

    def forget_early(p: FieldPlanner) -> None:
        i = next(batches, None)
        if i is not None:
            for _ in range(2):
                p.map.update(*_rays_through(far[i:i + 5]))
        if p.mode == "retreat" and (not looks or looks[-1][2] != p.look_backs):
            looks.append((p.time - t_wait, p.path.end_arc_length, p.look_backs))

    t_stall = _step_each(planner, lambda p: p.stalled, t_wait + 30.0, forget_early)
    assert t_stall - t_wait == pytest.approx(14.0, abs=1.5 * DT)
    if not forget:
        assert planner.look_backs == 0 and looks == [] and planner.path.end_arc_length == end
        return
    assert planner.look_backs == 2 and [n for *_, n in looks] == [1, 2]
    assert 5.0 <= looks[0][0] < 5.5  # 4 s after the last point was forgotten (about 1 s into the wait)
    assert looks[1][1] == pytest.approx(end - 0.15, abs=1e-6)  # the second from 0.15 m back,
    assert looks[1][0] - looks[0][0] < 4.5  # as soon as the first is done (~3.5 s): nothing forgotten while backing
    assert planner.path.end_arc_length == pytest.approx(max(end - 0.3, start), abs=1e-6)  # not behind the tip's start
    assert planner.map.forgetting  # still waiting for the map to change


def test_a_face_forgotten_when_an_escape_is_due_lets_it_go_on():
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=30.0)))
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    _step_until(planner, lambda p: p.time - t_wait > 4.5, t_max=t_wait + 5.0)
    for _ in range(2):
        planner.map.update(*_rays_through(_front_face()))
    _step_until(planner, lambda p: p.mode != "wait", t_max=planner.time + 1.5)
    assert planner.mode in ("plan", "explore") and not planner.stalled


def test_what_goes_as_forgetting_begins_counts_as_forgotten():
    """Passes through the front face before the wait (motion never sensed: latent evidence 0, the points kept)
    are counted when the wait turns forgetting on: the face goes at once and the planner goes on."""
    cfg = FieldPlannerConfig(map=MapConfig(motion_contradictions=10**6), escape=EscapeConfig(patience=30.0))
    planner = _boxed_in(cfg)
    for _ in range(2):
        planner.map.update(*_rays_through(_front_face()))
    n = planner.map.n_points
    assert not planner.map.forgetting
    _step_until(planner, lambda p: p.mode == "wait")
    assert planner.map.n_points < n
    _step_until(planner, lambda p: p.mode != "wait", t_max=planner.time + 2.0)
    assert not planner.stalled


def test_begin_forgetting_once_forgetting_changes_nothing():
    smap = _boxed_in(FieldPlannerConfig()).map
    smap.begin_forgetting()
    at = smap.motion_sensed_at
    smap.update(*_rays_through(_front_face()[:3]))
    assert smap.begin_forgetting() == 0 and smap.motion_sensed_at == at


def test_a_stall_whose_searches_spent_their_budget_does_not_say_boxed_in(monkeypatch):
    """The searches back along the path ran out of expansions (``PARTIAL``; here made so) rather than proving
    there is no way (``NO_PATH``): the stall reason names the budget instead of "boxed in" (a held-out vessel
    world's stall said "boxed in" where a search of 100,000 expansions found a way)."""
    planner = _boxed_in_after_a_run(FieldPlannerConfig(escape=EscapeConfig(patience=0.0)))
    real = planner._plan_from

    def plan_from(p, h, k, at=None, budget=None):
        plan = real(p, h, k, at, budget)
        return replace(plan, status=PARTIAL) if at is not None and plan.status != REACHED else plan

    monkeypatch.setattr(planner, "_plan_from", plan_from)
    _step_until(planner, lambda p: p.stalled or p.mode == "wait")
    assert planner.stalled
    assert "boxed in" not in planner.stall_reason
    assert planner.stall_reason.endswith(
        "no way on found from here, nor from any point up to 1.5 m back along the path, within a search's budget "
        f"(SearchConfig.max_expansions = {planner.config.search.max_expansions}; a way may exist that is longer or "
        "more winding)")


def test_a_patience_under_a_second_is_still_waited_out():
    """Any patience above zero is a wait (0.5 s here): boxed in, it waits, forgetting, and gives up after it."""
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=0.5)))
    t_wait = _step_until(planner, lambda p: p.stalled or p.mode == "wait")
    assert planner.mode == "wait" and not planner.stalled and planner.map.forgetting
    t_stall = _step_until(planner, lambda p: p.stalled)
    assert t_stall - t_wait == pytest.approx(0.5, abs=1.5 * DT)


def test_a_way_on_found_by_the_wait_s_escape_ends_the_forgetting():
    """The front face forgotten when an escape is due: the escape's search finds the way on from where the tip
    waits, and the map, static again, stops forgetting (as when a search from here finds it)."""
    planner = _boxed_in(FieldPlannerConfig(escape=EscapeConfig(patience=30.0)))
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    _step_until(planner, lambda p: p.time - t_wait > 4.5, t_max=t_wait + 5.0)
    assert planner.map.forgetting
    for _ in range(2):
        planner.map.update(*_rays_through(_front_face()))
    _step_until(planner, lambda p: p.mode != "wait", t_max=planner.time + 1.5)
    assert not planner.stalled and planner.retreats == 0  # on from here, not from back along the path
    assert not planner.map.forgetting and not planner.map.forgetting_for_a_while


@pytest.mark.parametrize("spent", [False, True], ids=["reached", "budget-spent"])
def test_the_mode_after_a_wait_says_whether_the_plan_reaches_the_goal(spent, monkeypatch):
    """The face the tip was stopped by forgotten, its goal 0.6 m ahead (0.4 m beyond the face, in the open):
    the plan through it reaches the goal, and the step on which the wait ends already says "plan"; if that
    search spent its budget (``PARTIAL``, here made so), the tip explores on along it: "explore"."""
    planner = FieldPlanner(np.zeros(3), X, [(0.6, 0.0, 0.0)], [0.02],
                           FieldPlannerConfig(escape=EscapeConfig(patience=30.0)))
    planner.map.add_points(box_surface([0.0, 0.0, 0.0], 0.2))
    _step_until(planner, lambda p: p.mode == "wait")
    if spent:
        real = planner._plan_from

        def plan_from(p, h, k, at=None, budget=None):
            plan = real(p, h, k, at, budget)
            return replace(plan, status=PARTIAL) if plan.status == REACHED else plan

        monkeypatch.setattr(planner, "_plan_from", plan_from)
    for _ in range(planner.config.map.initial_evidence):
        planner.map.update(*_rays_through(_front_face()))
    cmds = []
    while planner.mode == "wait":
        assert planner.time < 40.0
        cmds.append(planner.step(DT, planner.path.head, X, None, 0))
    assert not planner.stalled and planner.retreat is None
    assert planner.follower.plan.status == (PARTIAL if spent else REACHED)
    mode = "explore" if spent else "plan"
    assert planner.mode == mode and cmds[-1].mode == mode


def _far_wall(x: float) -> np.ndarray:
    """Points across the way at ``x`` beyond the goal (off the way): the map forgets them as rays pass."""
    y, z = np.meshgrid(np.arange(-0.3, 0.3, 0.01), np.arange(-0.3, 0.3, 0.01))
    return np.column_stack([np.full(y.size, x), y.ravel(), z.ravel()])


def _look_backs(planner: FieldPlanner, far: np.ndarray, t_max: float) -> tuple[float, float, list]:
    """Wait boxed in, the map forgetting ``far`` in the wait's first second, until the planner gives up: (the
    wait's start, the stall's [s], [(time into the wait [s], path end [m]) as each look-back begins])."""
    planner.map.add_points(far)
    t_wait = _step_until(planner, lambda p: p.mode == "wait")
    batches = iter(range(0, 150, 5))
    looks: list[tuple[float, float]] = []

    def forget_early(p: FieldPlanner) -> None:
        i = next(batches, None)
        if i is not None:
            for _ in range(2):
                p.map.update(*_rays_through(far[i:i + 5]))
        if p.mode == "retreat" and len(looks) < p.look_backs:
            looks.append((p.time - t_wait, p.path.end_arc_length))

    t_stall = _step_each(planner, lambda p: p.stalled, t_wait + t_max, forget_early)
    return t_wait, t_stall, looks


def test_no_look_back_begins_once_the_patience_is_out():
    """Patience 7 s: the first look-back begins about 5 s into the wait and ends after the patience is out
    (backing 0.15 m takes some 3.5 s); the planner then gives up rather than look back again."""
    planner = _boxed_in_after_a_run(FieldPlannerConfig(escape=EscapeConfig(patience=7.0)))
    t_wait, t_stall, looks = _look_backs(planner, _far_wall(2.3), 20.0)
    assert planner.look_backs == 1 and len(looks) == 1 and looks[0][0] < 7.0
    assert t_stall - t_wait >= 7.0 - 1e-9 and planner.stalled


def test_with_a_short_backbone_the_look_backs_stop_at_the_tip_s_start():
    """Links of 0.1 m (the tip's start 0.9 m of arc from the path's end behind it, as the path memory measures
    it): 0.25 m on, the first look-back backs 0.15 m, the second the 0.1 m left, to the tip's start."""
    cfg = FieldPlannerConfig(search=replace(FieldPlannerConfig().search, link_length=0.1),
                             escape=EscapeConfig(patience=14.0))
    planner = _boxed_in_after_a_run(cfg)
    end, start = planner.path.end_arc_length, planner.path.start_arc_length
    assert start < 1.0 and end - start > 0.2
    _, _, looks = _look_backs(planner, _far_wall(2.3), 30.0)
    assert planner.look_backs == 2 and looks[1][1] == pytest.approx(end - 0.15, abs=1e-6)
    assert planner.path.end_arc_length == pytest.approx(start, abs=1e-6)


@pytest.mark.parametrize("max_look_backs", [1, 2])
def test_no_more_look_backs_for_a_goal_than_max_look_backs_with_path_left(max_look_backs):
    """Look-backs of 0.05 m, 0.25 m on (path for five of them): it looks back ``EscapeConfig.max_look_backs``
    times, each 0.05 m, then waits out the patience where the last one ended."""
    cfg = FieldPlannerConfig(escape=EscapeConfig(patience=14.0, look_back=0.05, max_look_backs=max_look_backs))
    planner = _boxed_in_after_a_run(cfg)
    end = planner.path.end_arc_length
    assert end - planner.path.start_arc_length > 0.2
    t_wait, t_stall, looks = _look_backs(planner, _far_wall(2.3), 30.0)
    assert t_stall - t_wait == pytest.approx(14.0, abs=1.5 * DT)
    assert planner.look_backs == max_look_backs and len(looks) == max_look_backs
    assert planner.path.end_arc_length == pytest.approx(end - 0.05 * max_look_backs, abs=1e-6)
