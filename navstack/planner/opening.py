"""Seen openings: a gap ringed by sensed points through which the tip's rays went far.

An optimistic planner plans through unseen space as if it were free.  Beside a structure whose outer faces
its rays meet edge-on (a duct seen from in front: the rim and the inner faces are sensed, the outside never
is), the shortest way to a goal inside the structure then runs round its unseen outside, and the tip, which
needs room to turn (``min_turn_radius``), commits to that side before the walls appear; from there the
opening can no longer be entered (duct-elbow at difficulty 1: the plans pass 15-17 cm from the mouth's
centre from the first second on, while a plan through the mouth costs no more).

A **seen opening** is a point on a far ray (one that met nothing, or met something ``far_range`` or more
away) around which sensed points lie on every side (all four quadrants about the ray) within
``ring_radius`` in a slab ``slab`` thick across the ray, none closer than ``min_clearance``: the ray went
through a gap in a sensed surface.  :func:`find_opening` returns the centre of the nearest such gap that
lies towards the goal; the planner then also searches through it (:mod:`navstack.planner.field`) and keeps
that plan unless the plan of the search alone is clearly cheaper.  Only rays and sensed points are read
(never obstacle geometry).  Units: metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.validate import flag, integer, positive

__all__ = ["FarRays", "OpeningConfig", "far_rays", "find_opening"]


@dataclass(frozen=True)
class OpeningConfig:
    """Parameters of the seen-opening preference (metres).

    Attributes:
        enabled: look for openings at all.
        far_range: a ray that told the map something (a hit, or free space up to the sensor's range) counts as
            far if it went at least this long without a hit [m]; at most the sensor's range (``TrialConfig``
            refuses more: no opening would ever be seen).
        ring_radius: sensed points within this distance of the ray's axis [m] make the ring.
        slab: ... and within half this distance along the ray of the candidate point [m].
        min_clearance: the ring's nearest point is at least this far from the ray's axis [m] (the tip fits).
        min_per_quadrant: points needed in each of the four quadrants about the ray.
        sample: spacing of the candidate points along a far ray [m].
        near: candidate points start this far along the ray [m].
        passed: an opening this close to the tip is being passed: none is returned [m].
        via_tolerance: the plan passes within this of the opening's centre [m] (times the search's
            ``goal_fraction``).
        cost_ratio: the plan through the opening is kept unless it costs more than this times the other.
        max_escapes: no opening is looked for once the planner has backed out more than this many times for the
            goal (0: not after the first escape).
        budget: expansions of the search through an opening beside a plan that reaches every goal (where it is a
            preference only).  The 41 such searches that reached the goal in the 12 duct-elbow trials this was
            made for took 1-492; a truss's openings between members rarely lead on, and each search that fails
            spends its whole budget (with 8,000: the 200-trial sweep 19 % slower).
    """

    enabled: bool = True
    far_range: float = 0.25
    ring_radius: float = 0.13
    slab: float = 0.06
    min_clearance: float = 0.04
    min_per_quadrant: int = 2
    sample: float = 0.02
    near: float = 0.06
    passed: float = 0.06
    via_tolerance: float = 0.03
    cost_ratio: float = 1.25
    max_escapes: int = 0
    budget: int = 600

    def __post_init__(self) -> None:
        flag(self, "enabled")
        positive(self, "far_range", "ring_radius", "slab", "min_clearance", "sample", "near", "passed",
                 "via_tolerance", "cost_ratio")
        if self.min_clearance >= self.ring_radius:
            raise ValueError("OpeningConfig.min_clearance must be below ring_radius")
        integer(self, "min_per_quadrant", "budget", lo=1)
        integer(self, "max_escapes", lo=0)


@dataclass(frozen=True)
class FarRays:
    """The far rays of one reading: ``origins`` (m, 3) [m], unit ``directions`` (m, 3), free ``lengths`` (m,) [m]."""

    origins: NDArray[np.float64]
    directions: NDArray[np.float64]
    lengths: NDArray[np.float64]


def far_rays(origins: NDArray[np.float64], directions: NDArray[np.float64], ranges: NDArray[np.float64],
             informative: NDArray[np.bool_], far_range: float) -> FarRays | None:
    """The rays of a reading, as fused into the map (``ranges`` [m], ``informative``: the ray told the map
    something), that went ``far_range`` [m] or further without a hit; None if none did."""
    far = np.asarray(informative, dtype=np.bool_) & (np.asarray(ranges, dtype=np.float64) >= far_range)
    if not far.any():
        return None
    return FarRays(np.asarray(origins, dtype=np.float64)[far], np.asarray(directions, dtype=np.float64)[far],
                   np.asarray(ranges, dtype=np.float64)[far])


def find_opening(points: NDArray[np.float64], rays: FarRays | None, tip: NDArray[np.float64],
                 goal: NDArray[np.float64], cfg: OpeningConfig, heading: NDArray[np.float64] | None = None,
                 min_turn_radius: float = 0.0) -> NDArray[np.float64] | None:
    """The centre [m] of the nearest seen opening towards ``goal`` (module docstring), or None.

    ``points`` (n, 3): the sensed surface points [m]; ``rays``: the last reading's far rays; ``tip`` the
    commanded tip [m].  An opening counts only if it is nearer the goal than the tip is, ahead of the tip
    towards the goal, and at least ``passed`` from the tip; with the tip's unit ``heading``, not inside either
    circle of ``min_turn_radius`` [m] it could turn on in the plane of its heading and the point (only a long
    detour of that curvature reaches such a point: a search through it spent its budget, on truss bays beside
    the tip).  Along each far
    ray towards the goal, points ``sample`` apart from ``near`` on are tried in turn, up to the first that a ring
    surrounds (:func:`_ring_shift`).
    """
    if rays is None or len(points) == 0:
        return None
    prm = np.array([cfg.ring_radius, cfg.slab, cfg.min_clearance, cfg.min_per_quadrant, cfg.sample, cfg.near,
                    cfg.passed, min_turn_radius if heading is not None else 0.0])
    h = np.zeros(3) if heading is None else np.asarray(heading, dtype=np.float64) / np.linalg.norm(heading)
    centre = np.empty(3)
    found = _find_opening(np.ascontiguousarray(points, dtype=np.float64), rays.origins, rays.directions,
                          rays.lengths, np.asarray(tip, dtype=np.float64), np.asarray(goal, dtype=np.float64),
                          h, prm, centre)
    return centre if found else None


@numba.njit(cache=True)
def _find_opening(points, origins, dirs, lengths, tip, goal, heading, prm, centre):  # pragma: no cover - jitted
    """:func:`find_opening`'s search (``prm`` = ring_radius, slab, min_clearance, min_per_quadrant, sample, near,
    passed, min_turn_radius); the centre into ``centre``; returns whether one was found."""
    ring_r, slab, min_q, sample, near, passed = prm[0], prm[1], int(prm[3]), prm[4], prm[5], prm[6]
    gx, gy, gz = goal[0] - tip[0], goal[1] - tip[1], goal[2] - tip[2]
    dist_goal = math.sqrt(gx * gx + gy * gy + gz * gz)
    if dist_goal < 1e-9:
        return False
    n = points.shape[0]
    beside = np.empty((n, 3))
    quads = np.empty((4, n))
    c = np.empty(3)
    shifted = np.empty(3)
    best_d = math.inf
    found = False
    for r in range(origins.shape[0]):
        o, d, length = origins[r], dirs[r], lengths[r]
        if d[0] * gx + d[1] * gy + d[2] * gz <= 0.0:
            continue
        nb = _beside_ray(points, o, d, length, ring_r + 0.5 * slab, beside)
        if nb < 4 * min_q:
            continue
        e1, e2 = _cross_axes(d)
        steps = max(int(math.ceil((length - 0.5 * sample - near) / sample)), 0)  # np.arange's count
        for i in range(steps):
            t = near + i * sample
            for a in range(3):
                c[a] = o[a] + t * d[a]
            if _dist(c, tip) >= best_d:
                break
            if not (_ring_shift(beside, nb, c, d, e1, e2, prm, quads, shifted)
                    and _ring_shift(beside, nb, shifted, d, e1, e2, prm, quads, shifted)
                    and _clear_of(beside, nb, shifted, d, prm)):
                continue  # twice: the second about the first's centre, so that a ray off the gap's centre sees
                # each side in its own quadrant; and the centre itself keeps min_clearance
            d_tip = _dist(shifted, tip)
            if d_tip < passed or _in_turning_circle(shifted, tip, heading, prm[7]):
                continue  # the gap the tip is passing through, or one it cannot turn into
            if _dist(shifted, goal) < dist_goal and d_tip < best_d:
                best_d = d_tip
                centre[:] = shifted
                found = True
            break  # the first gap along this ray
    return found


@numba.njit(cache=True)
def _in_turning_circle(c, tip, h, radius):  # pragma: no cover - jitted
    """Whether ``c`` lies inside a circle of ``radius`` [m] tangent to the unit heading ``h`` at ``tip`` (in the
    plane of ``h`` and ``c - tip``): ``a^2 + l^2 < 2 radius l``, ``a`` along ``h``, ``l`` across it."""
    rx, ry, rz = c[0] - tip[0], c[1] - tip[1], c[2] - tip[2]
    a = rx * h[0] + ry * h[1] + rz * h[2]
    lx, ly, lz = rx - a * h[0], ry - a * h[1], rz - a * h[2]
    lat = math.sqrt(lx * lx + ly * ly + lz * lz)
    return a * a + lat * lat < 2.0 * radius * lat


@numba.njit(cache=True, inline="always")
def _dist(a, b):  # pragma: no cover - jitted
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


@numba.njit(cache=True)
def _cross_axes(d):  # pragma: no cover - jitted
    """Two unit vectors perpendicular to the unit ``d`` and to each other."""
    ax, ay, az = (1.0, 0.0, 0.0) if abs(d[0]) < 0.9 else (0.0, 1.0, 0.0)
    e1 = np.array([d[1] * az - d[2] * ay, d[2] * ax - d[0] * az, d[0] * ay - d[1] * ax])
    e1 /= math.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2)
    e2 = np.array([d[1] * e1[2] - d[2] * e1[1], d[2] * e1[0] - d[0] * e1[2], d[0] * e1[1] - d[1] * e1[0]])
    return e1, e2


@numba.njit(cache=True)
def _ring_shift(points, n, c, d, e1, e2, prm, quads, out):  # pragma: no cover - jitted
    """``c`` moved across the unit ray direction ``d`` to midway between the ring's sides (the median offset of
    the points in each quadrant about the ray, along the cross axes ``e1``, ``e2``) into ``out`` [m]; False (and
    ``out`` untouched) if the sensed ``points[:n]`` do not ring it: fewer than ``min_per_quadrant`` in any quadrant
    within ``ring_radius`` of the ray in a slab ``slab`` thick across it, or one closer than ``min_clearance``."""
    ring_r, half_slab, min_clear, min_q = prm[0], 0.5 * prm[1], prm[2], int(prm[3])
    counts = np.zeros(4, dtype=np.int64)
    n_near = 0
    for q in range(n):
        rx, ry, rz = points[q, 0] - c[0], points[q, 1] - c[1], points[q, 2] - c[2]
        along = rx * d[0] + ry * d[1] + rz * d[2]
        lx, ly, lz = rx - along * d[0], ry - along * d[1], rz - along * d[2]
        rho = math.sqrt(lx * lx + ly * ly + lz * lz)
        if abs(along) > half_slab or rho > ring_r:
            continue
        if rho < min_clear:
            return False
        n_near += 1
        u = lx * e1[0] + ly * e1[1] + lz * e1[2]
        v = lx * e2[0] + ly * e2[1] + lz * e2[2]
        if u >= abs(v):  # the +e1 side
            quads[0, counts[0]] = u
            counts[0] += 1
        if -u >= abs(v):  # -e1
            quads[1, counts[1]] = u
            counts[1] += 1
        if v > abs(u):  # +e2
            quads[2, counts[2]] = v
            counts[2] += 1
        if -v > abs(u):  # -e2
            quads[3, counts[3]] = v
            counts[3] += 1
    if n_near < 4 * min_q or counts.min() < min_q:
        return False
    m = np.empty(4)
    for side in range(4):
        m[side] = np.median(quads[side, : counts[side]])
    su, sv = 0.5 * (m[0] + m[1]), 0.5 * (m[2] + m[3])
    for a in range(3):
        out[a] = c[a] + su * e1[a] + sv * e2[a]
    return True


@numba.njit(cache=True)
def _clear_of(points, n, c, d, prm):  # pragma: no cover - jitted
    """Whether none of ``points[:n]`` in the slab across the unit ``d`` about ``c`` is within ``min_clearance`` of
    the ray through ``c`` (a shifted centre is checked again: the shift is about the points round the old one)."""
    half_slab, min_clear = 0.5 * prm[1], prm[2]
    for q in range(n):
        rx, ry, rz = points[q, 0] - c[0], points[q, 1] - c[1], points[q, 2] - c[2]
        along = rx * d[0] + ry * d[1] + rz * d[2]
        if abs(along) > half_slab:
            continue
        lx, ly, lz = rx - along * d[0], ry - along * d[1], rz - along * d[2]
        if lx * lx + ly * ly + lz * lz < min_clear * min_clear:
            return False
    return True


@numba.njit(cache=True)
def _beside_ray(points, o, d, length, r, out):  # pragma: no cover - jitted
    """The ``points`` within ``r`` [m] of the ray from ``o`` along the unit ``d`` over ``length`` [m] into
    ``out``; returns how many."""
    n = 0
    for q in range(points.shape[0]):
        rx, ry, rz = points[q, 0] - o[0], points[q, 1] - o[1], points[q, 2] - o[2]
        t = min(max(rx * d[0] + ry * d[1] + rz * d[2], 0.0), length)
        ex, ey, ez = rx - t * d[0], ry - t * d[1], rz - t * d[2]
        if ex * ex + ey * ey + ez * ez <= r * r:
            out[n, 0], out[n, 1], out[n, 2] = points[q, 0], points[q, 1], points[q, 2]
            n += 1
    return n
