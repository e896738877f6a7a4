"""Families whose goals do not mark the way (``slot-rack``, ``sparse-truss``, ``bend-clutter``, ``fin-bank``,
``rod-forest``), the ``dead-end`` and ``duct-elbow`` families, and ``retract`` worlds.

Each family's worlds pass :func:`check_world` with the user's 12 mm for every link (stored in
``extra.generator.check_config``); their goals alone do not lead through (the spline through them cuts
into an obstacle, the scripted planner collides), while the hidden reference path does.  Distances in
metres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navstack.cli import main
from navstack.generate import (
    FAMILY_EXAMPLES,
    CheckConfig,
    check_world,
    generate_world,
    obstacle_distance,
    reference_path,
    with_reference_goals,
    write_family_examples,
)
from navstack.generate.build import time_limit_for
from navstack.generate.duct_elbow import curve
from navstack.trial import run_trial
from navstack.truss import PAPER_BASE_RPY, robot_tip_start
from navstack.world import Cylinder, load_world, save_world

TIP, HEADING = robot_tip_start((0.0, 0.0, 0.3), PAPER_BASE_RPY)
WORLDS = Path(__file__).resolve().parents[1] / "worlds"
SPARSE = ("slot-rack", "sparse-truss", "bend-clutter", "fin-bank", "rod-forest", "duct-elbow", "sized-slot-rack")
NEW = (*SPARSE, "dead-end")
CASES = [(f, s, d) for f in NEW for s, d in ((0, 0.0), (1, 0.3), (2, 0.6), (3, 1.0), (4, 1.0))]


@pytest.mark.parametrize(("family", "seed", "difficulty"), CASES)
def test_sparse_world_passes_the_strict_checks_after_round_trip(family, seed, difficulty, tmp_path):
    w = generate_world(family, seed, difficulty)
    gen = w.extra["generator"]
    assert gen["check_config"] == {"body_margin": 0.012}
    save_world(w, tmp_path / "w.json")
    back = load_world(tmp_path / "w.json")
    assert back == w and back.retract == (family == "dead-end")
    report = check_world(back)  # re-applies the stored body margin
    assert report.ok, report.problems
    assert report.body_clearance >= 0.012 and report.arm_clearance >= CheckConfig().arm_margin
    assert report.min_turn_radius >= 0.25 and report.goal_clearance >= 0.06
    assert report.start_clearance is not None and report.start_clearance >= 0.05
    # the same world fails a stricter body margin than it was built for, so the stored one is what counts
    assert not check_world(back, config=CheckConfig(body_margin=report.body_clearance + 1e-3)).ok
    if family not in SPARSE:
        return
    # the goals do not mark the way: the body on the spline through the goals alone cuts into an obstacle
    assert gen["goal_path_clearance"] <= -0.005
    goal_path = reference_path(TIP, HEADING, w.goal_positions)
    assert obstacle_distance(w.obstacles, goal_path.points).min() < w.robot.serpentine_radius + 0.01


@pytest.mark.parametrize(("seed", "difficulty"), [(s, d) for s in range(4) for d in (0.0, 1.0)])
def test_slot_rack_goals_do_not_mark_the_slots(seed, difficulty):
    w = generate_world("slot-rack", seed, difficulty)
    gen = w.extra["generator"]
    entry, final = w.goal_positions
    assert len(w.goals) == 2
    # the straight segment entry -> final comes within the tip's radius of the rack
    line = entry + np.linspace(0.0, 1.0, 500)[:, None] * (final - entry)
    assert obstacle_distance(w.obstacles, line).min() < 0.025
    # slots alternate from one side of the line to the other, 0.12-0.15 m wide, rows 0.33-0.65 m apart
    offsets = np.array(gen["slot_offsets"])
    assert np.all(np.sign(offsets[1:]) == -np.sign(offsets[:-1]))
    assert np.all(np.abs(offsets) >= np.array(gen["slot_widths"]) / 2 - 0.02 - 1e-9)
    assert all(0.12 - 1e-9 <= s <= 0.15 + 1e-9 for s in gen["slot_widths"])
    gaps = np.diff(gen["row_positions"])
    assert np.all((gaps >= 0.33 - 1e-9) & (gaps <= 0.65 + 1e-9)) and gen["rows"] in (2, 3)
    first = gen["row_positions"][0]
    assert 0.15 <= first <= 0.2
    # the reference path passes the entry goal off-centre, inside the tolerance, already turning
    ref = reference_path(TIP, HEADING, gen["reference_via"])
    d = np.linalg.norm(ref.points - entry, axis=1)
    i = int(np.argmin(d))
    assert 0.005 <= d[i] <= 0.018
    tangent = ref.points[i + 1] - ref.points[i - 1]
    lateral = np.linalg.norm(np.cross(tangent / np.linalg.norm(tangent), HEADING))
    assert lateral > np.sin(np.radians(1.0))


def assert_rolls_vary(rolls_deg: list[float]) -> None:
    """Rolls about the approach line [deg]: some near horizontal, some near vertical, some oblique."""
    rolls = np.array(rolls_deg) % 180.0
    near_horizontal = np.minimum(rolls, 180.0 - rolls) < 30.0
    near_vertical = np.abs(rolls - 90.0) < 30.0
    assert near_horizontal.any() and near_vertical.any() and (~near_horizontal & ~near_vertical).any()


def test_slot_rack_orientations_and_kinds_vary():
    worlds = [generate_world("slot-rack", s, 0.5).extra["generator"] for s in range(12)]
    assert_rolls_vary([g["roll_deg"] for g in worlds])
    assert {g["kind"] for g in worlds} == {"pipes", "plates"}
    assert {np.sign(g["slot_offsets"][0]) for g in worlds} == {-1.0, 1.0}


def test_difficulty_narrows_slots_and_rows():
    easy = [generate_world("slot-rack", s, 0.0).extra["generator"] for s in range(4)]
    hard = [generate_world("slot-rack", s, 1.0).extra["generator"] for s in range(4)]
    assert max(min(g["slot_widths"]) for g in hard) < min(min(g["slot_widths"]) for g in easy)
    assert max(np.diff(g["row_positions"]).max() for g in hard) <= 0.45 + 1e-9
    assert min(np.diff(g["row_positions"]).min() for g in easy) >= 0.5 - 1e-9


def fin_frame(fin) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A fin box's half extents sorted from thin to long, and its axes in that order (columns) [m]."""
    R = Rotation.from_euler("xyz", fin.rpy).as_matrix()
    order = np.argsort(fin.half_extents)
    return np.asarray(fin.half_extents)[order], R[:, order], fin.center


