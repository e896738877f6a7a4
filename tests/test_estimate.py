"""Per-ray Kalman range filters (filterpy) on synthetic readings: no simulator needed."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.estimate import EstimatorConfig, RangeEstimator
from navstack.sensing import SensorConfig, SensorReading, frame_from_direction, make_reading, ray_directions

WALL_X = 0.5  # the wall is the plane x = WALL_X


def _wall_ranges(T: np.ndarray, cfg: SensorConfig) -> tuple[np.ndarray, np.ndarray]:
    """Exact ranges from the tip pose T to the plane x = WALL_X."""
    d = ray_directions(cfg) @ T[:3, :3].T
    gap = WALL_X - T[0, 3]
    with np.errstate(divide="ignore"):
        r = np.where(d[:, 0] > 1e-9, gap / d[:, 0], np.inf)
    hit = r <= cfg.max_range
    return np.where(hit, r, cfg.max_range), hit


def _moving_tip(k: int, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tip approaching the wall obliquely while its heading slowly turns."""
    v = np.array([0.035, 0.03, -0.01])
    pos = np.array([0.15, 0.0, 0.0]) + v * k * dt
    yaw = 0.3 * np.sin(0.4 * k * dt)
    heading = np.array([np.cos(yaw), np.sin(yaw), 0.1])
    return pos, heading, v


def _run(cfg: SensorConfig, n: int = 120, dt: float = 0.05, seed: int = 0, velocity_input: bool = True):
    rng = np.random.default_rng(seed)
    est = RangeEstimator(cfg.n_rays, EstimatorConfig(measurement_std=max(cfg.noise_std, 1e-4)))
    raw_err, filt_err, coast_err = [], [], []
    for k in range(n):
        pos, heading, v = _moving_tip(k, dt)
        T = frame_from_direction(pos, heading)
        true, hit = _wall_ranges(T, cfg)
        reading = make_reading(T, true, hit, cfg, rng)
        out = est.update(reading, dt, v if velocity_input else np.zeros(3))
        m = out.measured
        raw_err.append(reading.ranges[m] - true[m])
        filt_err.append(out.ranges[m] - true[m])
        coasting = out.tracking & ~reading.valid
        coast_err.append(out.ranges[coasting] - true[coasting])
        # filtered points lie near the wall
        if m.any():
            assert np.all(np.abs(out.measured_points[:, 0] - WALL_X) < 6 * max(cfg.noise_std, 1e-3))
    cat = np.concatenate
    return cat(raw_err), cat(filt_err), cat(coast_err), est


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e**2)))


def test_filter_reduces_range_noise_on_a_moving_tip():
    cfg = SensorConfig(noise_std=0.005, dropout_prob=0.0)
    raw, filt, _, est = _run(cfg)
    print(f"\nwall, moving tip: raw RMS {_rms(raw) * 1e3:.2f} mm, filtered RMS {_rms(filt) * 1e3:.2f} mm "
          f"({raw.size} samples, {est.n_resets} gate resets)")
    assert raw.size > 500
    assert _rms(raw) == pytest.approx(0.005, rel=0.15)
    assert _rms(filt) < 0.7 * _rms(raw)


def test_tip_velocity_input_removes_the_lag():
    """Exact ranges, tip flying at a wall: with the input the prediction is right from the first step."""
    v = np.array([0.05, 0.0, 0.0])
    errors = {}
    for name, u in (("with input", v), ("zero input", np.zeros(3))):
        est = RangeEstimator(1, EstimatorConfig(measurement_std=0.005))
        e = []
        for k in range(20):
            true = 0.35 - 0.05 * 0.05 * k
            out = est.update(_single_ray_reading(true), 0.05, u)
            e.append(abs(out.ranges[0] - true))
        errors[name] = max(e)
    print(f"\nmax range error, exact readings: {errors}")
    assert errors["with input"] < 1e-9
    assert errors["zero input"] > 5e-4


