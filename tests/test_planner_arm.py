"""The arm carried by the lathe bed (navstack.planner.search.ArmShape with the lathe's axis and travel).

References: a brute-force (k-d tree) statement of the rule, "the bed translates the arm by the flange's
displacement along its axis, clipped to its travel; the arm keeps its reach plus what is left of the
displacement", on random scenes; hand-made plans whose arm clearance is known in closed form; PyBullet's
own link states for the lathe's axis and travel in a trial.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from navstack.planner.map import SensedMap
from navstack.planner.potential import Repulsion
from navstack.planner.search import ArmShape, Plan, SearchConfig, _arm_shifted_clear, point_index, still_clear

CFG = SearchConfig()
REP = Repulsion()


def _map(points) -> SensedMap:
    smap = SensedMap([-2.5, -1.0, -1.0], [2.0, 1.0, 1.0])
    smap.add_points(np.asarray(points, dtype=np.float64))
    return smap


def _carried_clear(chain, arm: ArmShape, r: float, smap: SensedMap) -> bool:
    """The compiled check, with its work arrays."""
    k = len(arm.points)
    return bool(_arm_shifted_clear(chain, arm.points, arm.carry, r, *point_index(smap), np.empty((k, 3)), np.empty(k)))


def _reference_clear(chain5, arm_pts, flange, axis, travel, reach, points) -> bool:
    """The rule in plain numpy: split the flange's displacement d into the bed's part t axis (t = d . axis
    clipped to ``travel``) and the rest e; the arm translated by t axis keeps reach + |e| from every point."""
    d = chain5 - flange
    t = float(np.clip(d @ axis, *travel))
    e = float(np.linalg.norm(d - t * axis))
    return bool(cKDTree(points).query(arm_pts + t * axis)[0].min() >= reach + e)


def test_the_carried_arm_check_is_the_brute_force_rule_on_random_scenes():
    """400 random scenes (tilted axes, travels, displacements and point clouds): the compiled check says
    clear exactly when the brute-force rule does (scenes within 1 mm of the boundary are skipped)."""
    rng = np.random.default_rng(32)
    agree, both = 0, [0, 0]
    for _ in range(400):
        points = rng.uniform(-1.0, 1.0, (12, 3))
        smap = _map(points)
        axis = Rotation.random(random_state=rng).apply([1.0, 0.0, 0.0])
        travel = (-rng.uniform(0.0, 0.6), rng.uniform(0.0, 0.6))
        flange = rng.uniform(-0.5, 0.5, 3)
        arm_pts = flange + np.linspace(0.0, 1.0, 8)[:, None] * rng.uniform(-0.4, 0.4, 3)
        chain = np.zeros((8, 3))
        chain[5] = flange + rng.uniform(-0.4, 0.4, 3)
        reach = rng.uniform(0.02, 0.1)
        arm = ArmShape(arm_pts, flange, reach, axis, travel)
        d = chain[5] - flange
        t = float(np.clip(d @ axis, *travel))
        margin = cKDTree(smap.points).query(arm_pts + t * axis)[0].min() - reach - np.linalg.norm(d - t * axis)
        if abs(margin) < 1e-3:
            continue
        want = _reference_clear(chain[5], arm_pts, flange, axis, travel, reach, smap.points)
        got = bool(_carried_clear(chain, arm, reach, smap))
        assert got == want
        agree += 1
        both[want] += 1
    print(f"\n{agree} scenes, {both[1]} clear, {both[0]} not")
    assert agree > 350 and min(both) > 50  # both answers well represented


def test_without_an_axis_the_arm_goes_with_the_whole_displacement():
    """No lathe axis (the old model): translated by d, keeping only the reach."""
    flange = np.array([-1.2, 0.0, 0.0])
    arm = ArmShape(np.column_stack([np.linspace(-2.0, -1.2, 17), np.zeros(17), np.zeros(17)]), flange, 0.06)
    chain = np.zeros((8, 3))
    chain[5] = flange + [0.0, 0.3, 0.0]
    beside = _map([[-1.6, 0.3 + 0.07, 0.0]])  # 7 cm from the arm moved 0.3 m sideways
    assert _carried_clear(chain, arm, 0.06, beside)
    lathe = ArmShape(arm.points, flange, 0.06, np.array([1.0, 0.0, 0.0]))
    # the bed cannot move sideways: the arm stays on the axis and keeps 0.06 + 0.3, the point is 0.37 away
    assert _carried_clear(chain, lathe, 0.06, beside)
    near = _map([[-1.6, -0.35, 0.0]])  # on the other side, 0.35 < 0.36 from the arm the bed leaves in place
    assert not _carried_clear(chain, lathe, 0.06, near)
    assert _carried_clear(chain, arm, 0.06, near)


def _straight_plan(length: float, ds: float = 0.005) -> Plan:
    n = int(round(length / ds))
    P = np.column_stack([np.linspace(0.0, length, n + 1), np.zeros(n + 1), np.zeros(n + 1)])
    return Plan(points=P, tangents=np.tile([1.0, 0.0, 0.0], (n + 1, 1)), arc=P[:, 0].copy(),
                goal_index=np.zeros(n + 1, dtype=np.int64), status=2, cost=0.0, expansions=0)


def _arm_behind(travel: tuple[float, float]) -> ArmShape:
    """The arm along -x behind the flange at (-1.2, 0, 0) (six links behind a tip at the origin heading +x),
    the lathe along +x with ``travel``."""
    pts = np.column_stack([np.linspace(-2.0, -1.2, 17), np.zeros(17), np.zeros(17)])
    return ArmShape(pts, np.array([-1.2, 0.0, 0.0]), 0.06, np.array([1.0, 0.0, 0.0]), travel)


@pytest.mark.parametrize(("hi", "clear"), [(2.0, True), (1.45, True), (1.0, False)])
def test_a_plan_needing_more_lathe_travel_than_is_left_is_refused(hi, clear):
    """A straight 1.5 m plan carries the flange 1.5 m along the lathe; a post 0.25 m beside the arm's way.
    Within the travel the arm passes it 0.25 m off (> 0.08); with only 1.0 m left the arm stops short and
    its joints must make the last 0.5 m: it must keep 0.08 + 0.5 m, which the post is nearer than.  With
    1.45 m the last 0.05 m leaves 0.13 < 0.25: clear."""
    z = np.arange(-0.3, 0.3 + 1e-9, 0.01)
    post = np.column_stack([np.full(len(z), -0.6), np.full(len(z), 0.25), z])
    history = np.column_stack([np.linspace(-2.0, 0.0, 401), np.zeros(401), np.zeros(401)])
    plan = _straight_plan(1.5)
    arm = _arm_behind((-1.0, hi))
    assert still_clear(_map(post), plan, 0.0, history, CFG, REP, arm) is clear
    free = ArmShape(arm.points, arm.flange, arm.radius)  # the old model: never refused here
    assert still_clear(_map(post), plan, 0.0, history, CFG, REP, free)


def test_the_trial_gives_the_planner_the_lathe_axis_and_travel_pybullet_reports():
    """A base turned every way and a start with the bed part-way along: the planner's axis and travel
    are those of frame 1's origin in PyBullet's own link states at the joint's two limits."""
    from navstack.jpl import jpl_serpentine
    from navstack.trial import TrialConfig, _Simulation
    from navstack.world import world_from_dict

    chain = jpl_serpentine()
    q0 = np.zeros(20)
    q0[0], q0[3], q0[4], q0[6] = 0.4, -math.pi / 2, math.pi / 3, math.pi / 6
    rpy = [0.3, -1.2, 2.5]
    base = np.eye(4)
    base[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    base[:3, 3] = [0.2, -0.1, 0.5]
    tip = base[:3, :3] @ chain.frames(q0)[21, :3, 3] + base[:3, 3]
    world = world_from_dict({
        "format": "navstack-world/1", "name": "turned",
        "robot": {"base": {"position": base[:3, 3].tolist(), "rpy": rpy}, "q0": q0.tolist()},
        "obstacles": [], "goals": [{"position": tip.tolist(), "tolerance": 0.02}], "time_limit": 1.0})
    sim = _Simulation(world, "slither", "field", 0, TrialConfig())
    try:
        ends = []
        for value in (chain.lower[0], chain.upper[0]):
            q = q0.copy()
            q[0] = value
            sim.body.reset(q)
            ends.append(sim.body.link_frames_world()[0, :3, 3])
        arm = sim.planner.arm
        axis = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
        np.testing.assert_allclose(arm.axis, axis, atol=1e-6)
        np.testing.assert_allclose(arm.travel, (chain.lower[0] - 0.4, chain.upper[0] - 0.4), atol=1e-6)
    finally:
        sim.close()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"axis": np.array([1.0, 1.0, 0.0])}, "ArmShape.axis"),
    ({"axis": np.array([np.nan, 0.0, 0.0])}, "ArmShape.axis"),
    ({"axis": np.zeros(2)}, "ArmShape.axis"),
    ({"travel": (0.1, 1.0)}, "ArmShape.travel"),
    ({"travel": (-1.0, -0.1)}, "ArmShape.travel"),
    ({"travel": (np.nan, 1.0)}, "ArmShape.travel"),
    ({"travel": (1.0,)}, "ArmShape.travel"),
    ({"travel": "far"}, "ArmShape.travel"),
    ({"travel": None}, "ArmShape.travel"),
    ({"axis": "x"}, "ArmShape.axis"),
    ({"axis": [1.0, "y", 0.0]}, "ArmShape.axis"),
])
def test_a_bad_lathe_axis_or_travel_is_refused_naming_the_field(kwargs, match):
    good = {"points": np.zeros((4, 3)), "flange": np.zeros(3), "radius": 0.06, "axis": np.array([0.0, 0.0, 1.0])}
    with pytest.raises(ValueError, match=match):
        ArmShape(**{**good, **kwargs})
    np.testing.assert_array_equal(ArmShape(**good).carry, [0, 0, 0, 0, 0, 1, -np.inf, np.inf])
    listed = ArmShape(**{**good, "axis": [0, 0, 1], "travel": [-1, 2]})  # plain lists: kept as float arrays
    assert listed.axis.dtype == np.float64 and listed.travel == (-1.0, 2.0)
