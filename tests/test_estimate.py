"""Per-ray Kalman range filters (filterpy) on synthetic readings: no simulator needed."""

from __future__ import annotations

import numpy as np
import pytest

from navstack.estimate import EstimatorConfig, RangeEstimator
from navstack.sensing import SensorConfig, frame_from_direction, make_reading, ray_directions

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
