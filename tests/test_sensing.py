"""Tip proximity sensor: ray pattern, noise model and the PyBullet ray caster."""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet as p
import pytest
from pybullet_utils.bullet_client import BulletClient

from navstack.sensing import (
    SensorConfig,
    SensorReading,
    apply_noise,
    frame_from_direction,
    ray_directions,
    ray_start_distances,
    reading_from_rays,
)
from navstack.sim.rays import RaySensor

EXACT = SensorConfig(noise_std=0.0, dropout_prob=0.0)


@pytest.fixture()
def client():
    c = BulletClient(connection_mode=p.DIRECT)
    yield c
    c.disconnect()


def _box(client, center, half_extents):
    shape = client.createCollisionShape(p.GEOM_BOX, halfExtents=list(half_extents))
    return client.createMultiBody(0, shape, -1, list(center))


def _quat_z_to(axis):
    """Quaternion (x, y, z, w) turning +z onto unit ``axis``."""
    z = np.asarray(axis, float) / np.linalg.norm(axis)
    v = np.cross([0.0, 0.0, 1.0], z)
    s, c = np.linalg.norm(v), z[2]
    if s < 1e-12:
        return [0.0, 0.0, 0.0, 1.0] if c > 0 else [1.0, 0.0, 0.0, 0.0]
    ang = np.arctan2(s, c)
    k = v / s
    return [*(k * np.sin(ang / 2)), float(np.cos(ang / 2))]


# ----------------------------------------------------------------- pattern
def test_default_pattern_counts_and_geometry():
    cfg = SensorConfig()
    d = ray_directions(cfg)
    assert d.shape == (1 + 3 * 12 + 12 + 8, 3) == (cfg.n_rays, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(d[0], [1.0, 0.0, 0.0])
    polar = np.arccos(np.clip(d[:, 0], -1, 1))
    cone = polar[1:37]
    # three rings at 1/3, 2/3 and 3/3 of the half-angle
    np.testing.assert_allclose(np.unique(np.round(cone, 9)), np.array([1, 2, 3]) / 3 * cfg.cone_half_angle)
    np.testing.assert_allclose(polar[37:49], np.pi / 2, atol=1e-12)  # side ring
    np.testing.assert_allclose(polar[49:], np.pi / 2 + cfg.back_tilt, atol=1e-12)  # backward ring


def test_rays_start_outside_the_tip_capsule():
    cfg = SensorConfig(back_tilt=1.0, body_radius=0.03, start_margin=0.0)
    d = ray_directions(cfg)
    start = ray_start_distances(cfg)[:, None] * d
    # capsule: segment from the tip (0,0,0) back to (-0.2,0,0), radius 0.03
    t = np.clip(start[:, 0], -0.2, 0.0)
    dist = np.linalg.norm(start - np.stack([t, 0 * t, 0 * t], axis=1), axis=1)
    assert np.all(dist >= 0.03 - 1e-12)
    # and exactly on its surface (margin 0): no blind zone larger than needed
    np.testing.assert_allclose(dist, 0.03, atol=1e-12)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("cone_rings", -1), ("cone_rays_per_ring", 0), ("cone_half_angle", 0.0), ("cone_half_angle", 1.6),
        ("side_rays", 1.5), ("back_rays", -2), ("back_tilt", 0.0), ("max_range", 0.0), ("max_range", np.nan),
        ("noise_std", -0.1), ("dropout_prob", 1.0), ("dropout_prob", -0.1), ("body_radius", -0.01),
        ("start_margin", np.inf), ("include_axis", 1), ("max_range", True),
    ],
)
def test_config_rejects_bad_values_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        SensorConfig(**{field: value})


def test_config_rejects_no_rays_and_short_range():
    with pytest.raises(ValueError, match="no rays"):
        SensorConfig(include_axis=False, cone_rings=0, side_rays=0, back_rays=0)
    with pytest.raises(ValueError, match="max_range"):
        SensorConfig(max_range=0.02)


def test_frame_from_direction_is_a_proper_frame():
    for d in ([1, 0, 0], [0, 0, -3], [0.3, -0.2, 0.9], [1e-3, 1, 0]):
        T = frame_from_direction([1, 2, 3], d)
        R = T[:3, :3]
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(R[:, 0], np.asarray(d, float) / np.linalg.norm(d), atol=1e-12)
        np.testing.assert_allclose(T[:3, 3], [1, 2, 3])
    with pytest.raises(ValueError, match="direction"):
        frame_from_direction([0, 0, 0], [0, 0, 0])