def test_dropouts_are_bridged_by_prediction():
    cfg = SensorConfig(noise_std=0.005, dropout_prob=0.25)
    raw, filt, coast, est = _run(cfg, seed=2)
    print(f"\nwith 25 % dropouts: raw RMS {_rms(raw) * 1e3:.2f} mm, filtered {_rms(filt) * 1e3:.2f} mm, "
          f"coasting {_rms(coast) * 1e3:.2f} mm over {coast.size} predictions")
    assert coast.size > 100
    assert _rms(coast) < 1.5 * _rms(raw)  # predictions stay sensible through the gaps
    assert _rms(filt) < 0.8 * _rms(raw)


def _single_ray_reading(r: float | None, valid: bool = True):
    """A one-ray reading straight along +x from the origin (r None = miss)."""
    from navstack.sensing import SensorReading

    hit = r is not None and valid
    rng_val = (r if r is not None else 0.4) if valid else np.nan
    return SensorReading(np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([rng_val]),
                         np.array([hit]), np.array([valid]), 0.4)


def test_track_start_jump_reset_stop_and_coast_limit():
    est = RangeEstimator(1, EstimatorConfig(measurement_std=0.003, max_coast=2))
    zero = np.zeros(3)
    out = est.update(_single_ray_reading(None), 0.05, zero)
    assert not out.tracking[0] and np.isnan(out.ranges[0]) and out.points.shape == (0, 3)
    out = est.update(_single_ray_reading(0.3), 0.05, zero)  # starts a track at the measurement
    assert out.tracking[0] and out.ranges[0] == pytest.approx(0.3)
    for _ in range(10):
        est.update(_single_ray_reading(0.3), 0.05, zero)
    out = est.update(_single_ray_reading(0.15), 0.05, zero)  # the ray slid onto a nearer surface
    assert est.n_resets == 1
    assert out.ranges[0] == pytest.approx(0.15, abs=1e-9)  # reset, not dragged from 0.3
    # coasting through dropouts: prediction only, then dropped after max_coast
    for k in range(2):
        out = est.update(_single_ray_reading(None, valid=False), 0.05, zero)
        assert out.tracking[0] and not out.measured[0], k
        assert out.ranges[0] == pytest.approx(0.15, abs=0.01)
    out = est.update(_single_ray_reading(None, valid=False), 0.05, zero)
    assert not out.tracking[0]
    # a valid miss stops a track at once
    est.update(_single_ray_reading(0.2), 0.05, zero)
    out = est.update(_single_ray_reading(None), 0.05, zero)
    assert not out.tracking[0] and np.isnan(out.ranges[0])


def test_velocity_from_origins_when_not_given():
    cfg = SensorConfig(noise_std=0.0, dropout_prob=0.0)
    a = RangeEstimator(cfg)  # built from the SensorConfig: n_rays and noise taken from it
    b = RangeEstimator(cfg.n_rays, EstimatorConfig(measurement_std=0.0))
    dt = 0.05
    for k in range(30):
        pos, heading, v = _moving_tip(k, dt)
        T = frame_from_direction(pos, heading)
        true, hit = _wall_ranges(T, cfg)
        reading = make_reading(T, true, hit, cfg, None)
        ra = a.update(reading, dt)
        rb = b.update(reading, dt, v if k else np.zeros(3))
    np.testing.assert_allclose(ra.ranges, rb.ranges, atol=1e-9, equal_nan=True)


def test_bad_inputs_raise_clear_errors():
    est = RangeEstimator(1)
    with pytest.raises(ValueError, match="rays"):
        RangeEstimator(2).update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    with pytest.raises(ValueError, match="dt"):
        est.update(_single_ray_reading(0.3), 0.0, np.zeros(3))
    with pytest.raises(ValueError, match="tip_velocity"):
        est.update(_single_ray_reading(0.3), 0.05, [np.nan, 0, 0])
    with pytest.raises(TypeError, match="SensorReading"):
        est.update({"ranges": [0.3]}, 0.05)
    with pytest.raises(ValueError, match="rays"):
        RangeEstimator(0)
    with pytest.raises(ValueError, match="gate_sigma"):
        EstimatorConfig(gate_sigma=0.0)
    with pytest.raises(ValueError, match="measurement_std"):
        EstimatorConfig(measurement_std=-1.0)
    with pytest.raises(ValueError, match="max_coast"):
        EstimatorConfig(max_coast=1.5)


