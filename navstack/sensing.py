"""Tip proximity sensing: ray pattern, noise model and the reading record (pure numpy).

The paper (section 2) mounts proximity sensors at the tip of the serpentine and
uses them, and nothing else, to find a collision-free tip path.  This module
describes such a sensor as a fixed bundle of range rays; the PyBullet adapter
that actually casts them is :class:`navstack.sim.rays.RaySensor`.  Nothing here
knows about obstacles.

Tip frame convention
--------------------
Ray directions are given in the **tip frame**, DH frame 21 of the JPL robot
(interfaces.md section 1): its origin is the tip point and its **x axis is the
forward direction** of the tip.  The last serpentine link runs from J1 (the
origin of frames 19/20) along the x axis of frame 20 to the tip, and frame 21
is frame 20 translated by 0.20 m along that axis (alpha_20 = theta_21 = 0), so
frames 20 and 21 share their orientation.  The y and z axes of the tip frame
are the two lateral directions.  With ``Q_DEFAULT`` the tip's x axis is +z0.
For a free point "robot" (tests, tools), :func:`frame_from_direction` builds a
tip frame from a position and a heading.

Ray pattern (:class:`SensorConfig`)
-----------------------------------
* a **forward cone**: optionally the axis ray (+x), then ``cone_rings`` rings of
  ``cone_rays_per_ring`` rays at polar angles ``k / cone_rings * cone_half_angle``
  (k = 1..cone_rings) from +x; odd rings are rotated by half an azimuth step so
  that the rings interleave;
* a **side ring** of ``side_rays`` rays perpendicular to the tip direction;
* a **backward ring** of ``back_rays`` rays tilted ``back_tilt`` rad behind the
  side ring (they look back along the body, e.g. at a member the tip has just
  passed).

Ranges are measured **from the tip point** (the frame origin).  The robot's own
tip capsule (radius ``body_radius``, hemispherical end at the tip, running
back along -x) would hide everything, so each ray starts where it leaves that
capsule, plus ``start_margin``: :func:`ray_start_distances`.  An obstacle
closer than that start distance (i.e. practically touching the tip) is not
seen; that blind zone is by design.

Noise model
-----------
For each ray independently (:func:`apply_noise`): with probability
``dropout_prob`` the ray returns nothing (``valid = False``, ``hit = False``,
range ``NaN``: no information, which is different from "free to max range");
otherwise a ray that hit gets zero-mean Gaussian noise of standard deviation
``noise_std`` [m] added to its true range, clipped to ``[start, max_range]``.
A ray that hit nothing reports exactly ``max_range`` with ``hit = False``.
One uniform and one normal number are drawn per ray per reading whatever the
outcome, so the random stream, and hence the readings, are deterministic
given the generator's seed.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.validate import flag, in_range, integer, positive

__all__ = [
    "SensorConfig",
    "SensorReading",
    "apply_noise",
    "check_pose",
    "frame_from_direction",
    "make_reading",
    "reading_from_rays",
    "ray_directions",
    "ray_start_distances",
]


@dataclass(frozen=True)
class SensorConfig:
    """Tip proximity sensor: ray pattern, range and noise (metres, radians).

    Attributes:
        cone_rings: number of rings in the forward cone (0 = axis ray only).
        cone_rays_per_ring: rays per forward ring.
        cone_half_angle: polar angle of the outermost forward ring [rad], in (0, pi/2).
        include_axis: cast a ray straight ahead (+x of the tip frame).
        side_rays: rays in the ring perpendicular to the tip direction (0 = none).
        back_rays: rays in the backward-tilted ring (0 = none).
        back_tilt: how far the backward ring is tilted behind the side ring [rad], in (0, 1.2].
        max_range: range of every ray, measured from the tip point [m].
        noise_std: standard deviation of the Gaussian range noise on hits [m].
        dropout_prob: probability that a ray returns nothing in a reading.
        body_radius: radius of the tip capsule the rays must leave first [m].
        start_margin: extra distance beyond the capsule surface where rays start [m].
    """

    cone_rings: int = 3
    cone_rays_per_ring: int = 12
    cone_half_angle: float = 0.7
    include_axis: bool = True
    side_rays: int = 12
    back_rays: int = 8
    back_tilt: float = 0.5
    max_range: float = 0.4
    noise_std: float = 0.004
    dropout_prob: float = 0.02
    body_radius: float = 0.025
    start_margin: float = 0.005

    def __post_init__(self) -> None:
        integer(self, "cone_rings", "side_rays", "back_rays", lo=0)
        integer(self, "cone_rays_per_ring", lo=1)
        flag(self, "include_axis")
        in_range(self, "cone_half_angle", lo=0.0, hi=np.pi / 2, lo_open=True, hi_open=True, unit=" [rad]")
        in_range(self, "back_tilt", lo=0.0, hi=1.2, lo_open=True, unit=" [rad]")
        in_range(self, "max_range", lo=0.0, hi=100.0, lo_open=True, unit=" [m]")
        in_range(self, "noise_std", "body_radius", "start_margin", lo=0.0, hi=1.0, unit=" [m]")
        in_range(self, "dropout_prob", lo=0.0, hi=1.0, hi_open=True)
        n = (1 if self.include_axis else 0) + self.cone_rings * self.cone_rays_per_ring
        if n + self.side_rays + self.back_rays == 0:
            raise ValueError("SensorConfig has no rays: set include_axis, cone_rings, side_rays or back_rays")
        start = float(ray_start_distances(self).max())
        if start >= self.max_range:
            raise ValueError(
                f"SensorConfig.max_range ({self.max_range} m) must exceed the farthest ray start "
                f"({start:.4f} m = body_radius/cos(back_tilt) + start_margin)"
            )

    @property
    def n_rays(self) -> int:
        """Total number of rays R."""
        return ray_directions(self).shape[0]


def _ring(polar: float, count: int, phase: float) -> NDArray[np.float64]:
    az = phase + 2.0 * np.pi * np.arange(count) / count
    return np.stack(
        [np.full(count, np.cos(polar)), np.sin(polar) * np.cos(az), np.sin(polar) * np.sin(az)], axis=1
    )


def ray_directions(config: SensorConfig) -> NDArray[np.float64]:
    """Unit ray directions (R, 3) in the tip frame (x forward), in a fixed order.

    Order: axis ray (if any), forward rings from the innermost out, side ring,
    backward ring.  Returns a new array.
    """
    return _ray_directions(config).copy()


@functools.lru_cache(maxsize=64)
def _ray_directions(config: SensorConfig) -> NDArray[np.float64]:
    parts: list[NDArray[np.float64]] = []
    if config.include_axis:
        parts.append(np.array([[1.0, 0.0, 0.0]]))
    m = config.cone_rays_per_ring
    for k in range(1, config.cone_rings + 1):
        phase = (np.pi / m) if k % 2 == 0 else 0.0
        parts.append(_ring(k / config.cone_rings * config.cone_half_angle, m, phase))
    if config.side_rays:
        parts.append(_ring(np.pi / 2, config.side_rays, 0.0))
    if config.back_rays:
        parts.append(_ring(np.pi / 2 + config.back_tilt, config.back_rays, np.pi / config.back_rays))
    dirs = np.concatenate(parts, axis=0)
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    dirs.setflags(write=False)
    return dirs


def ray_start_distances(config: SensorConfig) -> NDArray[np.float64]:
    """Distance (R,) [m] from the tip point at which each ray starts.

    A ray leaves the tip capsule (hemisphere of radius ``body_radius`` ahead of
    the tip, cylinder of the same radius behind it) after ``body_radius`` if it
    points forward or sideways, and after ``body_radius / sin(polar)`` if it
    points backward (polar angle > pi/2 from +x); ``start_margin`` is added.
    Returns a new array.
    """
    return _ray_start_distances(config).copy()


@functools.lru_cache(maxsize=64)
def _ray_start_distances(config: SensorConfig) -> NDArray[np.float64]:
    dirs = _ray_directions(config)
    lateral = np.sqrt(np.clip(1.0 - dirs[:, 0] ** 2, 1e-12, None))
    exit_dist = np.where(dirs[:, 0] >= 0.0, config.body_radius, config.body_radius / lateral)
    out = exit_dist + config.start_margin
    out.setflags(write=False)
    return out


_IDENTITY3 = np.eye(3)
_ORTHONORMAL_TOL = 1e-6 + 1e-5 * np.eye(3)
"""Allowed ``|R^T R - I|`` per entry in :func:`check_pose`: ``numpy.allclose(R.T @ R, I, atol=1e-6)``'s bound,
written out (a tenth of its cost)."""


def check_pose(tip_T_world: ArrayLike, name: str = "tip_T_world") -> NDArray[np.float64]:
    """Return ``tip_T_world`` as a (4, 4) float array, or raise ``ValueError`` naming the problem.

    The rotation block must be orthonormal (to 1e-6) and every entry finite.
    """
    T = np.asarray(tip_T_world, dtype=np.float64)
    if T.shape != (4, 4):
        raise ValueError(f"{name} must be a (4, 4) homogeneous transform, got shape {T.shape}")
    if not np.isfinite(T).all():
        raise ValueError(f"{name} contains non-finite values")
    R = T[:3, :3]
    if not (np.abs(R.T @ R - _IDENTITY3) <= _ORTHONORMAL_TOL).all():
        raise ValueError(f"{name}: the rotation block is not orthonormal")
    return T


def frame_from_direction(position: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
    """A tip frame (4, 4) at ``position`` [m] whose x axis is ``direction``.

    The lateral axes are chosen deterministically: y is perpendicular to x and
    to whichever world axis is least aligned with x; z = x cross y.  Raises
    ``ValueError`` for a non-finite position or a zero/non-finite direction.
    """
    p = np.asarray(position, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"position must be 3 finite numbers, got {position!r}")
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) < 1e-12:
        raise ValueError(f"direction must be a non-zero finite 3-vector, got {direction!r}")
    x = d / np.linalg.norm(d)
    ref = np.eye(3)[int(np.argmin(np.abs(x)))]
    y = np.cross(ref, x)
    y /= np.linalg.norm(y)
    z = np.cross(x, y)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, p
    return T


@dataclass(frozen=True)
class SensorReading:
    """One reading of the tip sensor, in the world frame.

    Attributes:
        origins: (R, 3) sensor origin of each ray [m] (the tip point); ranges
            are measured from here.
        directions: (R, 3) unit ray directions in the world frame.
        ranges: (R,) range [m]: distance to the first obstacle hit, ``max_range``
            when nothing was hit, ``NaN`` for a dropout.
        hit: (R,) True where an obstacle was hit (False for dropouts).
        valid: (R,) False where the ray dropped out (no information).
        max_range: the sensor's maximum range [m].
    """

    origins: NDArray[np.float64]
    directions: NDArray[np.float64]
    ranges: NDArray[np.float64]
    hit: NDArray[np.bool_]
    valid: NDArray[np.bool_]
    max_range: float

    def __post_init__(self) -> None:
        o = np.array(self.origins, dtype=np.float64)
        d = np.array(self.directions, dtype=np.float64)
        r = np.array(self.ranges, dtype=np.float64)
        h = np.array(self.hit, dtype=np.bool_)
        v = np.array(self.valid, dtype=np.bool_)
        n = r.shape[0] if r.ndim == 1 else -1
        if n < 0 or o.shape != (n, 3) or d.shape != (n, 3) or h.shape != (n,) or v.shape != (n,):
            raise ValueError(
                "SensorReading arrays disagree: origins "
                f"{o.shape}, directions {d.shape}, ranges {r.shape}, hit {h.shape}, valid {v.shape}"
            )
        if np.any(h & ~v):
            raise ValueError("SensorReading: a ray cannot be both a hit and a dropout (hit & ~valid)")
        positive(self, "max_range")
        for name, arr in (("origins", o), ("directions", d), ("ranges", r), ("hit", h), ("valid", v)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @classmethod
    def _owned(cls, origins: NDArray[np.float64], directions: NDArray[np.float64], ranges: NDArray[np.float64],
               hit: NDArray[np.bool_], valid: NDArray[np.bool_], max_range: float) -> SensorReading:
        """A reading of arrays its maker has just built (float and bool arrays of agreeing shapes, no hit that
        dropped out, a positive ``max_range``) and hands over: frozen without the checks and copies of
        :meth:`__post_init__`."""
        reading = object.__new__(cls)
        for name, arr in (("origins", origins), ("directions", directions), ("ranges", ranges), ("hit", hit),
                          ("valid", valid)):
            arr.setflags(write=False)
            object.__setattr__(reading, name, arr)
        object.__setattr__(reading, "max_range", max_range)
        return reading

    @property
    def n_rays(self) -> int:
        """Number of rays R."""
        return int(self.ranges.shape[0])

    @property
    def points(self) -> NDArray[np.float64]:
        """World positions (H, 3) [m] of the hits (rays with ``hit``), in ray order."""
        m = self.hit
        return self.origins[m] + self.ranges[m, None] * self.directions[m]


def apply_noise(
    true_ranges: NDArray[np.float64],
    hit: NDArray[np.bool_],
    config: SensorConfig,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
    """Apply the dropout and Gaussian noise model to exact ranges.

    Args:
        true_ranges: (R,) exact ranges from the tip point [m] (``max_range`` for misses).
        hit: (R,) exact hit flags.
        config: the sensor configuration (``noise_std``, ``dropout_prob``, ranges).
        rng: the random generator; exactly 2 R numbers are drawn.

    Returns:
        ``(ranges, hit, valid)`` as described in the module docstring.
    """
    r = np.asarray(true_ranges, dtype=np.float64)
    h = np.asarray(hit, dtype=np.bool_)
    if r.shape != h.shape or r.ndim != 1:
        raise ValueError(f"true_ranges {r.shape} and hit {h.shape} must be equal 1-D shapes")
    u = rng.random(r.shape[0])
    g = rng.standard_normal(r.shape[0])
    valid = u >= config.dropout_prob
    start = _ray_start_distances(config)
    if start.shape != r.shape:
        raise ValueError(f"{r.shape[0]} ranges given but the SensorConfig has {start.shape[0]} rays")
    noisy = np.where(h, np.minimum(np.maximum(r + config.noise_std * g, start), config.max_range), config.max_range)
    hit_out = h & valid
    ranges = np.where(valid, noisy, np.nan)
    return ranges, hit_out, valid


def make_reading(
    tip_T_world: NDArray[np.float64],
    true_ranges: NDArray[np.float64],
    hit: NDArray[np.bool_],
    config: SensorConfig,
    rng: np.random.Generator | None,
) -> SensorReading:
    """Build a :class:`SensorReading` from exact ranges (noise from ``rng``; ``None`` = exact).

    ``tip_T_world`` (4, 4) is the tip frame's pose in the world (world <- tip).
    """
    T = check_pose(tip_T_world)
    return reading_from_rays(T[:3, 3], _ray_directions(config) @ T[:3, :3].T, true_ranges, hit, config, rng)


def reading_from_rays(
    origin: NDArray[np.float64],
    directions: NDArray[np.float64],
    true_ranges: NDArray[np.float64],
    hit: NDArray[np.bool_],
    config: SensorConfig,
    rng: np.random.Generator | None,
) -> SensorReading:
    """:func:`make_reading` for a caller that already has the tip point ``origin`` (3,) [m] and the world ray
    directions (R, 3) of a checked pose (``ray_directions(config) @ R.T``)."""
    origins = np.broadcast_to(origin, directions.shape).copy()
    if rng is None:
        r = np.where(hit, true_ranges, config.max_range)
        return SensorReading(origins, directions, r, np.asarray(hit, bool), np.ones(len(r), bool),
                             config.max_range)
    ranges, h, valid = apply_noise(true_ranges, hit, config, rng)  # (R,) each, R the config's rays
    d = np.array(directions, dtype=np.float64)
    if d.shape != (ranges.shape[0], 3) or origins.shape != d.shape:
        raise ValueError(f"reading_from_rays: directions {d.shape} and origin {np.shape(origin)} do not match "
                         f"{ranges.shape[0]} rays")
    return SensorReading._owned(origins.astype(np.float64, copy=False), d, ranges, h, valid, float(config.max_range))
