"""Backing out along the tip's own path (navstack.planner.escape) and the retreat that follows it.

``find_branch_point`` is tested with fake searches whose answer is a known function of the state (the
expected branch point is then known in closed form), and with the real search in a point-cloud pocket;
the reverse commands of :class:`navstack.retreat.Retreat` are checked against the recorded path.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from navstack.path import PathMemory
from navstack.planner.escape import EscapeConfig, Scanned, find_branch_point
from navstack.planner.map import SensedMap
from navstack.planner.potential import Repulsion
from navstack.planner.search import NO_PATH, REACHED, Plan, SearchConfig, search
from navstack.retreat import Retreat

CFG = EscapeConfig(step=0.05, min_back=0.05, max_back=1.5)  # pinned: the expected candidates are worked out below
X = np.array([1.0, 0.0, 0.0])
LINK = 0.2


def _memory() -> PathMemory:
    """The planner's record: a straight backbone behind the start (the origin, heading +x), as FieldPlanner
    builds it."""
    return PathMemory(-np.outer(np.arange(7), X) * LINK, link_length=LINK, spacing=1e-3)


def _straight_path(length: float) -> PathMemory:
    path = _memory()
    for x in np.arange(0.001, length + 1e-9, 0.001):
        path.record([x, 0.0, 0.0])
    return path


def _curved_path() -> PathMemory:
    """0.3 m straight along x, then a left arc of radius 0.3 m through 90 degrees (arc 0.471 m)."""
    path = _memory()
    for x in np.arange(0.001, 0.3 + 1e-9, 0.001):
        path.record([x, 0.0, 0.0])
    for phi in np.arange(0.001 / 0.3, 0.5 * math.pi + 1e-9, 0.001 / 0.3):
        path.record([0.3 + 0.3 * math.sin(phi), 0.3 * (1.0 - math.cos(phi)), 0.0])
    return path


def _fake_plan(status: int, cost: float = 0.0) -> Plan:
    return Plan(points=np.zeros((1, 3)), tangents=np.array([X]), arc=np.zeros(1),
                goal_index=np.zeros(1, dtype=np.int64), status=status, cost=cost, expansions=1)


class FakeSearch:
    """``plan_from`` that reaches the goals exactly from the states where ``ok(position, heading)``, with the
    plan cost ``cost(position)`` [m] (0 if not given); records calls (and checks that the arc length it is given
    is that of the state)."""

    def __init__(self, ok, path: PathMemory | None = None, cost=None) -> None:
        self.ok = ok
        self.cost = cost
        self.path = path
        self.calls: list[tuple[np.ndarray, np.ndarray]] = []
        self.arcs: list[float] = []

    def __call__(self, p, t, s) -> Plan:
        self.calls.append((np.array(p), np.array(t)))
        self.arcs.append(float(s))
        if self.path is not None:
            q, u = self.path.point_at(s)
            np.testing.assert_allclose(p, q, atol=1e-12)
            np.testing.assert_allclose(t, u, atol=1e-12)
        return _fake_plan(REACHED if self.ok(p, t) else NO_PATH, 0.0 if self.cost is None else self.cost(p))


# ---------------------------------------------------------------------------- with a fake search
def test_the_nearest_candidate_with_a_way_on_is_the_branch_point():
    path = _straight_path(0.8)
    s0, end = path.start_arc_length, path.end_arc_length
    assert end - s0 == pytest.approx(0.8)
    fake = FakeSearch(lambda p, t: p[0] <= 0.32, path)  # a way on only from x <= 0.32
    s, plan = find_branch_point(path, fake, CFG)
    assert plan.status == REACHED
    # candidates every 5 cm from 5 cm behind the end: x = 0.75, 0.70, ...; the first at or below 0.32 is 0.30
    assert s - s0 == pytest.approx(0.30, abs=1e-9)
    xs = np.array([p[0] for p, _ in fake.calls])
    np.testing.assert_allclose(xs, 0.8 - CFG.min_back - CFG.step * np.arange(len(xs)), atol=1e-9)
    assert xs[-1] == pytest.approx(0.30)
    np.testing.assert_allclose(np.array(fake.arcs) - s0, xs, atol=1e-9)  # the arc length of each state


def test_the_branch_point_has_the_least_retreat_plus_plan_cost():
    """A way on from every candidate, but from x <= 0.32 (a retreat of 0.5 m or more) one that costs 0.2 m
    against 1.0 m nearer the end: the totals are 0.05 + 1.0 ... 0.45 + 1.0, then 0.5 + 0.2 = 0.7 at x = 0.30,
    the least; the scan stops before the first candidate whose retreat alone is 0.7 m (x = 0.10)."""
    path = _straight_path(0.8)
    fake = FakeSearch(lambda p, t: True, path, cost=lambda p: 0.2 if p[0] <= 0.32 else 1.0)
    s, plan = find_branch_point(path, fake, CFG)
    assert s - path.start_arc_length == pytest.approx(0.30, abs=1e-9) and plan.cost == 0.2
    xs = np.array([p[0] for p, _ in fake.calls])
    np.testing.assert_allclose(xs, 0.75 - CFG.step * np.arange(13), atol=1e-9)  # 0.75 ... 0.15, not 0.10


def test_a_cost_floor_spares_searches_but_not_the_answer():
    """Plans cost 1.0 m from x > 0.32 and 0.2 m from x <= 0.32, never less than the floor min(cost, 0.6 - x):
    with the floor, the candidates whose retreat plus floor cannot beat the best total are not searched; the
    branch point is the same. With the exact cost as the floor, the winner comes after skipped candidates."""
    path = _straight_path(0.8)
    cost = lambda p: 0.2 if p[0] <= 0.32 else 1.0  # noqa: E731
    floor = lambda p: min(cost(p), max(0.1, 0.6 - p[0]))  # noqa: E731  (never more than the cost)
    plain = FakeSearch(lambda p, t: True, path, cost=cost)
    bounded = FakeSearch(lambda p, t: True, path, cost=cost)
    s, plan = find_branch_point(path, plain, CFG)
    s2, plan2 = find_branch_point(path, bounded, CFG, cost_floor=floor)
    assert s2 == s and plan2.cost == plan.cost == 0.2 and s - path.start_arc_length == pytest.approx(0.30)
    # after the first candidate (total 1.05), x = 0.70 .. 0.35 are searched only if 0.8 - x + floor < 1.05:
    # retreat 0.1 .. 0.45 plus floor 0.1 .. 0.25: all of them; once the best is 0.7 (x = 0.30), x = 0.25 .. 0.15
    # have retreat + floor 0.55 + 0.2 = 0.75 and more: not searched
    searched = [round(float(p[0]), 6) for p, _ in bounded.calls]
    assert searched == [round(float(p[0]), 6) for p, _ in plain.calls][: len(searched)]
    assert len(searched) == 10 and searched[-1] == pytest.approx(0.30) and len(plain.calls) == 13
    exact = FakeSearch(lambda p, t: True, path, cost=cost)
    s3, _ = find_branch_point(path, exact, CFG, cost_floor=cost)  # x = 0.70 .. 0.35: 0.1 + 1.0 >= 1.05, ...
    assert s3 == s and [round(float(p[0]), 6) for p, _ in exact.calls] == [0.75, 0.3]


def test_candidates_to_skip_are_not_searched_and_count_as_no_way_on():
    """``skip`` leaves out the candidates it names, the others searched as before (and the scan goes on past
    them): here x = 0.70 .. 0.50 are skipped, the only way on from x <= 0.62 is then first found at x = 0.45."""
    path = _straight_path(0.8)
    s0 = path.start_arc_length
    plain = FakeSearch(lambda p, t: p[0] <= 0.62, path)
    skipping = FakeSearch(lambda p, t: p[0] <= 0.62, path)
    s, _ = find_branch_point(path, plain, CFG)
    s2, _ = find_branch_point(path, skipping, CFG, skip=lambda a: 0.5 - 1e-9 <= a - s0 <= 0.7 + 1e-9)
    assert s - s0 == pytest.approx(0.60) and s2 - s0 == pytest.approx(0.45)
    assert [round(a - s0, 6) for a in plain.arcs] == [0.75, 0.7, 0.65, 0.6]
    assert [round(a - s0, 6) for a in skipping.arcs] == [0.75, 0.45]


def test_a_scanned_stretch_covers_what_was_searched_while_goal_map_and_path_hold():
    scanned = Scanned(goal=1, version=3, cuts=2, lo=math.inf, hi=-math.inf, spent=False)
    assert not scanned.covers(0.0)  # nothing searched yet
    scanned.extend([0.9, 0.8, 0.7], spent=False)
    assert (scanned.lo, scanned.hi, scanned.spent) == (0.7, 0.9, False)
    assert scanned.covers(0.7) and scanned.covers(0.85) and scanned.covers(0.9)
    assert not scanned.covers(0.69) and not scanned.covers(0.91)
    scanned.extend([0.95], spent=True)  # the next scan's new candidate
    assert (scanned.lo, scanned.hi, scanned.spent) == (0.7, 0.95, True)
    scanned.extend([], spent=False)  # a scan that searched nothing new keeps both
    assert (scanned.lo, scanned.hi, scanned.spent) == (0.7, 0.95, True)
    assert scanned.holds(1, 3, 2)
    assert not scanned.holds(2, 3, 2) and not scanned.holds(1, 4, 2) and not scanned.holds(1, 3, 3)


def test_an_escape_searches_again_only_the_path_beyond_the_stretch_searched_in_vain():
    """Following a fallback plan, every replan's escape scans back along the path: the candidates of a stretch an
    earlier scan searched in vain are not searched again while the goal, the path behind and the map hold; only
    the new path is.  A retreat or a look-back (the path cut), a point added to the map, or another goal: the whole
    stretch again.  Every search here spends its budget (PARTIAL), as on
    ``worlds/hard5/goal_far.json``, and the stall reason still says so."""
    from navstack.planner.field import FieldPlanner
    from navstack.planner.search import PARTIAL

    pl = FieldPlanner((0.0, 0.0, 0.0), X, [(3.0, 0.0, 0.0), (3.5, 0.0, 0.0)], [0.02, 0.02])
    for x in np.arange(0.001, 2.0 + 1e-9, 0.001):
        pl.path.record([x, 0.0, 0.0])
    arcs: list[float] = []

    def spent(p, h, k, at=None, budget=None):
        if budget is None:  # (not the deeper searches of a scan that found nothing: tested below)
            arcs.append(round(at - pl.path.start_arc_length, 6))
        return _fake_plan(PARTIAL)

    pl._plan_from = spent

    def scan() -> list[float]:
        arcs.clear()
        pl._start_escape(fallback=pl.follower.plan)
        assert pl.retreat is None and pl._wait is None and pl._budget_spent
        return list(arcs)

    first = scan()
    assert first == [round(2.0 - 0.05 - 0.1 * i, 6) for i in range(15)]  # min_back 0.05 to max_back 1.5
    assert scan() == []  # nothing new
    for x in np.arange(2.001, 2.03 + 1e-9, 0.001):  # 3 cm on: one new candidate
        pl.path.record([x, 0.0, 0.0])
    assert scan() == [1.98]
    pl.map.add_points([[2.5, 1.0, 0.0]])  # the map changes: every candidate again
    assert scan() == [round(2.03 - 0.05 - 0.1 * i, 6) for i in range(15)]
    assert scan() == []
    pl.look_backs += 1  # the path was cut (a retreat or look-back)
    assert len(scan()) == 15 and scan() == []
    pl.command_goal = 1  # another goal
    assert len(scan()) == 15 and scan() == []


def test_candidates_whose_search_spent_its_budget_are_searched_deeper_before_exploring_on():
    """An escape whose candidates' searches all spent their budget (PARTIAL) searches them once more with
    FieldPlannerConfig.deep_budget, and backs out to a branch point found so rather than following the partial
    plan from the tip ("explore") into a pocket (worlds/hard6/corner_late.json: the planner explored on in front
    of a wall's end, every escape's searches spent, and stalled without backing out; the way round the end from
    0.1-0.35 m back took 11-19 thousand expansions, the budget 8000).  Candidates boxed in (NO_PATH) are not
    searched again; the deeper scan is made once per goal and escape count, from deep_escape_after_retreats
    escapes on (1: not before the first); deep_budget 0: never."""
    from dataclasses import replace

    from navstack.planner.field import FieldPlanner, FieldPlannerConfig
    from navstack.planner.search import PARTIAL

    def planner(config=None, deep_finds=lambda at: True):
        pl = FieldPlanner((0.0, 0.0, 0.0), X, [(3.0, 0.0, 0.0)], [0.02], config=config)
        for x in np.arange(0.001, 1.0 + 1e-9, 0.001):
            pl.path.record([x, 0.0, 0.0])
        calls: list[tuple[float, int | None]] = []

        def plan_from(p, h, k, at=None, budget=None):
            back = round(pl.path.end_arc_length - at, 6)
            calls.append((back, budget))
            if back < 0.3:
                return _fake_plan(NO_PATH)  # boxed in near the tip
            if budget is None or not deep_finds(back):
                return _fake_plan(PARTIAL, 2.0)  # the budget spent
            return _fake_plan(REACHED, 2.0)

        pl._plan_from = plan_from
        return pl, calls

    pl, calls = planner()  # the defaults: no deeper scan before the first escape for the goal
    pl._start_escape(fallback=pl.follower.plan)
    assert pl.retreat is None and calls and all(budget is None for _, budget in calls)
    pl, calls = planner()
    pl._goal_retreats[0] = 1  # ... and after it
    pl._start_escape(fallback=pl.follower.plan)
    assert pl.retreat is not None and [b for _, b in calls if b is not None] == [FieldPlannerConfig().deep_budget]

    cfg = FieldPlannerConfig(deep_escape_after_retreats=0)
    pl, calls = planner(cfg)
    pl._start_escape(fallback=pl.follower.plan)
    assert pl.retreat is not None and pl.mode == "retreat" and pl.retreats == 1  # backs out ...
    assert pl._pending[0] == pytest.approx(pl.path.end_arc_length - 0.35)  # ... to the nearest such point
    normal = [back for back, budget in calls if budget is None]
    deep = [back for back, budget in calls if budget is not None]
    assert normal == [round(0.05 + 0.1 * i, 6) for i in range(10)] + [1.0]  # every candidate, to the path's start
    assert deep == [0.35] and {budget for _, budget in calls} == {None, cfg.deep_budget}
    # (0.05-0.25 boxed in: not searched again; from 0.45 on the retreat alone exceeds 0.35 + 2.0: not searched)

    pl, calls = planner(cfg, deep_finds=lambda back: False)  # the deeper searches find nothing either
    fallback = pl.follower.plan
    pl._start_escape(fallback=fallback)
    assert pl.retreat is None and pl.follower.plan is fallback  # explores on along the partial plan
    deep = [back for back, budget in calls if budget is not None]
    assert deep == [round(0.35 + 0.1 * i, 6) for i in range(7)] + [1.0]
    calls.clear()
    pl.map.add_points([[2.5, 1.0, 0.0]])  # (the map changed: every candidate searched again, not Scanned's skip)
    pl._start_escape(fallback=pl.follower.plan)  # the same goal, no retreat since: no deeper scan again
    assert calls and all(budget is None for _, budget in calls) and pl.retreat is None

    pl, calls = planner(replace(cfg, deep_budget=0))  # no deeper budget: as before
    pl._start_escape(fallback=pl.follower.plan)
    assert pl.retreat is None and all(budget is None for _, budget in calls)


def test_of_equal_totals_the_nearer_branch_point_is_kept():
    path = _straight_path(0.8)
    fake = FakeSearch(lambda p, t: True, path, cost=lambda p: p[0])  # retreat + cost = 0.8 everywhere
    s, _ = find_branch_point(path, fake, CFG)
    assert s - path.start_arc_length == pytest.approx(0.75, abs=1e-9)


def test_the_default_configuration_looks_back_in_its_own_steps():
    path = _straight_path(0.8)
    cfg = EscapeConfig()
    fake = FakeSearch(lambda p, t: p[0] <= 0.32, path)
    s, _ = find_branch_point(path, fake, cfg)
    backs = 0.8 - np.array([p[0] for p, _ in fake.calls])
    np.testing.assert_allclose(backs, cfg.min_back + cfg.step * np.arange(len(backs)), atol=1e-9)
    assert s - path.start_arc_length <= 0.32 < s - path.start_arc_length + cfg.step
    for p, t in fake.calls:  # each candidate state is the path's point and forward tangent
        np.testing.assert_allclose(p[1:], 0.0, atol=1e-12)
        np.testing.assert_allclose(t, X, atol=1e-12)


def test_candidates_on_a_curved_path_are_its_points_and_forward_tangents():
    path = _curved_path()
    s0 = path.start_arc_length
    fake = FakeSearch(lambda p, t: p[1] < 0.05, path)  # only from early on the arc (or the straight part)
    s, _ = find_branch_point(path, fake, CFG)
    for p, t in fake.calls:
        assert _nearest_on_path(path, p)[1] < 1e-9
        # on the arc: the tangent is perpendicular to the radius from the arc's centre (0.3, 0.3)
        if p[0] > 0.3 + 1e-6:
            radial = p - np.array([0.3, 0.3, 0.0])
            assert np.linalg.norm(radial) == pytest.approx(0.3, abs=1e-5)  # on chords of 1-2 mm
            assert abs(radial @ t) < 2e-3 and t[1] > 0
    # the arc's height y = 0.3 (1 - cos phi) < 0.05 for phi < 0.586 rad: arc length below 0.176 m
    arc_ok = 0.3 * math.acos(1 - 0.05 / 0.3)
    total = 0.3 + 0.5 * math.pi * 0.3
    backs = total - CFG.min_back - CFG.step * np.arange(40)
    expected = backs[backs - 0.3 < arc_ok][0]
    assert s - s0 == pytest.approx(expected, abs=2e-3)


def test_no_candidate_lies_behind_the_start_of_the_path():
    path = _straight_path(0.33)
    s0 = path.start_arc_length
    fake = FakeSearch(lambda p, t: False)
    assert find_branch_point(path, fake, CFG) is None
    xs = np.array([p[0] for p, _ in fake.calls])
    assert np.all(xs >= -1e-12)
    assert xs[-1] == pytest.approx(0.0, abs=1e-12)  # the last candidate is the start itself, once
    assert np.sum(np.abs(xs) < 1e-9) == 1
    # a way on from the start only: the start is the branch point
    fake = FakeSearch(lambda p, t: p[0] <= 1e-9)
    s, _ = find_branch_point(path, fake, CFG)
    assert s == pytest.approx(s0, abs=1e-12)


def test_no_candidate_farther_back_than_max_back():
    path = _straight_path(2.5)
    fake = FakeSearch(lambda p, t: p[0] <= 0.5)  # 2 m back: beyond max_back = 1.5 m
    assert find_branch_point(path, fake, CFG) is None
    xs = np.array([p[0] for p, _ in fake.calls])
    assert xs.min() >= 2.5 - CFG.max_back - 1e-9
    fake = FakeSearch(lambda p, t: p[0] <= 1.0 + 1e-9)
    s, _ = find_branch_point(path, fake, CFG)  # exactly max_back back
    assert s - path.start_arc_length == pytest.approx(1.0, abs=1e-9)


def test_before_bounds_the_candidates():
    path = _straight_path(1.0)
    s0, end = path.start_arc_length, path.end_arc_length
    before = end - 0.33
    fake = FakeSearch(lambda p, t: True)
    s, _ = find_branch_point(path, fake, CFG, before=before)
    assert s == pytest.approx(before, abs=1e-12)  # the first candidate is `before` itself
    fake = FakeSearch(lambda p, t: p[0] <= 0.5)
    s, _ = find_branch_point(path, fake, CFG, before=before)
    xs = np.array([p[0] for p, _ in fake.calls])
    assert np.all(xs <= before - s0 + 1e-9)
    np.testing.assert_allclose(xs, (before - s0) - CFG.step * np.arange(len(xs)), atol=1e-9)
    assert s - s0 == pytest.approx(0.47, abs=1e-9)  # 0.67, 0.62, ..., 0.47
    # a `before` beyond the path's end changes nothing
    fake2 = FakeSearch(lambda p, t: p[0] <= 0.5)
    s2, _ = find_branch_point(path, fake2, CFG, before=end + 1.0)
    s3, _ = find_branch_point(path, FakeSearch(lambda p, t: p[0] <= 0.5), CFG)
    assert s2 == s3


@pytest.mark.parametrize(("name", "value"), [("step", 0.0), ("min_back", -0.05), ("max_back", np.nan),
                                             ("speed", True), ("accel", np.inf)])
def test_escape_config_rejects_bad_values(name, value):
    with pytest.raises(ValueError, match=name):
        EscapeConfig(**{name: value})


def test_max_retreats_may_be_zero_but_not_negative_or_a_bool():
    assert EscapeConfig(max_retreats=0).max_retreats == 0  # never back out: give up at once
    for bad in (-1, True, 1.5):
        with pytest.raises(ValueError, match="max_retreats"):
            EscapeConfig(max_retreats=bad)


# ---------------------------------------------------------------------------- the retreat to the branch point
def _retreat_commands(path: PathMemory, s: float, dt: float = 1.0 / 30.0, steps: int = 2000):
    r = Retreat(path, s, CFG.speed, CFG.accel)
    cmds = []
    while not r.done and len(cmds) < steps:
        cmds.append(r.step(dt))
    assert r.done
    return cmds


@pytest.mark.parametrize("make_path", [lambda: _straight_path(0.8), _curved_path], ids=["straight", "curved"])
def test_the_reverse_commands_run_back_along_the_path_to_the_branch_point(make_path):
    path = make_path()
    s, _ = find_branch_point(path, FakeSearch(lambda p, t: p[0] <= 0.32), CFG)
    # the controller records the same commands as the planner: a copy of the path, cut back by the retreat
    controller = make_path()
    cmds = _retreat_commands(path, s)
    dt = 1.0 / 30.0
    prev = path.end_arc_length
    speeds = []
    for c in cmds:
        assert c.reverse and not c.stalled and c.mode == "retreat"
        assert _nearest_on_path(path, c.position)[1] < 1e-9  # on the recorded path
        controller.advance(c.position, c.velocity, reverse=True)  # never off the path: no ValueError
        now = controller.end_arc_length
        assert now <= prev + 1e-12
        speeds.append((prev - now) / dt)
        prev = now
        assert np.linalg.norm(c.velocity) <= CFG.speed + 1e-12
    np.testing.assert_allclose(cmds[-1].position, path.point_at(s)[0], atol=1e-12)
    assert controller.end_arc_length == pytest.approx(s, abs=1e-9)
    assert max(speeds) <= CFG.speed + 1e-9
    # the velocity points back along the path (against the recording direction)
    for c in cmds[:-1]:
        if np.linalg.norm(c.velocity) > 0:
            _, t = path.point_at(_arc_of(path, c.position))
            assert c.velocity @ t < 0


def _nearest_on_path(path: PathMemory, p: np.ndarray) -> tuple[float, float]:
    """Arc length and distance of the point of the recorded path (its vertices, then the head) nearest p,
    by brute force over every segment."""
    V = np.vstack([path.points, path.head])
    S = np.append(path.arc_length, path.end_arc_length)
    d = np.diff(V, axis=0)
    L2 = np.einsum("ij,ij->i", d, d)
    keep = L2 > 0
    V0, d, L2, S0, S1 = V[:-1][keep], d[keep], L2[keep], S[:-1][keep], S[1:][keep]
    f = np.clip(np.einsum("ij,ij->i", p - V0, d) / L2, 0.0, 1.0)
    e = np.linalg.norm(V0 + f[:, None] * d - p, axis=1)
    i = int(np.argmin(e))
    return float(S0[i] + f[i] * (S1[i] - S0[i])), float(e[i])


def _arc_of(path: PathMemory, p: np.ndarray) -> float:
    return _nearest_on_path(path, p)[0]


# ---------------------------------------------------------------------------- a pocket in a point cloud
def _cup(x0=0.5, x1=0.9, a=0.12, spacing=0.02) -> np.ndarray:
    """A box-shaped pocket open towards -x: side walls |y| = a and |z| = a from x0 to x1, its back at x1."""
    g = np.arange(-a, a + 1e-9, spacing)
    xs = np.arange(x0, x1 + 1e-9, spacing)
    pts = []
    for s in (-a, a):
        X_, G = np.meshgrid(xs, g, indexing="ij")
        pts.append(np.column_stack([X_.ravel(), np.full(X_.size, s), G.ravel()]))
        pts.append(np.column_stack([X_.ravel(), G.ravel(), np.full(X_.size, s)]))
    Y, Z = np.meshgrid(g, g, indexing="ij")
    pts.append(np.column_stack([np.full(Y.size, x1), Y.ravel(), Z.ravel()]))
    return np.vstack(pts)


def test_backing_out_of_a_pocket_in_a_point_cloud():
    """The tip went 0.15 m into a pocket (0.24 m wide: it cannot turn inside, 0.3 m deep) whose back is
    closed; the goal lies behind the pocket.  From inside there is no way on; the branch point is the
    nearest point of the path from which the search goes round the pocket (body and arm clear of it), and
    the retreat takes the tip back to it."""
    mouth, back = 0.7, 1.0
    goal = np.array([[1.6, 0.0, 0.0]])
    smap = SensedMap([0, 0, 0], goal[0])
    cup = _cup(mouth, back)
    smap.add_points(cup)
    smap.mark_free([0.35, 0.0, 0.0], 0.3)
    path = _straight_path(mouth + 0.15)
    s0 = path.start_arc_length
    rep = Repulsion()
    cfg = SearchConfig(max_expansions=4000)  # a smaller budget keeps the test fast (a PARTIAL plan fails too)

    def plan_from(p, t, s):
        hist = np.array([path.point_at(x)[0] for x in np.append(np.arange(max(s - 1.5, 0.0), s - 0.005, 0.01), s)])
        return search(smap, p, t, goal, [0.02], 0, cfg, rep, history=hist)

    head, tangent = path.point_at(path.end_arc_length)
    assert plan_from(head, tangent, path.end_arc_length).status == NO_PATH  # boxed in
    s, plan = find_branch_point(path, plan_from, CFG)
    x_branch = s - s0
    print(f"\npocket: branch point at x = {x_branch:.3f} m ({path.end_arc_length - s:.2f} m back), "
          f"plan {plan.length:.2f} m")
    assert x_branch < mouth - 0.25  # well outside the mouth: room to swing round the pocket
    assert plan.status == REACHED
    # the nearest such point: from one candidate nearer, no way on
    p1, t1 = path.point_at(s + CFG.step)
    assert plan_from(p1, t1, s + CFG.step).status != REACHED
    # the plan goes round the pocket, clear of it
    d = cKDTree(cup).query(plan.points)[0]
    assert d.min() >= rep.r_block - 4e-4
    assert np.abs(plan.points[:, 1:]).max(axis=1).max() > 0.12 + rep.r_block
    # the retreat runs back along the path, out of the pocket, to the branch point
    cmds = _retreat_commands(path, s)
    xs = np.array([c.position[0] for c in cmds])
    assert np.all(np.diff(xs) <= 1e-12) and xs[-1] == pytest.approx(x_branch, abs=1e-9)
    assert cKDTree(cup).query(np.array([c.position for c in cmds]))[0].min() >= 0.12 - 1e-9
