"""Range estimation: one small Kalman filter per ray, all rays stepped together as one stack.

Design decision: **per ray**, not per sector.  The tip sensor has a few dozen
thin rays and the obstacles of an inspection world are thin (truss members of
radius ~0.02 m): averaging rays over a sector would smear a member over the
sector and shift its apparent position, while a per-ray filter keeps every
ray's geometry exact and only removes range noise.  The rays are independent,
so R two-state filters cost the same as one 2R-state filter with a block
diagonal structure and are much simpler to reset one at a time.

Model of ray ``i`` (state ``x = [r, b]``: range [m] and the part of the range
rate not explained by the tip's own motion [m/s]):

    r_{k+1} = r_k + dt (u_k + b_k),   u_k = -v_tip . d_i   (input: the tip's velocity)
    b_{k+1} = b_k + w                  (random walk: Q_discrete_white_noise)
    z_k     = r_k + noise              (measurement std ``measurement_std``)

``u`` is the exact range rate for an obstacle point straight along the ray;
``b`` absorbs the rest (surface slope as the ray slides along it, the tip's
rotation).  So ``F = [[1, dt], [0, 1]]``, ``B = [[dt], [0]]``, ``H = [[1, 0]]``.
The tip velocity comes from the caller, or from the displacement of the
reading's origin between readings.

Measured limitation: on a wall seen obliquely by a tip that also turns, most
of a ray's range rate comes from the hit point sliding along the surface
(which needs the unknown surface normal and the tip's rotation), so the input
``-v . d`` helps little there and ``b`` does the work; the input matters for
surfaces facing the ray and at track starts.  With 5 mm noise on such a wall
(tests/test_estimate.py) the filtered RMS error is about 0.6 of the raw one.

Track management, per ray and per reading:

* a ray that hits while not tracked **starts** a track: ``x = [z, 0]``,
  ``P = diag(measurement_std^2, initial_rate_std^2)``;
* a tracked ray that hits again is predicted then updated, unless the
  innovation exceeds ``gate_sigma`` standard deviations, in which case the
  ray jumped to another surface (an edge) and the track is **reset** to the
  measurement;
* a tracked ray that reports a miss (valid, no hit) **stops** its track: it
  now sees free space to its maximum range;
* a dropout (``valid = False``) is **predicted only** (coasting); after
  ``max_coast`` consecutive dropouts the track is dropped.

The output (:class:`RangeEstimate`) gives the filtered range of every tracked
ray (``NaN`` elsewhere) and the corresponding world-frame obstacle points.
Nothing here reads obstacle geometry: only sensor readings and the tip's
velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from filterpy.common import Q_discrete_white_noise
from numpy.typing import ArrayLike, NDArray

from navstack.fused import fma
from navstack.sensing import SensorConfig, SensorReading
from navstack.validate import integer, non_negative, positive

__all__ = ["EstimatorConfig", "RangeEstimate", "RangeEstimator"]


@dataclass(frozen=True)
class EstimatorConfig:
    """Parameters of the per-ray range filters (metres, seconds).

    Attributes:
        measurement_std: assumed range noise std [m] (use the sensor's ``noise_std``;
            a floor of 1e-4 m is applied so exact sensors still give a proper filter).
        rate_process_std: white-noise intensity driving the rate state b [m/s^2].
        initial_rate_std: prior std of b when a track starts [m/s].
        gate_sigma: innovation gate in standard deviations; beyond it the track resets.
        max_coast: consecutive dropouts a track survives by prediction alone.
        lag_sigma: a measured ray whose filtered range is more than this many ``measurement_std`` from its own
            measurement is *lagging* (:attr:`RangeEstimate.lagging`): the filter's rate carried it past a
            change its model does not have, such as a rim where the range stops falling while the rate still
            says it falls.  ``inf``: no ray ever is.
    """

    measurement_std: float = 0.004
    rate_process_std: float = 0.1
    initial_rate_std: float = 0.05
    gate_sigma: float = 4.0
    max_coast: int = 5
    lag_sigma: float = 2.0

    def __post_init__(self) -> None:
        non_negative(self, "measurement_std", "rate_process_std", "initial_rate_std", "gate_sigma")
        positive(self, "gate_sigma")  # (a number >= 0 first, as the others: one message for a value of no number)
        positive(self, "lag_sigma", inf_ok=True)  # inf: never lagging
        integer(self, "max_coast", lo=0)


@dataclass(frozen=True)
class RangeEstimate:
    """Filtered ranges of one reading.

    Attributes:
        origins: (R, 3) ray origins of the reading [m] (world).
        directions: (R, 3) unit ray directions (world).
        ranges: (R,) filtered range [m] of tracked rays, ``NaN`` for untracked ones.
        rates: (R,) estimated unexplained range rate b [m/s] (``NaN`` if untracked).
        tracking: (R,) True where the ray currently tracks an obstacle (coasting included).
        measured: (R,) True where the track was updated by a hit in this very reading
            (False for coasting tracks, which are predictions only).
        range_std: (R,) posterior standard deviation of the range [m] (``NaN`` if untracked).
        valid: (R,) False where the ray dropped out of this reading (no information).
        max_range: the sensor's range [m] (a valid ray that is not tracking saw free space this far).
        measured_ranges: (R,) this reading's own range [m] where ``measured``, ``NaN`` elsewhere (None: not
            given, as by a caller that builds an estimate itself).
        lagging: (R,) True where a measured ray's filtered range is more than
            :attr:`EstimatorConfig.lag_sigma` measurement stds from ``measured_ranges`` (None: none is).
    """

    origins: NDArray[np.float64]
    directions: NDArray[np.float64]
    ranges: NDArray[np.float64]
    rates: NDArray[np.float64]
    tracking: NDArray[np.bool_]
    measured: NDArray[np.bool_]
    range_std: NDArray[np.float64]
    valid: NDArray[np.bool_] | None = None
    max_range: float = float("nan")
    measured_ranges: NDArray[np.float64] | None = None
    lagging: NDArray[np.bool_] | None = None

    @property
    def points(self) -> NDArray[np.float64]:
        """World positions (K, 3) [m] of the filtered obstacle points (tracked rays)."""
        m = self.tracking
        return self.origins[m] + self.ranges[m, None] * self.directions[m]

    @property
    def measured_points(self) -> NDArray[np.float64]:
        """World positions [m] of the filtered points of rays that hit in this reading."""
        m = self.measured
        return self.origins[m] + self.ranges[m, None] * self.directions[m]


class RangeEstimator:
    """Per-ray constant-rate Kalman filters with the tip's velocity as input, run as one stack.

    Every ray has its own two-state filter (module docstring); their states ``[r, b]`` and covariances
    are stacked in arrays of shape (R, 2, 1) and (R, 2, 2), and one reading runs filterpy's predict and
    update equations (``x = F x + B u``, ``P = F P F' + Q``; ``y = z - H x``, ``S = H P H' + R``,
    ``K = P H' S^-1``, ``x = x + K y``, ``P = (I - K H) P (I - K H)' + K R K'``) on the rays that need
    them in one compiled pass over the stack (:func:`_filter_stack`) where filterpy's ``KalmanFilter``
    uses ``dot`` on one filter: the same estimates (to 1e-12, tests/test_estimate.py) without 57 Python
    objects.  The process noise ``Q`` is filterpy's ``Q_discrete_white_noise``.

    Args:
        sensor: the sensor's :class:`SensorConfig` (its ray count, and its
            ``noise_std`` as the measurement noise when ``config`` is None), or
            just the number of rays R of the readings that will be passed in.
        config: filter parameters (``None`` = defaults).
    """

    _H = np.array([[1.0, 0.0]])

    def __init__(self, sensor: SensorConfig | int, config: EstimatorConfig | None = None) -> None:
        if isinstance(sensor, SensorConfig):
            n_rays = sensor.n_rays
            if config is None:
                config = EstimatorConfig(measurement_std=sensor.noise_std)
        elif isinstance(sensor, (int, np.integer)) and not isinstance(sensor, bool):
            n_rays = int(sensor)
        else:
            raise TypeError(f"sensor must be a SensorConfig or a number of rays, got {type(sensor).__name__}")
        if n_rays < 1:
            raise ValueError(f"the number of rays must be >= 1, got {n_rays}")
        if config is None:
            config = EstimatorConfig()
        if not isinstance(config, EstimatorConfig):
            raise TypeError(f"config must be an EstimatorConfig, got {type(config).__name__}")
        self.n_rays = int(n_rays)
        self.config = config
        self._std = max(config.measurement_std, 1e-4)
        self._R = np.array([[self._std**2]])
        self._P0 = np.diag([self._std**2, config.initial_rate_std**2 + 1e-12])
        self._x = np.zeros((self.n_rays, 2, 1))
        """Stacked states [r, b] [m, m/s] of every ray's filter (meaningful where tracking)."""
        self._P = np.zeros((self.n_rays, 2, 2))
        """Stacked covariances [m^2, m^2/s, m^2/s^2]."""
        self._models: dict[float, tuple[NDArray[np.float64], ...]] = {}
        self.tracking = np.zeros(self.n_rays, dtype=np.bool_)
        self._coast = np.zeros(self.n_rays, dtype=np.int64)
        self._last_origin: NDArray[np.float64] | None = None
        self.n_resets = 0
        """Number of innovation-gate resets so far (edges, jumps between surfaces)."""

    def reset(self) -> None:
        """Forget every track."""
        self.tracking[:] = False
        self._coast[:] = 0
        self._last_origin = None

    def _model(self, dt: float) -> tuple[NDArray[np.float64], ...]:
        """``F``, ``B`` and ``Q`` for a step of ``dt`` [s] (built once per distinct ``dt``)."""
        model = self._models.get(dt)
        if model is None:
            F = np.array([[1.0, dt], [0.0, 1.0]])
            Q = Q_discrete_white_noise(dim=2, dt=dt, var=self.config.rate_process_std**2)
            model = (F, np.array([[dt], [0.0]]), Q)
            if len(self._models) < 16:
                self._models[dt] = model
        return model

    def _start(self, rays: NDArray[np.intp], z: NDArray[np.float64]) -> None:
        """Start (or restart) the tracks of ``rays`` at the measured ranges ``z`` [m]."""
        self._x[rays, 0, 0] = z
        self._x[rays, 1, 0] = 0.0
        self._P[rays] = self._P0
        self.tracking[rays] = True
        self._coast[rays] = 0

    def update(
        self, reading: SensorReading, dt: float, tip_velocity: ArrayLike | None = None
    ) -> RangeEstimate:
        """Fuse one reading.

        Args:
            reading: the new sensor reading (R rays).
            dt: time since the previous reading [s], > 0.
            tip_velocity: (3,) the tip's velocity [m/s] over that interval (world
                frame), the filters' input; ``None`` = the displacement of the
                reading's origin since the previous reading divided by ``dt``
                (zero for the first reading).

        Returns:
            The filtered ranges and obstacle points after this reading.
        """
        if not isinstance(reading, SensorReading):
            raise TypeError(f"reading must be a SensorReading, got {type(reading).__name__}")
        if reading.n_rays != self.n_rays:
            raise ValueError(f"reading has {reading.n_rays} rays, the estimator was built for {self.n_rays}")
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.floating)) or not np.isfinite(dt) \
                or dt <= 0:
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        origin = np.array(reading.origins[0])
        if tip_velocity is None:
            v = np.zeros(3) if self._last_origin is None else (origin - self._last_origin) / dt
        else:
            v = np.asarray(tip_velocity, dtype=np.float64)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ValueError(f"tip_velocity must be 3 finite numbers [m/s], got {tip_velocity!r}")
        self._last_origin = origin
        self._filter(reading, float(dt), v)
        return self._estimate(reading)

    def _filter(self, reading: SensorReading, dt: float, v: NDArray[np.float64]) -> None:
        """Step every ray's filter over ``dt`` [s] with the tip velocity ``v`` [m/s] as input (module docstring).

        The whole stack is predicted and updated; per ray, masks keep the outcome its case calls for:
        a tracked ray's hit is predicted and updated (or restarted beyond the gate), its dropout predicted
        (coasting), its valid miss stops the track; an untracked ray's hit starts one (:func:`_filter_stack`)."""
        cfg = self.config
        F, B, Q = self._model(dt)
        self.n_resets += _filter_stack(
            self._x, self._P, self.tracking, self._coast, np.ascontiguousarray(reading.hit),
            np.ascontiguousarray(reading.valid), np.ascontiguousarray(reading.ranges, dtype=np.float64),
            np.ascontiguousarray(reading.directions, dtype=np.float64), v, F, B, Q, self._R[0, 0], self._P0,
            cfg.gate_sigma**2, cfg.max_coast)

    def _estimate(self, reading: SensorReading) -> RangeEstimate:
        """The current tracks as a :class:`RangeEstimate` of ``reading``."""
        t = self.tracking
        nan = np.nan
        measured = reading.hit & t
        z = np.where(measured, reading.ranges, nan)
        lagging = np.abs(self._x[:, 0, 0] - z) > self.config.lag_sigma * self._std  # NaN (not measured): False
        return RangeEstimate(
            origins=np.array(reading.origins),
            directions=np.array(reading.directions),
            ranges=np.where(t, self._x[:, 0, 0], nan),
            rates=np.where(t, self._x[:, 1, 0], nan),
            tracking=t.copy(),
            measured=measured,
            range_std=np.where(t, np.sqrt(np.maximum(self._P[:, 0, 0], 0.0)), nan),
            valid=np.array(reading.valid),
            max_range=float(reading.max_range),
            measured_ranges=z,
            lagging=lagging,
        )


