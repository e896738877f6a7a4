"""Pure pursuit of the goal spline (:mod:`navstack.guide`) by the reactive planner.

With a guide and ``x_d`` within ``guide_capture`` of it, the attraction is the unit vector to the guide point
``guide_lookahead`` beyond the nearest one (never beyond the current goal), so the tip arrives at each goal
already turned towards the next along a curve of feasible curvature.  Once the sensed points lie on the guide
itself (it leads into an obstacle) it is dropped for the rest of that goal; after an escape too.  Near the
guide the straight-tube look-ahead is scaled by how deep the known points reach into the tube along the guide
(:meth:`GuidePursuit.tube_intrusion`): a member beside a curved guide must not push the tip off a bend it
cannot rejoin before the goal.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from navstack.guide import GuidePath
from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.vectors import unit

GUIDE_HIT = 0.005
"""A known point within ``body_radius + GUIDE_HIT`` [m] of the guide ahead blocks it (the tip would hit)."""


class GuidePursuit:
    """Where ``x_d`` is along the guide, and the carrot it pursues.

    Attributes:
        guide: the goal spline, or None (no pursuit).
        s: arc length [m] of the guide point nearest to ``x_d`` (monotone search window).
        deviation: distance [m] of ``x_d`` from the guide at the last step (inf without a guide).
        blocked: sensed points lie on the guide ahead: not pursued for the rest of this goal.
    """

    def __init__(self, config: PlannerConfig, guide: GuidePath | None) -> None:
        if guide is not None and not isinstance(guide, GuidePath):
            raise TypeError(f"guide must be a navstack.guide.GuidePath or None, got {type(guide).__name__}")
        self.config = config
        self.guide = guide
        self.s = 0.0
        self.deviation = np.inf
        self.blocked = False

    def aim(self, x: NDArray[np.float64], g: NDArray[np.float64], escaped: bool) -> NDArray[np.float64] | None:
        """Pure pursuit of the guide: the unit direction from ``x`` [m] to the carrot, or None (no guide, the
        guide blocked, after an escape (``escaped``), or a goal ``g`` that is not one of the guide's goals).

        The nearest guide point is searched in a window from just behind the last one up to the current
        goal's arc length (O(window) per step); the carrot is ``guide_lookahead`` further along, never
        beyond the current goal.
        """
        guide = self.guide
        self.deviation = np.inf
        if guide is None or escaped or self.blocked:
            return None  # (after an escape the way round is the tip's own: the guide led into the trap)
        match = np.flatnonzero(np.all(np.abs(guide.goals - g) <= 1e-9, axis=1))
        if match.size == 0:
            return None
        s_goal = float(guide.goal_arcs[match.min()])
        s, dev = guide.project(x, self.s - 0.05, min(s_goal, self.s + 0.3))
        self.s = s
        self.deviation = dev
        carrot, _ = guide.point(min(s + self.config.guide_lookahead, s_goal))
        return unit(carrot - x)

    def tube_distance(self, x: NDArray[np.float64], P: NDArray[np.float64], horizon: float, reach: float) -> float:
        """Smallest distance [m] of a memory point from the next ``horizon`` metres of the guide, shifted to
        pass through ``x``; exact below ``reach``, inf if no point is that close."""
        guide = self.guide
        assert guide is not None
        P = P[np.linalg.norm(P - x, axis=1) < horizon + reach]
        if P.shape[0] == 0:
            return np.inf
        ss = np.arange(self.s, min(self.s + horizon, guide.length) + 1e-9, 0.01)
        centre = guide.positions(ss) + (x - guide.positions(np.array([self.s]))[0])
        d2 = ((P[:, None, :] - centre[None, :, :]) ** 2).sum(axis=2)
        return float(np.sqrt(d2.min()))

    def tube_intrusion(self, dmin: float) -> float:
        """How deep the nearest known point (at ``dmin`` [m] from the guide ahead, shifted through ``x_d``)
        reaches into the tube along the guide: 0 at or beyond ``body_radius + tube_margin``, 1 for a point
        the tip would hit (within ``body_radius + GUIDE_HIT``), quadratic in between."""
        cfg = self.config
        tube = cfg.body_radius + cfg.tube_margin
        if dmin >= tube:
            return 0.0
        f = float(np.clip((tube - dmin) / max(tube - GUIDE_HIT - cfg.body_radius, 1e-9), 0.0, 1.0))
        return f * f
