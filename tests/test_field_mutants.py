"""The field planner's orchestration (navstack.planner.field) on small constructed situations.

A planner whose path runs 1 m along +x (recorded by hand, goal 3 m on, the map empty), as in
test_recovery_mutants.py.  Cases the scenario tests (test_planner_field.py) leave open: when the cached
navigation function is kept and when it is redone, and the periodic replan of a plan that reaches no goal
in a map that does not change.
"""

from __future__ import annotations

import numpy as np
import pytest

from navstack.planner.field import FieldPlanner, FieldPlannerConfig
from navstack.planner.search import NO_PATH, PARTIAL, REACHED, Plan
from navstack.planner.steering import PlanFollower

DT = 1.0 / 30.0
X = np.array([1.0, 0.0, 0.0])


def _planner_on_a_run(config: FieldPlannerConfig | None = None) -> FieldPlanner:
    """A planner at the origin heading +x, goal 3 m on, whose path then runs 1 m along +x."""
    pl = FieldPlanner((0.0, 0.0, 0.0), X, [(3.0, 0.0, 0.0)], [0.02], config)
    for x in np.arange(0.001, 1.0 + 1e-9, 0.001):
        pl.path.record([x, 0.0, 0.0])
    return pl


def _fake_plan(status: int, cost: float = 0.0) -> Plan:
    return Plan(points=np.zeros((1, 3)), tangents=np.array([X]), arc=np.zeros(1),
                goal_index=np.zeros(1, dtype=np.int64), status=status, cost=cost, expansions=1)


def _straight_plan(start: np.ndarray, length: float, status: int) -> Plan:
    """A hand-made plan straight along +x from ``start`` for ``length`` [m], samples every millimetre."""
    arc = np.linspace(0.0, length, int(round(length / 1e-3)) + 1)
    return Plan(points=start + arc[:, None] * X, tangents=np.tile(X, (len(arc), 1)), arc=arc,
                goal_index=np.zeros(len(arc), dtype=np.int64), status=status, cost=float(length), expansions=1)


def test_the_navigation_function_is_kept_while_the_map_is_unchanged_and_redone_once_it_has_changed():
    """``nav_period`` (1 s): the navigation function to the goal is reused, however old, while the map has not
    changed; once it has, it is computed again, but not before ``nav_period`` since it was computed."""
    pl = _planner_on_a_run()
    period = pl.config.nav_period
    p = pl.path.head
    nav = pl._navigation(p, 0, False)
    assert nav is not None and np.isfinite(nav.lookup(p))
    pl.time += 2.0 * period
    assert pl._navigation(p, 0, False) is nav  # the map unchanged: nothing to redo
    version = pl.map.version
    pl.map.add_points([[2.0, 0.3, 0.0]])
    assert pl.map.version > version
    nav2 = pl._navigation(p, 0, False)
    assert nav2 is not nav  # changed, and computed 2 periods ago: redone
    pl.map.add_points([[2.0, -0.3, 0.0]])
    pl.time += 0.5 * period
    assert pl._navigation(p, 0, False) is nav2  # changed again, but within nav_period of the last one
    pl.time += 0.6 * period
    assert pl._navigation(p, 0, False) is not nav2


def test_a_plan_that_reaches_no_goal_is_replanned_every_replan_period_in_an_unchanged_map():
    """Following a ``PARTIAL`` plan (exploring), the planner searches again once ``replan_period`` (0.5 s) has
    passed since the last search, on any step from then on, even though the map has not changed; a ``REACHED``
    plan in the same unchanged map is not searched again."""
    pl = _planner_on_a_run()
    period = pl.config.replan_period
    for status, expected in ((PARTIAL, True), (REACHED, False)):
        pl.follower = PlanFollower(_straight_plan(pl.path.head, 0.5, status), pl.config.steering)
        pl._planned_at = pl.time = 0.0
        pl._planned_version = pl.map.version
        assert len(pl.map.new_points) == 0
        due = []
        times = 0.01 + DT * np.arange(30)  # 1 s, in steps of DT (none within 10 ms of replan_period)
        for t in times:
            pl.time = float(t)
            due.append(pl._needs_replan())
        # due from replan_period on (on every step until it replans), never before
        assert due == [expected and bool(t >= period) for t in times]


