"""A plain numpy statement of :func:`navstack.planner.opening.find_opening` (the compiled search), for tests only.

Written as the module docstring reads, one array operation per rule, with no scratch buffers and no early
exits beyond the documented ones; ``tests/test_opening.py`` compares the compiled search with it on random
scenes."""

from __future__ import annotations

import math

import numpy as np

from navstack.planner.opening import FarRays, OpeningConfig


def cross_axes(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The compiled search's cross axes of the unit ``d`` (its quadrants are taken about them)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(d, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


def _across(points: np.ndarray, c: np.ndarray, d: np.ndarray, cfg: OpeningConfig):
    """The points in the slab about ``c`` across ``d``: their offsets across the ray and distances from it."""
    rel = points - c
    along = rel @ d
    lat = rel - np.outer(along, d)
    keep = np.abs(along) <= 0.5 * cfg.slab
    return lat[keep], np.linalg.norm(lat[keep], axis=1)


def ring_shift(points: np.ndarray, c: np.ndarray, d: np.ndarray, cfg: OpeningConfig) -> np.ndarray | None:
    """``c`` moved to midway between the ring's four sides, or None if the points do not ring it."""
    lat, rho = _across(points, c, d, cfg)
    ring = rho <= cfg.ring_radius
    lat, rho = lat[ring], rho[ring]
    if len(rho) and rho.min() < cfg.min_clearance:
        return None
    if len(rho) < 4 * cfg.min_per_quadrant:
        return None
    e1, e2 = cross_axes(d)
    u, v = lat @ e1, lat @ e2
    sides = (u >= np.abs(v), -u >= np.abs(v), v > np.abs(u), -v > np.abs(u))
    if min(np.count_nonzero(s) for s in sides) < cfg.min_per_quadrant:
        return None
    su = 0.5 * (np.median(u[sides[0]]) + np.median(u[sides[1]]))
    sv = 0.5 * (np.median(v[sides[2]]) + np.median(v[sides[3]]))
    return c + su * e1 + sv * e2


def in_turning_circle(c: np.ndarray, tip: np.ndarray, h: np.ndarray, radius: float) -> bool:
    """``c`` inside a circle of ``radius`` tangent to the unit ``h`` at ``tip``."""
    r = c - tip
    a = r @ h
    lat = np.linalg.norm(r - a * h)
    return a * a + lat * lat < 2.0 * radius * lat


def find_opening(points, rays: FarRays | None, tip, goal, cfg: OpeningConfig, heading=None,
                 min_turn_radius: float = 0.0) -> np.ndarray | None:
    """The nearest seen opening towards ``goal`` (the compiled search's documented rules), or None."""
    if rays is None or len(points) == 0:
        return None
    dist_goal = float(np.linalg.norm(goal - tip))
    if dist_goal < 1e-9:
        return None
    h = None if heading is None else heading / np.linalg.norm(heading)
    best, best_d = None, math.inf
    for o, d, length in zip(rays.origins, rays.directions, rays.lengths, strict=True):
        if d @ (goal - tip) <= 0.0:
            continue
        rel = points - o
        t = np.clip(rel @ d, 0.0, length)
        beside = points[np.linalg.norm(rel - np.outer(t, d), axis=1) <= cfg.ring_radius + 0.5 * cfg.slab]
        if len(beside) < 4 * cfg.min_per_quadrant:
            continue
        for s in np.arange(cfg.near, length - 0.5 * cfg.sample, cfg.sample):
            c = o + s * d
            if np.linalg.norm(c - tip) >= best_d:
                break
            first = ring_shift(beside, c, d, cfg)
            centre = None if first is None else ring_shift(beside, first, d, cfg)
            if centre is None or _across(beside, centre, d, cfg)[1].min(initial=np.inf) < cfg.min_clearance:
                continue
            d_tip = float(np.linalg.norm(centre - tip))
            if d_tip < cfg.passed or (h is not None and in_turning_circle(centre, tip, h, min_turn_radius)):
                continue
            if np.linalg.norm(goal - centre) < dist_goal and d_tip < best_d:
                best, best_d = centre, d_tip
            break
    return best
