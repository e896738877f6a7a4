"""The goal spline (navstack.guide) and the field planner's pursuit of it."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.guide import GuidePath, goal_spline
from navstack.planner.reactive import PlannerConfig, PotentialFieldPlanner

# the goals of a generated truss where the goal-only field planner missed the climb (relative to the tip)
CLIMB = np.array([[0.316, 0.0, 0.0], [0.671, 0.0, 0.041], [0.802, 0.0, 0.194], [0.822, 0.0, 0.556]])


def test_goal_spline_passes_the_goals_and_leaves_along_the_heading() -> None:
    g = goal_spline(np.zeros(3), [1.0, 0.0, 0.0], CLIMB)
    assert isinstance(g, GuidePath) and g.points.shape[1] == 3 and g.arc[0] == 0.0
    assert np.all(np.diff(g.arc) > 0) and np.all(np.diff(g.goal_arcs) > 0)
    for goal, s in zip(CLIMB, g.goal_arcs, strict=True):
        p, _ = g.point(s)
        assert np.linalg.norm(p - goal) < 1e-4
    _, t0 = g.point(0.0)
    assert t0 @ [1.0, 0.0, 0.0] > 0.9999
    # the spline turns no tighter than what it reports, and at least as tight as its chord polygon allows
    assert 0.2 < g.min_turn_radius < 1.0
    assert g.length > np.linalg.norm(CLIMB[-1])


def test_project_searches_only_its_window() -> None:
    g = goal_spline(np.zeros(3), [1.0, 0.0, 0.0], [[1.0, 0.0, 0.0]])
    s, d = g.project([0.5, 0.03, 0.0], 0.0, g.length)
    assert abs(s - 0.5) < 0.003 and abs(d - 0.03) < 1e-3
    s, _ = g.project([0.5, 0.0, 0.0], 0.7, 0.9)  # the nearest point within the window is its start
    assert abs(s - 0.7) < 0.003


@pytest.mark.parametrize(
    "args",
    [
        (np.zeros(2), [1, 0, 0], CLIMB),
        (np.zeros(3), [0, 0, 0], CLIMB),
        (np.zeros(3), [1, 0, 0], np.zeros((0, 3))),
        (np.zeros(3), [1, 0, 0], [[np.nan, 0, 0]]),
    ],
)
def test_goal_spline_rejects_bad_input(args) -> None:
    with pytest.raises(ValueError, match="goal_spline"):
        goal_spline(*args)


def _fly_goals(goals: np.ndarray, guide: GuidePath | None, dt: float = 1 / 30, t_max: float = 60.0):
    """Free flight through the goals, advancing like the trial loop: (reached, positions)."""
    pl = PotentialFieldPlanner(start=np.zeros(3), heading=[1, 0, 0], guide=guide)
    x, h, k = np.zeros(3), np.array([1.0, 0.0, 0.0]), 0
    pos = [x]
    for _ in range(int(t_max / dt)):
        last = k == len(goals) - 1
        cmd = pl.step(dt, x, h, None, goals[k], 0.02, approach=last, next_goal=None if last else goals[k + 1])
        x = cmd.position
        pos.append(x)
        if np.linalg.norm(cmd.velocity) > 0:
            h = cmd.velocity / np.linalg.norm(cmd.velocity)
        while k < len(goals) and np.linalg.norm(x - goals[k]) <= 0.02:
            k += 1
        if k == len(goals) or cmd.stalled:
            break
    return k == len(goals), np.array(pos)


def test_pursuing_the_guide_takes_the_climb_on_the_spline() -> None:
    guide = goal_spline(np.zeros(3), [1.0, 0.0, 0.0], CLIMB)
    ok, pos = _fly_goals(CLIMB, guide)
    dev = max(guide.project(p, 0.0, guide.length)[1] for p in pos)
    length = float(np.linalg.norm(np.diff(pos, axis=0), axis=1).sum())
    ok_plain, pos_plain = _fly_goals(CLIMB, None)
    dev_plain = max(guide.project(p, 0.0, guide.length)[1] for p in pos_plain)
    print(f"\nclimb: guide {ok}, path {length:.3f} m (spline {guide.length:.3f} m), max deviation {dev * 1e3:.1f} mm;"
          f" goal-only {ok_plain}, max deviation {dev_plain * 1e3:.1f} mm")
    assert ok
    assert dev < 0.01
    assert length < guide.length + 0.02
    # the turn rate limit holds on the guide too
    v = np.diff(pos, axis=0)
    sp = np.linalg.norm(v, axis=1)
    m = sp > 1e-9
    c = np.einsum("ij,ij->i", v[:-1][m[:-1] & m[1:]], v[1:][m[:-1] & m[1:]])
    ang = np.arccos(np.clip(c / (sp[:-1][m[:-1] & m[1:]] * sp[1:][m[:-1] & m[1:]]), -1, 1))
    assert np.all(ang <= sp[1:][m[:-1] & m[1:]] / PlannerConfig().min_turn_radius + 1e-9)


def test_planner_rejects_a_guide_of_the_wrong_type() -> None:
    with pytest.raises(TypeError, match="guide"):
        PotentialFieldPlanner(guide=CLIMB)  # type: ignore[arg-type]
