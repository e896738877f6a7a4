"""PathMemory: the recorded tip path and the chord-rule slithering chain on it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navstack import jpl_serpentine
from navstack.path import PathMemory, full_distance

L = 0.2
M = 7  # tip + J1..J6


# ---------------------------------------------------------------- analytic test curves
def _line(s: np.ndarray) -> np.ndarray:
    s = np.atleast_1d(s)
    return np.stack([0.1 + 0 * s, -0.2 + 0 * s, 0.5 + s], axis=1)


R_CIRCLE = 0.3


def _circle(s: np.ndarray, radius: float = R_CIRCLE) -> np.ndarray:
    """Straight along +z for s < 0, then a circle of ``radius`` in the x-z plane (tangent at s = 0)."""
    s = np.atleast_1d(s)
    ph = np.clip(s, 0, None) / radius
    arc = np.stack([radius - radius * np.cos(ph), 0 * s, radius * np.sin(ph)], axis=1)
    arc[s < 0, 2] = s[s < 0]
    return arc


R_HELIX, C_HELIX = 0.3, 0.25 / (2 * np.pi)  # radius, rise per radian
K_HELIX = np.hypot(R_HELIX, C_HELIX)


def _helix(s: np.ndarray) -> np.ndarray:
    """Helix about the z axis (radius 0.3 m, pitch 0.25 m), extended along its tangent for s < 0."""
    s = np.atleast_1d(s)
    ph = np.clip(s, 0, None) / K_HELIX
    out = np.stack([R_HELIX * np.cos(ph), R_HELIX * np.sin(ph), C_HELIX * ph], axis=1)
    t0 = np.array([0.0, R_HELIX, C_HELIX]) / K_HELIX
    neg = s < 0
    out[neg] = np.array([R_HELIX, 0.0, 0.0]) + s[neg, None] * t0
    return out


HELIX_CURVATURE_RADIUS = (R_HELIX**2 + C_HELIX**2) / R_HELIX


DENSE_STEP = 1e-4


def _dense(curve, s0: float, s1: float) -> np.ndarray:
    """The curve as a fine polyline (step 0.1 mm: within DENSE_STEP^2 / (8 rho) < 5e-9 m of it)."""
    return np.ascontiguousarray(curve(np.arange(s0, s1, DENSE_STEP)))


def _backbone(curve) -> np.ndarray:
    """Tip at s = 0 and J1..J6 behind it on the (straight) part s < 0."""
    return curve(-L * np.arange(M))


def _drive(curve, s_end: float, ds: float = 4e-4, spacing: float = 1e-3):
    """Record the tip along ``curve`` up to ``s_end``; yield (path, tip, chain points) every step."""
    pm = PathMemory(_backbone(curve), link_length=L, spacing=spacing)
    for s in np.arange(ds, s_end + 1e-12, ds):
        tip = curve(s)[0]
        pm.record(tip)
        pts, _ = pm.chain(tip, np.zeros(3))
        yield pm, tip, pts


def _check_chain(curve, s_end: float, curvature_radius: float | None) -> PathMemory:
    dense = _dense(curve, -1.3, s_end + 0.01)
    worst_gap = worst_on = worst_curve = 0.0
    pm = None
    for step, (pm, tip, pts) in enumerate(_drive(curve, s_end)):
        chain = np.vstack([tip, pts])
        gaps = np.linalg.norm(np.diff(chain, axis=0), axis=1)
        worst_gap = max(worst_gap, float(np.abs(gaps - L).max()))
        if step % 10 == 0:
            for p in pts:
                worst_on = max(worst_on, pm.distance_to_path(p))
                worst_curve = max(worst_curve, float(full_distance(dense, len(dense), p)))
    assert pm is not None
    assert worst_gap <= 1e-9, worst_gap
    assert worst_on <= 1e-9, worst_on
    seg = np.linalg.norm(np.diff(pm.points, axis=0), axis=1)
    if curvature_radius is None:
        assert worst_curve <= 1e-9, worst_curve
    else:
        # vertices lie on the curve: the polyline is within its sagitta h^2/(8 rho) of the curve
        h = seg[seg < 0.9 * L].max()
        sagitta = h**2 / (8 * curvature_radius)
        dense_sagitta = DENSE_STEP**2 / (8 * curvature_radius)
        assert worst_curve <= 1.02 * sagitta + dense_sagitta, (worst_curve, sagitta)
        assert worst_curve > 0.0
    return pm


# ---------------------------------------------------------------- initialisation
def test_backbone_initialisation_reproduces_the_joint_points_exactly():
    chain = jpl_serpentine()
    for q in (chain.q_default, np.random.default_rng(3).uniform(chain.lower, chain.upper)):
        bb = chain.points_and_jacobians(q)[0]
        pm = PathMemory(bb)
        pts, vel = pm.chain(bb[0], np.zeros(3))
        np.testing.assert_allclose(pts, bb[1:], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(vel, 0.0)
        # vertices: extension end, J6 ... J1, tip
        np.testing.assert_array_equal(pm.points[1:], bb[::-1])
        ext = pm.points[0] - bb[-1]
        np.testing.assert_allclose(np.linalg.norm(ext), 3 * L, rtol=1e-12)
        d56 = (bb[-1] - bb[-2]) / np.linalg.norm(bb[-1] - bb[-2])
        np.testing.assert_allclose(ext / np.linalg.norm(ext), d56, atol=1e-12)
        assert pm.length == pytest.approx(3 * L + 6 * L, abs=1e-12)
        for p in bb[1:]:
            assert pm.distance_to_path(p) <= 1e-12


def test_bad_backbone_and_inputs_raise_clear_errors():
    bb = _backbone(_line)
    with pytest.raises(ValueError, match="backbone points 2 and 3"):
        bad = bb.copy()
        bad[3:] += [0.0, 0.0, 0.01]
        PathMemory(bad)
    with pytest.raises(ValueError, match="shape"):
        PathMemory(bb[:, :2])
    with pytest.raises(ValueError, match="extension"):
        PathMemory(bb, extension=0.3)
    with pytest.raises(ValueError, match="spacing"):
        PathMemory(bb, spacing=0.05)
    pm = PathMemory(bb)
    with pytest.raises(ValueError, match="x_tip"):
        pm.record([0.0, np.nan, 1.0])
    with pytest.raises(ValueError, match="xdot_tip"):
        pm.chain(bb[0], [0.0, np.inf, 0.0])
    with pytest.raises(ValueError, match="x_tip"):
        pm.chain([0.0, 1.0], np.zeros(3))
    with pytest.raises(ValueError, match="joint"):
        pm.distance_to_path(bb[1], joint=7)
    assert pm.n_points == M + 1  # nothing recorded by the failed calls


def test_record_keeps_the_spacing_and_grows_its_storage():
    bb = _backbone(_line)
    pm = PathMemory(bb, spacing=1e-3, capacity=16)
    assert not pm.record(bb[0] + [0.0, 0.0, 5e-4])  # too close to the last vertex
    n0 = pm.n_points
    for s in np.arange(1e-3, 0.5, 2.5e-4):
        pm.record(_line(s)[0])
    pts = pm.points
    gaps = np.linalg.norm(np.diff(pts[n0 - 1 :], axis=0), axis=1)
    assert gaps.min() >= 1e-3 - 1e-15
    assert gaps.max() <= 1e-3 + 2.5e-4 + 1e-12
    assert pm.capacity >= pm.n_points > 16  # grew past the initial 16 slots
    np.testing.assert_array_equal(pts[1 : M + 1], bb[::-1])  # old vertices survived the growth
    np.testing.assert_allclose(pm.arc_length[-1], pm.length)
    np.testing.assert_allclose(pm.length, 9 * L + np.linalg.norm(pts[-1] - bb[0]), atol=1e-12)


# ---------------------------------------------------------------- chord geometry
def test_straight_line_chain_points_are_exact():
    _check_chain(_line, 1.0, curvature_radius=None)


def test_circle_chain_points_lie_on_the_path_one_link_apart():
    pm = _check_chain(_circle, 1.5, curvature_radius=R_CIRCLE)
    assert pm.overruns == 0 and pm.singular == 0


def test_helix_chain_points_lie_on_the_path_one_link_apart():
    _check_chain(_helix, 2.0, curvature_radius=HELIX_CURVATURE_RADIUS)


def test_chord_points_follow_the_analytic_circle_chord_rule():
    """Deep inside the arc, consecutive chord points subtend 2 asin(L / 2R) on the circle."""
    *_, (pm, tip, pts) = _drive(_circle, 1.5)
    chain = np.vstack([tip, pts])
    assert np.all(chain[:, 0] > 0)  # all on the arc
    ang = np.unwrap(np.arctan2(chain[:, 2], R_CIRCLE - chain[:, 0]))
    np.testing.assert_allclose(-np.diff(ang), 2 * np.arcsin(L / (2 * R_CIRCLE)), atol=1e-5)


def test_velocities_match_finite_differences_of_the_chord_points():
    """Straight -> tight arc (radius 0.15 m) transition: chord point speeds differ from the tip's."""
    v, dt, radius = 0.05, 0.004, 0.15  # the tip moves 0.2 mm per step

    def curve(s):
        return _circle(s, radius)

    pm = PathMemory(_backbone(curve), link_length=L, spacing=1e-3)
    P, Vel = [], []
    for k in range(1, int(0.8 / (v * dt))):
        s = k * v * dt
        tip = curve(s)[0]
        tangent = (curve(s + 1e-7)[0] - curve(s - 1e-7)[0]) / 2e-7
        pm.record(tip)
        pts, vel = pm.chain(tip, v * tangent)
        P.append(pts)
        Vel.append(vel)
    P, Vel = np.array(P), np.array(Vel)
    fd = (P[2:] - P[:-2]) / (2 * dt)
    err = np.linalg.norm(fd - Vel[1:-1], axis=2)
    assert err.max() <= 0.01 * v, err.max() / v
    speeds = np.linalg.norm(Vel, axis=2)
    assert np.abs(speeds - v).max() > 0.1 * v  # a non-trivial case: not every point moves at tip speed
    # rigid chord: d/dt |P_i - P_{i-1}|^2 = 0 holds for the returned velocities
    # (checked on J2..J6, whose predecessor's velocity is also returned)
    chords = P[:, 1:] - P[:, :-1]
    rel = Vel[:, 1:] - Vel[:, :-1]
    assert np.abs(np.einsum("tij,tij->ti", chords, rel)).max() <= 1e-12