@pytest.mark.parametrize(("seed", "difficulty"), [(s, d) for s in range(3) for d in (0.0, 1.0)])
def test_fin_bank_fins_are_thin_edge_on_and_block_the_line(seed, difficulty):
    w = generate_world("fin-bank", seed, difficulty)
    gen = w.extra["generator"]
    fins, cables = w.obstacles[: gen["structure_obstacles"]], w.obstacles[gen["structure_obstacles"]:]
    assert gen["banks"] == 2 and len(w.goals) == 2 and len(cables) == gen["cables"]
    entry, final = w.goal_positions
    thin_lo, thin_hi = 0.003 - 0.0015 * difficulty, 0.008 - 0.004 * difficulty
    normal = fin_frame(fins[0])[1][:, 0]
    banks: dict[int, list[tuple[float, float]]] = {}  # bank -> (offset along the normal, thickness) per fin
    leading = np.inf
    for f in fins:
        half, axes, centre = fin_frame(f)
        assert thin_lo / 2 - 1e-6 <= half[0] <= thin_hi / 2 + 1e-6  # thin: 1.5-8 mm
        assert 0.025 - 1e-6 <= half[1] <= 0.05 + 1e-6 and half[2] >= 0.45 - 1e-6  # 5-10 cm deep, >= 0.9 m long
        assert abs(axes[:, 1] @ HEADING) > 1 - 1e-5  # the depth runs along the line: met edge-on
        assert abs(abs(axes[:, 0] @ normal) - 1) < 1e-5  # all fins parallel
        x = float((centre - entry) @ HEADING)
        leading = min(leading, x - half[1])
        banks.setdefault(int(x > 0.5 * (gen["bank_positions"][0] + gen["bank_positions"][1])), []).append(
            (float((centre - entry) @ normal), 2 * half[0]))
    assert 0.15 - 1e-6 <= leading <= 0.23 + 1e-6  # the entry goal stands before the first leading edges
    # each bank's channels, measured between its fins, are all one width; one is centred where the params say,
    # and those two lie on opposite sides of the line
    sides = []
    for k in (0, 1):
        fin_at, thick = np.array(sorted(banks[k])).T
        widths = np.diff(fin_at) - thick[0]
        assert np.allclose(widths, gen["channel_widths"][k], atol=2e-4)
        assert 0.12 - 1e-6 <= widths[0] <= 0.153 - 0.03 * difficulty + 1e-4
        centres = 0.5 * (fin_at[1:] + fin_at[:-1])
        near = int(np.argmin(np.abs(np.abs(centres) - abs(gen["channel_offsets"][k]))))
        assert abs(abs(centres[near]) - abs(gen["channel_offsets"][k])) < 2e-4
        sides.append(np.sign(centres[near]))
        assert fin_at.min() < -0.2 and fin_at.max() > 0.2  # the bank reaches across the line both ways
    assert sides[0] == -sides[1] != 0
    # the straight segment entry -> final comes within the tip's radius of a fin
    line = entry + np.linspace(0.0, 1.0, 500)[:, None] * (final - entry)
    assert obstacle_distance(fins, line).min() < 0.025
    # between the banks, free of fins: the S-curve's length plus the straight 3-6 cm beyond each bank
    x, depth = np.array(gen["bank_positions"]), np.array(gen["fin_half_depths"])
    gap = x[1] - x[0] - depth.sum()
    assert 0.36 - 0.1 * difficulty + 2 * 0.03 - 1e-9 <= gap <= 0.45 - 0.1 * difficulty + 2 * 0.06 + 1e-9
    # cables: parallel to the fins' length, between the banks, clear of every fin by 5 mm
    for c in cables:
        assert isinstance(c, Cylinder) and 0.005 <= c.radius <= 0.01
        along = (c.p1 - c.p0) / np.linalg.norm(c.p1 - c.p0)
        assert abs(along @ HEADING) < 1e-4 and abs(along @ normal) < 1e-4
        assert x[0] + depth[0] < (c.p0 - entry) @ HEADING < x[1] - depth[1]
        axis = c.p0 + np.linspace(0.0, 1.0, 200)[:, None] * (c.p1 - c.p0)
        assert obstacle_distance(fins, axis).min() - c.radius >= 0.005 - 1e-4