# ---------------------------------------------------------------------- against an independent reference
class _ReferenceFilter:
    """The estimator as its module docstring documents it, built here from filterpy's plain KalmanFilter.

    Per ray: state [r, b]; F = [[1, dt], [0, 1]], B = [[dt], [0]], H = [[1, 0]], input u = -v . d;
    Q the discrete white-noise model written out (var * [[dt^4/4, dt^3/2], [dt^3/2, dt^2]], var =
    rate_process_std^2); R = measurement_std^2 (floor 1e-4 m). A hit starts a track at [z, 0] with
    P = diag(R, initial_rate_std^2); a valid miss stops it; a dropout predicts only, and more than
    max_coast in a row drop the track; a hit whose innovation exceeds gate_sigma standard deviations of the
    innovation (predicted range variance plus R) restarts the track at the measurement.
    """

    def __init__(self, n: int, cfg: EstimatorConfig):
        from filterpy.kalman import KalmanFilter

        self.cfg = cfg
        self.R = max(cfg.measurement_std, 1e-4) ** 2
        self.kfs = []
        for _ in range(n):
            kf = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
            kf.H = np.array([[1.0, 0.0]])
            kf.R = np.array([[self.R]])
            self.kfs.append(kf)
        self.tracking = np.zeros(n, bool)
        self.coast = np.zeros(n, int)
        self.last_origin = None
        self.resets = 0
        self.innovation_var = np.full(n, np.nan)  # of the last gated hit, per ray

    def _start(self, i, z):
        self.kfs[i].x = np.array([[z], [0.0]])
        self.kfs[i].P = np.diag([self.R, self.cfg.initial_rate_std**2])
        self.tracking[i], self.coast[i] = True, 0

    def update(self, reading, dt, v=None):
        o = reading.origins[0]
        if v is None:
            v = np.zeros(3) if self.last_origin is None else (o - self.last_origin) / dt
        self.last_origin = np.array(o)
        F = np.array([[1.0, dt], [0.0, 1.0]])
        B = np.array([[dt], [0.0]])
        var = self.cfg.rate_process_std**2
        Q = var * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
        for i, kf in enumerate(self.kfs):
            if not self.tracking[i]:
                if reading.hit[i]:
                    self._start(i, reading.ranges[i])
                continue
            if reading.valid[i] and not reading.hit[i]:
                self.tracking[i] = False
                continue
            kf.predict(u=np.array([[-(reading.directions[i] @ v)]]), B=B, F=F, Q=Q)
            kf.x[0, 0] = max(kf.x[0, 0], 0.0)
            if not reading.valid[i]:
                self.coast[i] += 1
                self.tracking[i] = self.coast[i] <= self.cfg.max_coast
                continue
            s = kf.P[0, 0] + self.R
            self.innovation_var[i] = s
            if (reading.ranges[i] - kf.x[0, 0]) ** 2 > self.cfg.gate_sigma**2 * s:
                self.resets += 1
                self._start(i, reading.ranges[i])
                continue
            kf.update(reading.ranges[i])
            self.coast[i] = 0
        t = self.tracking
        x = np.array([kf.x[:, 0] for kf in self.kfs])
        std = np.sqrt([kf.P[0, 0] for kf in self.kfs])
        return np.where(t, x[:, 0], np.nan), np.where(t, x[:, 1], np.nan), np.where(t, std, np.nan)


