"""The reactive potential-field tip planner (``--planner reactive``): :class:`PotentialFieldPlanner`.

The planner integrates its own commanded point ``x_d`` with heading ``h`` (started at the initial tip position
and direction) like a vehicle: speed ``0 <= v <= v_max`` and curvature ``<= 1 / min_turn_radius`` (the heading
turns by at most ``v dt / min_turn_radius`` per step), because the body will pass through every bend of the tip
path and its pitch/yaw joints must stay well inside their limits.  It never reverses: the path memory of the
slithering controller only grows.  Each step:

1. **Sense**: a new reading is filtered by :class:`navstack.estimate.RangeEstimator` (per-ray Kalman filters)
   and the filtered hit points of rays that hit are stored in the voxel point memory
   (:mod:`~navstack.planner.reactive.memory`); only points within ``memory_radius`` of ``x_d`` are used.
2. **Attract**: on the guide, its pure pursuit (:mod:`~navstack.planner.reactive.guide_pursuit`); off it, the
   goal direction (with a ``next_goal``, a carrot on a local corner curve), bent towards the free-space centre
   of the opening ahead (:mod:`~navstack.planner.reactive.gap`).  A **reachability guard** keeps the
   direction within ``asin(goal_guard * d / 2R)`` of the goal direction (``d`` the distance to the goal), so
   the goal never falls inside the turning circle (not while an obstacle is within ``safety_distance``:
   safety first).
3. **Repel** (Khatib-style, density independent; :func:`~navstack.planner.reactive.terms.repulsion`), faded
   out within ``goal_repulsion_radius`` of the goal.
4. **Look ahead** (:mod:`~navstack.planner.reactive.lookahead`): points in the forward tube push the heading
   sideways, in a committed turning sense.
5. **Steer and move**: the heading turns towards the sum (rate-limited) at the speed of
   :func:`~navstack.planner.reactive.terms.speed`.  When ``x_d`` is within half the tolerance of the goal it
   holds there until the caller moves on to the next goal.  A goal inside the current turning circle cannot be
   reached by turning towards it; the planner then keeps straight (still avoiding obstacles) until the goal is
   outside 1.25 turn radii, then turns onto it.

**Local minima.**  A stall is declared when the reach length (the shortest curvature-bounded path from ``x_d``
along ``h`` to the goal) has not improved by ``stall_progress`` for ``stall_window`` seconds; the escape is
boundary following (:mod:`~navstack.planner.reactive.wall_follow`).  The planner **gives up** (``stalled``,
zero velocity, held position) if an escape lasts longer than ``escape_timeout``, after ``max_escapes`` escapes
for the same goal, when it cannot move for ``stall_window`` (the tube ahead blocked, or the actual tip lagging
``x_d`` by ``max_lead``), or when holding at a goal the actual tip does not reach within ``stall_window``.  The
trial then ends with reason ``stalled``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.estimate import RangeEstimate, RangeEstimator
from navstack.guide import GuidePath
from navstack.planner.reactive import terms
from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.gap import GapCentering
from navstack.planner.reactive.guide_pursuit import GUIDE_HIT, GuidePursuit
from navstack.planner.reactive.lookahead import Lookahead
from navstack.planner.reactive.memory import PointMemory
from navstack.planner.reactive.vectors import rotate_towards, unit, vec3
from navstack.planner.reactive.wall_follow import WallFollower
from navstack.planner.types import TipCommand
from navstack.sensing import SensorReading

__all__ = ["GoalListAdapter", "PotentialFieldPlanner"]


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

    def __init__(self, config: PlannerConfig | None = None, start: ArrayLike | None = None,
                 heading: ArrayLike | None = None, guide: GuidePath | None = None) -> None:
        if config is None:
            config = PlannerConfig()
        if guide is not None and not isinstance(guide, GuidePath):
            raise TypeError(f"guide must be a navstack.guide.GuidePath or None, got {type(guide).__name__}")
        if not isinstance(config, PlannerConfig):
            raise TypeError(f"config must be a PlannerConfig, got {type(config).__name__}")
        self.config = config
        self.pursuit = GuidePursuit(config, guide)
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
        self.gap = GapCentering(config)
        self.lookahead = Lookahead(config)
        self.follower = WallFollower(config)
        self._widening = False
        self._still_since: float | None = None
        self._goal: NDArray[np.float64] | None = None
        self._ref_dist = np.inf
        self._ref_time = 0.0
        self._last_reading_time = 0.0
        if start is not None or heading is not None:
            if start is None or heading is None:
                raise ValueError("give both start and heading, or neither")
            self.reset(start, heading)

    def reset(self, position: ArrayLike, direction: ArrayLike) -> None:
        """Restart the commanded point at ``position`` [m] heading along ``direction``."""
        p = vec3(position, "position")
        d = vec3(direction, "direction")
        u = unit(d)
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

    @property
    def guide(self) -> GuidePath | None:
        """The goal spline pursued, or None."""
        return self.pursuit.guide

    def step(self, dt: float, tip_position_measured: ArrayLike, tip_direction: ArrayLike,
             reading: SensorReading | RangeEstimate | None, goal: ArrayLike, goal_tolerance: float, *,
             approach: bool = False, next_goal: ArrayLike | None = None) -> TipCommand:
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
        tip = vec3(tip_position_measured, "tip_position_measured")
        tdir = vec3(tip_direction, "tip_direction")
        g = vec3(goal, "goal")
        g_next = None if next_goal is None else vec3(next_goal, "next_goal")
        if isinstance(goal_tolerance, bool) or not np.isfinite(goal_tolerance) or goal_tolerance <= 0:
            raise ValueError(f"goal_tolerance must be a positive distance in metres, got {goal_tolerance!r}")
        if reading is not None and not isinstance(reading, (SensorReading, RangeEstimate)):
            raise TypeError(
                f"reading must be a SensorReading, a RangeEstimate or None, got {type(reading).__name__}"
            )
        if self.x_d is None:
            self.reset(tip, tdir)
        assert self.x_d is not None and self.heading is not None
        self.time += dt
        if reading is not None:
            self._sense(reading)
        if self._goal is None or not np.array_equal(g, self._goal):
            self._new_goal(g)
        if self.stalled:
            return self._hold("stalled")
        return self._advance(dt, tip, g, float(goal_tolerance), approach, g_next)

    # ------------------------------------------------------------------ parts
    def _advance(self, dt: float, tip: NDArray[np.float64], g: NDArray[np.float64], goal_tolerance: float,
                 approach: bool, g_next: NDArray[np.float64] | None) -> TipCommand:
        """One step towards ``g``: progress and stall bookkeeping, the direction, the speed, the move."""
        assert self.x_d is not None and self.heading is not None
        cfg = self.config
        x = self.x_d
        h = self.heading
        to_goal = g - x
        dist = float(np.linalg.norm(to_goal))
        # progress bookkeeping (stall detection), on the curvature-bounded reach length
        reach = terms.reach_length(cfg.min_turn_radius, x, h, g)
        if reach < self._ref_dist - cfg.stall_progress:
            self._ref_dist = reach
            self._ref_time = self.time
        if dist <= 0.5 * goal_tolerance:
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
            elif self.mode == "follow" and self.time - self.follower.start_time > cfg.escape_timeout:
                self.stalled = True
                return self._hold("stalled")
        P = self.memory.near(x, cfg.memory_radius)
        e = to_goal / dist if dist > 1e-12 else h
        # obstacle terms (near its goal the tip trusts the goal: repulsion fades out, and
        # points behind the goal do not steer it)
        F_rep, clear_min, clear_ahead = terms.repulsion(cfg, x, h, P)
        F_rep = F_rep * min(1.0, dist / cfg.goal_repulsion_radius)
        horizon = cfg.lookahead if self.mode != "goal" else min(cfg.lookahead, dist + cfg.body_radius)
        F_avoid, free_ahead = self.lookahead.push(self.time, x, h, P, e, horizon)
        if self.mode == "follow":
            u = unit(self.follower.direction(x, P, e) + F_rep + F_avoid)
            d = h.copy() if u is None else u
            if self.follower.may_leave(x, g, dist, P):
                self.mode = "goal"
                self._ref_dist = np.inf
                self._ref_time = self.time
        else:
            d = self._field_direction(x, h, g, e, dist, P, dt, F_rep, F_avoid, horizon, clear_min,
                                      goal_tolerance, g_next)
        v = terms.speed(cfg, clear_ahead, free_ahead, h, d, dist, approach, float(np.linalg.norm(x - tip)))
        if v > 0.0:
            self._still_since = None
        elif self._still_since is None:
            self._still_since = self.time
        elif self.time - self._still_since > cfg.stall_window:
            self.stalled = True  # blocked (or the tip cannot catch up): no way to move on
            return self._hold("stalled")
        h_new = rotate_towards(h, d, v * dt / cfg.min_turn_radius, self.lookahead.pref)
        self.heading = h_new
        self.speed = v
        vel = v * h_new
        self.x_d = x + vel * dt
        return TipCommand(self.x_d.copy(), vel, False, self.mode)

    def _field_direction(self, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64],
                         e: NDArray[np.float64], dist: float, P: NDArray[np.float64], dt: float,
                         F_rep: NDArray[np.float64], F_avoid: NDArray[np.float64], horizon: float, clear_min: float,
                         goal_tolerance: float, g_next: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """The direction (unit) of the field in goal mode: attraction (the guide's, or the goal's bent to the
        opening ahead) plus the repulsion ``F_rep`` and the look-ahead push ``F_avoid``, then the turning
        circle's and the reachability guard's limits."""
        cfg = self.config
        e_guide = self.pursuit.aim(x, g, self.n_escapes > 0)
        on_guide = e_guide is not None and self.pursuit.deviation <= cfg.guide_capture
        if on_guide:
            dmin = self.pursuit.tube_distance(x, P, horizon, cfg.body_radius + cfg.tube_margin)
            if dmin < cfg.body_radius + GUIDE_HIT:
                # something sits on the guide itself (the tip would hit it): the goal spline
                # leads into an obstacle, so for this goal the field alone steers
                self.pursuit.blocked = True
                on_guide = False
            else:
                # the straight tube ahead is no forecast on a curved guide: the push is scaled
                # by how deep known points reach into the tube along the guide (shifted by the
                # current deviation): none if it is clear, full where the tip would hit them
                F_avoid = F_avoid * self.pursuit.tube_intrusion(dmin)
        # on the guide: pursue it; off it (an obstacle pushed the tip away): head for the goal
        e_aim = e_guide if on_guide else terms.aim_direction(cfg, x, h, g, e, dist, g_next)
        F_att = self.gap.attraction(x, h, e, e_aim, dist, P, dt)
        u = unit(F_att + F_rep + F_avoid)
        d = h.copy() if u is None else u
        R = cfg.min_turn_radius
        if on_guide:
            self._widening = False  # the guide's curvature is feasible: pursue it
        elif self._widening:
            self._widening = terms.goal_inside_turn_circle(R, x, h, g, goal_tolerance, margin=1.25)
        else:
            self._widening = terms.goal_inside_turn_circle(R, x, h, g, goal_tolerance)
        if self._widening:
            # unreachable by turning towards it: keep on (avoiding obstacles) until it is not
            u = unit(h + F_rep + F_avoid)
            return h.copy() if u is None else u
        if clear_min > cfg.safety_distance:
            # (safety first: with an obstacle within safety_distance the field is not bent)
            return terms.reachability_guard(cfg, d, h, e, dist, self.lookahead.pref)
        return d

    def _hold(self, mode: str) -> TipCommand:
        assert self.x_d is not None
        self.speed = 0.0
        if mode == "stalled":
            self.mode = "stalled"
        return TipCommand(self.x_d.copy(), np.zeros(3), mode == "stalled", mode)

    def _new_goal(self, g: NDArray[np.float64]) -> None:
        self._goal = g.copy()
        self.pursuit.blocked = False
        self._widening = False
        self.mode = "goal"
        self.n_escapes = 0
        self._ref_dist = np.inf
        self._ref_time = self.time
        self.gap.reset()

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

    def _on_stall(self, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64]) -> None:
        """A stall in goal mode: start an escape (boundary following), or give up after ``max_escapes``."""
        cfg = self.config
        if self.n_escapes >= cfg.max_escapes:
            self.stalled = True
            return
        self.n_escapes += 1
        self._ref_time = self.time
        # with no obstacle near there is nothing to follow (the field keeps going; after
        # max_escapes such stalls the planner gives up)
        if self.follower.start(self.time, x, h, g, self.memory.near(x, cfg.memory_radius)):
            self.mode = "follow"


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
