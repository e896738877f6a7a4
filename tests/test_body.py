"""The PyBullet body and the joint servo against the kinematics."""

from __future__ import annotations

import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient
from scipy.spatial.transform import Rotation

import navstack
from navstack.sim.body import ARM_COLOUR, SERPENTINE_COLOUR, RobotBody
from navstack.sim.servo import JointServo, ServoConfig

ROBOT = navstack.jpl_serpentine()


@pytest.fixture
def client():
    c = BulletClient(connection_mode=pybullet.DIRECT)
    yield c
    c.disconnect()


def _base() -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", [0.3, -0.7, 2.0]).as_matrix()
    T[:3, 3] = [0.4, -1.2, 0.8]
    return T


def test_link_states_equal_frames(client):
    T0 = _base()
    body = RobotBody.build(client, ROBOT, T0)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(50):
        q = rng.uniform(ROBOT.lower, ROBOT.upper)
        body.reset(q)
        F = T0 @ ROBOT.frames(q)
        Fw = body.link_frames_world()
        worst = max(worst, np.abs(Fw[:, :3, 3] - F[1:, :3, 3]).max())
        np.testing.assert_allclose(Fw[:, :3, :3], F[1:, :3, :3], atol=1e-6)
        np.testing.assert_array_equal(Fw[:, 3], F[1:, 3])  # homogeneous: the last row [0, 0, 0, 1]
    print(f"max |getLinkState - frames(q)| position: {worst:.2e} m")
    assert worst < 1e-6


def test_calculate_jacobian_agrees(client):
    T0 = _base()
    body = RobotBody.build(client, ROBOT, T0)
    rng = np.random.default_rng(8)
    for _ in range(10):
        q = rng.uniform(ROBOT.lower, ROBOT.upper)
        body.reset(q)
        _, jac = ROBOT.points_and_jacobians(q)
        for m, frame in enumerate((21, 19, 17, 15, 13, 11, 9)):
            lin, _ = client.calculateJacobian(
                body.body_id, frame - 1, [0, 0, 0], list(q), [0.0] * 20, [0.0] * 20
            )
            # PyBullet expresses a fixed-base body's Jacobian in the base frame (DH frame 0)
            np.testing.assert_allclose(np.array(lin), jac[m], atol=1e-9)


def test_capsules_span_the_backbone(client):
    """A probe sphere touches the serpentine exactly at radius distance from a link's midpoint."""
    body = RobotBody.build(client, ROBOT, np.eye(4), serpentine_radius=0.025)
    q = ROBOT.q_default
    body.reset(q)
    F = ROBOT.frames(q)
    probe = client.createMultiBody(0, client.createCollisionShape(pybullet.GEOM_SPHERE, radius=0.01))
    for a, b in ((21, 19), (11, 9)):
        mid = 0.5 * (F[a, :3, 3] + F[b, :3, 3])
        side = mid + np.array([0.1, 0.0, 0.0])  # the serpentine runs along z here
        client.resetBasePositionAndOrientation(probe, list(side), [0, 0, 0, 1])
        client.performCollisionDetection()
        pts = client.getClosestPoints(body.body_id, probe, 1.0)
        d = min(p[8] for p in pts)
        assert d == pytest.approx(0.1 - 0.025 - 0.01, abs=1e-4)


def test_servo_tracks_smooth_trajectory(client):
    body = RobotBody.build(client, ROBOT, np.eye(4))
    servo = JointServo(body, ServoConfig())
    q0 = ROBOT.q_default
    amp = np.full(20, 0.2)
    amp[0] = 0.1
    freq = np.linspace(0.1, 0.25, 20)  # Hz
    body.reset(q0, amp * 2 * np.pi * freq)  # start on the trajectory, at its velocity
    servo.hold(q0)
    dt = servo.config.control_dt
    worst = np.zeros(20)
    tip_err = 0.0
    for k in range(1, int(6.0 / dt) + 1):
        t = k * dt
        q_d = q0 + amp * np.sin(2 * np.pi * freq * t)
        qd_d = amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * t)
        servo.command(q_d, qd_d)
        servo.step()
        q, _ = body.joint_state()
        worst = np.maximum(worst, np.abs(q - q_d))
        tip_err = max(tip_err, np.linalg.norm(ROBOT.frames(q)[21, :3, 3] - ROBOT.frames(q_d)[21, :3, 3]))
    print(
        f"servo tracking: max joint error {worst.max():.2e} (rad or m), max tip error {tip_err * 1e3:.2f} mm"
    )
    assert worst.max() < 2e-3
    assert tip_err < 5e-3