def _plane_readings(n_steps: int, seed: int, noise: float, dropout: float, dt: float = 0.05):
    """Readings of 5 rays from a tip crossing a tilted plane, with a step in the plane (an edge) halfway."""
    rng = np.random.default_rng(seed)
    dirs = np.array([[1.0, 0, 0], [0.9, 0.3, 0], [0.9, -0.3, 0.1], [0.8, 0, 0.5], [0.0, 1.0, 0.0]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    normal = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])
    out = []
    for k in range(n_steps):
        v = np.array([0.04, 0.01 * np.cos(0.3 * k * dt), -0.005])
        origin = v * k * dt
        offset = 0.35 if k < n_steps // 2 else 0.25  # the surface ahead steps 10 cm closer: gate resets
        true = (offset - normal @ origin) / (dirs @ normal)
        hit = (true > 0) & (true < 0.4)
        valid = rng.random(5) >= dropout
        ranges = np.where(hit, true + noise * rng.standard_normal(5), 0.4)
        ranges = np.where(valid, ranges, np.nan)
        reading = SensorReading(np.tile(origin, (5, 1)), dirs, ranges, hit & valid, valid, 0.4)
        out.append((reading, v))
    return out


@pytest.mark.parametrize("velocity_given", [True, False])
@pytest.mark.parametrize("cfg", [
    EstimatorConfig(),
    EstimatorConfig(measurement_std=0.002, rate_process_std=0.3, initial_rate_std=0.2, gate_sigma=3.0, max_coast=2),
], ids=["defaults", "other"])
def test_filter_matches_an_independent_filterpy_reference(cfg, velocity_given):
    """Same readings into the estimator and the reference: same ranges, rates, posterior stds, tracks, resets."""
    est, ref = RangeEstimator(5, cfg), _ReferenceFilter(5, cfg)
    steps = _plane_readings(160, seed=11, noise=cfg.measurement_std, dropout=0.15)
    for k, (reading, v) in enumerate(steps):
        out = est.update(reading, 0.05, v if velocity_given else None)
        r, b, std = ref.update(reading, 0.05, v if velocity_given else None)
        np.testing.assert_array_equal(out.tracking, ref.tracking, err_msg=f"step {k}")
        np.testing.assert_allclose(out.ranges, r, rtol=0, atol=1e-9, equal_nan=True, err_msg=f"step {k}")
        np.testing.assert_allclose(out.rates, b, rtol=0, atol=1e-7, equal_nan=True, err_msg=f"step {k}")
        np.testing.assert_allclose(out.range_std, std, rtol=1e-6, atol=0, equal_nan=True, err_msg=f"step {k}")
    print(f"\n{est.n_resets} gate resets, reference {ref.resets}")
    assert est.n_resets == ref.resets and 1 <= ref.resets <= 8  # the edge resets tracks; noise does not


def _settled_track(cfg: EstimatorConfig, z: float = 0.3, n: int = 40):
    """An estimator and a reference that tracked a still surface at ``z`` for ``n`` exact readings."""
    est, ref = RangeEstimator(1, cfg), _ReferenceFilter(1, cfg)
    for _ in range(n):
        est.update(_single_ray_reading(z), 0.05, np.zeros(3))
        ref.update(_single_ray_reading(z), 0.05, np.zeros(3))
    return est, ref


@pytest.mark.parametrize("sigmas, resets", [(3.9, 0), (4.1, 1)])
def test_the_gate_is_on_the_innovation_std_including_measurement_noise(sigmas, resets):
    """A settled track's predicted range is far surer than one reading (P << R): the gate must count R.
    A jump of 3.9 innovation sigmas is filtered in, 4.1 sigmas restarts the track."""
    cfg = EstimatorConfig(measurement_std=0.004)
    est, ref = _settled_track(cfg)
    dt, P = 0.05, ref.kfs[0].P
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = cfg.rate_process_std**2 * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
    s = (F @ P @ F.T + Q)[0, 0] + cfg.measurement_std**2  # the next innovation's variance
    assert s < 1.5 * cfg.measurement_std**2  # P < R / 2: a gate on P alone would be ~1.8x tighter
    z = 0.3 + sigmas * np.sqrt(s)
    out = est.update(_single_ray_reading(z), 0.05, np.zeros(3))
    assert est.n_resets == resets
    if resets:
        assert out.ranges[0] == pytest.approx(z, abs=1e-12)
    else:
        assert 0.3 < out.ranges[0] < z - 0.5 * (z - 0.3)  # pulled a little toward the reading, not restarted


