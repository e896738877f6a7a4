"""The field planner's escapes and look-backs (navstack.planner.recovery) on small constructed situations.

A planner whose path runs 1 m along +x (recorded by hand, goal 3 m on, the map empty) and whose searches are
replaced where a case needs it: boxed in (``NO_PATH``) near the tip, the real search farther back.  Cases the
wait and escape tests (test_planner_wait.py, test_planner_escape.py) leave open: where a new escape soon after
the last branch point starts looking, the replan at once when an escape's retreat ends, the deeper scan's escape
count, the speed a look-back's plan sets off with, and the stall reason after a stretch searched in vain.
"""

from __future__ import annotations

import numpy as np
import pytest

from navstack.planner.escape import EscapeConfig, Wait
from navstack.planner.field import FieldPlanner, FieldPlannerConfig
from navstack.planner.search import NO_PATH, PARTIAL, REACHED, Plan

DT = 1.0 / 30.0
X = np.array([1.0, 0.0, 0.0])


def _fake_plan(status: int, cost: float = 0.0) -> Plan:
    return Plan(points=np.zeros((1, 3)), tangents=np.array([X]), arc=np.zeros(1),
                goal_index=np.zeros(1, dtype=np.int64), status=status, cost=cost, expansions=1)


def _planner_on_a_run(config: FieldPlannerConfig | None = None) -> FieldPlanner:
    """A planner at the origin heading +x, goal 3 m on, whose path then runs 1 m along +x."""
    pl = FieldPlanner((0.0, 0.0, 0.0), X, [(3.0, 0.0, 0.0)], [0.02], config)
    for x in np.arange(0.001, 1.0 + 1e-9, 0.001):
        pl.path.record([x, 0.0, 0.0])
    return pl


@pytest.mark.parametrize(("last_back", "first_back"), [(0.1, 0.2), (0.29, 0.39), (0.31, 0.05), (0.5, 0.05)])
def test_an_escape_soon_after_the_last_branch_point_looks_only_beyond_it(last_back, first_back):
    """The last branch point ``last_back`` [m] behind the tip: within 0.3 m of it, the escape's first candidate
    is one ``EscapeConfig.step`` (0.1 m) behind it (no retreat cycles); farther, ``min_back`` (0.05 m) behind
    the tip, as for a first escape."""
    pl = _planner_on_a_run()
    end = pl.path.end_arc_length
    pl._last_branch = end - last_back
    backs: list[float] = []

    def plan_from(p, h, k, at=None, budget=None):
        backs.append(round(end - at, 6))
        return _fake_plan(NO_PATH)

    pl._plan_from = plan_from
    pl._start_escape()
    assert pl.retreat is None and pl.mode == "wait"  # boxed in everywhere
    assert backs[0] == pytest.approx(first_back) and backs == sorted(backs)
    assert all(b >= first_back - 1e-9 for b in backs)


@pytest.mark.parametrize(("speed", "accel"), [(0.2, 1.0), (4.0, 100.0)])
def test_when_an_escape_s_retreat_ends_it_replans_at_once(speed, accel):
    """Boxed in within 0.3 m of the tip, a way on farther back: the planner backs out to the branch point, then
    (the map may have grown while it backed out) plans again on the very next step, not a replan_period later,
    also when the retreat (fast here) ends within the planner's first replan_period (0.5 s)."""
    cfg = FieldPlannerConfig(escape=EscapeConfig(speed=speed, accel=accel))
    pl = _planner_on_a_run(cfg)
    end = pl.path.end_arc_length
    real = pl._plan_from

    def plan_from(p, h, k, at=None, budget=None):
        if at is not None and end - at < 0.3:
            return _fake_plan(NO_PATH)
        return real(p, h, k, at, budget)

    pl._plan_from = plan_from
    pl._start_escape()
    assert pl.mode == "retreat" and pl.retreats == 1
    branch = pl._pending[0]
    assert end - branch > 0.3
    while pl.retreat is not None:
        assert pl.time < 30.0
        pl.step(DT, pl.path.head, X, None, 0)
    assert pl.path.end_arc_length == pytest.approx(branch)
    assert speed < 1.0 or pl.time < pl.config.replan_period  # the fast retreat: over within the first period
    assert pl.follower.plan.status == REACHED and pl.follower.remaining > 0.0  # the branch point's plan
    replans = pl.replans
    pl.step(DT, pl.path.head, X, None, 0)
    assert pl.replans == replans + 1 and pl._planned_at == pl.time
    pl.step(DT, pl.path.head, X, None, 0)  # and only once, not on every step after
    assert pl.replans == replans + 1


