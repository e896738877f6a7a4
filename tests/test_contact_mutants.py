"""Behaviours of the contact-deciding modules that surviving mutants showed no test pinned (session 47's mutation
runs of navstack.sim.lipschitz, mover_sweep, far_clearance and mesh_depth), each against an independent reference:
a closed form, brute-force sampling, or PyBullet's own distance."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest
from _probes import R_PROBE, counting, probe_at, probe_boxes, pybullet_distance, with_a_nearer_static_sphere, world_of
from _worlds import ROBOT, TIP
from pybullet_utils import bullet_client
from test_far_clearance import closed_form
from test_far_clearance import world as far_world

import navstack.sim.far_clearance as far
from navstack import jpl_serpentine
from navstack.sim.lipschitz import interval_bound, sampled_minimum
from navstack.sim.mover_sweep import SWEEP_STEP
from navstack.sim.probe import build_scene
from navstack.sim.scene import Scene
from navstack.world import LinearMotion, OscillateMotion, Sphere, world_from_dict


@pytest.fixture
def client():
    c = bullet_client.BulletClient(connection_mode=p.DIRECT)
    yield c
    c.disconnect()


def exact(g):
    return lambda t: (g(t), g(t))


# --- navstack.sim.lipschitz -------------------------------------------------------------------------------------


def test_a_touch_exactly_at_the_floor_between_two_samples_is_found():
    """A V that comes down to exactly 0 (a touch: a contact) midway between the only two samples.  The cones of
    slope ``rate`` from the ends meet exactly at the floor there; such an interval must still be halved."""
    g = lambda t: abs(t - 0.5)  # noqa: E731  closed form: least value 0 at t = 0.5
    assert interval_bound(g(0.0), g(1.0), 1.0, 1.0) == 0.0  # the bound is the floor itself, not below it
    best, calls = sampled_minimum(exact(g), 0.0, 1.0, 1, rate=1.0)
    assert best <= 0.0 and calls == 3


@pytest.mark.parametrize("high_at", [0.0, 1.0])
def test_an_end_read_high_with_an_exact_lower_bound_still_refines_its_interval(high_at):
    """A sample may read high (PyBullet's rounded corners) so long as its lower bound holds.  The interval's
    bound must come from the lower bounds of *both* ends: from the value at either end it clears the floor
    and the dip to -0.05 between the samples (closed form) would be missed."""
    rate = 0.5
    g = lambda t: abs(t - 0.5) * rate - 0.05  # noqa: E731  true value; -0.05 at t = 0.5, 0.2 at both ends
    f = lambda t: (g(t) + (0.5 if t == high_at else 0.0), g(t))  # noqa: E731  reads 0.5 high at one end only
    assert interval_bound(g(0.0) + 0.5, g(1.0), rate, 1.0) > 0.0  # what the value alone would clear
    best, _ = sampled_minimum(f, 0.0, 1.0, 1, rate)
    assert best <= 0.0
    assert best == pytest.approx(min(g(k / 1000) for k in range(1001)))  # brute force: found where it is


def test_the_even_samples_span_the_interval_wherever_it_starts():
    """On [t0, t1] with t0 > 0, the n + 1 first samples are the even times from t0 to t1 (a function whose least
    value, 0 at the middle, is one of them: found there, nothing more asked)."""
    t0, t1, n = 2.0, 3.0, 4
    asked = []
    g = lambda t: abs(t - 2.5)  # noqa: E731
    best, calls = sampled_minimum(lambda t: asked.append(t) or (g(t), g(t)), t0, t1, n, rate=1.0)
    assert asked == pytest.approx(np.linspace(t0, t1, n + 1).tolist(), abs=1e-15)
    assert best == 0.0 and calls == n + 1


def test_a_rate_of_zero_is_allowed_and_a_negative_resolution_is_not():
    """``rate`` is "at least 0" (a value that cannot change: the samples are the answer); ``resolution`` must be
    positive (a negative one would never stop halving)."""
    best, calls = sampled_minimum(exact(lambda t: 0.25 + t), 0.0, 1.0, 3, rate=0.0)
    assert best == 0.25 and calls == 4
    with pytest.raises(ValueError, match="resolution"):
        sampled_minimum(exact(lambda t: 1.0), 0.0, 1.0, 2, 1.0, resolution=-1e-6)


def test_a_contact_seen_at_an_even_sample_ends_the_search_at_once():
    """Found at an even sample: no interval is refined any more (each further call is a PyBullet query per mover
    and control step, up to max_extra of them), and the answer is the least sample."""
    for depth in (0.001, 0.0):  # -1 mm at the middle sample (the true minimum), or a touch there
        g = lambda t, depth=depth: abs(t - 0.5) - depth  # noqa: E731
        best, calls = sampled_minimum(exact(g), 0.0, 1.0, 2, rate=1.0)
        assert calls == 3 and best == pytest.approx(-depth)


def test_max_extra_zero_is_allowed_and_counts_any_interval_a_contact_could_hide_in():
    """``max_extra`` is "at least 0": with 0, nothing is refined, and a possible contact is reported as the least
    bound of the intervals it could hide in (here the cones' meeting point, closed form)."""
    g = lambda t: abs(t - 0.5) - 0.1  # noqa: E731
    best, calls = sampled_minimum(exact(g), 0.0, 1.0, 1, rate=1.0, max_extra=0)
    assert calls == 2 and best == pytest.approx(0.5 * (g(0.0) + g(1.0) - 1.0)) and best <= 0.0


def test_an_interval_within_the_resolution_is_not_halved_so_a_hair_of_clearance_stays_clear():
    """A value 1 nm above the floor for 10 us at 1 m/s (the mover moves 10 um, ten times the 1 um resolution):
    halving stops at intervals over which the value changes by at most the resolution, about
    ``rate (t1 - t0) / resolution`` calls, and the answer is clear.  Halving down to the 2 nm the speed bound
    alone would need takes thousands of calls, past max_extra, and reads a contact that did not happen."""
    t0, t1, rate, resolution = 1.0, 1.0 + 1e-5, 1.0, 1e-6
    best, calls = sampled_minimum(exact(lambda t: 1e-9), t0, t1, 1, rate, resolution=resolution, max_extra=1000)
    assert best == 1e-9
    assert calls <= 2 + 2 * math.ceil(rate * (t1 - t0) / resolution)


# --- navstack.sim.mover_sweep -----------------------------------------------------------------------------------


@pytest.mark.parametrize("speed", [1.0, 0.5])
def test_a_mover_at_exactly_one_metre_per_second_grazing_between_two_steps_is_seen(client, speed):
    """A sphere crossing past the probe at ``speed`` (1 m/s exactly: no speed is "still" but 0), 0.5 mm deep at
    the middle of the step and clear at both looks.  References: the closed form ``h - r - R_PROBE`` and
    PyBullet's own distance with the sphere placed at the middle of the step."""
    h, r, dt = R_PROBE + 0.005 - 0.0005, 0.005, 1 / 30
    s = Sphere(center=[-speed * dt / 2, h, 0.0], radius=r, motion=LinearMotion(velocity=[speed, 0.0, 0.0]))
    assert s.motion.peak_speed == speed
    scene = Scene.build(client, world_of(s))
    probe = probe_at(client, [0.0, 0.0, 0.0])
    ends = []
    for t in (0.0, dt):
        scene.update(t)
        client.performCollisionDetection()
        ends.append(scene.clearance(probe))
    assert min(ends) > 0.0  # neither look sees it
    swept = scene.swept_clearance(probe, 0.0, dt, min(ends), probe_boxes([0.0, 0.0, 0.0]))
    body = scene.obstacle_body[0]
    client.resetBasePositionAndOrientation(body, (s.center + s.motion.displacement(dt / 2)).tolist(), [0, 0, 0, 1])
    deepest = pybullet_distance(client, probe, body)
    assert deepest == pytest.approx(h - r - R_PROBE, abs=1e-9) and deepest < 0.0
    assert swept <= 0.0 and swept == pytest.approx(deepest, abs=1e-5)  # to within the 1 mm sampling


@pytest.mark.parametrize("moved", [0.0, 0.001])
def test_a_clear_mover_is_sampled_at_a_millimetre_of_the_relative_motion(client, monkeypatch, moved):
    """A sphere at 0.5 m/s, 5 mm clear of a 0.2 m link across its path (closed form, and PyBullet's distance at
    the look).  Held (no capsules before) the link adds no speed; moved ``moved`` m along its own axis over the
    step, its ends' speed (not its length over dt) is added.  The sphere is asked at
    ceil((v + moved / dt) dt / SWEEP_STEP) + 1 even times, the fewest at most SWEEP_STEP of the relative motion
    apart, and nothing more (the speed bound clears 0 between them)."""
    v, r, gap, dt = 0.5, 0.01, 0.005, 1 / 30
    s = Sphere(center=[-v * dt / 2, R_PROBE + r + gap, 0.0], radius=r, motion=LinearMotion(velocity=[v, 0.0, 0.0]))
    scene = Scene.build(client, world_of(s))
    probe = probe_at(client, [0.0, 0.0, 0.0])
    scene.update(dt)
    ends = pybullet_distance(client, probe, scene.obstacle_body[0])  # the probe sphere: the link's middle ball
    assert ends == pytest.approx(math.hypot(v * dt / 2, R_PROBE + r + gap) - r - R_PROBE, abs=1e-9)
    a, b = np.array([[0.0, 0.0, -0.1]]), np.array([[0.0, 0.0, 0.1]])  # the link along z, the sphere in its span
    caps = (a, b, np.array([R_PROBE]))
    previous = (a - [0.0, 0.0, moved], b - [0.0, 0.0, moved], caps[2]) if moved else None
    boxes = (a - R_PROBE, b + R_PROBE)
    calls = counting(scene, monkeypatch)
    swept = scene.swept_clearance(probe, 0.0, dt, ends, boxes, caps, previous)
    assert gap - 1e-12 <= swept <= gap + 1e-5  # closed form: closest at the middle of the step, sampled 1 mm apart
    assert len(calls) == math.ceil((v + moved / dt) * dt / SWEEP_STEP) + 1


def test_a_mover_beyond_what_was_found_is_not_asked_while_the_robot_moves_a_millimetre(client, monkeypatch):
    """The robot's box is grown by how far its capsules' ends moved (1 mm here), not by a link's length: a sphere
    5 cm beside a 0.2 m link that moved 1 mm along its axis, with 1 cm already found, is not asked.  Reference:
    the sphere's distance to the link over the step (closed form: 5 cm), far above what was found."""
    dt, v, r_c = 1 / 30, 0.03, 0.02
    a1, b1 = np.array([0.5, 0.0, 0.0]), np.array([0.7, 0.0, 0.0])
    step = np.array([0.001, 0.0, 0.0])
    s = Sphere(center=[0.6, r_c + 0.05 + 0.01, 0.0], radius=0.01, motion=LinearMotion(velocity=[0.0, 0.0, v]))
    scene = Scene.build(client, world_of(s))
    probe = probe_at(client, [0.6, 0.0, 0.0], r_c)
    after = (a1[None], b1[None], np.array([r_c]))
    before = (a1[None] - step, b1[None] - step, np.array([r_c]))
    boxes = (np.array([a1 - r_c]), np.array([b1 + r_c]))
    calls = counting(scene, monkeypatch)
    assert scene.swept_clearance(probe, 0.0, dt, 0.01, boxes, after, before) == 0.01
    assert calls == []


def test_a_mover_flying_through_between_two_looks_is_asked_though_a_static_body_is_nearer(client):
    """A sphere at 5 m/s (the speed bound) through the probe between two looks, 83 mm clear at both, while a static
    sphere 5 mm away is what the looks found: the mover's box over the step [t0, t1] reaches the probe, so it is
    asked.  Closed form: the centres meet at t0 + dt / 2, -(R_PROBE + r)."""
    v, r, dt = 5.0, 0.01, 1 / 30
    mover = Sphere(center=[0.0, v * dt / 2, 0.0], radius=r, motion=LinearMotion(velocity=[0.0, -v, 0.0]))
    scene, probe, look = with_a_nearer_static_sphere(client, mover, dt)
    for t in (0.0, dt):
        assert abs(mover.center[1] + mover.motion.displacement(t)[1]) - r - R_PROBE > look  # clear at both looks
    swept = scene.swept_clearance(probe, 0.0, dt, look, probe_boxes([0.0, 0.0, 0.0]))
    assert -(R_PROBE + r) - 1e-9 <= swept <= 0.0  # a contact, never deeper than it is (the search stops at one)


@pytest.mark.parametrize("side", [1.0, -1.0])
@pytest.mark.parametrize("given", [False, True])
def test_a_mover_vibrating_once_per_step_is_asked_though_far_at_both_looks(client, side, given):
    """A sphere oscillating 10 mm along y (on the probe's +y or -y ``side``) with a period of one control step, at
    its far crest at both looks (19 mm clear) and 1 mm deep at its near crest mid-step, while a static sphere 5 mm
    away is what the looks found.  The mover's box must cover where it is *between* the looks, and the robot's
    box must reach to every side (``given``: with its capsules at both ends of the step, here unmoved).
    References: the closed form (the near crest 1 mm deep) and brute-force sampling of the motion."""
    amp, r, depth, dt = 0.01, 0.01, 0.001, 1 / 30
    mover = Sphere(center=[0.0, side * (R_PROBE + r - depth + amp), 0.0], radius=r,
                   motion=OscillateMotion(axis=[0.0, -side, 0.0], amplitude=amp, period=dt, phase=-math.pi / 2))
    scene, probe, look = with_a_nearer_static_sphere(client, mover, dt)
    ts = np.linspace(0.0, dt, 20001)
    gaps = [abs(mover.center[1] + mover.motion.displacement(t)[1]) - r - R_PROBE for t in ts]
    assert gaps[0] == pytest.approx(2 * amp - depth) and gaps[-1] == pytest.approx(2 * amp - depth)
    assert min(gaps) == pytest.approx(-depth, abs=1e-9)
    caps = (np.zeros((1, 3)), np.zeros((1, 3)), np.array([R_PROBE])) if given else None
    swept = scene.swept_clearance(probe, 0.0, dt, look, probe_boxes([0.0, 0.0, 0.0]), caps, caps)
    assert -depth - 1e-9 <= swept <= 0.0  # a contact, never deeper than it is (the search stops at one)


# --- navstack.sim.far_clearance ---------------------------------------------------------------------------------


def test_the_replay_sweeps_a_fast_mover_between_the_recorded_steps_and_measures_a_single_step():
    """A sphere passing 0.6 m above the still robot at 4.5 m/s, closest midway between the second and third recorded
    steps (75 mm from there at each): the replay (a trial that never came within the horizon) finds the closest
    approach, as the trial's swept check would, not the 4.6 mm more of the looks; it leaves the mover where the
    last step had it; a one-step trajectory is measured (the sphere at t = 0), and an empty one has no clearance.
    Reference: the closed-form robot-sphere distance, brute force over 20,001 instants of the step."""

    v, rs, dt = 4.5, 0.05, 1 / 30
    data = {"format": "navstack-world/1", "name": "far", "robot": ROBOT, "obstacles": [],
            "goals": [{"position": (TIP + [0.6, 0.0, 0.3]).tolist()}], "time_limit": 3.0}
    base = world_from_dict(data)
    T0 = base.robot.base.transform()
    R0, p0 = T0[:3, :3], T0[:3, 3]
    chain, q0 = jpl_serpentine(), np.array(base.robot.q0, dtype=float)
    O = chain.frames(q0)[1:22, :3, 3] @ R0.T + p0
    up, across = R0[:, 2], R0[:, 1]
    k = int(np.argmax(O @ up))
    above = O[k] + (0.6 + 0.025 + rs) * up  # the sphere's centre at its closest, t = 1.5 dt
    start = above - across * v * 1.5 * dt
    data["obstacles"] = [{"type": "sphere", "center": start.tolist(), "radius": rs,
                          "motion": {"type": "linear", "velocity": (v * across).tolist()}}]
    w = world_from_dict(data)
    mover = w.obstacles[0]
    client, body, scene = build_scene(w)
    try:
        qs = np.array([q0, q0, q0])
        origins = np.array([O, O, O])
        times = np.arange(3) * dt
        ts = np.linspace(0.0, 2 * dt, 20001)
        brute = min(closed_form(np.asarray([q0]), w, mover.center + mover.motion.displacement(t), rs) for t in ts)
        looks = [closed_form(np.asarray([q0]), w, mover.center + mover.motion.displacement(t), rs) for t in times]
        assert min(looks) - brute > 4e-3  # the looks alone read 4.6 mm high
        assert brute > 0.5  # beyond the trial's clearance horizon: only the replay measures it
        replay = far.replay_min_clearance(scene, body, qs, origins, times, dt)
        assert brute - 1e-9 <= replay <= brute + 1e-5
        pos, _ = client.getBasePositionAndOrientation(scene.obstacle_body[0])
        np.testing.assert_allclose(pos, mover.center + mover.motion.displacement(times[-1]), atol=1e-12)
        one = far.replay_min_clearance(scene, body, qs[:1], origins[:1], times[:1], dt)
        assert one == pytest.approx(looks[0], abs=1e-6)
        assert far.replay_min_clearance(scene, body, qs[:0], origins[:0], times[:0], dt) == math.inf
    finally:
        client.disconnect()


def test_the_skip_bound_is_the_documented_one_for_any_motion_of_the_frames():
    """``_next_step`` against the module docstring's bound computed here step by step: a later step ``k`` is
    measured first where ``here - MARGIN - (farthest any frame origin moved from step j, Euclidean, at step k - 1
    or k) - speed (t_k - t_j + dt)`` is below ``best``.  Random walks of all 21 origins in 3-D (diagonal moves,
    going back and forth; more than one chunk of steps), random speeds and clearances."""
    from navstack.sim.exact_distance import MARGIN

    rng = np.random.default_rng(47)
    dt = 1 / 30
    for _ in range(60):
        n = int(rng.integers(2, 700))
        origins = np.cumsum(rng.normal(scale=float(rng.uniform(1e-4, 3e-3)), size=(n, 21, 3)), axis=0)
        if rng.uniform() < 0.3:
            origins[:, :20] = origins[0, :20]  # only the tip moves, diagonally
        times = np.arange(n) * dt
        j = int(rng.integers(0, n - 1))
        here = float(rng.uniform(0.5, 2.0))
        best = here - float(rng.uniform(0.0, 0.3))
        speed = float(rng.choice([0.0, rng.uniform(0.0, 0.5)]))
        expected = n
        for k in range(j + 1, n):
            moved = max(float(np.linalg.norm(origins[i] - origins[j], axis=1).max()) for i in (k - 1, k))
            if here - MARGIN - moved - speed * (times[k] - times[j] + dt) < best:
                expected = k
                break
        assert far._next_step(origins, times, j, here, best, speed, dt) == expected


def test_the_replays_query_distance_doubles_from_one_metre_until_something_lies_within_it():
    """A sphere 2.5 m from the robot (closed form): the replay asks PyBullet within 1, 2 and then 4 m, and no
    farther (a query far beyond the nearest body returns a point for every triangle of a mesh within it, and one
    of 10 km crashed PyBullet), and reads the closed-form distance."""
    base = world_from_dict(far_world())
    q0 = np.array(base.robot.q0, dtype=float)
    T0 = base.robot.base.transform()
    O = jpl_serpentine().frames(q0)[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3]
    up = T0[:3, 2]
    k = int(np.argmax(O @ up))
    w = world_from_dict(far_world({"type": "sphere", "center": (O[k] + (2.5 + 0.025 + 0.1) * up).tolist(),
                                   "radius": 0.1}))
    truth = closed_form(np.asarray([q0]), w, w.obstacles[0].center, 0.1)
    assert 2.0 < truth < 4.0
    client, body, scene = build_scene(w)
    try:
        reaches, original = [], scene.clearance
        scene.clearance = lambda robot, reach, *a: reaches.append(reach) or original(robot, reach, *a)
        got = far.replay_min_clearance(scene, body, q0[None], O[None], np.zeros(1), 1 / 30)
        assert got == pytest.approx(truth, abs=1e-6)
        assert reaches == [1.0, 2.0, 4.0]
    finally:
        client.disconnect()


def test_the_replay_sweeps_the_movers_over_the_step_before_each_from_the_first():
    """A sphere passing 5 cm from the still robot at 4.5 m/s, closest 0.6 ms after the first recorded step
    (t = 0), 2.7 mm along its path from there: the step before the second look is [0, dt], and the replay finds
    the closest approach in it (brute force over 20,001 instants, closed-form distances), not the 29 um more of
    the first look."""
    v, rs, dt, t_close = 4.5, 0.05, 1 / 30, 0.6e-3
    base = world_from_dict(far_world())
    q0 = np.array(base.robot.q0, dtype=float)
    T0 = base.robot.base.transform()
    O = jpl_serpentine().frames(q0)[1:22, :3, 3] @ T0[:3, :3].T + T0[:3, 3]
    up, across = T0[:3, 2], T0[:3, 1]
    k = int(np.argmax(O @ up))
    start = O[k] + (0.05 + 0.025 + rs) * up - across * v * t_close
    w = world_from_dict(far_world({"type": "sphere", "center": start.tolist(), "radius": rs,
                                   "motion": {"type": "linear", "velocity": (v * across).tolist()}}))
    mover = w.obstacles[0]
    ts = np.linspace(0.0, dt, 20001)
    brute = min(closed_form(np.asarray([q0]), w, mover.center + mover.motion.displacement(t), rs) for t in ts)
    first = closed_form(np.asarray([q0]), w, mover.center, rs)
    assert first - brute > 2e-5
    client, body, scene = build_scene(w)
    try:
        got = far.replay_min_clearance(scene, body, np.array([q0, q0]), np.array([O, O]), np.arange(2) * dt, dt)
        assert brute - 1e-9 <= got <= brute + 5e-6
    finally:
        client.disconnect()


# --- navstack.sim.mesh_depth ------------------------------------------------------------------------------------


def _reference_point_triangle(p, a, b, c) -> float:
    """The distance from point p to triangle abc, independently: to the plane where p's projection lies inside the
    triangle (same-side tests), else the least distance to the three edges (each a clamped projection)."""
    def to_segment(u, v):
        t = np.clip((p - u) @ (v - u) / ((v - u) @ (v - u)), 0.0, 1.0)
        return float(np.linalg.norm(p - (u + t * (v - u))))

    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n)
    q = p - ((p - a) @ n) * n
    if all(np.cross(v - u, q - u) @ n >= 0.0 for u, v in ((a, b), (b, c), (c, a))):
        return abs(float((p - a) @ n))
    return min(to_segment(a, b), to_segment(b, c), to_segment(c, a))


def test_the_point_triangle_distance_is_exact_in_every_region_of_obtuse_and_thin_triangles():
    """Ericson's closest point, each of its seven regions (three corners, three edges, the face), against the
    reference above, on random triangles (many obtuse, some thin) and points around them.  A box mesh's right
    triangles never put a point's closest point on an obtuse corner's edges, nor on a hypotenuse alone (the
    neighbouring triangle shares it)."""
    from navstack.sim.mesh_depth import _point_triangle

    rng = np.random.default_rng(47)
    obtuse = thin = 0
    regions = set()
    for _ in range(3000):
        a, b, c = rng.normal(size=(3, 3))
        if rng.uniform() < 0.2:
            c = a + rng.uniform(0.01, 0.99) * (b - a) + 0.02 * rng.normal(size=3)  # thin: c near edge ab
            thin += 1
        cosines = [(v - u) @ (w - u) for u, v, w in ((a, b, c), (b, c, a), (c, a, b))]
        obtuse += min(cosines) < 0.0
        p = (a + b + c) / 3 + 1.5 * rng.normal(size=3)
        got = math.sqrt(_point_triangle(p[0], p[1], p[2], a, b, c))
        assert got == pytest.approx(_reference_point_triangle(p, a, b, c), rel=1e-9, abs=1e-12), (p, a, b, c)
        # which feature is closest (by the reference's candidates): every region is visited
        n = np.cross(b - a, c - a)
        q = p - ((p - a) @ n) / (n @ n) * n
        if all(np.cross(v - u, q - u) @ n >= 0.0 for u, v in ((a, b), (b, c), (c, a))):
            regions.add("face")
        else:
            for name, (u, v) in {"ab": (a, b), "bc": (b, c), "ca": (c, a)}.items():
                t = (p - u) @ (v - u) / ((v - u) @ (v - u))
                d = np.linalg.norm(p - (u + np.clip(t, 0.0, 1.0) * (v - u)))
                if d == pytest.approx(got, rel=1e-9):
                    regions.add(name if 0.0 < t < 1.0 else "corner")
    assert regions == {"face", "ab", "bc", "ca", "corner"} and obtuse > 1000 and thin > 300