def test_process_noise_sets_how_fast_the_rate_follows():
    """A surface that starts receding at 5 cm/s: the rate state b converges at the speed Q allows.
    After 0.25 s the default filter's b is 0.47 of the true rate (a filter with ten times the process noise
    variance is at 0.85, one with a tenth at 0.20)."""
    cfg = EstimatorConfig(measurement_std=0.004)
    rates = {}
    for name, c in (("default", cfg), ("x10", EstimatorConfig(measurement_std=0.004,
                                                             rate_process_std=cfg.rate_process_std * 10**0.5)),
                    ("x0.1", EstimatorConfig(measurement_std=0.004, rate_process_std=cfg.rate_process_std / 10**0.5))):
        est, _ = _settled_track(c)
        for k in range(1, 6):
            out = est.update(_single_ray_reading(0.3 + 0.05 * 0.05 * k), 0.05, np.zeros(3))
        rates[name] = out.rates[0] / 0.05
    print(f"\nrate state after 0.25 s, as a fraction of the true rate: {rates}")
    assert 0.35 < rates["default"] < 0.6
    assert rates["x10"] > 0.75 and rates["x0.1"] < 0.3


def test_points_are_origin_plus_filtered_range_along_each_ray():
    """From a tip away from the world origin: tracked and measured points, coasting rays included."""
    origin = np.array([0.4, -0.2, 1.1])
    dirs = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0.6, 0.8]])

    def reading(ranges, valid):
        ranges = np.asarray(ranges, dtype=np.float64)
        valid = np.asarray(valid)
        hit = valid & (ranges < 0.4)
        return SensorReading(np.tile(origin, (3, 1)), dirs, np.where(valid, ranges, np.nan), hit, valid, 0.4)

    est = RangeEstimator(3, EstimatorConfig(measurement_std=0.004))
    est.update(reading([0.25, 0.3, 0.4], [True, True, True]), 0.05, np.zeros(3))
    out = est.update(reading([0.25, 0.3, 0.4], [True, False, True]), 0.05, np.zeros(3))  # ray 1 coasts
    assert out.tracking.tolist() == [True, True, False] and out.measured.tolist() == [True, False, False]
    np.testing.assert_allclose(out.points, origin + np.array([[0.25, 0, 0], [0, 0.3, 0]]), atol=1e-12)
    np.testing.assert_allclose(out.measured_points, [origin + [0.25, 0, 0]], atol=1e-12)


def test_max_coast_zero_is_allowed_and_negative_is_not():
    assert EstimatorConfig(max_coast=0).max_coast == 0
    with pytest.raises(ValueError, match="max_coast"):
        EstimatorConfig(max_coast=-1)
    est = RangeEstimator(1, EstimatorConfig(max_coast=0))
    est.update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    assert not est.update(_single_ray_reading(None, valid=False), 0.05, np.zeros(3)).tracking[0]  # no coasting


@pytest.mark.parametrize("sensor", [True, "5", 5.0, None])
def test_the_sensor_argument_is_a_sensor_config_or_a_ray_count(sensor):
    with pytest.raises(TypeError, match="SensorConfig or a number of rays"):
        RangeEstimator(sensor)


def test_reset_forgets_every_track():
    est = RangeEstimator(1, EstimatorConfig(measurement_std=0.004))
    for _ in range(5):
        est.update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    est.reset()
    out = est.update(_single_ray_reading(0.2), 0.05, np.zeros(3))  # a new track at the reading, no gate reset
    assert est.n_resets == 0 and out.ranges[0] == 0.2 and out.range_std[0] == pytest.approx(0.004)
    est.reset()
    out = est.update(_single_ray_reading(None, valid=False), 0.05, np.zeros(3))
    assert not out.tracking[0]  # nothing left to coast


