"""Behaviours of :meth:`Scene.swept_clearance <navstack.sim.mover_sweep.MoverSweeps.swept_clearance>` that the
second sampled mutation run of navstack.sim.mover_sweep (SAMPLE=50 SEED=2) showed no test pinned, each against an
independent reference: a closed form or brute-force sampling of the motions.  Every earlier test sweeps the step
that starts at t0 = 0 and moves the robot along one axis."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest
from _probes import R_PROBE, counting, probe_at, probe_boxes, with_a_nearer_static_sphere, world_of
from pybullet_utils import bullet_client

from navstack.sim.mover_sweep import SWEEP_STEP
from navstack.sim.scene import BOX_SLACK, Scene
from navstack.world import LinearMotion, OscillateMotion, Sphere

DT = 1 / 30  # s: one control step


@pytest.fixture
def client():
    c = bullet_client.BulletClient(connection_mode=p.DIRECT)
    yield c
    c.disconnect()


# Samples of an oscillation of period DT taken a whole number of periods apart all fall on one phase: n + 1 even
# samples over [t0 + DT - 1, t0 + DT] with n = 30, or over [t0, 3 t0 + DT] with n = 61 and t0 = 1 s, instead of
# over the step.  n = ceil(2 pi amplitude / SWEEP_STEP): amplitudes 4.7 mm (n = 30) and 9.6 mm (n = 61).
@pytest.mark.parametrize("amp", [0.0047, 0.0096])
@pytest.mark.parametrize("t0", [0.0, 1.0])
def test_a_vibrating_mover_is_boxed_over_its_own_step_whatever_the_step_and_the_amplitude(client, amp, t0):
    """A sphere oscillating along y once per control step, at its far crest at both looks (t0 and t0 + DT) and
    1 mm deep at its near crest mid-step, while a static sphere 5 mm away is what the looks found.  The mover's
    box must be where it goes during [t0, t0 + DT]: from samples of that step, not of some other second (they
    can all land on its far crest).  References: the closed form (the near crest 1 mm deep) and brute-force
    sampling of the motion over the step."""
    r, depth = 0.01, 0.001
    t1 = t0 + DT
    mover = Sphere(center=[0.0, R_PROBE + r - depth + amp, 0.0], radius=r,
                   motion=OscillateMotion(axis=[0.0, -1.0, 0.0], amplitude=amp, period=DT, phase=-math.pi / 2))
    scene, probe, look = with_a_nearer_static_sphere(client, mover, t1)
    ts = np.linspace(t0, t1, 20001)
    gaps = [abs(mover.center[1] + mover.motion.displacement(t)[1]) - r - R_PROBE for t in ts]
    assert gaps[0] == pytest.approx(2 * amp - depth, abs=1e-9) and gaps[-1] == pytest.approx(2 * amp - depth, abs=1e-9)
    assert min(gaps[0], gaps[-1]) > look + SWEEP_STEP + BOX_SLACK  # both looks, and a box of them, stay clear
    assert min(gaps) == pytest.approx(-depth, abs=1e-9)
    swept = scene.swept_clearance(probe, t0, t1, look, probe_boxes([0.0, 0.0, 0.0]))
    assert -depth - 1e-9 <= swept <= 0.0  # a contact, never deeper than it is (the search stops at one)


def _capsule_to_sphere(a, b, radius: float, centre, r: float) -> float:
    """Closed form: the signed distance (m) from capsule ``a``-``b`` of ``radius`` to a sphere."""
    ab = b - a
    t = float(np.clip((centre - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(a + t * ab - centre)) - radius - r


@pytest.mark.parametrize("flip", [False, True])
@pytest.mark.parametrize("t0", [0.0, 1.0])
@pytest.mark.parametrize("g", [0.002, -0.001])
def test_a_link_moving_over_a_later_step_is_swept_from_its_place_then_to_its_place_now(client, monkeypatch, t0, g,
                                                                                       flip):
    """A 0.2 m link along z whose ends move in straight lines over the step [t0, t0 + DT]: its lower end by
    (40, 0, 30) mm (50 mm), its upper one by (40, 0, 0) mm, past a sphere beside its lower half that approaches it
    at 0.15 m/s while drifting along it (``g`` from it at mid-step, 1.6 mm or more at both ends of the step);
    ``flip``: the capsule's ends given in the other order.  The
    distance is the robot's capsules at each instant, interpolated between their places at t0
    (``previous_capsules``) and now, whatever t0 is; when clear the sphere is asked at
    ceil((|v| + |moved| / DT) DT / SWEEP_STEP) + 1 even times, |moved| the farthest any end moved (Euclidean).
    References: the closed-form capsule-sphere distance, brute force over 20,001 instants of the step."""
    vel, r = np.array([0.0, -0.15, 0.05]), 0.01
    t1, tm = t0 + DT, t0 + DT / 2
    a0, a1 = np.array([-0.02, 0.0, -0.115]), np.array([0.02, 0.0, -0.085])
    b0, b1 = np.array([-0.02, 0.0, 0.115]), np.array([0.02, 0.0, 0.115])
    if flip:  # the same link, its ends named the other way round: the end that moves farthest comes second
        a0, a1, b0, b1 = b0, b1, a0, a1
    moved = max(float(np.linalg.norm(a1 - a0)), float(np.linalg.norm(b1 - b0)))
    assert moved == pytest.approx(0.05)
    s = Sphere(center=(np.array([0.0, R_PROBE + r + g, -0.05]) - vel * tm).tolist(), radius=r,
               motion=LinearMotion(velocity=vel))
    scene = Scene.build(client, world_of(s))
    robot = probe_at(client, [5.0, 5.0, 5.0])  # only its capsules are asked
    scene.update(t1)

    def truth(t: float) -> float:
        w = (t - t0) / (t1 - t0)
        return _capsule_to_sphere(a0 + w * (a1 - a0), b0 + w * (b1 - b0), R_PROBE,
                                  s.center + s.motion.displacement(t), r)

    ends = min(truth(t0), truth(t1))
    brute = min(truth(t) for t in np.linspace(t0, t1, 20001))
    assert ends > 0.0015 and brute <= g
    after = (a1[None], b1[None], np.array([R_PROBE]))
    before = (a0[None], b0[None], np.array([R_PROBE]))
    boxes = (np.minimum(a1, b1)[None] - R_PROBE, np.maximum(a1, b1)[None] + R_PROBE)
    calls = counting(scene, monkeypatch)
    swept = scene.swept_clearance(robot, t0, t1, ends, boxes, after, before)
    if g > 0.0:
        assert brute - 1e-9 <= swept <= brute + 1e-5  # sampled 1 mm of the relative motion apart
        assert len(calls) == math.ceil((float(np.linalg.norm(vel)) + moved / DT) * DT / SWEEP_STEP) + 1
    else:
        assert brute - 1e-9 <= swept <= 0.0  # a contact, never deeper than it is
    pos, _ = client.getBasePositionAndOrientation(scene.obstacle_body[0])
    np.testing.assert_allclose(pos, s.center + s.motion.displacement(t1), atol=1e-12)  # put back where t1 has it


def test_a_mover_flying_through_is_asked_though_a_static_body_is_nearer_than_the_box_slack(client):
    """A sphere at 5 m/s through the probe between two looks, 43 mm clear at both, while a static sphere only
    0.5 mm away (less than BOX_SLACK) is what the looks found: the mover's box over the step reaches the probe (a
    box gap of 0 less the slack is below 0.5 mm), so it is asked and its contact found.  Closed form: the
    centres meet at dt / 2, -(R_PROBE + r)."""
    v, r = 5.0, 0.01
    assert BOX_SLACK > 0.0005
    mover = Sphere(center=[0.0, v * DT / 2, 0.0], radius=r, motion=LinearMotion(velocity=[0.0, -v, 0.0]))
    scene, probe, look = with_a_nearer_static_sphere(client, mover, DT, gap=0.0005)
    for t in (0.0, DT):
        assert abs(mover.center[1] + mover.motion.displacement(t)[1]) - r - R_PROBE > 0.04  # clear at both looks
    swept = scene.swept_clearance(probe, 0.0, DT, look, probe_boxes([0.0, 0.0, 0.0]))
    assert -(R_PROBE + r) - 1e-9 <= swept <= 0.0


T0_STILL = 1.0  # s: the step [T0_STILL, T0_STILL + DT] of the next test
STILL_MOTIONS = {
    "starts at t1": LinearMotion(velocity=[0.5, 0.0, 0.0], start=T0_STILL + DT),
    "starts after t1": LinearMotion(velocity=[0.5, 0.0, 0.0], start=T0_STILL + 0.5),
    "stopped at t0": LinearMotion(velocity=[0.5, 0.0, 0.0], stop=T0_STILL),
    "stopped before t0": LinearMotion(velocity=[0.5, 0.0, 0.0], start=0.2, stop=T0_STILL - 0.5),
    "zero velocity": LinearMotion(velocity=[0.0, 0.0, 0.0]),
    "zero amplitude": OscillateMotion(axis=[1.0, 0.0, 0.0], amplitude=0.0, period=0.5),
}


@pytest.mark.parametrize("held", [True, False])
@pytest.mark.parametrize("name", list(STILL_MOTIONS))
def test_a_mover_that_does_not_move_over_the_step_costs_no_query(client, monkeypatch, name, held):
    """A sphere 5 mm beside a 0.2 m link whose motion leaves it where it is over the whole step (it starts moving
    exactly at the step's end, stopped exactly at its start, or has no speed; brute force over the step), the
    link held or moved 1 mm along its own axis (so the relative motion is not zero): what the look found stands
    (closed form: 5 mm all through the step) and no distance is asked for it."""
    t0, t1, r, gap = T0_STILL, T0_STILL + DT, 0.01, 0.005
    motion = STILL_MOTIONS[name]
    centre = np.array([0.0, R_PROBE + r + gap, 0.0])  # where it is over the step
    s = Sphere(center=(centre - motion.displacement(t1)).tolist(), radius=r, motion=motion)
    ts = np.linspace(t0, t1, 2001)
    np.testing.assert_array_equal([motion.displacement(t) for t in ts], [motion.displacement(t1)] * len(ts))
    scene = Scene.build(client, world_of(s))
    robot = probe_at(client, [5.0, 5.0, 5.0])  # only its capsules are asked
    scene.update(t1)
    a, b = np.array([[0.0, 0.0, -0.1]]), np.array([[0.0, 0.0, 0.1]])
    caps = (a, b, np.array([R_PROBE]))
    previous = caps if held else (a - [0.0, 0.0, 0.001], b - [0.0, 0.0, 0.001], caps[2])
    assert _capsule_to_sphere(a[0], b[0], R_PROBE, centre, r) == pytest.approx(gap)
    assert _capsule_to_sphere(previous[0][0], previous[1][0], R_PROBE, centre, r) == pytest.approx(gap)
    calls = counting(scene, monkeypatch)
    assert scene.swept_clearance(robot, t0, t1, gap, (a - R_PROBE, b + R_PROBE), caps, previous) == gap
    assert calls == []


@pytest.mark.parametrize("t0", [0.0, 1.0])
def test_a_slow_vibration_that_moves_less_than_a_sample_spacing_is_still_swept(client, t0):
    """A sphere vibrating 0.15 mm along y once per control step (peak speed 28 mm/s: less than SWEEP_STEP over
    the step, so a single interval, n = 1), at its far crest at both looks (0.25 mm clear) and 0.05 mm deep at
    its near crest mid-step, a static sphere 0.1 mm away what the looks found, the robot still: the sphere moved,
    so it is swept, and its speed bound finds the dip between the two looks.  References: the closed form and
    brute-force sampling of the motion over the step."""
    r, depth, amp = 0.01, 0.00005, 0.00015
    t1 = t0 + DT
    motion = OscillateMotion(axis=[0.0, -1.0, 0.0], amplitude=amp, period=DT, phase=-math.pi / 2)
    assert math.ceil(motion.peak_speed * DT / SWEEP_STEP) == 1
    mover = Sphere(center=[0.0, R_PROBE + r - depth + amp, 0.0], radius=r, motion=motion)
    scene, probe, look = with_a_nearer_static_sphere(client, mover, t1, gap=0.0001)  # what the looks found
    gaps = [abs(mover.center[1] + motion.displacement(t)[1]) - r - R_PROBE for t in np.linspace(t0, t1, 20001)]
    assert gaps[0] == pytest.approx(2 * amp - depth, abs=1e-12)
    assert gaps[-1] == pytest.approx(2 * amp - depth, abs=1e-12)
    assert min(gaps) == pytest.approx(-depth, abs=1e-12)
    swept = scene.swept_clearance(probe, t0, t1, look, probe_boxes([0.0, 0.0, 0.0]))
    assert -depth - 1e-9 <= swept <= 0.0


def test_a_link_end_sweeping_past_a_mover_is_boxed_and_sampled_by_its_own_motion(client):
    """A 0.2 m link in the plane y = 0 (its coordinates there exactly 0 at both ends and both times), its lower end
    held and its upper end swung 60 mm along x over the step, past a sphere drifting at 0.1 mm/s beside where the
    upper end is a quarter of the way through: 1 mm deep there, 1.8 mm and 19.5 mm clear at the two looks, and
    5 mm outside the link's box at the step's end.  Only the upper end moved, so it alone must grow the robot's box
    (else the sphere is left out) and set the robot's rate (else the two looks are the only samples and the
    mover's own speed bound excuses the interval).  References: the closed-form capsule-sphere distance and brute
    force over 20,001 instants of the step."""
    t0, t1, r, g = 1.0, 1.0 + DT, 0.01, -0.001
    a = np.array([0.0, 0.0, -0.1])
    b0, b1 = np.array([-0.06, 0.0, 0.1]), np.array([0.0, 0.0, 0.1])
    vel = np.array([0.0, 0.0, 1e-4])
    here = np.array([-0.045, R_PROBE + r + g, 0.1])  # where the sphere is at a quarter of the step
    s = Sphere(center=(here - vel * (t0 + DT / 4)).tolist(), radius=r, motion=LinearMotion(velocity=vel))
    scene = Scene.build(client, world_of(s))
    robot = probe_at(client, [5.0, 5.0, 5.0])  # only its capsules are asked
    scene.update(t1)

    def truth(t: float) -> float:
        w = (t - t0) / (t1 - t0)
        return _capsule_to_sphere(a, b0 + w * (b1 - b0), R_PROBE, s.center + s.motion.displacement(t), r)

    ends = min(truth(t0), truth(t1))
    brute = min(truth(t) for t in np.linspace(t0, t1, 20001))
    assert 0.0015 < ends < 0.002 and brute == pytest.approx(g, abs=1e-6)
    boxes = (np.minimum(a, b1)[None] - R_PROBE, np.maximum(a, b1)[None] + R_PROBE)
    assert boxes[0][0, 0] - (here[0] + r) > 0.0045  # outside the box the link has at t1
    after = (a[None], b1[None], np.array([R_PROBE]))
    before = (a[None], b0[None], np.array([R_PROBE]))
    swept = scene.swept_clearance(robot, t0, t1, ends, boxes, after, before)
    assert brute - 1e-9 <= swept <= 0.0


@pytest.mark.parametrize("first", ["still", "far"])
def test_a_mover_passed_over_does_not_end_the_sweep_of_the_movers_after_it(client, first):
    """Two movers: first one the sweep passes over (``still``: it starts moving only after the step; ``far``: it
    moves, but 1 m away), then a sphere at 5 m/s through the probe between two looks, 43 mm clear at both.  The
    second is still swept and its contact found.  Closed form: the centres meet at dt / 2, -(R_PROBE + r)."""
    v, r = 5.0, 0.01
    if first == "still":
        other = Sphere(center=[0.0, 0.0, 0.3], radius=0.02, motion=LinearMotion(velocity=[0.5, 0.0, 0.0], start=1.0))
    else:
        other = Sphere(center=[0.0, 0.0, 1.0], radius=0.02, motion=LinearMotion(velocity=[0.5, 0.0, 0.0]))
    mover = Sphere(center=[0.0, v * DT / 2, 0.0], radius=r, motion=LinearMotion(velocity=[0.0, -v, 0.0]))
    scene = Scene.build(client, world_of(other, mover))
    probe = probe_at(client, [0.0, 0.0, 0.0])
    scene.update(DT)
    look = scene.clearance(probe)
    assert look > 0.04  # clear at the look, as at the one before
    for t in (0.0, DT):
        assert abs(mover.center[1] + mover.motion.displacement(t)[1]) - r - R_PROBE > 0.04
    swept = scene.swept_clearance(probe, 0.0, DT, look, probe_boxes([0.0, 0.0, 0.0]))
    assert -(R_PROBE + r) - 1e-9 <= swept <= 0.0