def test_pointer_work_per_step_is_bounded_and_independent_of_history():
    pm = PathMemory(_backbone(_line), link_length=L, spacing=1e-3)
    per_step = []
    for s in np.arange(5e-4, 6.0, 5e-4):  # 6 m of path: ~6000 vertices
        tip = _line(s)[0]
        pm.record(tip)
        pm.chain(tip, np.array([0.0, 0.0, 0.1]))
        per_step.append(pm.last_iterations)
    per_step = np.array(per_step)
    # each of the 6 pointers passes at most one 1 mm vertex per 0.5 mm step
    assert per_step.max() <= 6
    middle, late = per_step[4000:6000].sum(), per_step[-2000:].sum()
    assert late <= 1.1 * middle  # no growth with the length of the history
    assert pm.total_iterations == per_step.sum()
    # total work ~ one pointer move per vertex per joint
    assert pm.total_iterations <= 6 * pm.n_points


def test_retreat_moves_the_chain_back_along_its_path():
    """The tip backs up along its own (curved) path: the path is cut back and the chord points go back too."""
    *_, (pm, tip, pts) = _drive(_circle, 0.8)
    before = pts.copy()
    dense = _dense(_circle, -3.0, 0.81)
    for s in np.arange(0.8, 0.5, -4e-4):  # retreat 0.3 m along the arc
        tip = _circle(s)[0]
        pm.advance(tip, np.zeros(3), reverse=True)
        pts = pm.pts
        chain = np.vstack([tip, pts])
        np.testing.assert_allclose(np.linalg.norm(np.diff(chain, axis=0), axis=1), L, atol=1e-9)
        assert max(full_distance(dense, len(dense), p) for p in pts) < 1e-6  # still on the curve
    assert np.all(pts[:, 2] < before[:, 2] + 1e-9) and np.linalg.norm(pts - before) > 0.2
    assert pm.end_arc_length == pytest.approx(pm.start_arc_length + 0.5, abs=5e-4)
    # the head is the nearest point of the recorded chords (up to 1.2 mm long: sagitta 6e-7 m) to the command
    np.testing.assert_allclose(pm.head, tip, atol=1e-6)