def test_servo_rejects_nan(client):
    body = RobotBody.build(client, ROBOT, np.eye(4))
    servo = JointServo(body)
    bad = ROBOT.q_default.copy()
    bad[4] = np.nan
    with pytest.raises(ValueError, match="joint 5"):
        servo.command(bad, np.zeros(20))
    with pytest.raises(ValueError, match="finite"):
        servo.command(ROBOT.q_default, np.full(20, np.inf))
    for n in (19, 21):  # one rate short or one too many: refused, whichever way
        with pytest.raises(ValueError, match="thetadot_d must be 20 finite joint rates"):
            servo.command(ROBOT.q_default, np.zeros(n))


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"physics_hz": 0.0}, "physics_hz"),
        ({"position_gain": 1.5}, "position_gain"),
        ({"physics_hz": 250.0}, "whole multiple"),
        ({"arm_torque": float("nan")}, "arm_torque"),
        ({"position_gain": 0.0}, "position_gain"),  # a motor that pulls nothing back
        ({"velocity_gain": 0.0}, "velocity_gain"),
        ({"physics_hz": 1e-12}, "whole multiple"),  # a ratio within 1e-9 of 0: no physics step per control step
    ],
)
def test_servo_config_validation(kwargs, field):
    with pytest.raises(ValueError, match=field):
        ServoConfig(**kwargs)


def test_without_visuals_the_same_body_for_physics_and_rays(client):
    """``visuals=False`` (trials without pictures): the same links, masses, link states after servoed steps and
    ray hits on the robot, bit for bit, as the body with visual shapes."""
    rng = np.random.default_rng(11)
    q0 = rng.uniform(ROBOT.lower, ROBOT.upper) * 0.3
    q1 = q0 + 0.05
    targets = (_base() @ ROBOT.frames(q0))[1:, :3, 3][rng.integers(1, 21, 100)]  # at the links
    away = rng.normal(size=(100, 3))
    starts = targets + 0.5 * away / np.linalg.norm(away, axis=1, keepdims=True)
    ends = 2.0 * targets - starts
    bare_client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        states = []
        for c, visuals in ((client, True), (bare_client, False)):
            body = RobotBody.build(c, ROBOT, _base(), visuals=visuals)
            body.reset(q0)
            servo = JointServo(body, ServoConfig())
            servo.hold(q0)
            for _ in range(5):
                servo.command(q1, np.zeros(ROBOT.n))
                servo.step()
            c.performCollisionDetection()
            links = range(c.getNumJoints(body.body_id))
            states.append((body.joint_state()[0].tolist(),
                           [c.getDynamicsInfo(body.body_id, k)[0] for k in links],
                           [c.getLinkState(body.body_id, k)[:2] for k in links],
                           [(h[0], h[1], h[2]) for h in c.rayTestBatch(starts, ends)]))
        assert states[0] == states[1]
        assert sum(h[0] >= 0 for h in states[0][3]) > 20  # the rays do hit the robot
    finally:
        bare_client.disconnect()


def test_with_visuals_every_shaped_link_and_the_lathe_bed_are_drawn(client):
    """What the pictures draw (``visuals=True``): each link's capsule as it collides, and the lathe bed's rail
    along the prismatic joint's whole travel with 0.1 m to spare at each end (``visuals=False``: no rail; PyBullet
    then makes the links' visual shapes from their collision shapes itself)."""
    body = RobotBody.build(client, ROBOT, np.eye(4), visuals=True)
    drawn = {s[1]: s for s in client.getVisualShapeData(body.body_id)}
    shaped = {k: client.getCollisionShapeData(body.body_id, k)[0] for k in range(ROBOT.n + 1)
              if client.getCollisionShapeData(body.body_id, k)}
    assert len(shaped) == 12 and set(drawn) == set(shaped) | {-1}
    for k, col in shaped.items():
        assert drawn[k][2] == pybullet.GEOM_CAPSULE and drawn[k][3][:2] == pytest.approx(col[3][:2])
        colour = SERPENTINE_COLOUR if k + 1 >= 9 else ARM_COLOUR  # link k carries DH frame k + 1
        assert drawn[k][7] == pytest.approx(colour)
    rail = drawn[-1]
    lo, hi = ROBOT.lower[0], ROBOT.upper[0]
    assert rail[2] == pybullet.GEOM_BOX and rail[3][2] == pytest.approx(hi - lo + 0.2)
    assert rail[5] == pytest.approx((-0.1, 0.0, 0.5 * (lo + hi))) and rail[7] == pytest.approx((0.3, 0.3, 0.35, 1.0))
    bare = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        plain = bare.getVisualShapeData(RobotBody.build(bare, ROBOT, np.eye(4), visuals=False).body_id)
        assert {s[1] for s in plain} == set(shaped)
    finally:
        bare.disconnect()