def test_config_closed_bounds_include_their_ends():
    """The documented ranges hold at their closed ends, and not a hair beyond them."""
    for field, at, beyond in (("back_tilt", 1.2, 1.2 + 1e-9), ("noise_std", 1.0, 1.0 + 1e-9),
                              ("body_radius", 1.0, 1.0 + 1e-9), ("start_margin", 1.0, 1.0 + 1e-9),
                              ("max_range", 100.0, 100.0 + 1e-6), ("cone_rays_per_ring", 1, 0)):
        roomy = {"max_range": 100.0} if field != "max_range" else {}
        assert getattr(SensorConfig(**roomy, **{field: at}), field) == at
        with pytest.raises(ValueError, match=field):
            SensorConfig(**roomy, **{field: beyond})


def test_ring_azimuths_alternate_as_documented():
    """Forward rings alternate: odd rings start at azimuth 0, even ones half a ray later (pi / m); the side ring
    starts at azimuth 0 (the tip frame's +y), the back ring half a ray along (pi / back_rays)."""
    cfg = SensorConfig(cone_rings=4, cone_rays_per_ring=6, side_rays=10, back_rays=8)
    d = ray_directions(cfg)
    first = [1 + 6 * k for k in range(4)] + [25, 35]  # the first ray of each ring, after the axis ray
    azimuth = np.arctan2(d[first, 2], d[first, 1])
    np.testing.assert_allclose(azimuth, [0.0, np.pi / 6, 0.0, np.pi / 6, 0.0, np.pi / 8], atol=1e-12)
    np.testing.assert_allclose(d[25], [0.0, 1.0, 0.0], atol=1e-12)
    second = np.arctan2(d[2, 2], d[2, 1])  # azimuth grows around +x (right-handed) within a ring
    assert second == pytest.approx(2 * np.pi / 6)


def test_bad_shapes_are_refused_with_a_clear_error():
    for position, direction in (([0, 0, 0], [1, 0]), ([0, 0, 0], [1, 0, 0, 0]), ([0, 0], [1, 0, 0])):
        with pytest.raises(ValueError, match="position|direction"):
            frame_from_direction(position, direction)
    t, f = np.ones(3, bool), np.zeros(3, bool)
    with pytest.raises(ValueError, match="disagree"):  # ranges not 1-D
        SensorReading(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 1)), f, t, 0.4)
    with pytest.raises(ValueError, match="disagree"):  # a short hit
        SensorReading(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(3), f[:2], t, 0.4)
    with pytest.raises(ValueError, match="disagree"):  # a long valid
        SensorReading(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(3), f, np.ones(4, bool), 0.4)
    n = EXACT.n_rays
    for count in (n - 1, n + 1):
        with pytest.raises(ValueError, match=f"{count} ranges given but the SensorConfig has {n} rays"):
            apply_noise(np.full(count, 0.2), np.ones(count, bool), EXACT, np.random.default_rng(0))


# ----------------------------------------------------------------- noise model
def test_noise_model_statistics_and_dropouts():
    cfg = SensorConfig(noise_std=0.01, dropout_prob=0.2)
    n = cfg.n_rays
    true = np.full(n, 0.2)
    hit = np.ones(n, bool)
    hit[::2] = False
    rng = np.random.default_rng(3)
    errs, drops, total = [], 0, 0
    for _ in range(400):
        r, h, v = apply_noise(np.where(hit, true, cfg.max_range), hit, cfg, rng)
        assert np.all(np.isnan(r[~v])) and not np.any(h[~v])
        assert np.all(r[v & ~hit] == cfg.max_range)  # misses report max_range exactly
        errs.append(r[v & hit] - 0.2)
        drops += int((~v).sum())
        total += n
    e = np.concatenate(errs)
    assert abs(e.mean()) < 1e-3
    assert e.std() == pytest.approx(0.01, rel=0.1)
    assert drops / total == pytest.approx(0.2, abs=0.02)


def test_reading_rejects_inconsistent_arrays():
    t, f = np.ones(3, bool), np.zeros(3, bool)
    with pytest.raises(ValueError, match="disagree"):
        SensorReading(np.zeros((3, 3)), np.zeros((2, 3)), np.zeros(3), f, t, 0.4)
    with pytest.raises(ValueError, match="dropout"):
        SensorReading(np.zeros((3, 3)), np.ones((3, 3)), np.ones(3), t, f, 0.4)