# ---------------------------------------------------------------- distances
def test_windowed_distance_equals_exact_near_the_chain_and_never_underestimates():
    rng = np.random.default_rng(5)
    *_, (pm, tip, pts) = _drive(_helix, 1.5)
    worst_near = 0.0
    for i, p in enumerate(pts, start=1):
        for scale in (1e-4, 1e-3, 1e-2, 0.05):
            q = p + rng.normal(size=3) * scale
            exact = pm.distance_to_path(q)
            windowed = pm.distance_to_path(q, joint=i)
            assert windowed >= exact - 1e-15
            worst_near = max(worst_near, windowed - exact)
        # brute force: distance to the vertices is an upper bound, close to exact at 1 mm spacing
        assert exact <= np.linalg.norm(pm.points - q, axis=1).min() + 1e-15
    assert worst_near <= 1e-12
    dev = pm.max_deviation(pts + [0.0, 0.0, 2e-3])
    assert 0 < dev <= 2e-3 + 1e-12


def test_distance_to_path_against_brute_force():
    pm = PathMemory(_backbone(_line), link_length=L)
    p = _line(-0.3)[0] + np.array([0.03, 0.04, 0.0])
    assert pm.distance_to_path(p) == pytest.approx(0.05, abs=1e-12)
    beyond = pm.points[0] + np.array([0.0, 0.0, -0.1])  # past the extension's end
    assert pm.distance_to_path(beyond) == pytest.approx(0.1, abs=1e-12)


