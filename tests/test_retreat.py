"""Retreat: reverse tip commands along a recorded path, and the path memory following them back."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.path import PathMemory, full_distance
from navstack.retreat import Retreat

L = 0.2
R = 0.3


def _arc_path() -> tuple[PathMemory, np.ndarray]:
    """A path memory driven 0.1 m straight along +z, then 0.4 m on a circle of radius 0.3 m (1 mm steps)."""

    def curve(s: float) -> np.ndarray:
        if s <= 0.1:
            return np.array([0.0, 0.0, s])
        ph = (s - 0.1) / R
        return np.array([R - R * np.cos(ph), 0.0, 0.1 + R * np.sin(ph)])

    backbone = np.array([[0.0, 0.0, -L * i] for i in range(7)])
    pm = PathMemory(backbone, link_length=L)
    for s in np.arange(1e-3, 0.5 + 1e-12, 1e-3):
        pm.advance(curve(s), np.zeros(3))
    dense = np.array([[0.0, 0.0, s] for s in np.arange(-2.0, 0.0, 1e-4)] + [curve(s) for s in
                                                                           np.arange(0.0, 0.5 + 1e-9, 1e-4)])
    return pm, dense  # dense: the curve as a 0.1 mm polyline (within 4e-9 m of it), extension included


def test_the_profile_accelerates_cruises_and_stops_on_the_target():
    pm, _ = _arc_path()
    target, speed, accel, dt = pm.start_arc_length + 0.05, 0.06, 0.1, 1 / 30
    r = Retreat(pm, target, speed, accel)
    start = pm.end_arc_length
    assert r.arc_length == start and r.remaining == pytest.approx(start - target) and not r.done
    arcs, speeds, cmds = [start], [0.0], []
    while not r.done:
        cmd = r.step(dt)
        cmds.append(cmd)
        arcs.append(r.arc_length)
        speeds.append(r.speed_now)
        assert len(cmds) < 10_000
    arcs, speeds = np.array(arcs), np.array(speeds)
    assert arcs[-1] == target and np.all(np.diff(arcs) <= 0)
    assert speeds.max() == pytest.approx(speed) and np.all(speeds <= speed + 1e-15)
    dv = np.abs(np.diff(speeds))
    assert dv[:-2].max() <= accel * dt + 1e-12  # acceleration limit, braking included
    assert dv[-2:].max() <= 1.125 * accel * dt + 1e-12  # the step that lands exactly on the target
    duration = len(cmds) * dt
    ideal = (start - target) / speed + speed / accel  # trapezoid from rest to rest
    assert ideal - dt <= duration <= ideal + 5 * dt  # measured: ideal + 4 dt (braking curve v^2 + a dt v = 2 a d)
    assert all(c.reverse and not c.stalled and c.mode == "retreat" for c in cmds)
    # positions on the path at the commanded arc length, velocities back along the tangent
    for k, c in enumerate(cmds, start=1):
        p, t = pm.point_at(arcs[k])
        np.testing.assert_allclose(c.position, p, atol=1e-15)
        np.testing.assert_allclose(c.velocity, -speeds[k] * t, atol=1e-15)
    held = r.step(dt)  # after done: at rest on the target
    np.testing.assert_array_equal(held.velocity, 0.0)
    assert r.arc_length == target
    # each speed is the module's rule, written out: the cruise speed, one step of acceleration, or the fastest
    # speed from which steps braking by accel * dt stop on the target (v^2 + a dt v <= 2 a remaining)
    for k in range(1, len(speeds) - 1):
        rem, adt = arcs[k - 1] - target, accel * dt
        brake = 0.5 * (np.sqrt(adt * adt + 8.0 * accel * rem) - adt)
        assert speeds[k] == pytest.approx(min(speed, speeds[k - 1] + adt, brake), rel=1e-12)


def test_following_a_retreat_cuts_the_path_and_keeps_the_chain_on_it():
    pm, dense = _arc_path()
    r = Retreat(pm, pm.start_arc_length, speed=0.06, accel=0.1)
    dt = 1 / 30
    h = np.linalg.norm(np.diff(pm.points, axis=0), axis=1)[8:].max()  # longest recorded chord (~1-2 mm)
    sagitta = h**2 / (8 * R)  # how far a chord strays from the arc
    prev = pm.head
    while not r.done:
        cmd = r.step(dt)
        v_fd = (cmd.position - prev) / dt
        assert np.linalg.norm(v_fd - cmd.velocity) <= 1e-3 * 0.06 + 5e-3 * np.linalg.norm(cmd.velocity)
        prev = cmd.position
        pm.advance(cmd.position, cmd.velocity, reverse=True)
        assert pm.end_arc_length == pytest.approx(r.arc_length, abs=1e-12)
        chain = np.vstack([cmd.position, pm.pts])
        np.testing.assert_allclose(np.linalg.norm(np.diff(chain, axis=0), axis=1), L, atol=1e-9)
        assert max(full_distance(dense, len(dense), p) for p in pm.pts) <= sagitta + 1e-8
    np.testing.assert_allclose(pm.head, [0.0, 0.0, 0.0], atol=1e-12)  # back at the start
    np.testing.assert_allclose(pm.pts, [[0.0, 0.0, -L * i] for i in range(1, 7)], atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"to_arc_length": 0.0}, "to_arc_length"),
        ({"to_arc_length": 99.0}, "to_arc_length"),
        ({"to_arc_length": float("nan")}, "to_arc_length"),
        ({"speed": 0.0}, "speed"),
        ({"accel": -1.0}, "accel"),
        ({"speed": True}, "speed"),
        ({"speed": float("nan")}, "speed"),
        ({"accel": float("inf")}, "accel"),
    ],
)
def test_bad_retreats_raise_naming_the_argument(kwargs, match):
    pm, _ = _arc_path()
    args = {"to_arc_length": pm.start_arc_length, "speed": 0.05, "accel": 0.1} | kwargs
    with pytest.raises(ValueError, match=match):
        Retreat(pm, **args)
    with pytest.raises(TypeError, match="PathMemory"):
        Retreat(object(), 1.0, 0.05, 0.1)  # type: ignore[arg-type]
    Retreat(pm, pm.end_arc_length, 0.05, 0.1)  # no way to go: allowed, and done at once
    assert Retreat(pm, pm.end_arc_length, 0.05, 0.1).done
    with pytest.raises(ValueError, match="to_arc_length"):
        Retreat(pm, 1e-9, 0.05, 0.1)  # not above the smallest arc length a path has
    for dt in (0.0, -1.0 / 30.0, float("nan")):
        with pytest.raises(ValueError, match="dt"):
            Retreat(pm, pm.start_arc_length, 0.05, 0.1).step(dt)


def test_once_there_the_command_holds_the_target_at_rest():
    pm, _ = _arc_path()
    r = Retreat(pm, pm.start_arc_length, 0.05, 0.1)
    for _ in range(10_000):
        if r.done:
            break
        r.step(1.0 / 30.0)
    assert r.done and r.arc_length == pm.start_arc_length
    for _ in range(3):
        cmd = r.step(1.0 / 30.0)
        assert r.speed_now == 0.0 and cmd.reverse
        np.testing.assert_array_equal(cmd.velocity, np.zeros(3))
        np.testing.assert_array_equal(cmd.position, pm.point_at(pm.start_arc_length)[0])
