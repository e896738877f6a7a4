"""Steering along a plan: the commanded tip runs along the planned arcs at a safe speed.

The planned path (:class:`navstack.planner.search.Plan`) is curvature-bounded by construction, so
the command follows it exactly: ``x_d(t + dt)`` is the plan's point ``v dt`` farther on, its
heading the plan's tangent.  What this module decides is the speed ``v``:

* ``v_max`` in the open, falling linearly to ``v_min`` as the tip's clearance to the nearest sensed
  surface (:meth:`SensedMap.distance` minus the tip radius) falls from ``slow_clearance`` to
  ``stop_clearance`` (the repulsion as a brake: the sensors get more readings per centimetre
  where it matters), and held at ``v_min`` below it (the plan keeps its clearance; turning needs motion);
* at most what still stops on the end of the plan (the final goal, or the end of a partial plan) when
  slowing by ``accel dt`` per step (about ``sqrt(2 accel remaining)``), without overshoot; it changes by
  at most ``accel dt`` per step (on the last step a little more, to land on the end);
* scaled down while the actual tip lags the command by more than ``max_lead / 2`` (zero at
  ``max_lead``): the command never runs away from a robot that cannot follow.

The plan's ``stops`` (goals lying exactly on the path, where a goal shot ends) are landed on: within
``stop_window`` steps of one, the command moves in equal steps of at most ``v dt`` so that one ends on it
(a speed change of at most ``v / stop_window``, below ``accel dt``), and there it waits while the tip lags
by more than ``stop_lag`` (at most ``stop_hold``): the tip is then on the goal at a control step, so a goal
whose tolerance is below the step's ``v dt`` (2 mm at ``v_max``) is neither stepped over nor passed by a
lagging tip.

Units: metres, seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from navstack.planner.search import Plan
from navstack.validate import integer, positive

__all__ = ["PlanFollower", "SteeringConfig"]


@dataclass(frozen=True)
class SteeringConfig:
    """Speed rules of :class:`PlanFollower` (metres, seconds).

    Attributes:
        v_max: cruise speed [m/s].
        v_min: speed at ``stop_clearance`` [m/s].
        accel: largest change of speed [m/s^2].
        slow_clearance: clearance below which the speed falls [m].
        stop_clearance: clearance at which the speed is ``v_min`` [m].
        max_lead: the command waits when it leads the actual tip by this much [m].
        stop_window: a stop (a goal on the plan) this many steps ahead or fewer is reached in whole steps
            of equal length, at most the speed's, so one step ends on it [count].
        stop_lag, stop_hold: on a stop, the command waits while the tip lags it by more than ``stop_lag``
            [m], at most ``stop_hold`` [s] (the tip, not only the command, must be on the goal).
    """

    v_max: float = 0.06
    v_min: float = 0.02
    accel: float = 0.1
    slow_clearance: float = 0.05
    stop_clearance: float = 0.01
    max_lead: float = 0.03
    stop_window: int = 24
    stop_lag: float = 5e-5
    stop_hold: float = 2.0

    def __post_init__(self) -> None:
        integer(self, "stop_window", lo=1)
        positive(self, "v_max", "v_min", "accel", "slow_clearance", "stop_clearance", "max_lead", "stop_lag",
                 "stop_hold")
        if self.v_min > self.v_max:
            raise ValueError(f"SteeringConfig.v_min ({self.v_min}) exceeds v_max ({self.v_max})")
        if self.stop_clearance >= self.slow_clearance:
            raise ValueError("SteeringConfig.stop_clearance must be below slow_clearance")


class PlanFollower:
    """The commanded tip on a plan: arc position ``s`` [m] and speed ``v`` [m/s]."""

    def __init__(self, plan: Plan, config: SteeringConfig, speed: float = 0.0) -> None:
        self.plan = plan
        self.config = config
        self.s = 0.0
        self.v = float(speed)
        self.held = 0.0  # [s] waited on the current stop

    @property
    def remaining(self) -> float:
        """Plan length still ahead [m]."""
        return self.plan.length - self.s

    def state(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The commanded position and heading now."""
        return self.plan.state(self.s)

    def target_speed(self, clearance: float, lag: float, dt: float) -> float:
        """The speed the rules above allow, from the tip's ``clearance`` [m] and the tip's ``lag`` [m]."""
        cfg = self.config
        f = (clearance - cfg.stop_clearance) / (cfg.slow_clearance - cfg.stop_clearance)
        v = cfg.v_min + (cfg.v_max - cfg.v_min) * min(max(f, 0.0), 1.0)
        # the fastest speed from which steps slowing by accel * dt still stop on the plan's end:
        # remaining - v dt >= v (v - a dt) / (2 a), i.e. v^2 + a dt v <= 2 a remaining
        adt = cfg.accel * dt
        v = min(v, 0.5 * (math.sqrt(adt * adt + 8.0 * cfg.accel * max(self.remaining, 0.0)) - adt))
        v *= min(max((cfg.max_lead - lag) / (0.5 * cfg.max_lead), 0.0), 1.0)
        return v

    def advance(self, dt: float, clearance: float, lag: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Move the command by one period ``dt`` [s]; return the new position and velocity [m/s]."""
        cfg = self.config
        target = self.target_speed(clearance, lag, dt)
        self.v = min(max(target, self.v - cfg.accel * dt), self.v + cfg.accel * dt)
        if self.v < 1e-4 * cfg.v_max:
            self.v = 0.0
        stops = self.plan.stops
        if len(stops) and self._wait_on_stop(dt, lag):
            p, t = self.plan.state(self.s)
            return p, t * 0.0
        s_new = min(self.s + self.v * dt, self.plan.length)
        i = int(np.searchsorted(stops, self.s, side="right"))
        ahead = float(stops[i]) - self.s if i < len(stops) and stops[i] < self.plan.length else math.inf
        # (a stop at the plan's end is landed on by the speed rule that stops there)
        if 0.0 < ahead <= cfg.stop_window * self.v * dt:  # whole steps onto the stop, each at most v dt
            steps = math.ceil(ahead / (self.v * dt) - 1e-9)
            s_new = float(stops[i]) if steps <= 1 else self.s + ahead / steps
            v = (s_new - self.s) / dt
        else:
            self.v = v = (s_new - self.s) / dt
        self.s = s_new
        p, t = self.plan.state(self.s)
        return p, t * v

    def _wait_on_stop(self, dt: float, lag: float) -> bool:
        """On a stop: whether to wait there this step (the tip lags by more than ``stop_lag``, for at most
        ``stop_hold`` in all); the speed starts again from rest."""
        cfg = self.config
        on = bool(np.any(self.plan.stops == self.s))
        if on and lag > cfg.stop_lag and self.held < cfg.stop_hold:
            self.held += dt
            self.v = 0.0
            return True
        if not on:
            self.held = 0.0
        return False