def test_max_distance_to_path_is_the_largest_exact_distance():
    pm = PathMemory(_backbone(_line), link_length=L)
    rng = np.random.default_rng(4)
    for _ in range(50):
        pts = pm.points[0] + rng.normal(size=(6, 3)) * 0.2
        assert pm.max_distance_to_path(pts) == max(pm.distance_to_path(p) for p in pts)
    assert pm.max_distance_to_path(np.zeros((0, 3))) == -np.inf
    with pytest.raises(ValueError, match="points"):
        pm.max_distance_to_path(np.zeros((2, 2)))


# ---------------------------------------------------------------- reverse slithering
SKEW = Rotation.from_rotvec([0.3, -0.5, 0.7]).as_matrix()
"""A rotation that mixes every axis: a line along no coordinate axis (an axis-aligned line hid a wrong
vertex index in one coordinate of the extrapolation's direction, a mutant that survived)."""


@pytest.mark.parametrize("frame", ["axis", "skew"])
@pytest.mark.parametrize("retreat", [0.5, 0.8, 0.9, 1.0, 1.15])
def test_retreat_past_the_extension_end_keeps_every_joint_behind_the_previous(retreat, frame):
    """Issue 14: once J5 is past the end of the initial extension, J6 took the wrong root (folded onto J4).

    The tip backs ``retreat`` metres straight along its initial backbone; every chord point must then be
    one link behind the one before it on the extrapolated line (extension 0.6 m behind J6: J5 leaves it
    for retreats over 0.8 m).  ``skew``: the same, the whole line rotated off the coordinate axes.
    """
    R = np.eye(3) if frame == "axis" else SKEW
    bb = _backbone(_line) @ R.T  # tip at s = 0, J1..J6 behind it along -z (rotated)
    pm = PathMemory(bb, link_length=L)
    back = R @ np.array([0.0, 0.0, -0.05])
    for s in np.arange(0.0, retreat + 1e-12, 0.002):
        tip = _line(-s)[0] @ R.T
        pts, _ = pm.chain(tip, back)
    expected = _line(-retreat - L * np.arange(1, M)) @ R.T
    np.testing.assert_allclose(pts, expected, rtol=0, atol=1e-9)