def test_a_plan_to_where_the_tour_turns_back_is_replanned_at_its_end_not_before():
    """A ``REACHED`` plan that ends with goals still ahead (a plan up to where the tour turns back): the planner
    searches again as soon as the command is at its end, in a map that has not changed; 0.3 m before the end,
    or at the end once every goal is passed, it does not."""
    pl = _planner_on_a_run()
    plan = _straight_plan(pl.path.head, 0.5, REACHED)
    pl.follower = PlanFollower(plan, pl.config.steering)
    pl._planned_at = pl.time = 0.0
    pl._planned_version = pl.map.version
    for s, command_goal, expected in ((0.2, 0, False), (plan.length, 0, True), (plan.length, 1, False)):
        pl.follower.s = s
        pl.command_goal = command_goal
        assert pl._needs_replan() is expected


def test_the_first_replan_of_a_fresh_planner_comes_one_replan_period_after_its_start():
    """The plan made at construction counts as made at time 0: stepping in an open map without readings (the
    command followed exactly), the first replan comes on the first step at or after ``replan_period``."""
    pl = FieldPlanner((0.0, 0.0, 0.0), X, [(1.0, 0.0, 0.0)], [0.02])
    assert pl.follower.plan.status == REACHED and pl.replans == 0
    dt = 0.04  # (no step within 10 ms of 0.5 s)
    tip = pl.start
    while pl.replans == 0:
        assert pl.time < 2.0
        tip = pl.step(dt, tip, X, None, 0).position
    assert pl.config.replan_period <= pl.time < pl.config.replan_period + dt


def test_the_cost_floor_is_the_tour_s_length_less_the_goal_tolerances():
    """The lower bound of a plan's cost: each leg between goals (from the tip to the first) less the tolerances
    at its ends (a plan passes within them): from the origin to (1, 0, 0) within 2 cm, then to (1, 1, 0)
    within 3 cm: (1 - 0.02) + (1 - 0.02 - 0.03); goals already within the search's reach are left out."""
    pl = FieldPlanner((0.0, 0.0, 0.0), X, [(1.0, 0.0, 0.0), (1.0, 1.0, 0.0)], [0.02, 0.03])
    assert pl._cost_floor(np.zeros(3), 0) == pytest.approx(0.98 + 0.95)
    assert pl._cost_floor(np.array([0.5, 0.0, 0.0]), 0) == pytest.approx(0.48 + 0.95)
    assert pl._cost_floor(np.zeros(3), 1) == pytest.approx(np.sqrt(2.0) - 0.03)
    assert pl._cost_floor(np.array([1.0, 0.001, 0.0]), 0) == pytest.approx(0.999 - 0.03)  # goal 0 passed
    assert pl._cost_floor(np.array([1.0, 0.999, 0.0]), 1) == 0.0  # every goal passed
    assert pl._cost_floor(np.array([1.0, 0.5, 0.0]), 0) == pytest.approx(0.5 - 0.02 + 0.95)


@pytest.mark.parametrize(("retreats", "deeper"), [(0, False), (1, True), (2, True)])
def test_by_default_a_deeper_escape_scan_waits_for_the_first_escape(retreats, deeper):
    """The default ``deep_escape_after_retreats`` (1, "not before the first" escape): an escape whose candidates'
    searches all spent their budget searches them again deeper only once an escape for the goal has been made."""
    pl = _planner_on_a_run()
    deep: list[float] = []

    def plan_from(p, h, k, at=None, budget=None):
        if budget is None:
            return _fake_plan(PARTIAL, 2.0)  # every search spends its budget
        deep.append(at)
        return _fake_plan(NO_PATH)

    pl._plan_from = plan_from
    pl._goal_retreats[0] = retreats
    pl._start_escape(fallback=pl.follower.plan)
    assert bool(deep) is deeper