# ----------------------------------------------------------------- PyBullet caster
class _CountingClient:
    def __init__(self, client):
        self._c = client
        self.batches = 0

    def rayTestBatch(self, *args, **kwargs):  # noqa: N802 - PyBullet's name
        self.batches += 1
        return self._c.rayTestBatch(*args, **kwargs)


def test_wall_ranges_are_exact_and_one_batch_per_read(client):
    _box(client, [0.35, 0, 0], [0.05, 2, 2])  # face at x = 0.3
    counting = _CountingClient(client)
    sensor = RaySensor(counting, EXACT, None, None)
    r = sensor.read(frame_from_direction([0, 0, 0], [1, 0, 0]))
    assert counting.batches == 1
    d = r.directions
    expect_hit = (d[:, 0] > 1e-9) & (0.3 / np.maximum(d[:, 0], 1e-9) <= EXACT.max_range)
    np.testing.assert_array_equal(r.hit, expect_hit)
    np.testing.assert_allclose(r.ranges[r.hit], 0.3 / d[r.hit, 0], atol=1e-6)
    np.testing.assert_allclose(r.points[:, 0], 0.3, atol=1e-6)
    assert r.ranges[0] == pytest.approx(0.3, abs=1e-6)
    assert np.all(r.ranges[~r.hit] == EXACT.max_range)
    assert r.valid.all()


def test_cylinder_ranges_in_a_rotated_pose(client):
    # vertical-in-its-frame cylinder: axis through c along a, radius 0.05
    c = np.array([1.0, 2.0, 3.0])
    a = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    shape = client.createCollisionShape(p.GEOM_CYLINDER, radius=0.05, height=2.0)
    client.createMultiBody(0, shape, -1, list(c), _quat_z_to(a))
    heading = np.cross(a, [1.0, 0.0, 0.0])  # perpendicular to the axis
    tip = c - 0.25 * heading / np.linalg.norm(heading)
    r = RaySensor(client, EXACT, None, None).read(frame_from_direction(tip, heading))
    assert r.ranges[0] == pytest.approx(0.20, abs=1e-5)  # axis ray: 0.25 - radius
    pts = r.points
    assert len(pts) >= 5
    rel = pts - c
    radial = np.linalg.norm(rel - (rel @ a)[:, None] * a, axis=1)
    # head-on hits are exact; Bullet's convex ray cast on a cylinder is ~1 mm off at oblique incidence
    assert np.abs(radial - 0.05).min() < 1e-5
    np.testing.assert_allclose(radial, 0.05, atol=1.5e-3)


def _robot_with_parallel_segment(client):
    """A 2-link 'robot': the tip link along -x of the tip, and a body segment
    folded back beside it (0.15 m to +y), as after a tight loop."""
    tip_link = client.createCollisionShape(p.GEOM_CAPSULE, radius=0.025, height=0.15)
    beside = client.createCollisionShape(p.GEOM_CAPSULE, radius=0.025, height=0.35)
    rot_x = client.getQuaternionFromEuler([0, np.pi / 2, 0])  # capsule axis z -> x
    return client.createMultiBody(
        baseMass=0,
        baseCollisionShapeIndex=tip_link,
        basePosition=[-0.1, 0, 0],
        baseOrientation=rot_x,
        linkMasses=[0],
        linkCollisionShapeIndices=[beside],
        linkVisualShapeIndices=[-1],
        linkPositions=[[0, 0.15, 0.0]],
        linkOrientations=[[0, 0, 0, 1]],
        linkInertialFramePositions=[[0, 0, 0]],
        linkInertialFrameOrientations=[[0, 0, 0, 1]],
        linkParentIndices=[0],
        linkJointTypes=[p.JOINT_FIXED],
        linkJointAxis=[[0, 0, 1]],
    )


def test_never_reports_a_hit_on_the_robot_itself(client):
    robot = _robot_with_parallel_segment(client)
    pose = frame_from_direction([0, 0, 0], [1, 0, 0])
    # the filter matters: without it, side rays do hit the folded body segment
    unfiltered = RaySensor(client, EXACT, None, None).read(pose)
    assert unfiltered.hit.sum() >= 1
    reading = RaySensor(client, EXACT, robot, None).read(pose)
    assert not reading.hit.any()
    assert np.all(reading.ranges == EXACT.max_range)


