"""Reactive tip planners: a 3D potential field on the serpentine's tip.

The paper (section 2) finds the tip path "by treating the robot tip as a
mobile robot" with a sensor-based method such as the potential field, and
lets the body slither after it.  A planner here turns sensor readings into
the commanded tip trajectory ``x_d(t), xdot_d(t)`` that the slithering
controller follows.  **It never reads obstacle geometry**: its only inputs are
the sensor readings, the current goal and the robot's own state (see
tests/test_isolation.py).

Common interface (:class:`TipPlanner`): ``step(dt, tip_position_measured,
tip_direction, reading, goal, goal_tolerance, *, approach=False,
next_goal=None) -> TipCommand``.  The caller (the trial loop) owns the goal list
and advances to the next goal when the *actual* tip comes within
``goal_tolerance``; it should pass ``next_goal`` (the goal after the current
one) when there is one and ``approach=True`` for the final goal.  ``reading``
is a raw :class:`SensorReading` (the planner filters it) or a
:class:`RangeEstimate` already filtered by the caller.

:class:`PotentialFieldPlanner`
==============================

The planner integrates its own commanded point ``x_d`` with heading ``h``
(started at the initial tip position and direction) like a vehicle: speed
``0 <= v <= v_max`` and curvature ``<= 1 / min_turn_radius`` (the heading
turns by at most ``v dt / min_turn_radius`` per step), because the body will
pass through every bend of the tip path and its pitch/yaw joints must stay
well inside their limits.  It never reverses: the path memory of the
slithering controller only grows.

Each step:

1. **Sense**: a new reading is filtered by :class:`navstack.estimate.RangeEstimator`
   (per-ray Kalman filters, the tip's measured velocity as input) and the
   filtered hit points of rays that hit in this reading are stored in a voxel
   **point memory** (``memory_voxel`` cells, world frame, a running mean per
   cell: the obstacles are static).
   Only memory points within ``memory_radius`` of ``x_d`` are used; they are
   all the planner knows about obstacles.
2. **Attract**: with a **guide** (the goal spline of :mod:`navstack.guide`,
   built from the start, the heading and the goals only) and ``x_d`` within
   ``guide_capture`` of it, pure pursuit of the guide: the unit vector to the
   guide point ``guide_lookahead`` beyond the nearest one (never beyond the
   current goal), so the tip arrives at each goal already turned towards the
   next along a curve of feasible curvature.  Off the guide, or once the
   sensed points lie on the guide itself (it leads into an obstacle: dropped
   for the rest of that goal), or after an escape: the unit vector towards
   the goal (with a ``next_goal``, towards a carrot on a local cubic curve that
   arrives at the goal along the corner's bisector);
   with ``gap_centering`` towards the **free-space centre of the opening ahead**
   instead (below).  A **reachability guard** keeps the resulting direction
   within ``asin(goal_guard * d / 2R)`` of the goal direction (``d`` the distance
   to the goal): beyond that the goal would fall inside the turning circle and
   the tip would have to loop back, so near a goal the field may deflect the
   tip only as much as it can still recover (not while an obstacle is within
   ``safety_distance``: safety first).
3. **Repel** (Khatib-style, density independent): over points whose clearance
   ``rho`` (distance to the tip surface, ``body_radius`` subtracted) is below
   ``influence_distance`` ``rho0``, the direction is the weighted mean of the
   unit vectors away from them (weights ``(1/rho - 1/rho0)^2``) and the magnitude
   ``repulsion_gain (1/rho_min - 1/rho0) / (1/safety_distance - 1/rho0)``,
   faded out within ``goal_repulsion_radius`` of the goal.
4. **Look ahead** (on the guide: only if a known point lies in the tube along the
   guide itself, shifted through ``x_d``; a straight tube is no forecast on a curve, and the
   push is scaled by how deep the points reach into that guide tube, quadratically from none
   at its edge to full where the tip would hit them, so a member beside a curved guide does
   not push the tip off a bend it cannot rejoin before the goal):
   points inside the forward tube (radius ``body_radius +
   tube_margin``, length ``lookahead``, in goal mode not beyond the goal) push
   the heading sideways, away from them, with full weight inside one turn
   radius plus the tube radius and for points the tip would hit; the turning
   sense is committed while the blockage lasts (a wall head-on: towards the
   goal's side, else a sticky preference), so the heading does not dither and
   the tip starts turning a full turn radius before a wall.
5. **Steer and move**: the heading turns towards the sum (rate-limited), the
   speed is ``v_max`` in the open, falls to ``v_min`` as the clearance of the
   points ahead of the tip (not beside or behind it) drops from
   ``slow_distance`` to ``safety_distance``, is halved at most while the heading
   still has to turn a lot, goes to zero if the tube ahead is blocked within
   ``stop_distance`` or if the actual tip lags ``x_d`` by ``max_lead``, and in
   **approach** mode is ``v_max * distance / approach_distance`` (a smooth stop
   on the goal, no overshoot).  When ``x_d`` is within half the tolerance of
   the goal it holds there until the caller moves on to the next goal.
   A goal inside the current turning circle cannot be reached by turning
   towards it; the planner then keeps straight (still avoiding obstacles)
   until the goal is outside 1.25 turn radii, then turns onto it.

Gap centring
------------
A plain field centres the tip only weakly in an opening: the repulsion of a
member 0.07 m off the goal line is small compared with the attraction.  The
planner instead estimates where the free-space centre of the opening ahead
is: memory points ahead (along the goal direction ``e``, from ``-gap_behind``
to ``lookahead``) are projected on the plane perpendicular to ``e`` and the
lateral offset ``c`` (``|c| <= gap_search_radius``, 0.01 m grid) maximising
``min(clearance(c), gap_clearance_cap) - gap_offset_cost |c|`` is chosen:
the straight line through ``x_d + c`` along ``e`` has the most room, and
among lines with enough room (the cap) the one closest to the goal line
wins.  ``c`` is low-pass filtered (``gap_time_constant``) and the attraction
becomes a pure pursuit of that line, ``unit(L e + c)`` with ``L`` the distance
to the opening (at least ``gap_min_lookahead``).  After the opening has
fallen behind, ``c`` returns to zero and the tip heads for the goal.  It is
only done while the heading is within ``gap_max_angle`` of the goal direction,
only if the best line has ``gap_min_clearance`` (a wall across the goal line
is no opening), and it fades out when the goal lies less than
``gap_recover_distance`` beyond the opening (a goal *in* the opening must
still be reached within its tolerance).  Measured (tests/test_planner.py):
a triangular opening (side 0.5 m, members r = 0.02 m) displaced 3/5/7 cm
from the goal line, goal 0.4 m behind it: the tip crosses it 6-13 mm from
its true centre (76-82 % of the offset recovered), the plain field 30-63 mm
(0-10 %).

Local minima: stall detection and escape
----------------------------------------
A **stall** is declared when the reach length (the shortest curvature-bounded
path from ``x_d`` along ``h`` to the goal, a Dubins "turn then straight" path)
has not improved by ``stall_progress`` for ``stall_window`` seconds.  The escape is
**boundary following** in the spirit of Bug / tangent-bug, in 3D:

* at the stall, the obstacle normal ``n`` (weighted mean direction away from
  the memory points within ``follow_range``) defines the obstacle's tangent
  plane; 12 candidate directions in that plane are scored by their free length
  (tube test against the memory, capped at 0.3 m) plus bonuses for being close
  to the current heading (what the tip can turn to) and for pointing towards
  the goal; the best one is **committed** to (a Bug "side");
* while following, the committed direction is re-projected on the current
  tangent plane every step (so it turns around corners), bent towards the
  goal's direction along the surface (weight 0.5, never stored in the
  commitment), plus a term holding the clearance near ``follow_distance``, the
  repulsion and the look-ahead; if the obstacle is lost (a convex corner) the
  tip curls back towards it;
* it **leaves** when ``x_d`` is closer to the goal than at the stall by
  ``stall_progress`` and the tube towards the goal is free of known points
  over ``lookahead``, or when the whole straight tube to a goal within
  ``memory_radius`` is free of known points; then the field resumes;
* a stall with no obstacle near counts as an escape but changes nothing (a
  goal inside the turning circle is handled by the field itself, see above).

The planner **gives up** (``stalled=True``, zero velocity, held position) if
an escape lasts longer than ``escape_timeout``, after ``max_escapes`` escapes
for the same goal, when it cannot move for ``stall_window`` (the tube ahead
blocked, or the actual tip lagging ``x_d`` by ``max_lead``), or when holding at
a goal the actual tip does not reach within ``stall_window``.  The trial then
ends with reason ``stalled``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from navstack.estimate import EstimatorConfig, RangeEstimate, RangeEstimator
from navstack.guide import GuidePath
from navstack.planner.types import TipCommand, TipPlanner
from navstack.sensing import SensorReading

__all__ = [
    "PlannerConfig",
    "PointMemory",
    "PotentialFieldPlanner",
    "TipCommand",
    "TipPlanner",
]


_GUIDE_HIT = 0.005
"""A known point within ``body_radius + _GUIDE_HIT`` [m] of the guide ahead blocks it (the tip would hit)."""

_POSITIVE = "positive"
_NONNEG = "nonneg"


@dataclass(frozen=True)
class PlannerConfig:
    """Parameters of :class:`PotentialFieldPlanner` (metres, seconds, radians).

    Attributes:
        v_max: cruise speed of the commanded tip [m/s].
        v_min: lowest speed while moving near obstacles [m/s] (turning needs motion).
        min_turn_radius: smallest radius of curvature of the tip path [m].
        body_radius: radius of the tip; clearances are measured from its surface [m].
        influence_distance: clearance below which an obstacle point repels [m].
        repulsion_gain: repulsion magnitude at clearance ``safety_distance``, relative
            to the unit attraction.
        safety_distance: clearance at which the speed has fallen to ``v_min`` [m].
        slow_distance: clearance below which the speed starts to fall [m].
        lookahead: length of the forward tube checked for obstacles [m].
        tube_margin: forward tube radius beyond ``body_radius`` [m].
        avoid_gain: magnitude of the sideways look-ahead push for a point at the tip.
        stop_distance: free length ahead below which the tip stops [m].
        max_lead: the commanded point waits when it leads the actual tip by this much [m].
        approach_distance: in approach mode the speed is ``v_max * d / approach_distance`` [m].
        gap_centering: steer to the estimated free-space centre of the opening ahead.
        gap_search_radius: largest lateral correction considered [m].
        gap_clearance_cap: clearance regarded as enough in an opening [m].
        gap_offset_cost: clearance traded per metre of lateral offset (tie-break to the goal line).
        gap_behind: points this far behind the tip still count for the opening [m].
        gap_min_clearance: an opening is centred on only if its best line has this clearance [m].
        gap_min_lookahead: shortest pure-pursuit distance to the opening line [m].
        gap_time_constant: low-pass time constant of the lateral correction [s].
        gap_recover_distance: the correction grows from none for an opening at the goal to
            full when the goal lies this far beyond the opening (the tip must still reach
            the goal itself) [m].
        gap_max_angle: no correction while the heading is more than this off the goal
            direction [rad].
        goal_repulsion_radius: the repulsion fades out linearly within this distance of
            the goal (a goal is a waypoint in free space; Ge & Cui's fix for goals near
            obstacles) [m].
        corner_lead: with a ``next_goal``, the carrot's parameter on the local Hermite curve
            to the goal (0 < corner_lead <= 1; larger = smoother, slower to converge).
        corner_tangent: length of the curve's tangent at the goal, in units of the distance
            to the goal (larger = the tip lines up with the corner's bisector earlier).
        guide_lookahead: with a guide (the goal spline), the carrot is this far ahead of the
            nearest guide point along the guide [m] (pure pursuit).
        guide_capture: the tip counts as on the guide within this distance of it [m]; then the
            guide's feasible curvature is trusted (no turning-circle or reachability override).
        goal_guard: fraction of the largest deflection from the goal direction that still
            lets the tip turn onto the goal (``sin a <= d / 2R``), in (0, 1].
        stall_window: time without progress that declares a stall [s].
        stall_progress: improvement of the distance to the goal that counts as progress [m].
        escape_timeout: longest boundary-following escape before giving up [s].
        max_escapes: escapes allowed per goal before giving up.
        follow_distance: clearance held while boundary following [m].
        follow_range: clearance within which points define the followed boundary [m].
        memory_voxel: cell size of the obstacle point memory [m].
        memory_radius: only memory points this close to x_d are used [m].
        memory_capacity: most points kept (the farthest are dropped beyond it).
        memory_average: samples in each voxel's running mean (noise averaging).
        estimator: the per-ray range filter parameters.
    """

    v_max: float = 0.06
    v_min: float = 0.02
    min_turn_radius: float = 0.25
    body_radius: float = 0.025
    influence_distance: float = 0.08
    repulsion_gain: float = 1.5
    safety_distance: float = 0.03
    slow_distance: float = 0.1
    lookahead: float = 0.4
    tube_margin: float = 0.035
    avoid_gain: float = 3.0
    stop_distance: float = 0.01
    max_lead: float = 0.03
    approach_distance: float = 0.1
    gap_centering: bool = True
    gap_search_radius: float = 0.12
    gap_clearance_cap: float = 0.12
    gap_offset_cost: float = 0.1
    gap_behind: float = 0.05
    gap_min_clearance: float = 0.03
    gap_min_lookahead: float = 0.12
    gap_time_constant: float = 0.3
    gap_recover_distance: float = 0.25
    gap_max_angle: float = 0.8
    goal_repulsion_radius: float = 0.05
    goal_guard: float = 0.8
    guide_lookahead: float = 0.05
    guide_capture: float = 0.05
    corner_lead: float = 0.2
    corner_tangent: float = 1.5
    stall_window: float = 10.0
    stall_progress: float = 0.03
    escape_timeout: float = 60.0
    max_escapes: int = 3
    follow_distance: float = 0.08
    follow_range: float = 0.2
    memory_voxel: float = 0.02
    memory_radius: float = 0.8
    memory_capacity: int = 50000
    memory_average: int = 10
    estimator: EstimatorConfig = field(default_factory=EstimatorConfig)

    def __post_init__(self) -> None:
        kinds = dict.fromkeys(
            ("v_max", "min_turn_radius", "influence_distance", "safety_distance", "slow_distance",
             "lookahead", "max_lead", "approach_distance", "gap_clearance_cap", "gap_min_lookahead",
             "gap_recover_distance", "goal_repulsion_radius", "gap_max_angle", "goal_guard",
             "guide_lookahead", "guide_capture",
             "stall_window", "stall_progress", "escape_timeout", "follow_distance", "follow_range",
             "memory_voxel", "memory_radius"),
            _POSITIVE,
        )
        kinds.update(dict.fromkeys(
            ("v_min", "body_radius", "corner_lead", "corner_tangent", "repulsion_gain", "tube_margin",
             "avoid_gain", "stop_distance", "gap_search_radius", "gap_offset_cost", "gap_behind",
             "gap_min_clearance", "gap_time_constant"),
            _NONNEG,
        ))
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in kinds:
                if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                    raise ValueError(f"PlannerConfig.{f.name} must be a number, got {v!r}")
                if not np.isfinite(v):
                    raise ValueError(f"PlannerConfig.{f.name} must be finite, got {v}")
                if kinds[f.name] == _POSITIVE and v <= 0:
                    raise ValueError(f"PlannerConfig.{f.name} must be > 0, got {v}")
                if kinds[f.name] == _NONNEG and v < 0:
                    raise ValueError(f"PlannerConfig.{f.name} must be >= 0, got {v}")
        for name, lo in (("max_escapes", 0), ("memory_capacity", 1), ("memory_average", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"PlannerConfig.{name} must be an integer >= {lo}, got {v!r}")
        if not 0.0 < self.goal_guard <= 1.0:
            raise ValueError(f"PlannerConfig.goal_guard must be in (0, 1], got {self.goal_guard}")
        if not isinstance(self.gap_centering, (bool, np.bool_)):
            raise ValueError(f"PlannerConfig.gap_centering must be a bool, got {self.gap_centering!r}")
        if not isinstance(self.estimator, EstimatorConfig):
            raise ValueError(f"PlannerConfig.estimator must be an EstimatorConfig, got {self.estimator!r}")
        if self.v_min > self.v_max:
            raise ValueError(f"PlannerConfig.v_min ({self.v_min}) must not exceed v_max ({self.v_max})")
        if self.safety_distance >= self.slow_distance:
            raise ValueError(
                f"PlannerConfig.safety_distance ({self.safety_distance}) must be < slow_distance "
                f"({self.slow_distance})"
            )
        if self.safety_distance >= self.influence_distance:
            raise ValueError(
                f"PlannerConfig.safety_distance ({self.safety_distance}) must be < influence_distance "
                f"({self.influence_distance})"
            )


class PointMemory:
    """Obstacle points seen so far, one per voxel (world frame, metres).

    Each voxel keeps the running mean of the points that fell in it (static
    obstacles: averaging removes range noise), over at most ``average``
    samples (then an exponential average with weight ``1/average``, so a stale
    estimate is still replaced).  Beyond ``capacity`` voxels the points
    farthest from the last query position are dropped.
    """

    def __init__(self, voxel: float, capacity: int, average: int = 10) -> None:
        if not (np.isfinite(voxel) and voxel > 0):
            raise ValueError(f"voxel must be a positive size in metres, got {voxel!r}")
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity!r}")
        if average < 1:
            raise ValueError(f"average must be >= 1, got {average!r}")
        self.voxel = float(voxel)
        self.capacity = int(capacity)
        self.average = int(average)
        self._index: dict[tuple[int, int, int], int] = {}
        self._pts = np.empty((min(1024, self.capacity), 3))
        self._cnt = np.zeros(self._pts.shape[0], dtype=np.int64)
        self._n = 0
        self._last_query = np.zeros(3)

    def __len__(self) -> int:
        return self._n

    @property
    def points(self) -> NDArray[np.float64]:
        """All stored points (N, 3) [m] (a copy)."""
        return self._pts[: self._n].copy()

    def add(self, pts: NDArray[np.float64]) -> None:
        """Store points (K, 3) [m]."""
        pts = np.asarray(pts, dtype=np.float64).reshape(-1, 3)
        if pts.shape[0] == 0:
            return
        keys = np.floor(pts / self.voxel).astype(np.int64)
        for key_arr, p in zip(keys, pts, strict=True):
            key = (int(key_arr[0]), int(key_arr[1]), int(key_arr[2]))
            idx = self._index.get(key)
            if idx is not None:
                c = min(int(self._cnt[idx]) + 1, self.average)
                self._cnt[idx] = c
                self._pts[idx] += (p - self._pts[idx]) / c
                continue
            if self._n == self.capacity:
                self._drop_far()
            if self._n == self._pts.shape[0]:
                size = min(2 * self._pts.shape[0], self.capacity)
                grown = np.empty((size, 3))
                grown[: self._n] = self._pts[: self._n]
                cnt = np.zeros(size, dtype=np.int64)
                cnt[: self._n] = self._cnt[: self._n]
                self._pts, self._cnt = grown, cnt
            self._pts[self._n] = p
            self._cnt[self._n] = 1
            self._index[key] = self._n
            self._n += 1

    def _drop_far(self) -> None:
        keep_n = max(self.capacity // 2, 1)
        d = np.linalg.norm(self._pts[: self._n] - self._last_query, axis=1)
        keep = np.sort(np.argsort(d, kind="stable")[:keep_n])
        self._pts[:keep_n] = self._pts[keep]
        self._cnt[:keep_n] = self._cnt[keep]
        self._n = keep_n
        self._index = {}
        keys = np.floor(self._pts[: self._n] / self.voxel).astype(np.int64)
        for i, k in enumerate(keys):
            self._index[(int(k[0]), int(k[1]), int(k[2]))] = i

    def near(self, x: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
        """Stored points within ``radius`` [m] of ``x`` (M, 3)."""
        self._last_query = np.array(x, dtype=np.float64)
        if self._n == 0:
            return np.empty((0, 3))
        P = self._pts[: self._n]
        d2 = np.sum((P - x) ** 2, axis=1)
        return P[d2 <= radius * radius].copy()


def _unit(v: NDArray[np.float64], eps: float = 1e-12) -> NDArray[np.float64] | None:
    n = float(np.linalg.norm(v))
    return None if n < eps else v / n


def _perpendicular(h: NDArray[np.float64]) -> NDArray[np.float64]:
    ref = np.eye(3)[int(np.argmin(np.abs(h)))]
    p = np.cross(h, ref)
    return p / np.linalg.norm(p)


def _rotate_towards(h: NDArray[np.float64], d: NDArray[np.float64], max_angle: float,
                    pref: NDArray[np.float64]) -> NDArray[np.float64]:
    """Turn unit ``h`` towards unit ``d`` by at most ``max_angle`` [rad].

    When ``d`` is opposite to ``h`` the turn goes towards ``pref`` (a lateral direction).
    """
    c = float(np.clip(h @ d, -1.0, 1.0))
    ang = float(np.arccos(c))
    if ang <= max_angle:
        return d.copy()
    axis = np.cross(h, d)
    if np.linalg.norm(axis) < 1e-9:
        axis = np.cross(h, pref)
        if np.linalg.norm(axis) < 1e-9:
            axis = _perpendicular(h)
    k = axis / np.linalg.norm(axis)
    out = h * np.cos(max_angle) + np.cross(k, h) * np.sin(max_angle) + k * (k @ h) * (1 - np.cos(max_angle))
    return out / np.linalg.norm(out)


def _vec3(value: object, name: str) -> NDArray[np.float64]:
    """A finite 3-vector; TypeError if ``value`` is not numeric at all, ValueError otherwise."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a sequence of 3 numbers, got {type(value).__name__}") from exc
    if arr.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr}")
    return arr.copy()