def test_config_accepts_any_positive_gate_and_estimates_are_frozen():
    import dataclasses

    assert EstimatorConfig(gate_sigma=0.5).gate_sigma == 0.5  # tight, but a gate
    out = RangeEstimator(1).update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    with pytest.raises(dataclasses.FrozenInstanceError):
        out.ranges = np.zeros(1)


def test_readings_of_the_wrong_size_and_short_velocities_are_refused():
    three = SensorReading(np.zeros((3, 3)), np.eye(3), np.full(3, 0.3), np.ones(3, bool), np.ones(3, bool), 0.4)
    with pytest.raises(ValueError, match="reading has 3 rays, the estimator was built for 1"):
        RangeEstimator(1).update(three, 0.05)
    with pytest.raises(ValueError, match="tip_velocity"):
        RangeEstimator(1).update(_single_ray_reading(0.3), 0.05, [0.1, 0.0])


def test_by_default_a_track_coasts_through_five_dropouts():
    """The documented default (max_coast 5): five dropouts in a row are bridged, the sixth drops the track."""
    est = RangeEstimator(1, EstimatorConfig(measurement_std=0.004))
    est.update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    for k in range(5):
        assert est.update(_single_ray_reading(None, valid=False), 0.05, np.zeros(3)).tracking[0], k
    assert not est.update(_single_ray_reading(None, valid=False), 0.05, np.zeros(3)).tracking[0]


def test_an_exact_sensor_still_gets_a_proper_filter():
    """measurement_std 0 (an exact sensor) is floored at 0.1 mm, so the filter's variances stay positive."""
    est = RangeEstimator(1, EstimatorConfig(measurement_std=0.0))
    out = est.update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    assert out.range_std[0] == pytest.approx(1e-4)
    for _ in range(20):
        out = est.update(_single_ray_reading(0.3), 0.05, np.zeros(3))
    assert 0.0 < out.range_std[0] < 1e-4 and out.ranges[0] == pytest.approx(0.3, abs=1e-9)


@pytest.mark.parametrize("field", ["measurement_std", "rate_process_std", "initial_rate_std", "gate_sigma"])
@pytest.mark.parametrize("value", [True, "0.1", None])
def test_config_numbers_must_be_numbers(field, value):
    import dataclasses

    with pytest.raises(ValueError, match=f"EstimatorConfig.{field} must be a number"):
        EstimatorConfig(**{field: value})
    with pytest.raises(dataclasses.FrozenInstanceError):
        EstimatorConfig().gate_sigma = 1.0


@pytest.mark.parametrize("dt", [True, float("nan"), float("inf"), -0.05, 0.0, "0.05"])
def test_dt_must_be_a_positive_finite_number(dt):
    with pytest.raises(ValueError, match="dt must be a positive number of seconds"):
        RangeEstimator(1).update(_single_ray_reading(0.3), dt, np.zeros(3))


@pytest.mark.parametrize("v", [[0.1, 0.0], [0.1, 0.0, 0.0, 0.0], [[0.1], [0.0], [0.0]], [0.0, np.inf, 0.0]])
def test_tip_velocity_must_be_three_finite_numbers(v):
    with pytest.raises(ValueError, match="tip_velocity must be 3 finite numbers"):
        RangeEstimator(1).update(_single_ray_reading(0.3), 0.05, v)


