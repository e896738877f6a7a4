"""The reactive planner's escape from a local minimum: boundary following (Bug / tangent-bug, in 3D).

* At the stall, the obstacle normal ``n`` (weighted mean direction away from the memory points within
  ``follow_range``) defines the obstacle's tangent plane; 12 candidate directions in that plane are scored by
  their free length (tube test against the memory, capped at 0.3 m) plus bonuses for being close to the
  current heading (what the tip can turn to) and for pointing towards the goal; the best one is **committed**
  to (a Bug "side").
* While following, the committed direction is re-projected on the current tangent plane every step (so it
  turns around corners), bent towards the goal's direction along the surface (weight 0.5, never stored in the
  commitment), plus a term holding the clearance near ``follow_distance``; if the obstacle is lost (a convex
  corner) the tip curls back towards it.
* It **leaves** when ``x_d`` is closer to the goal than at the stall by ``stall_progress`` and the tube towards
  the goal is free of known points over ``lookahead``, or when the whole straight tube to a goal within
  ``memory_radius`` is free of known points.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.vectors import along_and_across, perpendicular, unit


def free_length(x: NDArray[np.float64], t: NDArray[np.float64], P: NDArray[np.float64], max_len: float,
                radius: float) -> float:
    """Free length [m] (up to ``max_len``) of the tube of ``radius`` [m] from ``x`` along unit ``t``, among the
    points ``P`` (N, 3) [m]."""
    if P.shape[0] == 0:
        return max_len
    a, lat = along_and_across(P, x, t)
    ld = np.linalg.norm(lat, axis=1)
    m = (a > 0) & (a < max_len) & (ld < radius)
    return float(a[m].min()) if np.any(m) else max_len


def boundary_normal(cfg: PlannerConfig, x: NDArray[np.float64], P: NDArray[np.float64]
                    ) -> NDArray[np.float64] | None:
    """The weighted mean direction away from the points within ``follow_range`` of the tip at ``x`` (unit),
    or None with none that close."""
    if P.shape[0] == 0:
        return None
    rel = x - P
    dist = np.linalg.norm(rel, axis=1)
    rho = dist - cfg.body_radius
    m = rho < cfg.follow_range
    if not np.any(m):
        return None
    w = 1.0 / np.maximum(rho[m], 1e-3) ** 2
    return unit((w[:, None] * rel[m] / dist[m, None]).sum(axis=0))


class WallFollower:
    """The committed direction along the obstacle's surface, and when to leave it (module docstring)."""

    def __init__(self, config: PlannerConfig) -> None:
        self.config = config
        self.start_time = 0.0
        """When the current escape began [s]."""
        self._start_dist = np.inf
        self._dir = np.zeros(3)
        self._normal = np.zeros(3)

    def _tube(self) -> float:
        return self.config.body_radius + self.config.tube_margin

    def start(self, time: float, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64],
              P: NDArray[np.float64]) -> bool:
        """Begin an escape at ``time`` [s] from ``x`` (heading ``h``, goal ``g``, known points ``P``); False if
        no obstacle is near (nothing to follow)."""
        self.start_time = time
        self._start_dist = float(np.linalg.norm(g - x))
        n = boundary_normal(self.config, x, P)
        if n is None:
            return False
        self._normal = n
        e = unit(g - x)
        e = h if e is None else e
        u = perpendicular(n)
        w = np.cross(n, u)
        best, best_score = None, -np.inf
        for k in range(12):
            ang = 2 * np.pi * k / 12
            t = np.cos(ang) * u + np.sin(ang) * w
            # enough room (capped) first, then what the tip can turn to (close to the heading)
            score = min(free_length(x, t, P, 0.6, self._tube()), 0.3) + 0.3 * float(t @ h) + 0.1 * float(t @ e)
            if score > best_score:
                best, best_score = t, score
        assert best is not None
        self._dir = best
        return True

    def direction(self, x: NDArray[np.float64], P: NDArray[np.float64], e: NDArray[np.float64]
                  ) -> NDArray[np.float64]:
        """The direction to follow from ``x`` (``e`` the unit goal direction)."""
        cfg = self.config
        n = boundary_normal(cfg, x, P)
        lost = n is None
        if n is None:
            n = self._normal
        else:
            self._normal = n
        t = self._dir - (self._dir @ n) * n
        tu = unit(t)
        if tu is not None:
            self._dir = tu
        # the committed direction leads; the goal direction along the surface bends it
        # (weight < 1, and never stored in the commitment, so it cannot lead back into the trap)
        t_goal = e - (e @ n) * n
        tb = unit(self._dir + 0.5 * t_goal)
        t = self._dir if tb is None else tb
        if lost:
            out = unit(t - 0.7 * n)
            return t if out is None else out
        rel = x - P
        clear = float((np.linalg.norm(rel, axis=1) - cfg.body_radius).min())
        k = float(np.clip((cfg.follow_distance - clear) / cfg.follow_distance, -1.0, 1.0))
        out = unit(t + k * n)
        return t if out is None else out

    def may_leave(self, x: NDArray[np.float64], g: NDArray[np.float64], dist: float, P: NDArray[np.float64]) -> bool:
        """Whether the escape may end at ``x`` (goal ``g``, ``dist`` [m] away; module docstring)."""
        cfg = self.config
        e = (g - x) / dist
        if dist < self._start_dist - cfg.stall_progress:
            # closer than where the escape began and free ahead towards the goal (Bug2-like)
            return free_length(x, e, P, min(dist, cfg.lookahead), self._tube()) >= min(dist, cfg.lookahead)
        # or the whole straight way to a goal within the memory radius is known to be free
        return dist <= cfg.memory_radius and free_length(x, e, P, dist, self._tube()) >= dist