def test_point_at_and_truncate_cut_the_path_back_to_an_arc_length():
    *_, (pm, tip, _) = _drive(_circle, 0.5)
    dense = _dense(_circle, -1.3, 0.51)
    end = pm.end_arc_length
    np.testing.assert_allclose(pm.point_at(end)[0], tip, atol=1e-12)
    assert end == pytest.approx(pm.start_arc_length + 0.5, abs=1e-6)  # polyline of ~1 mm chords on the arc
    S, P = pm.arc_length, pm.points
    for k in (0, 3, 7, len(S) // 2, len(S) - 1):
        np.testing.assert_allclose(pm.point_at(S[k])[0], P[k], atol=1e-12)
    for s in np.linspace(pm.start_arc_length + 0.01, end - 0.01, 17):  # on the arc: point and tangent
        p, t = pm.point_at(s)
        u = s - pm.start_arc_length
        assert full_distance(dense, len(dense), p) < 1e-6  # on the chords: within their sagitta (4e-7 m)
        assert np.linalg.norm(p - _circle(u)[0]) < 1e-5  # chords are shorter than the arc: the parameter drifts
        tangent = (_circle(u + 1e-7)[0] - _circle(u - 1e-7)[0]) / 2e-7
        assert np.linalg.norm(t - tangent) < 4e-3 and np.linalg.norm(t) == pytest.approx(1.0)
    s_cut = pm.start_arc_length + 0.2345
    p_cut, _ = pm.point_at(s_cut)
    pm.truncate(s_cut)
    assert pm.end_arc_length == pytest.approx(s_cut, abs=1e-15)
    np.testing.assert_allclose(pm.head, p_cut, atol=1e-15)
    np.testing.assert_allclose(pm.points[-1], p_cut, atol=1e-15)  # the turning point became a vertex
    assert pm.arc_length.max() == pytest.approx(s_cut, abs=1e-15)
    beyond = _circle(0.3)[0]  # dropped: now farther from the path than the sagitta
    assert pm.distance_to_path(beyond) > 0.05
    for bad in (0.0, -1.0, s_cut + 1e-3, np.nan):
        with pytest.raises(ValueError, match="arc length"):
            pm.truncate(bad)
    with pytest.raises(ValueError, match="arc length"):
        pm.point_at(s_cut + 1e-3)


def test_points_at_is_point_at_for_many_arc_lengths_bit_for_bit():
    """The vectorized lookup (the planner's history) gives point_at's values exactly: on vertices, between
    them, on the live segment, at the end, and after a cut where the head is the last vertex."""
    *_, (pm, _, _) = _drive(_circle, 0.5)
    rng = np.random.default_rng(3)

    def check():
        S, end = pm.arc_length, pm.end_arc_length
        s = np.concatenate([rng.uniform(0.0, end, 400), S[:: max(len(S) // 20, 1)], [0.0, S[-1], end],
                            np.linspace(S[-1], end, 5)])
        expected = np.array([pm.point_at(x)[0] for x in s])
        np.testing.assert_array_equal(pm.points_at(s), expected)

    check()
    pm.truncate(pm.start_arc_length + 0.2345)
    check()
    assert pm.points_at([]).shape == (0, 3)
    for bad in ([-1e-3], [pm.end_arc_length + 1e-3], [np.nan]):
        with pytest.raises(ValueError, match="arc length"):
            pm.points_at(bad)


def test_truncation_work_is_bounded_by_the_dropped_vertices():
    """A long history, then a retreat in small steps: each step visits only what it drops (no scan)."""
    pm = PathMemory(_backbone(_line), link_length=L, spacing=1e-3)
    for s in np.arange(5e-4, 6.0, 5e-4):
        pm.record(_line(s)[0])
    n_long = pm.n_points
    counts = []
    for _ in range(1, 200):  # back 2 mm per step
        s = pm.end_arc_length - 2e-3
        n0 = pm.n_points
        pm.advance(_line(s - pm.start_arc_length)[0], np.array([0.0, 0.0, -0.06]), reverse=True)
        counts.append(n0 - pm.n_points)
    assert max(counts) <= 3  # 2 mm of ~1 mm segments and the previous turning point
    assert n_long - pm.n_points >= 199 and pm.end_arc_length == pytest.approx(7.7995 - 0.398, abs=1e-9)


def test_reverse_then_a_new_branch_keeps_the_old_part_under_the_joints():
    """In along a circle, back 0.15 m, then straight on along the tangent at the turning point."""
    v, dt = 0.05, 0.004
    pm = PathMemory(_backbone(_circle), link_length=L, spacing=1e-3)
    for s in np.arange(v * dt, 0.6 + 1e-12, v * dt):
        pm.advance(_circle(s)[0], v * (_circle(s + 1e-7)[0] - _circle(s - 1e-7)[0]) / 2e-7)
    s_end = pm.end_arc_length
    for k in range(1, round(0.15 / (v * dt)) + 1):
        p, t = pm.point_at(s_end - k * v * dt)
        pm.advance(p, -v * t, reverse=True)
    assert pm.end_arc_length == pytest.approx(s_end - 0.15, abs=1e-9)
    turn, tangent = pm.point_at(pm.end_arc_length)
    n_turn = pm.n_points
    dense_old = _dense(_circle, -3.0, 0.45)
    for k in range(1, 300):  # 0.06 m of a new straight branch
        pm.advance(turn + k * v * dt * tangent, v * tangent)
        branch = np.vstack([pm.points[n_turn - 1 :], pm.head])
        chain = np.vstack([pm.head, pm.pts])
        np.testing.assert_allclose(np.linalg.norm(np.diff(chain, axis=0), axis=1), L, atol=1e-9)
        on_old = [p for p in pm.pts if full_distance(dense_old, len(dense_old), p) < 1e-6]
        assert len(on_old) >= 5  # J2..J6 (and J1 for the first 0.2 m) still on the old arc
    np.testing.assert_allclose(pm.points[n_turn - 1], turn, atol=1e-15)  # the new branch starts at the turn
    off = branch - turn
    assert np.abs(off - np.outer(off @ tangent, tangent)).max() < 1e-12  # and is straight along the tangent
    assert pm.distance_to_path(_circle(0.55)[0]) > 0.005  # the retracted arc is gone


def test_reverse_chain_velocities_match_finite_differences():
    v, dt, radius = 0.05, 0.004, 0.15

    def curve(s):
        return _circle(s, radius)

    pm = PathMemory(_backbone(curve), link_length=L, spacing=1e-3)
    for s in np.arange(v * dt, 0.8, v * dt):
        pm.advance(curve(s)[0], np.zeros(3))
    P, Vel = [], []
    s_end = pm.end_arc_length
    for k in range(1, int(0.7 / (v * dt))):
        p, t = pm.point_at(s_end - k * v * dt)
        pm.advance(p, -v * t, reverse=True)
        P.append(pm.pts.copy())
        Vel.append(pm.vel.copy())
    P, Vel = np.array(P), np.array(Vel)
    fd = (P[2:] - P[:-2]) / (2 * dt)
    err = np.linalg.norm(fd - Vel[1:-1], axis=2)
    assert err.max() <= 0.01 * v, err.max() / v
    assert np.all(np.diff(P[:, -1, 2]) < 0)  # J6, on the straight part along +z, goes back all the time


def test_a_reverse_command_off_the_path_raises_and_changes_nothing():
    *_, (pm, tip, _) = _drive(_circle, 0.4)
    n, end, ptr = pm.n_points, pm.end_arc_length, pm.ptr.copy()
    with pytest.raises(ValueError, match="retrace the path"):
        pm.advance(tip + [0.0, 0.01, 0.0], np.zeros(3), reverse=True)
    with pytest.raises(ValueError, match="x_tip"):
        pm.advance([np.nan, 0.0, 0.0], np.zeros(3), reverse=True)
    assert pm.n_points == n and pm.end_arc_length == end
    np.testing.assert_array_equal(pm.ptr, ptr)


def test_a_retreat_cannot_cut_the_path_back_past_the_extension_end():
    """The path may be cut back to any point after the extension's end (arc length 0, ``MIN_ARC``), never to
    it: a reverse command there is refused (``ValueError``) and the path stays as it was."""
    bb = _backbone(_line)
    pm = PathMemory(bb, link_length=L)
    back = np.array([0.0, 0.0, -0.05])
    end = pm.points[0]  # the extension's end, 0.6 m behind J6
    total = float(np.linalg.norm(bb[0] - end))
    steps = np.arange(0.0, total - 0.001, 0.002)
    for s in steps:
        pm.advance(_line(-s)[0], back, reverse=True)
    assert pm.end_arc_length == pytest.approx(total - steps[-1], abs=1e-9) and pm.end_arc_length > 0
    before = (pm.points.copy(), pm.end_arc_length)
    with pytest.raises(ValueError, match="retrace"):
        pm.advance(end, back, reverse=True)
    np.testing.assert_array_equal(pm.points, before[0])
    assert pm.end_arc_length == before[1]
