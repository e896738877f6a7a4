"""Scripted tip path: a smooth curve through the goals, no sensing (the baseline).

The curve is :func:`navstack.guide.goal_spline`: a cubic spline through the
start tip position and every goal, parameterised by chord length, leaving the
start along the tip's current heading (clamped first derivative) so the
serpentine need not kink on the first step.  It is traversed by arc length with a trapezoidal
speed profile (``speed`` [m/s], ``accel`` [m/s^2]).  The smallest radius of
curvature is reported (``min_turn_radius``); worlds for the scripted planner
should keep it above about 0.25 m so the serpentine joints stay near 40 deg.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from navstack.guide import goal_spline
from navstack.planner import TipCommand
from navstack.validate import positive


@dataclass(frozen=True)
class ScriptedConfig:
    """Speed profile of the scripted tip path."""

    speed: float = 0.06
    """Cruise speed of the tip [m/s]."""
    accel: float = 0.05
    """Acceleration and deceleration [m/s^2]."""
    sample: float = 0.002
    """Arc-length resolution of the resampled curve [m]."""

    def __post_init__(self) -> None:
        positive(self, "speed", "accel", "sample")


class ScriptedPlanner:
    """Follows a precomputed spline through ``goals``; ignores sensor readings."""

    def __init__(
        self,
        start: ArrayLike,
        heading: ArrayLike,
        goals: ArrayLike,
        config: ScriptedConfig | None = None,
    ) -> None:
        self.config = config or ScriptedConfig()
        self.guide = goal_spline(start, heading, goals, self.config.sample)  # ValueError on bad input
        self.length = self.guide.length
        self.min_turn_radius = self.guide.min_turn_radius
        self._arc = 0.0
        self._v = 0.0
        self.done = False

    def step(
        self,
        dt: float,
        tip: ArrayLike | None = None,
        direction: ArrayLike | None = None,
        reading: object | None = None,
        goal_index: int = 0,
    ) -> TipCommand:
        """Advance along the curve by one period ``dt`` [s]; the other arguments are ignored."""
        cfg = self.config
        remaining = self.length - self._arc
        v_stop = np.sqrt(max(2.0 * cfg.accel * remaining, 0.0))
        self._v = min(cfg.speed, self._v + cfg.accel * dt, v_stop)
        self._arc = min(self.length, self._arc + self._v * dt)
        if self._arc >= self.length - 1e-9:
            self._v = 0.0
            self.done = True
        p, t = self.guide.point(self._arc)
        return TipCommand(position=p, velocity=t * self._v, stalled=False)