def test_rays_starting_inside_another_robot_capsule_still_see_obstacles(client):
    # a fat robot link (arm-sized, radius 0.06) around the tip: every ray starts inside it
    fat = client.createCollisionShape(p.GEOM_SPHERE, radius=0.06)
    robot = client.createMultiBody(0, fat, -1, [0, 0, 0])
    _box(client, [0.35, 0, 0], [0.05, 2, 2])
    r = RaySensor(client, EXACT, robot, None).read(frame_from_direction([0, 0, 0], [1, 0, 0]))
    assert r.ranges[0] == pytest.approx(0.3, abs=1e-6)
    np.testing.assert_allclose(r.points[:, 0], 0.3, atol=1e-6)


def test_obstacles_made_before_the_robot_are_seen_and_the_robot_is_not(client):
    """The robot's own hits are dropped by its body id alone, whatever the order the bodies were made in: a wall
    with a smaller id than the robot's is seen through the robot's folded segment's side."""
    _box(client, [0.35, 0, 0], [0.05, 2, 2])  # made first: the smaller body id
    robot = _robot_with_parallel_segment(client)
    reading = RaySensor(client, EXACT, robot, None).read(frame_from_direction([0, 0, 0], [1, 0, 0]))
    assert reading.ranges[0] == pytest.approx(0.3, abs=1e-6)
    np.testing.assert_allclose(reading.points[:, 0], 0.3, atol=1e-6)


def test_a_batch_of_the_wrong_length_is_an_error(client):
    """PyBullet answers one result per ray; a client that does not is refused, never half read."""
    class Short(_CountingClient):
        def __init__(self, client, extra):
            super().__init__(client)
            self.extra = extra

        def rayTestBatch(self, *args, **kwargs):  # noqa: N802 - PyBullet's name
            out = list(super().rayTestBatch(*args, **kwargs))
            return out[:-1] if self.extra < 0 else out + out[:1]

    pose = frame_from_direction([0, 0, 0], [1, 0, 0])
    for extra in (-1, 1):
        with pytest.raises(RuntimeError, match="rayTestBatch returned"):
            RaySensor(Short(client, extra), EXACT, None, None).read(pose)


def test_same_seed_same_noisy_readings(client):
    _box(client, [0.35, 0, 0], [0.05, 2, 2])
    pose = frame_from_direction([0, 0.01, 0], [1, 0.1, 0])
    cfg = SensorConfig(noise_std=0.005, dropout_prob=0.1)

    def readings(seed):
        s = RaySensor(client, cfg, None, np.random.default_rng(seed))
        return [s.read(pose) for _ in range(5)]

    a, b, c = readings(7), readings(7), readings(8)
    for ra, rb in zip(a, b, strict=True):
        np.testing.assert_array_equal(ra.ranges, rb.ranges)  # NaNs compare equal here
        np.testing.assert_array_equal(ra.valid, rb.valid)
    assert any(not np.array_equal(ra.ranges, rc.ranges, equal_nan=True) for ra, rc in zip(a, c, strict=True))
    # the noise is really there, with the configured size
    exact = RaySensor(client, EXACT, None, None).read(pose)
    m = a[0].hit & exact.hit
    assert 0 < np.abs(a[0].ranges[m] - exact.ranges[m]).max() < 5 * cfg.noise_std


def test_read_rejects_bad_poses_and_arguments(client):
    sensor = RaySensor(client, EXACT, None, None)
    with pytest.raises(ValueError, match="tip_T_world"):
        sensor.read(np.eye(3))
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(ValueError, match="orthonormal"):
        sensor.read(bad)
    with pytest.raises(TypeError, match="SensorConfig"):
        RaySensor(client, dataclasses.asdict(EXACT), None, None)
    with pytest.raises(TypeError, match="robot_id"):
        RaySensor(client, EXACT, "robot", None)


def test_reading_from_rays_rejects_directions_that_do_not_match_the_rays():
    cfg = SensorConfig()
    n = ray_directions(cfg).shape[0]
    with pytest.raises(ValueError, match="do not match"):
        reading_from_rays(np.zeros(3), np.ones((n - 1, 3)), np.full(n, 0.4), np.zeros(n, bool), cfg,
                          np.random.default_rng(0))
