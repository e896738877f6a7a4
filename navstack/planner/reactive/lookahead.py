"""The reactive planner's look-ahead: a sideways push from known points in the tube ahead of the tip.

Points inside the forward tube (radius ``body_radius + tube_margin``, length ``lookahead``) push the heading
sideways, away from them, with full weight inside one turn radius plus the tube radius and for points the tip
would hit; the turning sense is committed while the blockage lasts (a wall head-on: towards the goal's side,
else a sticky preference), so the heading does not dither and the tip starts turning a full turn radius
before a wall.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.vectors import along_and_across, lateral_preference, unit


class Lookahead:
    """The push and the committed turning sense (its state: the axis turned about, when the tube was last
    blocked, and the lateral preference ``pref`` the planner also turns towards when a turn is ambiguous)."""

    def __init__(self, config: PlannerConfig) -> None:
        self.config = config
        self.pref = np.zeros(3)
        """The last push direction (unit, lateral), or zeros before the first."""
        self._axis: NDArray[np.float64] | None = None
        self._seen = -np.inf

    def push(self, time: float, x: NDArray[np.float64], h: NDArray[np.float64], P: NDArray[np.float64],
             e: NDArray[np.float64], horizon: float) -> tuple[NDArray[np.float64], float]:
        """Sideways push from points in the forward tube up to ``horizon`` [m], and the free length ahead [m]
        (at the planner's time ``time`` [s]; ``e`` the unit goal direction)."""
        cfg = self.config
        if P.shape[0] == 0:
            return np.zeros(3), np.inf
        a, lat = along_and_across(P, x, h)
        ld = np.linalg.norm(lat, axis=1)
        tube = cfg.body_radius + cfg.tube_margin
        m = (a > 0) & (a < horizon) & (ld < tube)
        blocking = (a > 0) & (ld < cfg.body_radius + 0.005)
        free = float(a[blocking].min() - cfg.body_radius) if np.any(blocking) else np.inf
        if not np.any(m):
            if time - self._seen > 1.0:
                self._axis = None
            return np.zeros(3), free
        self._seen = time
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
        s_unit = unit(s)
        side = None
        if self._axis is not None:
            # committed turning sense: keep turning about the same axis while the
            # blockage persists (a wall head-on must not make the heading dither)
            k = self._axis - (self._axis @ h) * h
            if np.linalg.norm(k) > 0.3:
                side = unit(np.cross(k, h))
        if side is None:
            side = s_unit if s_unit is not None and strength >= 0.3 else lateral_preference(h, e, self.pref)
            self._axis = np.cross(h, side) / np.linalg.norm(np.cross(h, side))
        direction = side
        if s_unit is not None and float(s_unit @ side) > 0.0:
            direction = unit(side + strength * s_unit)
            direction = side if direction is None else direction
        self.pref = direction
        return cfg.avoid_gain * float(w.max()) * direction, free