def test_fin_bank_rolls_sides_and_cables_vary():
    worlds = [generate_world("fin-bank", s, 0.5).extra["generator"] for s in range(12)]
    assert_rolls_vary([g["roll_deg"] for g in worlds])
    assert {np.sign(g["channel_offsets"][0]) for g in worlds} == {-1.0, 1.0}
    assert {g["cables"] for g in worlds} == {1, 2}  # round(2 d) plus a coin toss
    assert max(max(g["fin_thicknesses"]) for g in worlds) > 0.005


@pytest.mark.parametrize(("seed", "difficulty"), [(s, d) for s in range(3) for d in (0.0, 1.0)])
def test_rod_forest_rods_are_thin_parallel_and_block_the_line(seed, difficulty):
    w = generate_world("rod-forest", seed, difficulty)
    gen = w.extra["generator"]
    assert len(w.goals) == 2 and gen["structure_obstacles"] == len(w.obstacles) == gen["rods"]
    lo, hi = 0.006 - 0.002 * difficulty, 0.012 - 0.004 * difficulty
    axes = []
    for o in w.obstacles:
        assert isinstance(o, Cylinder) and lo - 1e-4 <= o.radius <= hi + 1e-4
        axes.append((o.p1 - o.p0) / np.linalg.norm(o.p1 - o.p0))
    axes = np.array(axes)
    assert np.allclose(np.abs(axes @ axes[0]), 1.0, atol=1e-4)  # all parallel ...
    assert np.abs(axes @ HEADING).max() < 1e-4  # ... and across the approach
    entry, final = w.goal_positions
    assert 0.82 - 1e-6 <= np.linalg.norm(final - entry) <= 0.98 + 1e-6  # the lobe and the straight after it
    line = entry + np.linspace(0.0, 1.0, 500)[:, None] * (final - entry)
    blockers = w.obstacles[: gen["blockers"]]
    assert 1 <= len(blockers) <= 3
    assert all(obstacle_distance((b,), line).min() < 0.007 for b in blockers)  # each on the straight line
    # the rods stand between the entry goal and 0.1 m before the destination, up to 0.3 m to either side
    centres = np.array([(o.p0 + o.p1) / 2 for o in w.obstacles]) - entry
    along = centres @ HEADING
    assert along.min() >= -1e-6 and along.max() <= np.linalg.norm(final - entry) - 0.1 + 1e-6
    across = centres @ np.array(gen["lobe_direction"])
    assert np.abs(across).max() <= 0.3 + 1e-6 and across.min() < -0.15 and across.max() > 0.15
    # the way winds aside by what a 0.3 m turn radius allows at most
    assert gen["lobe_height"] <= gen["lobe_length"] ** 2 / (2 * np.pi**2 * 0.3) + 1e-4
    ref = reference_path(TIP, HEADING, gen["reference_via"])
    aside = np.linalg.norm(np.cross(ref.points - TIP, HEADING), axis=1).max()
    assert abs(aside - gen["lobe_height"]) < 0.005