def test_equal_to_the_per_ray_filterpy_filters_on_a_recorded_trial():
    """The stacked filter against the estimator it replaced (57 filterpy ``KalmanFilter`` objects, commit
    aea5384) on 200 recorded readings of ``worlds/truss_clutter.json`` (seed 0, control steps 150-349: 1729
    hits, 236 dropouts, 14 gate resets, 30 coasting predictions): the same tracks, resets and measured rays,
    and ranges, rates and posterior stds equal to 1e-12."""
    from pathlib import Path

    data = np.load(Path(__file__).parent / "data" / "range_readings.npz")
    n_rays = data["ranges"].shape[1]
    est = RangeEstimator(SensorConfig())
    assert est.n_rays == n_rays
    for k in range(len(data["ranges"])):
        reading = SensorReading(np.tile(data["origins"][k], (n_rays, 1)), data["directions"][k], data["ranges"][k],
                                data["hit"][k], data["valid"][k], float(data["max_range"]))
        out = est.update(reading, float(data["dt"]))
        np.testing.assert_array_equal(out.tracking, data["out_tracking"][k], err_msg=f"step {k}")
        np.testing.assert_array_equal(out.measured, data["out_measured"][k], err_msg=f"step {k}")
        for name, want in (("ranges", "out_ranges"), ("rates", "out_rates"), ("range_std", "out_std")):
            np.testing.assert_allclose(getattr(out, name), data[want][k], rtol=0, atol=1e-12, equal_nan=True,
                                       err_msg=f"{name}, step {k}")
        np.testing.assert_array_equal(out.valid, data["valid"][k])
        assert out.max_range == float(data["max_range"])
    assert est.n_resets == int(data["n_resets"]) == 14


def _numpy_filter(est: RangeEstimator, reading: SensorReading, dt: float, v: np.ndarray) -> None:
    """The stacked equations as numpy ``matmul`` over the stack (the code the compiled kernel replaced)."""
    cfg = est.config
    F, B, Q = est._model(dt)
    Ft = F.T
    hit, valid, z = reading.hit, reading.valid, reading.ranges
    tracked = est.tracking
    x = F @ est._x + B @ -(reading.directions @ v)[:, None, None]
    P = F @ est._P @ Ft + Q
    np.maximum(x[:, 0, 0], 0.0, out=x[:, 0, 0])
    predicted = tracked & (hit | ~valid)
    innovation = z - x[:, 0, 0]
    gated = tracked & hit & (innovation * innovation > cfg.gate_sigma**2 * (P[:, 0, 0] + est._R[0, 0]))
    updated = tracked & hit & ~gated
    H, R = est._H, est._R
    PHT = P @ H.T
    K = PHT @ (1.0 / (H @ PHT + R))
    I_KH = np.eye(2) - K @ H
    x_post = x + K @ innovation[:, None, None]
    P_post = I_KH @ P @ I_KH.transpose(0, 2, 1) + K @ R @ K.transpose(0, 2, 1)
    keep, pred = updated[:, None, None], predicted[:, None, None]
    est._x = np.where(keep, x_post, np.where(pred, x, est._x))
    est._P = np.where(keep, P_post, np.where(pred, P, est._P))
    est._coast = np.where(updated, 0, est._coast + (tracked & ~valid))
    est.n_resets += int(np.count_nonzero(gated))
    est.tracking = tracked & ~(valid & ~hit) & (est._coast <= cfg.max_coast)
    starts = (~tracked & hit) | gated
    est._start(np.flatnonzero(starts), z[starts])


