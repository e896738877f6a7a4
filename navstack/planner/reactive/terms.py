"""The reactive planner's stateless terms: repulsion, the turning limit's geometry, the aim and the speed.

Each is a pure function of the configuration, the commanded state (``x`` [m], unit heading ``h``) and the
remembered obstacle points ``P`` (N, 3) [m]; the module docstring of :mod:`navstack.planner.reactive`
says where each enters a step.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from navstack.planner.reactive.config import PlannerConfig
from navstack.planner.reactive.vectors import lateral_preference, unit


def repulsion(cfg: PlannerConfig, x: NDArray[np.float64], h: NDArray[np.float64], P: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], float, float]:
    """Repulsive vector (Khatib-style, density independent), the smallest clearance [m], and the smallest
    one ahead of the tip [m]."""
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
    u = unit(s)
    if u is None:
        return np.zeros(3), clear_min, clear_ahead
    rmin = max(clear_min, 1e-3)
    mag = cfg.repulsion_gain * (1.0 / rmin - 1.0 / rho0) / (1.0 / cfg.safety_distance - 1.0 / rho0)
    return mag * u, clear_min, clear_ahead


def reachability_guard(cfg: PlannerConfig, d: NDArray[np.float64], h: NDArray[np.float64],
                       e: NDArray[np.float64], dist: float, pref: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bend ``d`` back towards the goal direction ``e`` so the goal stays reachable.

    A heading at angle ``a`` off the goal direction keeps the goal outside the turning circle iff
    ``sin(a) <= dist / (2 R)``; the field may deflect the tip only that far (times ``goal_guard``), so it
    cannot push the tip past a goal it can no longer turn onto.  If the heading ``h`` itself is already
    beyond the limit, the tip turns straight for the goal.  ``pref``: the look-ahead's last push, which
    picks the side to bend to when ``d`` lies along ``e``.
    """
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
    side = side / n if n > 1e-9 else lateral_preference(e, e, pref)
    return np.cos(limit) * e + np.sin(limit) * side


def goal_inside_turn_circle(radius: float, x: NDArray[np.float64], h: NDArray[np.float64],
                            g: NDArray[np.float64], tolerance: float = 0.0, margin: float = 1.0) -> bool:
    """True if ``g`` is inside the turning circle (radius ``margin * radius`` [m]) on its side, so turning
    towards it cannot reach it, and it is not passed within ``tolerance / 2`` by going straight on.  Once
    inside, the planner keeps straight until the goal is outside ``1.25 R`` (hysteresis: it then turns onto
    it with room to spare instead of spiralling around a goal on the circle's boundary)."""
    rel = g - x
    along = float(rel @ h)
    lat = rel - along * h
    n = float(np.linalg.norm(lat))
    if n < 1e-9 or (along > 0 and n < 0.5 * tolerance):
        return False
    centre = x + radius * lat / n
    return float(np.linalg.norm(g - centre)) < margin * radius


def reach_length(radius: float, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64]) -> float:
    """Length [m] of the shortest path to ``g`` with curvature <= 1/``radius`` starting along ``h``.

    A turn on the circle of that radius towards the goal, then a straight tangent (Dubins "CS" path to a
    point, free final heading).  For a goal inside the turning circle: a full circle plus how far the goal
    is inside.
    """
    R = radius
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


def aim_direction(cfg: PlannerConfig, x: NDArray[np.float64], h: NDArray[np.float64], g: NDArray[np.float64],
                  e: NDArray[np.float64], dist: float, g_next: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """Direction to aim at: the goal, or with a next goal a carrot on a local curve.

    With ``g_next`` the curve is the cubic Hermite from ``x`` (tangent ``h``) to the goal (tangent ``t``,
    the bisector of the incoming direction ``e`` and the outgoing one towards ``g_next``), tangent lengths
    ``dist``; the carrot is the curve point at parameter ``corner_lead`` (recomputed every step, so the tip
    arrives at the goal already turned towards the next one, like the scripted spline through the goals).
    """
    if g_next is None:
        return e
    out = unit(g_next - g)
    t = None if out is None else unit(e + out)
    if t is None:
        return e
    u = cfg.corner_lead
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    carrot = h00 * x + h10 * dist * h + h01 * g + h11 * cfg.corner_tangent * dist * t
    aim = unit(carrot - x)
    return e if aim is None else aim


def speed(cfg: PlannerConfig, clear_ahead: float, free_ahead: float, h: NDArray[np.float64],
          d: NDArray[np.float64], dist: float, approach: bool, lag: float) -> float:
    """The commanded speed [m/s]: ``v_max`` in the open, down to ``v_min`` as the clearance ahead falls,
    at most halved while the heading ``h`` still has to turn to ``d``, zero with the tube ahead blocked
    within ``stop_distance``; in approach mode proportional to the distance ``dist`` [m] to the goal; and
    down to zero as the command leads the actual tip by ``lag`` [m] up to ``max_lead``."""
    span = cfg.slow_distance - cfg.safety_distance
    f = float(np.clip((clear_ahead - cfg.safety_distance) / span, 0.0, 1.0))
    v = cfg.v_min + (cfg.v_max - cfg.v_min) * f
    v *= max(0.5, 0.5 * (1.0 + float(h @ d)))
    v = max(v, cfg.v_min)
    if free_ahead < cfg.stop_distance:
        v = 0.0
    if approach:
        v = min(v, cfg.v_max * dist / cfg.approach_distance)
    v *= float(np.clip((cfg.max_lead - lag) / (0.5 * cfg.max_lead), 0.0, 1.0))
    return v if v > 1e-4 * cfg.v_max else 0.0