def test_rod_forest_grows_denser_and_thinner_with_difficulty():
    assert_rolls_vary([generate_world("rod-forest", s, 0.5).extra["generator"]["roll_deg"] for s in range(12)])
    easy = [generate_world("rod-forest", s, 0.0) for s in range(3)]
    hard = [generate_world("rod-forest", s, 1.0) for s in range(3)]
    assert max(len(w.obstacles) for w in easy) < min(len(w.obstacles) for w in hard)
    assert max(o.radius for w in hard for o in w.obstacles) < max(o.radius for w in easy for o in w.obstacles)


@pytest.mark.parametrize(("seed", "difficulty"), [(0, 0.0), (1, 0.5), (2, 1.0), (3, 1.0)])
def test_sparse_truss_gives_an_inspection_point_inside_and_the_exit_only(seed, difficulty):
    w = generate_world("sparse-truss", seed, difficulty)
    gen = w.extra["generator"]
    n = gen["structure_obstacles"]
    truss, clutter = w.obstacles[:n], w.obstacles[n:]
    inspect, exit_ = w.goal_positions
    assert len(w.goals) == 2 and gen["manoeuvre"] in ("climb", "side")
    ends = np.array([p for o in truss for p in (o.p0, o.p1)])
    assert np.all(inspect > ends.min(axis=0)) and np.all(inspect < ends.max(axis=0))  # inside the truss
    assert obstacle_distance(truss, inspect[None])[0] >= 0.07
    assert np.allclose(exit_, gen["reference_via"][-1], atol=1e-6)  # the exit, not the openings
    assert len(gen["reference_via"]) >= 3  # the hidden way: in front of the opening, through it, the turn
    # clutter beside the way: 17 mm to 5.2 cm from the tip's surface on the reference path
    ref = reference_path(TIP, HEADING, gen["reference_via"])
    assert len(clutter) >= 3
    near = [obstacle_distance([o], ref.points).min() - 0.025 for o in clutter[gen["blockers"]:]]
    assert all(0.015 <= g <= 0.053 for g in near), near
    # where the truss does not block the goals-only spline, one sphere of equipment does
    assert gen["blocked_by"] in ("truss", "clutter")
    assert gen["blockers"] == (1 if gen["blocked_by"] == "clutter" else 0)


@pytest.mark.parametrize(("seed", "difficulty"), [(0, 0.0), (1, 0.5), (2, 1.0)])
def test_bend_clutter_goals_before_and_after_the_bend_clutter_on_both_sides(seed, difficulty):
    w = generate_world("bend-clutter", seed, difficulty)
    gen = w.extra["generator"]
    column, plate, *clutter = w.obstacles
    entry, dest = w.goal_positions
    assert isinstance(column, Cylinder) and len(w.goals) == 2 and len(clutter) == gen["clutter"] >= 2
    assert 60.0 <= gen["bend_deg"] <= 110.0 and 0.3 <= gen["bend_radius"] <= 0.45
    # the entry goal is on the straight before the bend, the destination after it
    assert np.linalg.norm(np.cross(entry - TIP, HEADING)) < 1e-6
    assert gen["straight"] - 0.12 - 1e-6 <= (entry - TIP) @ HEADING <= gen["straight"] - 0.05 + 1e-6
    # heading for the goals cuts the corner through the column
    goal_path = reference_path(TIP, HEADING, w.goal_positions)
    assert obstacle_distance([column], goal_path.points).min() < 0.0
    # clutter on the inside (towards the column) and the outside of the bend
    ref = reference_path(TIP, HEADING, gen["reference_via"])
    axis = column.p1 - column.p0
    axis /= np.linalg.norm(axis)
    sides = set()
    for o in clutter:
        c = o.center if not isinstance(o, Cylinder) else (o.p0 + o.p1) / 2
        p = ref.points[np.argmin(np.linalg.norm(ref.points - c, axis=1))]
        towards = column.p0 - p
        towards -= (towards @ axis) * axis
        sides.add(bool((c - p) @ towards > 0))
    assert sides == {True, False}


