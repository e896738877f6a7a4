"""Gap centring: steer the reactive planner's tip to the free-space centre of the opening ahead.

A plain field centres the tip only weakly in an opening: the repulsion of a member 0.07 m off the goal line is
small compared with the attraction.  The planner instead estimates where the free-space centre of the opening
ahead is: memory points ahead (along the goal direction ``e``, from ``-gap_behind`` to ``lookahead``) are
projected on the plane perpendicular to ``e`` and the lateral offset ``c`` (``|c| <= gap_search_radius``,
0.01 m grid) maximising ``min(clearance(c), gap_clearance_cap) - gap_offset_cost |c|`` is chosen: the straight
line through ``x_d + c`` along ``e`` has the most room, and among lines with enough room (the cap) the one
closest to the goal line wins.  ``c`` is low-pass filtered (``gap_time_constant``) and the attraction becomes a
pure pursuit of that line, ``unit(L e + c)`` with ``L`` the distance to the opening (at least
``gap_min_lookahead``).  After the opening has fallen behind, ``c`` returns to zero and the tip heads for the
goal.  It is only done while the heading is within ``gap_max_angle`` of the goal direction, only if the best
line has ``gap_min_clearance`` (a wall across the goal line is no opening), and it fades out when the goal lies
less than ``gap_recover_distance`` beyond the opening (a goal *in* the opening must still be reached within
its tolerance).  Measured (tests/test_planner.py): a triangular opening (side 0.5 m, members r = 0.02 m)
displaced 3/5/7 cm from the goal line, goal 0.4 m behind it: the tip crosses it 6-13 mm from its true centre
(76-82 % of the offset recovered), the plain field 30-63 mm (0-10 %).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.vectors import along_and_across, perpendicular


class GapCentering:
    """The attraction bent towards the opening ahead (see the module docstring).

    Attributes:
        offset: smoothed lateral correction c [m] towards the centre of the opening ahead.
        offset_raw: the latest unsmoothed correction [m].
    """

    def __init__(self, config: PlannerConfig) -> None:
        self.config = config
        self.offset = np.zeros(3)
        self.offset_raw = np.zeros(3)
        r = config.gap_search_radius
        step = 0.01
        g = np.arange(-r, r + 1e-9, step) if r > 0 else np.zeros(1)
        gu, gv = np.meshgrid(g, g, indexing="ij")
        grid = np.stack([gu.ravel(), gv.ravel()], axis=1)
        self._grid = grid[np.linalg.norm(grid, axis=1) <= r + 1e-9]
        self._grid_norm = np.linalg.norm(self._grid, axis=1)

    def reset(self) -> None:
        """Forget the smoothed correction (a new goal)."""
        self.offset = np.zeros(3)

    def attraction(self, x: NDArray[np.float64], h: NDArray[np.float64], e: NDArray[np.float64],
                   e_aim: NDArray[np.float64], dist: float, P: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """The unit attraction: ``e_aim`` (the aim, unit) bent towards the opening ahead of ``x`` [m] (heading
        ``h``) along the goal direction ``e`` (the goal ``dist`` [m] away), over a step of ``dt`` [s]."""
        cfg = self.config
        if not cfg.gap_centering or cfg.gap_search_radius <= 0:
            return e_aim
        if float(h @ e) >= np.cos(cfg.gap_max_angle):
            c_raw, a_open = self._offset_to_opening(x, e, dist, P)
            # the goal must still be reached: no correction for an opening at the goal, a full
            # one when the goal lies gap_recover_distance or more beyond it (the reachability
            # guard bounds what remains)
            room = (dist - a_open) / cfg.gap_recover_distance
            c_raw = c_raw * float(np.clip(room, 0.0, 1.0))
        else:  # not heading along the goal line: no opening to pass on the way
            c_raw, a_open = np.zeros(3), np.inf
        self.offset_raw = c_raw
        alpha = 1.0 if cfg.gap_time_constant <= 0 else 1.0 - np.exp(-dt / cfg.gap_time_constant)
        # keep the smoothed offset lateral to the current goal direction
        c = self.offset - (self.offset @ e) * e
        c = c + alpha * (c_raw - c)
        self.offset = c
        if float(np.linalg.norm(c)) < 1e-6:
            return e_aim
        L = float(np.clip(a_open, cfg.gap_min_lookahead, max(cfg.gap_min_lookahead, dist)))
        return (L * e_aim + c) / np.linalg.norm(L * e_aim + c)

    def _offset_to_opening(self, x: NDArray[np.float64], e: NDArray[np.float64], dist: float,
                           P: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
        """Lateral offset (3,) [m] to the free-space centre of the opening ahead, and its distance [m]."""
        cfg = self.config
        if P.shape[0] == 0:
            return np.zeros(3), np.inf
        a, lat = along_and_across(P, x, e)
        reach = cfg.gap_search_radius + cfg.gap_clearance_cap + cfg.body_radius
        m = (a >= -cfg.gap_behind) & (a <= min(cfg.lookahead, dist + cfg.body_radius)) & (
            np.linalg.norm(lat, axis=1) < reach
        )
        if not np.any(m):
            return np.zeros(3), np.inf
        u = perpendicular(e)
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