class PotentialFieldPlanner:
    """Sensor-based 3D potential-field tip planner (see the module docstring).

    Args:
        config: planner parameters (``None`` = defaults).
        start: (3,) initial commanded tip position [m] (world); ``None`` = the
            measured tip position of the first :meth:`step`.
        heading: (3,) initial heading (world, normalised here); ``None`` = the
            measured tip direction of the first :meth:`step`.
        guide: the goal spline (:func:`navstack.guide.goal_spline`, built from the start,
            the heading and the goals only) whose carrot the attraction pursues; ``None``
            = head for each goal (with a ``next_goal``, along a local corner curve).

    The constructor takes no world, scene or obstacle: the planner only ever
    sees sensor readings (tests/test_isolation.py).
    """

    def __init__(
        self,
        config: PlannerConfig | None = None,
        start: ArrayLike | None = None,
        heading: ArrayLike | None = None,
        guide: GuidePath | None = None,
    ) -> None:
        if config is None:
            config = PlannerConfig()
        if guide is not None and not isinstance(guide, GuidePath):
            raise TypeError(f"guide must be a navstack.guide.GuidePath or None, got {type(guide).__name__}")
        self.guide = guide
        self.guide_s = 0.0
        """Arc length [m] of the guide point nearest to ``x_d`` (monotone search window)."""
        self.guide_deviation = np.inf
        """Distance [m] of ``x_d`` from the guide at the last step (inf without a guide)."""
        self._guide_blocked = False
        if not isinstance(config, PlannerConfig):
            raise TypeError(f"config must be a PlannerConfig, got {type(config).__name__}")
        self.config = config
        self.memory = PointMemory(config.memory_voxel, config.memory_capacity, config.memory_average)
        self.estimator: RangeEstimator | None = None
        self.estimate: RangeEstimate | None = None
        """The latest filtered reading (None before the first reading)."""
        self.x_d: NDArray[np.float64] | None = None
        self.heading: NDArray[np.float64] | None = None
        self.speed = 0.0
        self.time = 0.0
        self.mode = "goal"
        self.stalled = False
        self.n_escapes = 0
        self.gap_offset = np.zeros(3)
        """Smoothed lateral correction c [m] towards the centre of the opening ahead."""
        self.gap_offset_raw = np.zeros(3)
        self._pref = np.zeros(3)
        self._avoid_axis: NDArray[np.float64] | None = None
        self._avoid_seen = -np.inf
        self._widening = False
        self._still_since: float | None = None
        self._goal: NDArray[np.float64] | None = None
        self._ref_dist = np.inf
        self._ref_time = 0.0
        self._escape_start = 0.0
        self._escape_dist = np.inf
        self._follow_dir = np.zeros(3)
        self._follow_normal = np.zeros(3)
        self._last_reading_time = 0.0
        r = config.gap_search_radius
        step = 0.01
        g = np.arange(-r, r + 1e-9, step) if r > 0 else np.zeros(1)
        gu, gv = np.meshgrid(g, g, indexing="ij")
        grid = np.stack([gu.ravel(), gv.ravel()], axis=1)
        self._grid = grid[np.linalg.norm(grid, axis=1) <= r + 1e-9]
        self._grid_norm = np.linalg.norm(self._grid, axis=1)
        if start is not None or heading is not None:
            if start is None or heading is None:
                raise ValueError("give both start and heading, or neither")
            self.reset(start, heading)

    # ------------------------------------------------------------------ state
    def reset(self, position: ArrayLike, direction: ArrayLike) -> None:
        """Restart the commanded point at ``position`` [m] heading along ``direction``."""
        p = _vec3(position, "position")
        d = _vec3(direction, "direction")
        u = _unit(d)
        if u is None:
            raise ValueError("direction must be non-zero")
        self.x_d = p
        self.heading = u
        self.speed = 0.0
        self.mode = "goal"
        self.stalled = False
        self._goal = None

    @property
    def obstacle_points(self) -> NDArray[np.float64]:
        """Every obstacle point the planner has stored (N, 3) [m], from sensor readings only."""
        return self.memory.points

    # ------------------------------------------------------------------ step
    def step(
        self,
        dt: float,
        tip_position_measured: ArrayLike,
        tip_direction: ArrayLike,
        reading: SensorReading | RangeEstimate | None,
        goal: ArrayLike,
        goal_tolerance: float,
        *,
        approach: bool = False,
        next_goal: ArrayLike | None = None,
    ) -> TipCommand:
        """Advance the commanded tip by ``dt`` [s].

        Args:
            dt: time step [s] (> 0).
            tip_position_measured: (3,) actual tip position [m].
            tip_direction: (3,) actual tip direction (used to start the heading).
            reading: a new raw sensor reading (filtered here by the planner's own
                :class:`RangeEstimator`), or one already filtered by the caller
                (a :class:`RangeEstimate`), or ``None`` if none arrived this step.
            goal: (3,) the current goal [m].
            goal_tolerance: the goal's tolerance [m] (> 0).
            approach: slow down to stop on this goal (e.g. the final goal)
                instead of passing through it at cruise speed.
            next_goal: (3,) the goal after this one, if any.  With it the tip
                aims to pass the goal along the bisector of the incoming and the
                outgoing directions (it arrives already turning), which a
                curvature-limited tip needs when consecutive goals turn sharply;
                without it the tip heads straight for each goal.

        Returns:
            The commanded position, velocity and the ``stalled`` flag.
        """
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.floating)) or not np.isfinite(dt) \
                or dt <= 0:
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        tip = _vec3(tip_position_measured, "tip_position_measured")
        tdir = _vec3(tip_direction, "tip_direction")
        g = _vec3(goal, "goal")
        g_next = None if next_goal is None else _vec3(next_goal, "next_goal")
        if isinstance(goal_tolerance, bool) or not np.isfinite(goal_tolerance) or goal_tolerance <= 0:
            raise ValueError(f"goal_tolerance must be a positive distance in metres, got {goal_tolerance!r}")
        if reading is not None and not isinstance(reading, (SensorReading, RangeEstimate)):
            raise TypeError(
                f"reading must be a SensorReading, a RangeEstimate or None, got {type(reading).__name__}"
            )
        if self.x_d is None:
            self.reset(tip, tdir)
        assert self.x_d is not None and self.heading is not None
        cfg = self.config
        self.time += dt

        if reading is not None:
            self._sense(reading)

        if self._goal is None or not np.array_equal(g, self._goal):
            self._new_goal(g)

        x = self.x_d
        h = self.heading
        to_goal = g - x
        dist = float(np.linalg.norm(to_goal))
        if self.stalled:
            return self._hold("stalled")

        # progress bookkeeping (stall detection), on the curvature-bounded reach length
        reach = self._reach_length(x, h, g)
        if reach < self._ref_dist - cfg.stall_progress:
            self._ref_dist = reach
            self._ref_time = self.time

        hold_radius = 0.5 * goal_tolerance
        if dist <= hold_radius:
            if float(np.linalg.norm(tip - g)) <= goal_tolerance:
                self._ref_time = self.time  # the tip is there: hold as long as the caller wishes
            elif self.time - self._ref_time > cfg.stall_window:
                self.stalled = True  # the actual tip never gets within the tolerance
                return self._hold("stalled")
            return self._hold("hold")

        if self.time - self._ref_time > cfg.stall_window:
            if self.mode in ("goal",):
                self._on_stall(x, h, g)
                if self.stalled:
                    return self._hold("stalled")
            elif self.mode == "follow" and self.time - self._escape_start > cfg.escape_timeout:
                self.stalled = True
                return self._hold("stalled")

        P = self.memory.near(x, cfg.memory_radius)
        e = to_goal / dist if dist > 1e-12 else h

        # obstacle terms (near its goal the tip trusts the goal: repulsion fades out, and
        # points behind the goal do not steer it)
        F_rep, clear_min, clear_ahead = self._repulsion(x, h, P)
        F_rep = F_rep * min(1.0, dist / cfg.goal_repulsion_radius)
        horizon = cfg.lookahead if self.mode != "goal" else min(cfg.lookahead, dist + cfg.body_radius)
        F_avoid, free_ahead = self._lookahead(x, h, P, e, horizon)

        if self.mode == "follow":
            d_follow = self._follow_direction(x, P, e)
            u = _unit(d_follow + F_rep + F_avoid)
            d = h.copy() if u is None else u
            if self._may_leave(x, g, dist, P):
                self.mode = "goal"
                self._ref_dist = np.inf
                self._ref_time = self.time
        else:
            e_guide = self._guide_aim(x, g)
            on_guide = e_guide is not None and self.guide_deviation <= cfg.guide_capture
            if on_guide:
                dmin = self._guide_tube_distance(x, P, horizon, cfg.body_radius + cfg.tube_margin)
                if dmin < cfg.body_radius + _GUIDE_HIT:
                    # something sits on the guide itself (the tip would hit it): the goal spline
                    # leads into an obstacle, so for this goal the field alone steers
                    self._guide_blocked = True
                    on_guide = False
                else:
                    # the straight tube ahead is no forecast on a curved guide: the push is scaled
                    # by how deep known points reach into the tube along the guide (shifted by the
                    # current deviation): none if it is clear, full where the tip would hit them
                    F_avoid = F_avoid * self._guide_tube_intrusion(dmin)
            # on the guide: pursue it; off it (an obstacle pushed the tip away): head for the goal
            e_aim = e_guide if on_guide else self._aim_direction(x, h, g, e, dist, g_next)
            F_att = self._attraction(x, h, e, e_aim, dist, P, dt)
            D = F_att + F_rep + F_avoid
            u = _unit(D)
            d = h.copy() if u is None else u
            if on_guide:
                self._widening = False  # the guide's curvature is feasible: pursue it
            elif self._widening:
                self._widening = self._goal_inside_turn_circle(x, h, g, goal_tolerance, margin=1.25)
            else:
                self._widening = self._goal_inside_turn_circle(x, h, g, goal_tolerance)
            if self._widening:
                # unreachable by turning towards it: keep on (avoiding obstacles) until it is not
                u = _unit(h + F_rep + F_avoid)
                d = h.copy() if u is None else u
            elif clear_min > cfg.safety_distance:
                # (safety first: with an obstacle within safety_distance the field is not bent)
                d = self._reachability_guard(d, h, e, dist)
        assert d is not None

        # speed
        v = self._speed(clear_ahead, free_ahead, h, d, dist, approach, tip)
        if v > 0.0:
            self._still_since = None
        elif self._still_since is None:
            self._still_since = self.time
        elif self.time - self._still_since > cfg.stall_window:
            self.stalled = True  # blocked (or the tip cannot catch up): no way to move on
            return self._hold("stalled")
        max_turn = v * dt / cfg.min_turn_radius
        h_new = _rotate_towards(h, d, max_turn, self._pref)
        self.heading = h_new
        self.speed = v
        vel = v * h_new
        self.x_d = x + vel * dt
        return TipCommand(self.x_d.copy(), vel, False, self.mode)

    # ------------------------------------------------------------------ parts
    def _hold(self, mode: str) -> TipCommand:
        assert self.x_d is not None
        self.speed = 0.0
        if mode == "stalled":
            self.mode = "stalled"
        return TipCommand(self.x_d.copy(), np.zeros(3), mode == "stalled", mode)

    def _new_goal(self, g: NDArray[np.float64]) -> None:
        self._goal = g.copy()
        self._guide_blocked = False
        self._widening = False
        self.mode = "goal"
        self.n_escapes = 0
        self._ref_dist = np.inf
        self._ref_time = self.time
        self.gap_offset = np.zeros(3)

    def _sense(self, reading: SensorReading | RangeEstimate) -> None:
        if isinstance(reading, RangeEstimate):
            self.estimate = reading  # already filtered by the caller's RangeEstimator
        else:
            if self.estimator is None or self.estimator.n_rays != reading.n_rays:
                self.estimator = RangeEstimator(reading.n_rays, self.config.estimator)
                self._last_reading_time = self.time
            elapsed = self.time - self._last_reading_time
            if elapsed <= 0.0:
                elapsed = 1e-3
            self.estimate = self.estimator.update(reading, elapsed)
            self._last_reading_time = self.time
        self.memory.add(self.estimate.measured_points)

    def _repulsion(
        self, x: NDArray[np.float64], h: NDArray[np.float64], P: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], float, float]:
        """Repulsive vector, the smallest clearance [m], and the smallest one ahead of the tip [m]."""
        cfg = self.config
        if P.shape[0] == 0:
            return np.zeros(3), np.inf, np.inf
        rel = x - P
        dist = np.linalg.norm(rel, axis=1)
        rho = dist - cfg.body_radius
        clear_min = float(rho.min())
        ahead = (-rel @ h) > -cfg.body_radius
        clear_ahead = float(rho[ahead].min()) if np.any(ahead) else np.inf
        m = rho < cfg.influence_distance
        if not np.any(m):
            return np.zeros(3), clear_min, clear_ahead
        rho0 = cfg.influence_distance
        rc = np.maximum(rho[m], 1e-3)
        w = (1.0 / rc - 1.0 / rho0) ** 2
        s = (w[:, None] * rel[m] / np.maximum(dist[m], 1e-9)[:, None]).sum(axis=0)
        u = _unit(s)
        if u is None:
            return np.zeros(3), clear_min, clear_ahead
        rmin = max(clear_min, 1e-3)
        mag = cfg.repulsion_gain * (1.0 / rmin - 1.0 / rho0) / (1.0 / cfg.safety_distance - 1.0 / rho0)
        return mag * u, clear_min, clear_ahead

    def _lateral_preference(self, h: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        lat_goal = e - (e @ h) * h
        if np.linalg.norm(lat_goal) > 0.2:
            pref = lat_goal / np.linalg.norm(lat_goal)
        else:
            p = self._pref - (self._pref @ h) * h
            pref = p / np.linalg.norm(p) if np.linalg.norm(p) > 0.3 else _perpendicular(h)
        return pref

    def _lookahead(
        self, x: NDArray[np.float64], h: NDArray[np.float64], P: NDArray[np.float64], e: NDArray[np.float64],
        horizon: float,
    ) -> tuple[NDArray[np.float64], float]:
        """Sideways push from points in the forward tube, and the free length ahead [m]."""
        cfg = self.config
        if P.shape[0] == 0:
            return np.zeros(3), np.inf
        rel = P - x
        a = rel @ h
        lat = rel - a[:, None] * h
        ld = np.linalg.norm(lat, axis=1)
        tube = cfg.body_radius + cfg.tube_margin
        m = (a > 0) & (a < horizon) & (ld < tube)
        blocking = (a > 0) & (ld < cfg.body_radius + 0.005)
        free = float(a[blocking].min() - cfg.body_radius) if np.any(blocking) else np.inf
        if not np.any(m):
            if self.time - self._avoid_seen > 1.0:
                self._avoid_axis = None
            return np.zeros(3), free
        self._avoid_seen = self.time
        # urgency: 0 at the end of the tube, 1 within a turn radius plus the tube radius
        # (a full-rate turn is due there to clear a wall across the path)
        a_hard = min(cfg.min_turn_radius + tube, 0.9 * cfg.lookahead)
        # lateral factor: 1 for points the tip body would hit (ld <= body_radius), down to 0
        # at the tube's edge
        lateral = np.clip((tube - ld[m]) / max(tube - cfg.body_radius, 1e-9), 0.0, 1.0)
        w = np.clip((cfg.lookahead - a[m]) / (cfg.lookahead - a_hard), 0.0, 1.0) * lateral
        away = -lat[m] / np.maximum(ld[m], 1e-9)[:, None]
        s = (w[:, None] * away).sum(axis=0)
        strength = float(np.linalg.norm(s)) / float(w.sum())
        s_unit = _unit(s)
        side = None
        if self._avoid_axis is not None:
            # committed turning sense: keep turning about the same axis while the
            # blockage persists (a wall head-on must not make the heading dither)
            k = self._avoid_axis - (self._avoid_axis @ h) * h
            if np.linalg.norm(k) > 0.3:
                side = _unit(np.cross(k, h))
        if side is None:
            side = s_unit if s_unit is not None and strength >= 0.3 else self._lateral_preference(h, e)
            self._avoid_axis = np.cross(h, side) / np.linalg.norm(np.cross(h, side))
        direction = side
        if s_unit is not None and float(s_unit @ side) > 0.0:
            direction = _unit(side + strength * s_unit)
            direction = side if direction is None else direction
        self._pref = direction
        return cfg.avoid_gain * float(w.max()) * direction, free

    def _guide_aim(self, x: NDArray[np.float64], g: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """Pure pursuit of the guide: the unit direction to the carrot, or None without a guide.

        The nearest guide point is searched in a window from just behind the last one up
        to the current goal's arc length (O(window) per step); the carrot is
        ``guide_lookahead`` further along, never beyond the current goal.  A goal that is
        not one of the guide's goals (the caller changed them) disables the guide.
        """
        guide = self.guide
        self.guide_deviation = np.inf
        if guide is None or self.n_escapes > 0 or self._guide_blocked:
            return None  # (after an escape the way round is the tip's own: the guide led into the trap)
        match = np.flatnonzero(np.all(np.abs(guide.goals - g) <= 1e-9, axis=1))
        if match.size == 0:
            return None
        s_goal = float(guide.goal_arcs[match.min()])
        cfg = self.config
        s, dev = guide.project(x, self.guide_s - 0.05, min(s_goal, self.guide_s + 0.3))
        self.guide_s = s
        self.guide_deviation = dev
        carrot, _ = guide.point(min(s + cfg.guide_lookahead, s_goal))
        return _unit(carrot - x)

    def _guide_tube_distance(self, x: NDArray[np.float64], P: NDArray[np.float64], horizon: float,
                             reach: float) -> float:
        """Smallest distance [m] of a memory point from the next ``horizon`` metres of the guide,
        shifted to pass through ``x``; exact below ``reach``, inf if no point is that close."""
        guide = self.guide
        assert guide is not None
        P = P[np.linalg.norm(P - x, axis=1) < horizon + reach]
        if P.shape[0] == 0:
            return np.inf
        ss = np.arange(self.guide_s, min(self.guide_s + horizon, guide.length) + 1e-9, 0.01)
        centre = guide.positions(ss) + (x - guide.positions(np.array([self.guide_s]))[0])
        d2 = ((P[:, None, :] - centre[None, :, :]) ** 2).sum(axis=2)
        return float(np.sqrt(d2.min()))

    def _guide_tube_intrusion(self, dmin: float) -> float:
        """How deep the nearest known point (at ``dmin`` [m] from the guide ahead, shifted through
        ``x_d``) reaches into the tube along the guide: 0 at or beyond ``body_radius + tube_margin``,
        1 for a point the tip would hit (within ``body_radius + 0.005``), quadratic in between.

        On the guide this scales the straight-tube look-ahead push: a member passing beside a
        curved guide lies in the straight tube (and is already handled by the repulsion), and a
        full sideways push there drives the tip off a guide it cannot rejoin before the goal."""
        cfg = self.config
        tube = cfg.body_radius + cfg.tube_margin
        if dmin >= tube:
            return 0.0
        f = float(np.clip((tube - dmin) / max(tube - _GUIDE_HIT - cfg.body_radius, 1e-9), 0.0, 1.0))
        return f * f

    def _aim_direction(self, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64],
                       e: NDArray[np.float64], dist: float, g_next: NDArray[np.float64] | None
                       ) -> NDArray[np.float64]:
        """Direction to aim at: the goal, or with a next goal a carrot on a local curve.

        With ``g_next`` the curve is the cubic Hermite from ``x_d`` (tangent ``h``) to the
        goal (tangent ``t``, the bisector of the incoming direction ``e`` and the outgoing
        one towards ``g_next``), tangent lengths ``dist``; the carrot is the curve point at
        parameter ``corner_lead`` (recomputed every step, so the tip arrives at the goal
        already turned towards the next one, like the scripted spline through the goals).
        """
        if g_next is None:
            return e
        out = _unit(g_next - g)
        t = None if out is None else _unit(e + out)
        if t is None:
            return e
        u = self.config.corner_lead
        h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
        h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
        carrot = h00 * x + h10 * dist * h + h01 * g + h11 * self.config.corner_tangent * dist * t
        aim = _unit(carrot - x)
        return e if aim is None else aim

    def _attraction(self, x: NDArray[np.float64], h: NDArray[np.float64], e: NDArray[np.float64],
                    e_aim: NDArray[np.float64], dist: float, P: NDArray[np.float64], dt: float
                    ) -> NDArray[np.float64]:
        cfg = self.config
        if not cfg.gap_centering or cfg.gap_search_radius <= 0:
            return e_aim
        if float(h @ e) >= np.cos(cfg.gap_max_angle):
            c_raw, a_open = self._gap_offset(x, e, dist, P)
            # the goal must still be reached: no correction for an opening at the goal, a full
            # one when the goal lies gap_recover_distance or more beyond it (the reachability
            # guard below bounds what remains)
            room = (dist - a_open) / cfg.gap_recover_distance
            c_raw = c_raw * float(np.clip(room, 0.0, 1.0))
        else:  # not heading along the goal line: no opening to pass on the way
            c_raw, a_open = np.zeros(3), np.inf
        self.gap_offset_raw = c_raw
        alpha = 1.0 if cfg.gap_time_constant <= 0 else 1.0 - np.exp(-dt / cfg.gap_time_constant)
        # keep the smoothed offset lateral to the current goal direction
        c = self.gap_offset - (self.gap_offset @ e) * e
        c = c + alpha * (c_raw - c)
        self.gap_offset = c
        if float(np.linalg.norm(c)) < 1e-6:
            return e_aim
        L = float(np.clip(a_open, cfg.gap_min_lookahead, max(cfg.gap_min_lookahead, dist)))
        return (L * e_aim + c) / np.linalg.norm(L * e_aim + c)

    def _gap_offset(self, x: NDArray[np.float64], e: NDArray[np.float64], dist: float,
                    P: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
        """Lateral offset (3,) to the free-space centre of the opening ahead, and its distance."""
        cfg = self.config
        if P.shape[0] == 0:
            return np.zeros(3), np.inf
        rel = P - x
        a = rel @ e
        lat = rel - a[:, None] * e
        reach = cfg.gap_search_radius + cfg.gap_clearance_cap + cfg.body_radius
        m = (a >= -cfg.gap_behind) & (a <= min(cfg.lookahead, dist + cfg.body_radius)) & (
            np.linalg.norm(lat, axis=1) < reach
        )
        if not np.any(m):
            return np.zeros(3), np.inf
        u = _perpendicular(e)
        w = np.cross(e, u)
        L2 = np.stack([lat[m] @ u, lat[m] @ w], axis=1)
        G = self._grid
        dmin = cKDTree(L2).query(G, k=1)[0] - cfg.body_radius
        score = np.minimum(dmin, cfg.gap_clearance_cap) - cfg.gap_offset_cost * self._grid_norm
        best = int(np.argmax(score))
        if dmin[best] < cfg.gap_min_clearance:
            # no passable opening near the goal line (e.g. a wall across it): nothing to centre on
            return np.zeros(3), np.inf
        c2 = G[best]
        constraining = np.linalg.norm(L2 - c2, axis=1) - cfg.body_radius < cfg.gap_clearance_cap + 0.02
        a_sel = a[m][constraining]
        a_open = float(np.mean(np.maximum(a_sel, 0.0))) if a_sel.size else np.inf
        return c2[0] * u + c2[1] * w, a_open

    def _reachability_guard(self, d: NDArray[np.float64], h: NDArray[np.float64], e: NDArray[np.float64],
                            dist: float) -> NDArray[np.float64]:
        """Bend ``d`` back towards the goal direction ``e`` so the goal stays reachable.

        A heading at angle ``a`` off the goal direction keeps the goal outside the
        turning circle iff ``sin(a) <= dist / (2 R)``; the field may deflect the tip
        only that far (times ``goal_guard``), so it cannot push the tip past a goal
        it can no longer turn onto.  If the heading ``h`` itself is already beyond
        the limit, the tip turns straight for the goal.
        """
        cfg = self.config
        limit = float(np.arcsin(min(1.0, cfg.goal_guard * dist / (2.0 * cfg.min_turn_radius))))
        if limit >= np.pi / 2 - 1e-9:
            return d
        if float(np.arccos(np.clip(h @ e, -1.0, 1.0))) > limit:
            return e.copy()
        c = float(np.clip(d @ e, -1.0, 1.0))
        ang = float(np.arccos(c))
        if ang <= limit:
            return d
        side = d - c * e
        n = float(np.linalg.norm(side))
        side = side / n if n > 1e-9 else self._lateral_preference(e, e)
        return np.cos(limit) * e + np.sin(limit) * side

    def _goal_inside_turn_circle(self, x: NDArray[np.float64], h: NDArray[np.float64],
                                 g: NDArray[np.float64], tolerance: float = 0.0, margin: float = 1.0
                                 ) -> bool:
        """True if ``g`` is inside the turning circle (radius ``margin * R``) on its side, so
        turning towards it cannot reach it, and it is not passed within ``tolerance / 2`` by
        going straight on.  Once inside, the planner keeps straight until the goal is outside
        ``1.25 R`` (hysteresis: it then turns onto it with room to spare instead of spiralling
        around a goal on the circle's boundary)."""
        R = self.config.min_turn_radius
        rel = g - x
        along = float(rel @ h)
        lat = rel - along * h
        n = float(np.linalg.norm(lat))
        if n < 1e-9 or (along > 0 and n < 0.5 * tolerance):
            return False
        centre = x + R * lat / n
        return float(np.linalg.norm(g - centre)) < margin * R

    def _reach_length(self, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64]) -> float:
        """Length [m] of the shortest path to ``g`` with curvature <= 1/R starting along ``h``.

        A turn on the circle of radius R towards the goal, then a straight
        tangent (Dubins "CS" path to a point, free final heading).  For a goal
        inside the turning circle: a full circle plus how far the goal is inside.
        """
        R = self.config.min_turn_radius
        rel = g - x
        along = float(rel @ h)
        lat_v = rel - along * h
        lat = float(np.linalg.norm(lat_v))
        # 2D coordinates relative to the turning centre: X along h, Y towards the goal side
        gx, gy = along, lat - R
        q2 = gx * gx + gy * gy
        if q2 < R * R:
            # inside: keep straight until the goal leaves the circle, then a full turn;
            # decreases as the goal moves out of the circle
            return 2.0 * np.pi * R + (R - float(np.sqrt(q2)))
        s = float(np.sqrt(q2 - R * R))
        phi = (np.arctan2(gy, gx) + np.pi / 2 - np.arctan2(s, R)) % (2.0 * np.pi)
        if phi > 2.0 * np.pi - 1e-9:
            phi = 0.0
        return R * phi + s

    def _speed(self, clear_ahead: float, free_ahead: float, h: NDArray[np.float64], d: NDArray[np.float64],
               dist: float, approach: bool, tip: NDArray[np.float64]) -> float:
        cfg = self.config
        span = cfg.slow_distance - cfg.safety_distance
        f = float(np.clip((clear_ahead - cfg.safety_distance) / span, 0.0, 1.0))
        v = cfg.v_min + (cfg.v_max - cfg.v_min) * f
        v *= max(0.5, 0.5 * (1.0 + float(h @ d)))
        v = max(v, cfg.v_min)
        if free_ahead < cfg.stop_distance:
            v = 0.0
        if approach:
            v = min(v, cfg.v_max * dist / cfg.approach_distance)
        assert self.x_d is not None
        lag = float(np.linalg.norm(self.x_d - tip))
        v *= float(np.clip((cfg.max_lead - lag) / (0.5 * cfg.max_lead), 0.0, 1.0))
        return v if v > 1e-4 * cfg.v_max else 0.0

    # ---------------------------------------------------------------- escape
    def _on_stall(self, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64]) -> None:
        cfg = self.config
        if self.n_escapes >= cfg.max_escapes:
            self.stalled = True
            return
        self.n_escapes += 1
        self._ref_time = self.time
        self._escape_start = self.time
        self._escape_dist = float(np.linalg.norm(g - x))
        P = self.memory.near(x, cfg.memory_radius)
        n = self._boundary_normal(x, P)
        if n is None:
            # no obstacle near: nothing to follow (the field keeps going; after
            # max_escapes such stalls the planner gives up)
            return
        self._follow_normal = n
        e = _unit(g - x)
        e = h if e is None else e
        u = _perpendicular(n)
        w = np.cross(n, u)
        best, best_score = None, -np.inf
        for k in range(12):
            ang = 2 * np.pi * k / 12
            t = np.cos(ang) * u + np.sin(ang) * w
            # enough room (capped) first, then what the tip can turn to (close to the heading)
            score = min(self._free_length(x, t, P, 0.6), 0.3) + 0.3 * float(t @ h) + 0.1 * float(t @ e)
            if score > best_score:
                best, best_score = t, score
        assert best is not None
        self._follow_dir = best
        self.mode = "follow"

    def _boundary_normal(self, x: NDArray[np.float64], P: NDArray[np.float64]) -> NDArray[np.float64] | None:
        cfg = self.config
        if P.shape[0] == 0:
            return None
        rel = x - P
        dist = np.linalg.norm(rel, axis=1)
        rho = dist - cfg.body_radius
        m = rho < cfg.follow_range
        if not np.any(m):
            return None
        w = 1.0 / np.maximum(rho[m], 1e-3) ** 2
        return _unit((w[:, None] * rel[m] / dist[m, None]).sum(axis=0))

    def _free_length(self, x: NDArray[np.float64], t: NDArray[np.float64], P: NDArray[np.float64],
                     max_len: float, radius: float | None = None) -> float:
        """Free length [m] (up to ``max_len``) of the tube of ``radius`` from ``x`` along unit ``t``."""
        if P.shape[0] == 0:
            return max_len
        if radius is None:
            radius = self.config.body_radius + self.config.tube_margin
        rel = P - x
        a = rel @ t
        ld = np.linalg.norm(rel - a[:, None] * t, axis=1)
        m = (a > 0) & (a < max_len) & (ld < radius)
        return float(a[m].min()) if np.any(m) else max_len

    def _follow_direction(self, x: NDArray[np.float64], P: NDArray[np.float64],
                          e: NDArray[np.float64]) -> NDArray[np.float64]:
        cfg = self.config
        n = self._boundary_normal(x, P)
        lost = n is None
        if n is None:
            n = self._follow_normal
        else:
            self._follow_normal = n
        t = self._follow_dir - (self._follow_dir @ n) * n
        tu = _unit(t)
        if tu is not None:
            self._follow_dir = tu
        # the committed direction leads; the goal direction along the surface bends it
        # (weight < 1, and never stored in the commitment, so it cannot lead back into the trap)
        t_goal = e - (e @ n) * n
        tb = _unit(self._follow_dir + 0.5 * t_goal)
        t = self._follow_dir if tb is None else tb
        if lost:
            out = _unit(t - 0.7 * n)
            return t if out is None else out
        rel = x - P
        clear = float((np.linalg.norm(rel, axis=1) - cfg.body_radius).min())
        k = float(np.clip((cfg.follow_distance - clear) / cfg.follow_distance, -1.0, 1.0))
        out = _unit(t + k * n)
        return t if out is None else out

    def _may_leave(self, x: NDArray[np.float64], g: NDArray[np.float64], dist: float,
                   P: NDArray[np.float64]) -> bool:
        cfg = self.config
        e = (g - x) / dist
        if dist < self._escape_dist - cfg.stall_progress:
            # closer than where the escape began and free ahead towards the goal (Bug2-like)
            return self._free_length(x, e, P, min(dist, cfg.lookahead)) >= min(dist, cfg.lookahead)
        # or the whole straight way to a goal within the memory radius is known to be free
        return dist <= cfg.memory_radius and self._free_length(x, e, P, dist) >= dist


class GoalListAdapter:
    """The :class:`TipPlanner` interface (goal index) on top of :class:`PotentialFieldPlanner` (one goal)."""

    def __init__(self, inner: PotentialFieldPlanner, goals: ArrayLike, tolerances: ArrayLike) -> None:
        self.inner = inner
        self.goals = np.asarray(goals, dtype=np.float64).reshape(-1, 3)
        self.tolerances = np.asarray(tolerances, dtype=np.float64).reshape(-1)

    def step(self, dt: float, tip: ArrayLike, direction: ArrayLike, reading: object | None,
             goal_index: int) -> TipCommand:
        k = int(goal_index)
        last = k == len(self.goals) - 1
        return self.inner.step(dt, tip, direction, reading, self.goals[k], float(self.tolerances[k]),
                               approach=last, next_goal=None if last else self.goals[k + 1])