@pytest.mark.parametrize("seed", [0, 1])
def test_the_compiled_stack_equals_numpys_stacked_equations(seed):
    """57 rays with hits, misses, dropouts and jumps: the kernel's states equal numpy's matmul over the stack,
    bit for bit where numpy's BLAS fuses as OpenBLAS (tests/test_fused.py), else to 1e-12 (the filterpy bound)."""
    from _blas import FUSES

    rng = np.random.default_rng(seed)
    cfg = SensorConfig()
    a, b = RangeEstimator(cfg), RangeEstimator(cfg)
    dirs = ray_directions(cfg)
    base = rng.uniform(0.05, 0.35, cfg.n_rays)
    resets = 0
    for k in range(300):
        v = rng.normal(scale=0.05, size=3)
        true = base + 0.02 * np.sin(0.1 * k + np.arange(cfg.n_rays))
        true = np.where(rng.random(cfg.n_rays) < 0.05, true - 0.1, true)  # jumps: gate resets
        hit = (true > 0.0) & (rng.random(cfg.n_rays) < 0.9)
        valid = rng.random(cfg.n_rays) >= 0.1
        ranges = np.where(valid, np.where(hit, true + 0.004 * rng.standard_normal(cfg.n_rays), 0.4), np.nan)
        reading = SensorReading(np.tile(v * k * 0.033, (cfg.n_rays, 1)), dirs, ranges, hit & valid, valid, 0.4)
        a._filter(reading, 1.0 / 30.0, v)
        _numpy_filter(b, reading, 1.0 / 30.0, v)
        assert a.n_resets == b.n_resets
        np.testing.assert_array_equal(a.tracking, b.tracking)
        np.testing.assert_array_equal(a._coast, b._coast)
        for got, want in ((a._x, b._x), (a._P, b._P)):
            if FUSES:
                np.testing.assert_array_equal(got, want)
            else:
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
        resets = a.n_resets
    assert resets > 50 and a.tracking.any() and not a.tracking.all()


def _rim_run(lag_sigma: float, rate: float = -0.25, dt: float = 1 / 30, n_ramp: int = 25, n_flat: int = 15):
    """One ray sliding along a face towards its rim (an exact range falling at ``rate`` [m/s], the tip still,
    so the filter's rate state learns it), then past the rim onto what lies behind it at the same range (the
    range stops falling): (exact ranges, estimates)."""
    est = RangeEstimator(1, EstimatorConfig(measurement_std=0.004, lag_sigma=lag_sigma))
    true = [0.38 + rate * dt * min(k, n_ramp) for k in range(n_ramp + n_flat)]  # 0.38 -> 0.17 m
    return np.array(true), [est.update(_single_ray_reading(r), dt, np.zeros(3)) for r in true]


def test_a_filter_that_runs_past_a_rim_is_lagging():
    true, outs = _rim_run(2.0)
    ahead = np.array([o.ranges[0] - r for o, r in zip(outs, true, strict=True)])
    lagging = np.array([o.lagging[0] for o in outs])
    # on the ramp the filter follows (a track starts with no rate: behind by up to 6.7 mm while it learns it);
    # past the rim (step 25) its rate carries it on, 11.6 mm in front of the surface, until the gate resets it
    assert not lagging[:26].any() and np.abs(ahead[8:26]).max() < 0.003
    assert ahead[26:].min() < -0.011 and lagging[26:].sum() == 1
    np.testing.assert_array_equal(lagging, np.abs(ahead) > 2.0 * 0.004)  # lagging: more than 2 stds off
    for o, r in zip(outs, true, strict=True):
        assert o.measured_ranges[0] == r
        np.testing.assert_array_equal(o.measured_points, o.origins[:1] + o.ranges[0] * o.directions[:1])


def test_with_an_infinite_lag_sigma_no_ray_is_lagging():
    true, outs = _rim_run(float("inf"))
    assert not any(o.lagging[0] for o in outs)
    assert min(o.ranges[0] - r for o, r in zip(outs, true, strict=True)) < -0.011  # in front of the rim all the same


def test_measured_ranges_of_rays_not_measured_are_nan_and_lag_sigma_is_checked():
    est = RangeEstimator(2, EstimatorConfig(measurement_std=0.004))
    reading = SensorReading(np.zeros((2, 3)), np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.array([0.2, 0.4]),
                            np.array([True, False]), np.array([True, True]), 0.4)
    out = est.update(reading, 0.05, np.zeros(3))
    assert out.measured_ranges[0] == 0.2 and np.isnan(out.measured_ranges[1])
    assert not out.lagging.any()
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="EstimatorConfig.lag_sigma"):
            EstimatorConfig(lag_sigma=bad)
    with pytest.raises(ValueError, match="EstimatorConfig.gate_sigma must be a number >= 0"):
        EstimatorConfig(gate_sigma=float("inf"))