@pytest.mark.parametrize("retreats", [1, 2, 5])
def test_a_deeper_escape_scan_is_made_at_every_escape_count_from_the_threshold_on(retreats):
    """``deep_escape_after_retreats`` = 1: an escape whose candidates' searches only spent their budget searches
    them again deeper once that many escapes for the goal have been made, or more (not only at exactly that
    many); a way found so is backed out to."""
    cfg = FieldPlannerConfig(deep_escape_after_retreats=1)
    pl = _planner_on_a_run(cfg)
    end = pl.path.end_arc_length
    deep: list[float] = []

    def plan_from(p, h, k, at=None, budget=None):
        if budget is None:
            return _fake_plan(PARTIAL, 2.0)  # every search spends its budget
        deep.append(round(end - at, 6))
        return _fake_plan(REACHED, 2.0)

    pl._plan_from = plan_from
    pl._goal_retreats[0] = retreats
    pl._start_escape(fallback=pl.follower.plan)
    assert deep and deep[0] == pytest.approx(0.05)
    assert pl.mode == "retreat" and pl._goal_retreats[0] == retreats + 1


def test_a_look_back_that_finds_the_way_open_sets_off_from_rest():
    """A look-back ended at the path's end (the tip stopped there) in an open map: the plan found from there is
    followed from rest, and the very next command already moves on along it (+x)."""
    pl = _planner_on_a_run()
    pl.map.begin_forgetting()
    pl._look_again(Wait.begin(pl.time, pl.map.forgotten))
    assert pl._wait is None and not pl.stalled and not pl.map.forgetting
    assert pl.follower.plan.status == REACHED and pl.follower.v == 0.0
    cmd = pl.step(DT, pl.path.head, X, None, 0)
    assert not cmd.stalled and cmd.mode == "plan" and float(cmd.velocity @ X) > 0.0


def test_a_stretch_searched_in_vain_without_spending_a_budget_still_says_boxed_in():
    """A first escape's candidates all boxed in (``NO_PATH``), the search from the tip partial: it explores on
    along that.  3 cm on, the search from the tip finds no way either (patience 0): it gives up, and as no
    search of either escape's candidates spent its budget, the reason says boxed in."""
    pl = _planner_on_a_run(FieldPlannerConfig(escape=EscapeConfig(patience=0.0)))
    searched: list[float] = []

    def plan_from(p, h, k, at=None, budget=None):
        searched.append(at)
        return _fake_plan(NO_PATH)

    pl._plan_from = plan_from
    pl._start_escape(fallback=_fake_plan(PARTIAL, 2.0))
    assert not pl.stalled and pl.retreat is None and len(searched) == 11  # 0.05-0.95 m back, and the start
    for x in np.arange(1.001, 1.03 + 1e-9, 0.001):
        pl.path.record([x, 0.0, 0.0])
    searched.clear()
    pl._start_escape()
    assert len(searched) == 1  # only the new candidate (the stretch searched in vain is skipped)
    assert pl.stalled and pl.stall_reason.endswith(
        "no way on from here (boxed in), nor from any point up to 1.5 m back along the path")


@pytest.mark.parametrize("max_retreats", [1, 2])
def test_no_more_escapes_for_a_goal_than_max_retreats(max_retreats):
    """A way on 0.3 m or more back each time: ``EscapeConfig.max_retreats`` escapes back along the path, then,
    with the way still not on from the tip, the planner gives up, saying so."""
    pl = _planner_on_a_run(FieldPlannerConfig(escape=EscapeConfig(max_retreats=max_retreats)))

    def plan_from(p, h, k, at=None, budget=None):
        return _fake_plan(REACHED if at is not None and pl.path.end_arc_length - at >= 0.3 else NO_PATH)

    pl._plan_from = plan_from
    for i in range(max_retreats):
        pl.retreat = pl._pending = None  # (each escape's retreat taken as done; the path left as it is)
        pl._start_escape()
        assert pl.mode == "retreat" and pl.retreats == i + 1 and not pl.stalled
    pl.retreat = pl._pending = None
    pl._start_escape()
    assert pl.stalled and pl.retreats == max_retreats
    assert pl.stall_reason == (f"goals[0] (of 1): no way on after {max_retreats} escapes back along the path "
                               "(EscapeConfig.max_retreats)")