@pytest.mark.parametrize(("seed", "difficulty"), [(0, 0.0), (1, 1.0), (2, 0.5), (6, 1.0)])  # 6: a cage
def test_dead_end_goal_at_the_back_of_a_pocket_retract_by_default(seed, difficulty, tmp_path):
    w = generate_world("dead-end", seed, difficulty)
    gen = w.extra["generator"]
    assert w.retract and w.name == f"dead-end-s{seed:04d}-d{difficulty:.2f}" and len(w.goals) == 1
    assert w.time_limit == time_limit_for(gen["checks"]["path_length"], True)
    report = check_world(w)
    assert report.ok and report.body_clearance >= 0.012, report.problems
    goal, axis = w.goal_positions[0], np.array(gen["axis"])
    pocket = w.obstacles[: gen["structure_obstacles"]]
    assert 0.07 - 1e-6 <= gen["depth"] - (goal - np.array(gen["mouth"])) @ axis <= 0.1 + 1e-6
    # closed but towards the mouth: the tip cannot leave the goal in any direction except out of the mouth
    rng = np.random.default_rng(0)
    for d in rng.normal(size=(300, 3)):
        d /= np.linalg.norm(d)
        if d @ axis > -0.5:
            ray = goal + np.linspace(0.0, 0.8, 400)[:, None] * d
            assert obstacle_distance(pocket, ray).min() < 0.025, d
    out = generate_world("dead-end", seed, difficulty, retract=False)
    assert not out.retract and out.name == w.name + "-noretract" and out.obstacles == w.obstacles


def test_dead_end_has_box_tubes_and_cages():
    kinds = {generate_world("dead-end", s, 0.5).extra["generator"]["kind"] for s in range(8)}
    assert kinds == {"box tube", "cage"}


def test_curve_arcs_end_where_the_closed_form_puts_them():
    """:func:`duct_elbow.curve`: straight 0.1 m, then a quarter circle of radius 0.3 m towards ``b``: it ends
    at ``TIP + 0.1 h + 0.3 (h + b)`` heading along ``b``, every point of the arc 0.3 m from its centre."""
    b = np.cross(HEADING, [0.0, 0.0, 1.0])
    b /= np.linalg.norm(b)
    pts, tans, arcs = curve([(0.1, 0.0, None), (0.3 * np.pi / 2, 0.3, b + 0.4 * HEADING)], step=0.01)
    assert np.allclose(pts[-1], TIP + 0.1 * HEADING + 0.3 * (HEADING + b), atol=1e-12)
    assert np.allclose(tans[-1], b, atol=1e-12) and arcs[-1] == pytest.approx(0.1 + 0.15 * np.pi)
    centre = TIP + 0.1 * HEADING + 0.3 * b
    on_arc = arcs >= 0.1
    assert np.allclose(np.linalg.norm(pts[on_arc] - centre, axis=1), 0.3, atol=1e-12)
    assert np.allclose(np.linalg.norm(np.diff(pts, axis=0), axis=1), np.diff(arcs), rtol=1e-3)