@numba.njit(cache=True)
def _filter_stack(x, P, tracking, coast, hit, valid, z, dirs, v, F, B, Q, r, P0, gate2, max_coast):  # pragma: no cover
    """One reading through every ray's filter, in place (``x`` (R, 2, 1), ``P`` (R, 2, 2), ``tracking``,
    ``coast``); returns the number of gate resets.

    Per ray: predict (``x = F x + B u``, ``u = -d . v``; ``P = F P F' + Q``; the range kept >= 0), update
    (``S = H P H' + r``, ``K = P H' / S``, ``x = x + K (z - H x)``, ``P = (I - K H) P (I - K H)' + K r K'``,
    ``H = [1, 0]``), then keep what the ray's case calls for (:meth:`RangeEstimator._filter`).  These are
    the stacked ``numpy.matmul`` equations this kernel replaced, in numpy's order of operations
    (:mod:`navstack.fused`), so the estimates are theirs bit for bit where BLAS fuses as OpenBLAS does."""
    n_gated = 0
    for i in range(x.shape[0]):
        u = -fma(dirs[i, 2], v[2], fma(dirs[i, 0], v[0], dirs[i, 1] * v[1]))
        x0, x1 = x[i, 0, 0], x[i, 1, 0]
        p00, p01, p10, p11 = P[i, 0, 0], P[i, 0, 1], P[i, 1, 0], P[i, 1, 1]
        # predict: F x (a matrix times a column) + B u (an inner dimension of 1)
        X0 = fma(F[0, 0], x0, F[0, 1] * x1) + B[0, 0] * u
        X1 = fma(F[1, 0], x0, F[1, 1] * x1) + B[1, 0] * u
        X0 = X0 if X0 > 0.0 or X0 != X0 else 0.0  # a range is never negative (numpy.maximum: NaN stays, +0.0)
        # (F P) F' + Q
        a00 = fma(F[0, 1], p10, F[0, 0] * p00)
        a01 = fma(F[0, 1], p11, F[0, 0] * p01)
        a10 = fma(F[1, 1], p10, F[1, 0] * p00)
        a11 = fma(F[1, 1], p11, F[1, 0] * p01)
        q00 = fma(a01, F[0, 1], a00 * F[0, 0]) + Q[0, 0]
        q01 = fma(a01, F[1, 1], a00 * F[1, 0]) + Q[0, 1]
        q10 = fma(a11, F[0, 1], a10 * F[0, 0]) + Q[1, 0]
        q11 = fma(a11, F[1, 1], a10 * F[1, 0]) + Q[1, 1]
        tracked = tracking[i]
        innovation = z[i] - X0  # NaN for dropouts: computed, never kept
        gated = tracked and hit[i] and innovation * innovation > gate2 * (q00 + r)
        updated = tracked and hit[i] and not gated
        predicted = tracked and (hit[i] or not valid[i])
        if updated:
            # P H' (a column: P[:, 0] * 1 + P[:, 1] * 0 in numpy's order), S = H (P H') + r, K = (P H') / S
            ph0 = fma(q00, 1.0, q01 * 0.0)
            ph1 = fma(q10, 1.0, q11 * 0.0)
            inv_s = 1.0 / (fma(0.0, ph1, 1.0 * ph0) + r)
            k0, k1 = ph0 * inv_s, ph1 * inv_s
            # I - K H
            i00, i01 = 1.0 - k0 * 1.0, 0.0 - k0 * 0.0
            i10, i11 = 0.0 - k1 * 1.0, 1.0 - k1 * 0.0
            x[i, 0, 0] = X0 + k0 * innovation
            x[i, 1, 0] = X1 + k1 * innovation
            # ((I - K H) P) (I - K H)' + (K r) K'
            b00 = fma(i01, q10, i00 * q00)
            b01 = fma(i01, q11, i00 * q01)
            b10 = fma(i11, q10, i10 * q00)
            b11 = fma(i11, q11, i10 * q01)
            kr0, kr1 = k0 * r, k1 * r
            P[i, 0, 0] = fma(b01, i01, b00 * i00) + kr0 * k0
            P[i, 0, 1] = fma(b01, i11, b00 * i10) + kr0 * k1
            P[i, 1, 0] = fma(b11, i01, b10 * i00) + kr1 * k0
            P[i, 1, 1] = fma(b11, i11, b10 * i10) + kr1 * k1
        elif predicted:
            x[i, 0, 0], x[i, 1, 0] = X0, X1
            P[i, 0, 0], P[i, 0, 1], P[i, 1, 0], P[i, 1, 1] = q00, q01, q10, q11
        if updated:
            coast[i] = 0
        elif tracked and not valid[i]:
            coast[i] += 1
        n_gated += gated
        tracking[i] = tracked and not (valid[i] and not hit[i]) and coast[i] <= max_coast
        if (not tracked and hit[i]) or gated:  # start (or restart) the track at the measurement
            x[i, 0, 0], x[i, 1, 0] = z[i], 0.0
            P[i] = P0
            tracking[i] = True
            coast[i] = 0
    return n_gated
