"""The robot against itself (``navstack.self_contact``): exact segment distances, the pairs checked, and a trial
whose serpentine loops into the arm ending in ``collision`` instead of the success it once reported."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from scipy.optimize import minimize

from navstack import jpl_serpentine, load_world
from navstack.cli import main
from navstack.self_contact import FIRST_SERPENTINE_FRAME, segment_distances, self_clearance, self_pairs
from navstack.sim.probe import build_scene


def _reference(p0, p1, q0, q1) -> float:
    """The least distance between two segments by brute force: the best of a 101 x 101 grid of (s, t), then a
    bounded minimisation from there (scipy's L-BFGS-B on the convex squared distance)."""
    def sq(x):
        g = p0 + (p1 - p0) * x[0] - q0 - (q1 - q0) * x[1]
        return float(g @ g)

    grid = np.linspace(0.0, 1.0, 101)
    s, t = np.meshgrid(grid, grid, indexing="ij")
    gaps = (p0 + (p1 - p0) * s[..., None]) - (q0 + (q1 - q0) * t[..., None])
    k = np.unravel_index(np.argmin(np.einsum("ijk,ijk->ij", gaps, gaps)), s.shape)
    best = minimize(sq, [s[k], t[k]], bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                    options={"ftol": 1e-15, "gtol": 1e-12})
    return float(np.sqrt(min(best.fun, sq([s[k], t[k]]))))


def _segments(rng, n):
    p0, q0 = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    p1, q1 = p0 + rng.normal(size=(n, 3)), q0 + rng.normal(size=(n, 3))
    third = n // 3
    q1[:third] = q0[:third] + (p1[:third] - p0[:third]) * rng.uniform(-2, 2, size=(third, 1))  # parallel
    p1[third:third + 10] = p0[third:third + 10]  # p a point
    q1[third + 5:third + 15] = q0[third + 5:third + 15]  # q a point (and both, for five)
    return p0, p1, q0, q1


def test_segment_distances_equal_a_brute_force_minimisation():
    p0, p1, q0, q1 = _segments(np.random.default_rng(37), 300)
    ours = segment_distances(p0, p1, q0, q1)
    ref = np.array([_reference(*x) for x in zip(p0, p1, q0, q1, strict=True)])
    assert np.all(ours <= ref + 1e-12)  # exact: never above a distance two points actually have
    np.testing.assert_allclose(ours, ref, atol=1e-7)


@pytest.mark.parametrize(("segments", "expected"), [
    (([0, 0, 0], [1, 0, 0], [0.5, -1, 1], [0.5, 1, 1]), 1.0),  # skew, crossing over the middle
    (([0, 0, 0], [1, 0, 0], [0.2, 0.3, 0], [2.0, 0.3, 0]), 0.3),  # parallel, overlapping
    (([0, 0, 0], [1, 0, 0], [1.5, 0, 0], [3, 0, 0]), 0.5),  # collinear, apart
    (([0, 0, 0], [1, 0, 0], [3, 0, 0], [2, 0, 0]), 1.0),  # collinear, reversed
    (([0, 0, 0], [0, 0, 0], [3, 4, 0], [3, 4, 0]), 5.0),  # two points
    (([0, 2, 0], [0, 2, 0], [-1, 0, 0], [1, 0, 0]), 2.0),  # a point over a segment
    (([0, 0, 0], [1, 0, 0], [2, 1, 0], [2, 5, 0]), np.sqrt(2.0)),  # end to end
])
def test_closed_form_cases(segments, expected):
    p0, p1, q0, q1 = (np.array([x], dtype=float) for x in segments)
    assert segment_distances(p0, p1, q0, q1)[0] == pytest.approx(expected, abs=1e-15)
    assert segment_distances(q1, q0, p1, p0)[0] == pytest.approx(expected, abs=1e-15)  # symmetric


def _body():
    world = load_world("worlds/paper_truss.json")
    client, body, _ = build_scene(world)
    client.disconnect()
    return world, body


def test_the_pairs_of_the_jpl_robot():
    _, body = _body()
    frames = np.flatnonzero(body.link_radii > 0.0) + 1
    assert list(frames) == [2, 3, 4, 5, 6, 7, 10, 12, 14, 16, 18, 20]
    i, j = self_pairs(body.link_radii)
    pairs = {(int(frames[a]), int(frames[b])) for a, b in zip(i, j, strict=True)}
    # each serpentine link against the six arm links (but the first against the last, its neighbour), and the
    # serpentine links against each other two or more apart
    assert len(pairs) == len(i) == 6 * 6 - 1 + 10
    assert all(b >= FIRST_SERPENTINE_FRAME for _, b in pairs)  # no arm pair
    assert (7, 10) not in pairs and (10, 12) not in pairs and (6, 10) in pairs and (10, 14) in pairs
    assert (5, 20) in pairs and (18, 20) not in pairs


def test_the_start_posture_keeps_clear_of_itself():
    world, body = _body()
    origins = jpl_serpentine().frames(world.robot.q0)[1:22, :3, 3]
    gap, k = self_clearance(*body.capsules(origins), self_pairs(body.link_radii))
    assert 0.08 < gap < 0.1 and k >= 0  # 90.5 mm: the fourth arm link to the first serpentine link


LOOP = [(2.2, 1.1668), (2.45, 1.4168), (2.2, 1.6668), (1.95, 1.4168), (1.82, 1.1968), (1.9, 1.0168)]
"""Goals (x, z) [m] at y = 0.1079 of a tour that loops back past the tip's start (test_retract.py's)."""


def _capsule_overlap(world, q) -> float:
    """The deepest overlap [m] of a serpentine capsule with an arm capsule not next to it, by sampling 200
    points along each axis (an independent check: no segment formula)."""
    origins = jpl_serpentine().frames(q)[:, :3, 3]
    r = {k: world.robot.arm_radius for k in (2, 3, 4, 5, 6)}
    pts = {k: origins[k] + np.linspace(0, 1, 200)[:, None] * (origins[k + 1] - origins[k]) for k in range(2, 21)}
    worst = np.inf
    for s in (10, 12, 14, 16, 18, 20):
        for a, ra in r.items():
            d = np.linalg.norm(pts[s][:, None] - pts[a][None], axis=2).min()
            worst = min(worst, d - ra - world.robot.serpentine_radius)
    return float(worst)


def test_a_tour_that_loops_into_the_arm_is_a_collision_not_a_success(tmp_path, capsys):
    """The scripted planner's smooth curve through these goals takes the tip link into the arm (55.7 mm deep):
    PyBullet's robot has no self-collision, so this reported ``success: true`` until session 37."""
    from navstack.generate.base import robot_dict

    data = {"format": "navstack-world/1", "name": "loop", "robot": robot_dict(), "obstacles": [],
            "goals": [{"position": [x, 0.1079, z], "tolerance": 0.02} for x, z in LOOP], "time_limit": 60.0}
    path = tmp_path / "loop.json"
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--planner", "scripted", "--out", str(tmp_path / "run")]) == 0
    result = json.loads((tmp_path / "run" / "result.json").read_text())
    assert result["goals_reached"] == len(LOOP) and result["metrics"]["contacts"] == 0  # no obstacle at all
    assert result["reason"] == "collision" and result["success"] is False
    assert "self_contacts" not in result and "self_clearance" not in result  # result.json as the spec has it
    out = capsys.readouterr().out
    assert "FAILURE (collision)" in out and "the robot touched itself in" in out
    # the pair named: the tip link (DH frame 20) in an arm link (frames 2-7), as session 37 found it
    a, b = map(int, re.search(r"between the capsules of DH frames (\d+) and (\d+)", out).groups())
    assert b == 20 and 2 <= a <= 7, out
    q = np.load(tmp_path / "run" / "trajectory.npz")["q"]
    deepest = min(_capsule_overlap(load_world(path), qk) for qk in q[::10])
    assert deepest < -0.04  # the sampled check agrees: a serpentine capsule deep in an arm capsule