@pytest.mark.parametrize(("seed", "difficulty"), [(0, 0.0), (1, 1.0), (2, 0.5), (5, 1.0)])
def test_duct_elbow_walls_enclose_the_way_round_the_elbow(seed, difficulty):
    """The hidden way runs inside the duct: from the mouth on, every reference point is about the half width
    from the walls (never closer than the serpentine radius + 15 mm), the straight line from the tip to the
    goal cuts a wall, and the duct turns by the drawn elbow angle."""
    w = generate_world("duct-elbow", seed, difficulty)
    gen = w.extra["generator"]
    duct = w.obstacles[: gen["structure_obstacles"]]
    h = gen["half_width"]
    assert 0.07 - 1e-9 <= h <= 0.1 and len(w.goals) == 1 and not w.retract
    ref = reference_path(TIP, HEADING, np.array(gen["reference_via"]))
    inside = ref.points[ref.arc >= gen["mouth_ahead"] + 0.05]
    d = obstacle_distance(duct, inside)
    assert d.min() >= 0.025 + 0.015 and d.max() <= np.sqrt(2.0) * h + 0.01
    line = TIP + np.linspace(0.0, 1.0, 400)[:, None] * (w.goal_positions[0] - TIP)
    assert obstacle_distance(duct, line).min() < 0.0
    via = np.array(gen["reference_via"])
    t0, t1 = via[1] - via[0], via[-1] - via[-2]
    turn = np.degrees(np.arccos(t0 @ t1 / np.linalg.norm(t0) / np.linalg.norm(t1)))
    assert turn <= gen["elbow_deg"] + gen["tilt_deg"] + 2.0 and turn >= abs(gen["elbow_deg"] - gen["tilt_deg"]) - 2.0


# --------------------------------------------------------------------------- retract


def test_retract_option_same_world_longer_time_limit(tmp_path):
    plain = generate_world("slot-rack", 2, 0.5)
    back = generate_world("slot-rack", 2, 0.5, retract=True)
    assert back.retract and not plain.retract
    assert back.name == plain.name + "-retract"
    assert back.obstacles == plain.obstacles and back.goals == plain.goals
    length = back.extra["generator"]["checks"]["path_length"]
    assert back.extra["generator"]["return_length"] == pytest.approx(length)
    assert back.time_limit == time_limit_for(length, True) > plain.time_limit == time_limit_for(length, False)
    assert time_limit_for(1.5, True) == 150.0 and time_limit_for(0.5, True) == 60.0
    assert check_world(back).ok
    save_world(back, tmp_path / "r.json")
    assert load_world(tmp_path / "r.json") == back
    with pytest.raises(ValueError, match="retract"):
        generate_world("slot-rack", 2, 0.5, retract="yes")


def test_cli_generate_retract(tmp_path, capsys):
    out = tmp_path / "g.json"
    assert main(["generate", "slot-rack", "--seed", "1", "--retract", "--out", str(out)]) == 0
    assert load_world(out) == generate_world("slot-rack", 1, 0.5, retract=True)
    assert "slot-rack-s0001-d0.50-retract" in capsys.readouterr().out
    assert main(["generate", "slot-rack", "--seed", "1", "--no-retract", "--out", str(out)]) == 0
    assert not load_world(out).retract


def test_family_examples_in_worlds_are_regenerated_identically(tmp_path):
    written = write_family_examples(tmp_path)
    assert [f.name for f in written] == [e[0] for e in FAMILY_EXAMPLES]
    for f in written:
        w = load_world(f)
        assert w == load_world(WORLDS / f.name), f"worlds/{f.name} is stale: rerun write_family_examples('worlds')"
        assert check_world(w).ok


# --------------------------------------------------------------------------- closed loop


@pytest.mark.slow
@pytest.mark.parametrize(("family", "seed", "difficulty"), [("slot-rack", 0, 0.5), ("slot-rack", 1, 1.0),
                                                          ("sparse-truss", 1, 1.0), ("bend-clutter", 0, 1.0),
                                                          ("fin-bank", 0, 1.0), ("rod-forest", 0, 1.0),
                                                          ("duct-elbow", 1, 1.0), ("sized-slot-rack", 6, 1.0),
                                                          ("sized-slot-rack", 3, 0.5)])
def test_scripted_collides_on_the_goals_but_follows_the_reference_through(family, seed, difficulty):
    w = generate_world(family, seed, difficulty)
    blind = run_trial(w, planner="scripted")
    assert not blind.success and blind.reason == "collision" and blind.metrics["contacts"] > 0
    ref = run_trial(with_reference_goals(w), planner="scripted")
    assert ref.success and ref.metrics["contacts"] == 0 and ref.metrics["min_clearance"] > 0.01, ref
