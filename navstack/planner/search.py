"""Descending the potential along paths the tip can follow: a hybrid A* over circular arcs.

The tip is a vehicle with a bounded curvature (``1 / min_turn_radius``): the slithering body
passes through every bend of its path, so a bend tighter than that would fold the serpentine.
A grid gradient ignores that and leads into slots the tip can no longer turn into (measured:
/work/shared/notes/finding-the-way.md), so the planner searches over curvature-bounded motion
primitives instead (hybrid A*, Dolgov, Thrun, Montemerlo and Diebel 2008, in 3D):

* a **state** is a position, a unit heading and the index of the next goal;
* its **successors** are arcs of length ``step`` [m]: straight ahead, and at curvature
  ``kappa_max`` and ``kappa_max / 2`` turning towards ``n_dirs`` directions around the heading;
* an arc's **cost** is its length plus the potential of :mod:`navstack.planner.potential` along
  it (sampled every ``step / samples``), plus ``w_turn`` per metre of full-curvature turning;
  an arc through a forbidden point is discarded;
* a **goal** is passed when a sample comes within ``goal_fraction`` of its tolerance: the state's
  goal index advances, so the search looks through every remaining goal and passes each one on
  the side the next one needs (the notes: "planning must look one goal ahead");
* the **heuristic** is the straight distance to the next goal's ball plus the distances between
  the remaining goals (admissible: no path is shorter), weighted by ``epsilon`` >= 1;
* states are merged in cells of ``cell`` [m] and ``heading_bin`` [rad] of azimuth and
  elevation (with the goal index); at most ``max_expansions`` states are expanded.

:func:`search` returns a :class:`Plan`: the arcs from the start state, densely sampled, with a
status: ``REACHED`` (through every goal), ``PARTIAL`` (the budget ran out: the path to the state
with the smallest heuristic) or ``NO_PATH`` (every reachable state was expanded: boxed in).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field, replace

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.fused import norm3
from navstack.jit import kernel
from navstack.planner.map import SensedMap
from navstack.planner.potential import (
    BLOCKED,
    NavigationFunction,
    Repulsion,
    cost_at,
    cost_reach,
    navigation_function,
    wave_value,
)
from navstack.planner.proximity import REACH, distance_below, distances_below, point_index, segment_distance_below
from navstack.validate import flag, in_range, integer, non_negative, positive

__all__ = ["NO_PATH", "PARTIAL", "REACHED", "ArmShape", "Plan", "SearchConfig", "only_the_arm_blocks", "search",
           "still_clear"]

REACHED, PARTIAL, NO_PATH = 0, 1, 2

_LINK_END = 1.0 / 12.0
"""The fraction of the last link at either end that its clearance check leaves out: its ends are the tip (checked
by the path's own samples) and a point the tip has passed (checked when it was the tip, and where the body
already is); the check covers what its 11 samples once did, exactly (:func:`_last_link_clear`)."""

_CLOSED, _ABSENT = -1.0, -2.0
"""The search's ``best_g`` values of an expanded state and of a state not reached yet (costs are >= 0)."""


@dataclass(frozen=True)
class SearchConfig:
    """Parameters of the hybrid A* (metres, radians).

    Attributes:
        min_turn_radius: smallest radius of curvature of a planned path [m].
        step: length of one motion primitive [m].
        samples: cost and collision samples per primitive.
        n_dirs: turning directions around the heading (at each of the two curvatures).
        cell: position cell of the closed set [m].
        heading_bin: azimuth / elevation bin of the closed set [rad].
        epsilon: heuristic weight (1 = optimal, larger = faster, up to epsilon times longer).
        w_turn: extra cost per metre of turning at full curvature (prefers straight paths).
        goal_fraction: a goal is passed when a sample is within this fraction of its tolerance.
        max_expansions: expansion budget per search.
        max_length: no path longer than this is searched [m].
        start_relax: within this arc length of the start (and the last link within ``start_relax +
            link_length``), the body may be closer to sensed surfaces than ``Repulsion.r_block``, as it may
            already be: no closer than ``start_slack`` nearer than the start is (the tip and its last link), and
            never closer than ``body_radius + start_margin`` [m].  A start that keeps ``r_block + start_slack``
            gets no relaxation: a planner that replans every few centimetres always follows the first
            centimetres of a plan, so a relaxation granted to every start would be its clearance for good
            (rotated_duct.json, a review world: the last link cut a duct's mouth corner at 28 mm from sensed
            points, 3 mm of margin, and touched it).
        start_margin: see ``start_relax`` [m].
        start_slack: see ``start_relax`` [m].
        link_length: the serpentine's links are straight chords of this length behind the tip [m].
        arm_clearance: the flange (six links behind the tip) and the point one link behind it, where the
            arm begins, keep this distance from sensed surfaces: the arm (radius 0.06 m) must not be
            drawn into the structure by a path longer than the serpentine [m].  Used when the arm's
            shape is not given (:class:`ArmShape`).
        arm_margin: with the arm's shape, its capsules keep this clearance from sensed surfaces [m].
        length_factor, length_slack: a state whose path length so far plus its shortest length to go
            (straight or turn-then-straight, obstacles ignored) exceeds ``length_factor`` times the
            start's plus ``length_slack`` [m] is not expanded: a detour that long would draw the arm
            into the structure, and without the bound a search from a state with no way on expands
            every loop it can reach.
        nav_margin: the navigation function covers the box around the start and the goal grown by
            this [m].
        half_curvature: also primitives at half the largest curvature.
    """

    min_turn_radius: float = 0.25
    step: float = 0.05
    samples: int = 5
    n_dirs: int = 8
    cell: float = 0.02
    heading_bin: float = math.radians(6.0)
    epsilon: float = 1.5
    w_turn: float = 0.05
    goal_fraction: float = 0.7
    max_expansions: int = 8000
    max_length: float = 3.0
    start_relax: float = 0.06
    start_margin: float = 0.003
    start_slack: float = 0.002
    link_length: float = 0.2
    arm_clearance: float = 0.08
    arm_margin: float = 0.02
    length_factor: float = 1.5
    length_slack: float = 0.3
    nav_margin: float = 0.35
    half_curvature: bool = True

    def __post_init__(self) -> None:
        positive(self, "min_turn_radius", "step", "cell", "heading_bin", "epsilon", "max_length", "link_length",
                 "length_factor")
        non_negative(self, "w_turn", "start_relax", "start_margin", "start_slack", "arm_clearance", "arm_margin",
                     "length_slack", "nav_margin")
        if self.epsilon < 1:
            raise ValueError(f"SearchConfig.epsilon must be >= 1, got {self.epsilon}")
        in_range(self, "goal_fraction", lo=0.0, hi=1.0, lo_open=True)
        integer(self, "samples", "max_expansions", lo=1)
        integer(self, "n_dirs", lo=3)
        flag(self, "half_curvature")


@dataclass(frozen=True)
class ArmShape:
    """The robot's own arm at the start: ``points`` (k, 3) along its capsules' axes [m], ``flange`` (3,) the
    flange J6 where the serpentine begins [m], ``radius`` the capsules' radius [m].  The lathe bed carries
    the arm after the serpentine, in about this posture: the planner checks it translated by the flange's
    displacement along the planned path.

    ``axis`` (3,): the lathe bed's unit axis [-], and ``travel`` (lo, hi): how far the bed may still move
    along it from the start [m] (its joint range minus the start).  With them the arm is translated only by
    the part of the flange's displacement the bed can make (along the axis, within its travel); the rest
    the arm's own joints must make, so its capsules keep that much more clearance
    (:func:`_arm_shifted_clear`).  ``axis`` None: translated by the whole displacement."""

    points: NDArray[np.float64]
    flange: NDArray[np.float64]
    radius: float
    axis: NDArray[np.float64] | None = None
    travel: tuple[float, float] = (-np.inf, np.inf)
    _carry: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:  # checked contiguous float arrays, once: the kernels take them every step
        points = np.ascontiguousarray(self.points, dtype=np.float64)
        flange = np.asarray(self.flange, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
            raise ValueError(f"ArmShape.points must be a finite (k, 3) array [m], got shape {points.shape}")
        if flange.shape != (3,) or not np.isfinite(flange).all():
            raise ValueError(f"ArmShape.flange must be a finite 3-vector [m], got shape {flange.shape}")
        positive(self, "radius")
        axis, travel = _floats(self.axis, (3,)), _floats(self.travel, (2,))
        norm = float(np.linalg.norm(axis)) if axis is not None and np.isfinite(axis).all() else 0.0
        if self.axis is not None and abs(norm - 1.0) > 1e-6:
            raise ValueError(f"ArmShape.axis must be a unit 3-vector or None, got {self.axis!r}")
        if travel is None or np.isnan(travel).any() or travel[0] > 0.0 or travel[1] < 0.0:
            raise ValueError(f"ArmShape.travel must be (lo <= 0, hi >= 0) [m], got {self.travel!r}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "flange", flange)
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "axis", None if self.axis is None else axis / norm)
        object.__setattr__(self, "travel", (float(travel[0]), float(travel[1])))
        axis = np.zeros(3) if self.axis is None else self.axis
        carry = np.concatenate([flange, axis, travel])
        object.__setattr__(self, "_carry", np.ascontiguousarray(carry))

    @property
    def carry(self) -> NDArray[np.float64]:
        """The kernels' (8,) view: the flange [m], the lathe's unit axis (zero: none) and its travel [m]."""
        return self._carry


def _floats(value: object, shape: tuple[int, ...]) -> NDArray[np.float64] | None:
    """``value`` as a float array of ``shape``, or None (not numbers, or another shape)."""
    try:
        out = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return out if out.shape == shape else None


_NO_ARM = (np.zeros((0, 3)), np.zeros(8))


def _arm_arrays(arm: ArmShape | None, config: SearchConfig) -> tuple[NDArray, NDArray, float]:
    """The kernels' view of the arm: its axis points, its :attr:`ArmShape.carry` and the reach its surface
    keeps [m] (no points and reach 0 without an arm)."""
    if arm is None:
        return _NO_ARM[0], _NO_ARM[1], 0.0
    return arm.points, arm.carry, arm.radius + config.arm_margin


@dataclass(frozen=True)
class Plan:
    """A planned tip path: dense samples from the start state.

    Attributes:
        points: (N, 3) positions [m], ``points[0]`` the start.
        tangents: (N, 3) unit headings.
        arc: (N,) arc length from the start [m].
        goal_index: (N,) index of the next goal at each sample (= number of goals when all passed).
        status: ``REACHED``, ``PARTIAL`` or ``NO_PATH`` (then a single sample, the start).
        cost: the path's cost [m]; ``expansions``: states expanded.
        stops: (S,) arc lengths [m] of the samples that lie exactly on a goal (where a goal shot ends), in
            order: the command lands on each (:class:`~navstack.planner.steering.PlanFollower`), so the
            tip is there at a control step however small the goal's tolerance.
        repulsion: the repulsion (clearances) the search kept; None: not known (a plan made by hand).
    """

    points: NDArray[np.float64]
    tangents: NDArray[np.float64]
    arc: NDArray[np.float64]
    goal_index: NDArray[np.int64]
    status: int
    cost: float
    expansions: int
    stops: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    repulsion: Repulsion | None = None

    @classmethod
    def standing(cls, point: NDArray[np.float64], tangent: NDArray[np.float64], goal_index: int, *,
                 cost: float = 0.0, expansions: int = 0, repulsion: Repulsion | None = None) -> Plan:
        """A ``NO_PATH`` plan: the single sample ``point`` [m] with unit ``tangent``, goal ``goal_index`` next."""
        return cls(points=np.array(point, dtype=float).reshape(1, 3),
                   tangents=np.array(tangent, dtype=float).reshape(1, 3), arc=np.zeros(1),
                   goal_index=np.array([goal_index], dtype=np.int64), status=NO_PATH, cost=cost,
                   expansions=expansions, repulsion=repulsion)

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def state(self, s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Position and unit tangent at arc length ``s`` (clamped), linearly interpolated."""
        if len(self.arc) == 1:
            return self.points[0].copy(), self.tangents[0].copy()
        return _state_at(self.arc, self.points, self.tangents, min(max(float(s), 0.0), self.length))


@numba.njit(cache=True)
def _state_at(arc, points, tangents, s):  # pragma: no cover - jitted
    """:meth:`Plan.state` for ``s`` within the plan (two or more samples): the segment holding ``s`` (the last
    sample at or before it, as ``numpy.searchsorted(side="right") - 1``, kept off the last sample), the position
    and tangent interpolated along it, the tangent divided by its norm (``numpy.linalg.norm``'s)."""
    lo, hi = 0, arc.shape[0]  # the first index whose arc exceeds s, by bisection
    while lo < hi:
        mid = (lo + hi) >> 1
        if arc[mid] > s:
            hi = mid
        else:
            lo = mid + 1
    i = min(max(lo - 1, 0), arc.shape[0] - 2)
    ds = arc[i + 1] - arc[i]
    f = 0.0 if ds <= 0 else (s - arc[i]) / ds
    p = np.empty(3)
    t = np.empty(3)
    for c in range(3):
        p[c] = points[i, c] + f * (points[i + 1, c] - points[i, c])
        t[c] = tangents[i, c] + f * (tangents[i + 1, c] - tangents[i, c])
    n = norm3(t[0], t[1], t[2])
    for c in range(3):
        t[c] = t[c] / n
    return p, t


# ------------------------------------------------------------------------------------------ kernels
@numba.njit(cache=True, inline="always")
def _basis(hx, hy, hz):  # pragma: no cover - jitted
    """Orthonormal u, w perpendicular to unit h (Duff et al. 2017)."""
    sign = 1.0 if hz >= 0.0 else -1.0
    a = -1.0 / (sign + hz)
    b = hx * hy * a
    return (1.0 + sign * hx * hx * a, sign * b, -sign * hx), (b, sign + hy * hy * a, -hy)


@numba.njit(cache=True, inline="always")
def _arc_terms(kappa, s):  # pragma: no cover - jitted
    """The terms of :func:`_arc` that depend on the curvature and the length alone."""
    a = kappa * s
    return math.sin(a) / kappa, (1.0 - math.cos(a)) / kappa, math.cos(a), math.sin(a)


@numba.njit(cache=True, inline="always")
def _arc_from(px, py, pz, hx, hy, hz, nx, ny, nz, kappa, s, sa, ca, c, sn):  # pragma: no cover - jitted
    """:func:`_arc` given its terms ``sa, ca, c, sn`` = :func:`_arc_terms` (kappa, s)."""
    if kappa < 1e-9:
        return px + s * hx, py + s * hy, pz + s * hz, hx, hy, hz
    return (px + sa * hx + ca * nx, py + sa * hy + ca * ny, pz + sa * hz + ca * nz,
            c * hx + sn * nx, c * hy + sn * ny, c * hz + sn * nz)


@numba.njit(cache=True, inline="always")
def _arc(px, py, pz, hx, hy, hz, nx, ny, nz, kappa, s):  # pragma: no cover - jitted
    """Position and heading after arc length ``s`` at curvature ``kappa`` turning towards unit ``n``."""
    if kappa < 1e-9:
        return px + s * hx, py + s * hy, pz + s * hz, hx, hy, hz
    sa, ca, c, sn = _arc_terms(kappa, s)
    return _arc_from(px, py, pz, hx, hy, hz, nx, ny, nz, kappa, s, sa, ca, c, sn)


@numba.njit(cache=True)
def _arc_table(kappas, step, n_samp):  # pragma: no cover - jitted
    """Per primitive ``m``: ``[s, sa, ca, c, sn]`` of :func:`_arc` at ``s = j * step / n_samp`` (row j, 1 .. n_samp,
    the samples) and at ``s = step`` (row 0, the end): the search's sines and cosines, once per search."""
    ds = step / n_samp
    out = np.zeros((kappas.shape[0], n_samp + 1, 5))
    for m in range(kappas.shape[0]):
        for j in range(n_samp + 1):
            s = step if j == 0 else j * ds
            out[m, j, 0] = s
            if kappas[m] >= 1e-9:
                out[m, j, 1], out[m, j, 2], out[m, j, 3], out[m, j, 4] = _arc_terms(kappas[m], s)
    return out


@numba.njit(cache=True)
def turn_then_straight(px, py, pz, hx, hy, hz, gx, gy, gz, radius, lower=False):  # pragma: no cover - jitted
    """Length [m] of the shortest path from (p, unit h) to the point g with curvature <= 1/radius.

    A turn on the circle of ``radius`` towards g, in the plane of h and g - p, then a straight
    tangent (Dubins' "CS" path to a point, free final heading).  For a goal inside the turning
    circle, where the tip must first move away, a full turn plus the depth inside (an estimate, often
    too long: with ``lower`` the straight distance instead, which never is).
    """
    rx, ry, rz = gx - px, gy - py, gz - pz
    along = rx * hx + ry * hy + rz * hz
    lx, ly, lz = rx - along * hx, ry - along * hy, rz - along * hz
    lat = math.sqrt(lx * lx + ly * ly + lz * lz)
    cx, cy = along, lat - radius
    q2 = cx * cx + cy * cy
    if q2 < radius * radius:
        if lower:  # a lower bound: the straight distance (the estimate below is not one)
            return math.sqrt(rx * rx + ry * ry + rz * rz)
        return 2.0 * math.pi * radius + (radius - math.sqrt(q2))
    t = math.sqrt(q2 - radius * radius)
    phi = (math.atan2(cy, cx) + 0.5 * math.pi - math.atan2(t, radius)) % (2.0 * math.pi)
    if phi > 2.0 * math.pi - 1e-9:
        phi = 0.0
    return radius * phi + t


@kernel
def _heuristic(px, py, pz, hx, hy, hz, k, k_nav, goals, reach, rest, nav, nav_origin, nav_cell,
               radius):  # pragma: no cover - jitted
    """Cost-to-go estimate: the larger of the navigation function (obstacles, no curvature) for goal
    ``k_nav`` (the straight distance for later goals) and the turn-then-straight length (curvature,
    no obstacles), plus the distances between the remaining goals.  ``k_nav = -1``: a lower bound on
    the length to go (no navigation function, no estimate inside the turning circle); ``-2``: the same
    without the navigation function but with that estimate.  ``nav``: the navigation function's
    :attr:`~navstack.planner.potential.NavigationFunction.wave`, run on as far as each cell asked for needs."""
    if k >= goals.shape[0]:
        return 0.0
    gx, gy, gz = goals[k, 0], goals[k, 1], goals[k, 2]
    dx, dy, dz = gx - px, gy - py, gz - pz
    d = math.sqrt(dx * dx + dy * dy + dz * dz) - reach[k]
    if k == k_nav:
        i = int(math.floor((px - nav_origin[0]) / nav_cell))
        j = int(math.floor((py - nav_origin[1]) / nav_cell))
        m = int(math.floor((pz - nav_origin[2]) / nav_cell))
        shape = nav[0].shape
        if 0 <= i < shape[0] and 0 <= j < shape[1] and 0 <= m < shape[2]:
            v = wave_value(nav, i, j, m) - 0.87 * nav_cell
            if v > d:
                d = v
    c = turn_then_straight(px, py, pz, hx, hy, hz, gx, gy, gz, radius, k_nav == -1) - reach[k]
    if c > d:
        d = c
    return (d if d > 0.0 else 0.0) + rest[k]


@kernel
def _key(px, py, pz, hx, hy, hz, k, origin, cell, hbin, dims, n_goals1):  # pragma: no cover - jitted
    ix = int(math.floor((px - origin[0]) / cell))
    iy = int(math.floor((py - origin[1]) / cell))
    iz = int(math.floor((pz - origin[2]) / cell))
    if ix < 0 or iy < 0 or iz < 0 or ix >= dims[0] or iy >= dims[1] or iz >= dims[2]:
        return -1
    az = math.atan2(hy, hx) + math.pi
    el = math.asin(min(1.0, max(-1.0, hz))) + 0.5 * math.pi
    na = int(math.ceil(2.0 * math.pi / hbin))
    ne = int(math.ceil(math.pi / hbin)) + 1
    ia = int(az / hbin) % na
    ie = min(int(el / hbin), ne - 1)
    key = ((ix * dims[1] + iy) * dims[2] + iz)
    key = (key * na + ia) * ne + ie
    return key * n_goals1 + k


@kernel
def _backward(qx, qy, qz, node, NP, NPAR, hist, reach, out):  # pragma: no cover - jitted
    """The path behind q as a polyline ``out[:n]`` (q first), back through the node's ancestors' end
    points, then the history ``hist`` (oldest first, ending at the root), then straight on, until it
    is ``reach`` [m] long; returns n."""
    out[0, 0], out[0, 1], out[0, 2] = qx, qy, qz
    n = 1
    length = 0.0
    cur = node
    h = hist.shape[0] - 2
    cap = out.shape[0]
    while length < reach and n < cap - 1:
        if cur >= 0:
            bx, by, bz = NP[cur, 0], NP[cur, 1], NP[cur, 2]
            cur = NPAR[cur]
        elif h >= 0:
            bx, by, bz = hist[h, 0], hist[h, 1], hist[h, 2]
            h -= 1
        else:
            break
        dx, dy, dz = bx - out[n - 1, 0], by - out[n - 1, 1], bz - out[n - 1, 2]
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d < 1e-9:
            continue
        out[n, 0], out[n, 1], out[n, 2] = bx, by, bz
        length += d
        n += 1
    if length < reach and n >= 2:
        # beyond the history: extend its last segment straight back
        ex, ey, ez = out[n - 1, 0] - out[n - 2, 0], out[n - 1, 1] - out[n - 2, 1], out[n - 1, 2] - out[n - 2, 2]
        en = math.sqrt(ex * ex + ey * ey + ez * ez)
        f = (reach - length + 0.01) / en
        out[n, 0], out[n, 1], out[n, 2] = out[n - 1, 0] + f * ex, out[n - 1, 1] + f * ey, out[n - 1, 2] + f * ez
        n += 1
    return n


@kernel
def _chain(line, n, L, count, pts):  # pragma: no cover - jitted
    """``count`` chord points one ``L`` apart back along the polyline ``line[:n]`` (its first point the
    tip) into ``pts``: the slithering chain (each the first crossing of the sphere of radius L around
    the previous one); returns how many were found."""
    cx, cy, cz = line[0, 0], line[0, 1], line[0, 2]
    k = 1
    L2 = L * L
    for i in range(count):
        found = False
        ax, ay, az = cx, cy, cz
        while k < n:
            bx, by, bz = line[k, 0], line[k, 1], line[k, 2]
            dx, dy, dz = bx - cx, by - cy, bz - cz
            if dx * dx + dy * dy + dz * dz >= L2:
                sx, sy, sz = bx - ax, by - ay, bz - az
                wx, wy, wz = ax - cx, ay - cy, az - cz
                A = sx * sx + sy * sy + sz * sz
                B = wx * sx + wy * sy + wz * sz
                C = wx * wx + wy * wy + wz * wz - L2
                disc = B * B - A * C
                t = (-B + math.sqrt(disc if disc > 0.0 else 0.0)) / A if A > 0.0 else 0.0
                cx, cy, cz = ax + t * sx, ay + t * sy, az + t * sz
                pts[i, 0], pts[i, 1], pts[i, 2] = cx, cy, cz
                found = True
                break
            ax, ay, az = bx, by, bz
            k += 1
        if not found:
            return i
    return count


@kernel
def _link_distance(ax, ay, az, qx, qy, qz, r, first, occ, start, S, origin, bucket, bdims):  # pragma: no cover
    """:func:`~navstack.planner.proximity.segment_distance_below` of the last link, the chord from a (the first
    chain point) to the tip q, between :data:`_LINK_END` of it from either end."""
    dx, dy, dz = qx - ax, qy - ay, qz - az
    e, f = _LINK_END, 1.0 - _LINK_END
    return segment_distance_below(ax + e * dx, ay + e * dy, az + e * dz, ax + f * dx, ay + f * dy, az + f * dz, r,
                                  first, occ, start, S, origin, bucket, bdims)


@kernel
def _last_link_clear(pts, qx, qy, qz, r, occ, start, S, origin, bucket, bdims):  # pragma: no cover
    """The last link, the chord from the first chain point ``pts[0]`` to the tip q, keeps ``r`` from every
    surface point between :data:`_LINK_END` of it from either end: the exact distance from each point to that
    part of the chord (samples along it checked with ``r`` alone let a point midway between two come closer, 4 mm
    with 5 samples 3.3 cm apart, r = 35 mm; checked with a radius grown to cover the gap, they refuse a chord that
    keeps ``r``, by up to 1 mm with 11 samples)."""
    return _link_distance(pts[0, 0], pts[0, 1], pts[0, 2], qx, qy, qz, r, True, occ, start, S, origin, bucket,
                          bdims) >= r


@kernel
def _flange_clear(pts, r, occ, start, S, origin, bucket, bdims):  # pragma: no cover - jitted
    """The flange (chain point 5) and the point one link behind it (6), where the arm begins, keep ``r``."""
    for i in (5, 6):
        if distance_below(pts[i, 0], pts[i, 1], pts[i, 2], r, occ, start, S, origin, bucket, bdims) < r:
            return False
    return True


@kernel
def _arm_shifted_clear(pts, arm_pts, carry, r, occ, start, S, origin, bucket, bdims, buf,
                       out):  # pragma: no cover - jitted
    """The arm's axis ``arm_pts``, carried by the lathe bed after the flange, keeps its clearance from
    every surface point: the bed carries the arm along behind the serpentine, in about its starting posture.

    ``carry`` = [the flange at the start (3), the lathe's unit axis (3), its travel lo, hi].  The flange's
    displacement d (chain point 5 minus the start's flange) is split: the bed makes t = d . axis, clipped
    to the travel, and translates the whole arm by t axis; the rest, e = d - t axis, the arm's own joints
    must make, moving its links off the translated posture by about |e| (the flange by exactly that).  So
    the translated arm keeps ``r + |e|``.  A zero axis: translated by the whole d, keeping ``r``.

    A radius beyond the proximity mask's reach is asked of all the arm's points in one shared scan
    (:func:`~navstack.planner.proximity.distances_below`, bit for bit the point-by-point distances), the
    translated points in ``buf`` (k, 3) and their distances in ``out`` (k,): point by point, each point's scan
    covers nearly the same buckets as its neighbours' 5 cm away (the 200-trial sweep: 12 % slower so)."""
    dx, dy, dz = pts[5, 0] - carry[0], pts[5, 1] - carry[1], pts[5, 2] - carry[2]
    ax, ay, az = carry[3], carry[4], carry[5]
    rr = r
    if ax * ax + ay * ay + az * az > 0.0:
        t = min(max(dx * ax + dy * ay + dz * az, carry[6]), carry[7])
        ex, ey, ez = dx - t * ax, dy - t * ay, dz - t * az
        rr = r + np.sqrt(ex * ex + ey * ey + ez * ez)
        dx, dy, dz = t * ax, t * ay, t * az
    k = arm_pts.shape[0]
    if math.ceil(rr / bucket) > REACH:
        for i in range(k):
            buf[i, 0], buf[i, 1], buf[i, 2] = arm_pts[i, 0] + dx, arm_pts[i, 1] + dy, arm_pts[i, 2] + dz
        distances_below(buf, k, rr, out, occ, start, S, origin, bucket, bdims)
        for i in range(k):
            if out[i] < rr:
                return False
        return True
    for i in range(k):
        if distance_below(arm_pts[i, 0] + dx, arm_pts[i, 1] + dy, arm_pts[i, 2] + dz, rr, occ, start, S,
                          origin, bucket, bdims) < rr:
            return False
    return True


@kernel
def _body_clear(qx, qy, qz, node, NP, NPAR, hist, L, r_link, r_arm, line, pts, occ, start, S, origin,
                bucket, bdims, arm):  # pragma: no cover - jitted
    """The body behind the tip at q: the last link (a straight chord, inside the bends of the path) keeps
    ``r_link`` from every surface point, and with ``arm`` the flange (the sixth chord point) and the point
    one link behind it, where the arm begins, keep ``r_arm`` (the chain is followed that far only then)."""
    count = 7 if arm and r_arm > 0.0 else 1
    n = _backward(qx, qy, qz, node, NP, NPAR, hist, (count + 0.5) * L, line)
    m = _chain(line, n, L, count, pts)
    if m < count:
        return True
    if not _last_link_clear(pts, qx, qy, qz, r_link, occ, start, S, origin, bucket, bdims):
        return False
    return not (arm and r_arm > 0.0) or _flange_clear(pts, r_arm, occ, start, S, origin, bucket, bdims)


@kernel
def _arm_clear(qx, qy, qz, node, NP, NPAR, hist, L, arm_pts, carry, r, line, pts, occ, start, S, origin,
               bucket, bdims, buf, out):  # pragma: no cover - jitted
    """True if the arm, carried with the flange of the chain behind q (:func:`_arm_shifted_clear`), keeps ``r``
    from every surface point."""
    n = _backward(qx, qy, qz, node, NP, NPAR, hist, 6.5 * L, line)
    if _chain(line, n, L, 6, pts) < 6:
        return True
    return _arm_shifted_clear(pts, arm_pts, carry, r, occ, start, S, origin, bucket, bdims, buf, out)


@numba.njit(cache=True)
def goal_shot(px, py, pz, hx, hy, hz, gx, gy, gz, kappa_max):  # pragma: no cover - jitted
    """The circular arc from the state (p, unit h) that ends exactly on the point g (hybrid A*'s analytic
    expansion, with one arc): ``(kappa, nx, ny, nz, length)``, ``n`` the unit direction it turns towards
    (perpendicular to h; any for a straight shot, kappa 0) and ``length`` its arc length [m]; ``length`` is
    -1 where g is not ahead of the heading or the arc would be tighter than ``kappa_max`` [1/m].

    In the plane of h and v = g - p, the arc tangent to h through g turns by twice the angle between h
    and v: curvature 2 sin(angle) / |v|, length 2 angle / curvature."""
    vx, vy, vz = gx - px, gy - py, gz - pz
    d = math.sqrt(vx * vx + vy * vy + vz * vz)
    along = vx * hx + vy * hy + vz * hz
    if d <= 0.0 or along <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, -1.0
    ex, ey, ez = vx - along * hx, vy - along * hy, vz - along * hz
    off = math.sqrt(ex * ex + ey * ey + ez * ez)
    kappa = 2.0 * off / (d * d)
    if kappa < 1e-9:
        return 0.0, 0.0, 0.0, 0.0, along
    if kappa > kappa_max:
        return 0.0, 0.0, 0.0, 0.0, -1.0
    return kappa, ex / off, ey / off, ez / off, 2.0 * math.atan2(off, along) / kappa


@numba.njit(cache=True)
def _shot_samples(px, py, pz, hx, hy, hz, nx, ny, nz, kap, total, n_sh, k, goals, reach, box_lo, box_hi,
                  sh):  # pragma: no cover - jitted
    """The shot's samples ``sh[:n_sh]`` (the last one the goal ``k`` itself) and the goal index after them, or
    -1 when one leaves the box or goal ``k`` is passed before the end (the primitives cover that)."""
    kk = k
    for j in range(1, n_sh + 1):
        x, y, z, _, _, _ = _arc(px, py, pz, hx, hy, hz, nx, ny, nz, kap, total * j / n_sh)
        if j == n_sh:
            x, y, z = goals[k, 0], goals[k, 1], goals[k, 2]  # the arc's end is the goal (to rounding)
        sh[j - 1, 0], sh[j - 1, 1], sh[j - 1, 2] = x, y, z
        if x < box_lo[0] or y < box_lo[1] or z < box_lo[2] or x > box_hi[0] or y > box_hi[1] or z > box_hi[2]:
            return -1
        while kk < goals.shape[0] and ((goals[kk, 0] - x) ** 2 + (goals[kk, 1] - y) ** 2 + (goals[kk, 2] - z) ** 2
                                       <= reach[kk] * reach[kk]):
            kk += 1
        if kk > k and j < n_sh:
            return -1
    return kk


@numba.njit(cache=True)
def _shot_pieces(node, k, kk, kap, nx, ny, nz, total, n_pc, goals, NP, NH, NK, NPAR, NKAP, NDIR, NEND, NL, NTURN,
                 n_nodes):  # pragma: no cover - jitted
    """Write the shot from ``node`` as ``n_pc`` equal pieces, nodes ``n_nodes`` on (their costs are the
    caller's): each turns towards its own direction, held in ``NTURN`` as (cos, sin) around its start heading
    (``NDIR`` -1), the last ending on goal ``k`` with the goal index ``kk``."""
    px, py, pz = NP[node, 0], NP[node, 1], NP[node, 2]
    hx, hy, hz = NH[node, 0], NH[node, 1], NH[node, 2]
    for i in range(n_pc):
        a = total * i / n_pc
        _, _, _, tx, ty, tz = _arc(px, py, pz, hx, hy, hz, nx, ny, nz, kap, a)
        tn = norm3(tx, ty, tz)
        ca, sa = math.cos(kap * a), math.sin(kap * a)
        mx, my, mz = ca * nx - sa * hx, ca * ny - sa * hy, ca * nz - sa * hz  # the turning direction there
        u, w = _basis(tx / tn, ty / tn, tz / tn)
        q = n_nodes + i
        NTURN[q, 0] = mx * u[0] + my * u[1] + mz * u[2]
        NTURN[q, 1] = mx * w[0] + my * w[1] + mz * w[2]
        x, y, z, ex, ey, ez = _arc(px, py, pz, hx, hy, hz, nx, ny, nz, kap, total * (i + 1) / n_pc)
        if i == n_pc - 1:
            x, y, z = goals[k, 0], goals[k, 1], goals[k, 2]
        en = norm3(ex, ey, ez)
        NP[q, 0], NP[q, 1], NP[q, 2] = x, y, z
        NH[q, 0], NH[q, 1], NH[q, 2] = ex / en, ey / en, ez / en
        NK[q] = kk if i == n_pc - 1 else k
        NPAR[q] = node if i == 0 else q - 1
        NKAP[q] = kap
        NDIR[q] = -1.0
        NEND[q] = total / n_pc
        NL[q] = NL[node] + total * (i + 1) / n_pc


@numba.njit(cache=True)
def _shot(node, k, g, goals, reach, kappa_max, ds, step, box_lo, box_hi, max_len, relax, r_start, w_turn, link,
          r_arm, rep, c_reach, sh, sh_d, line, chain_pts, occ, start, S, origin, bucket, bdims, free, fcell, fdims,
          cell, hbin, dims, best_g, hist, NP, NH, NK, NG, NPAR, NKAP, NDIR, NEND, NL, NTURN,
          n_nodes):  # pragma: no cover - jitted
    """The goal shot from ``node`` (:func:`goal_shot` to goal ``k``), tested as a primitive is (the box,
    the potential and blocked samples ``ds`` [m] apart or less, the body every other sample and at the end)
    and written as nodes of at most ``step`` [m] from ``n_nodes`` on (:func:`_shot_pieces`).  Returns the last
    node written, or -1 when the shot fails, or passes goal ``k`` before its end, or its end state is closed
    or no cheaper."""
    px, py, pz = NP[node, 0], NP[node, 1], NP[node, 2]
    hx, hy, hz = NH[node, 0], NH[node, 1], NH[node, 2]
    kap, nx, ny, nz, total = goal_shot(px, py, pz, hx, hy, hz, goals[k, 0], goals[k, 1], goals[k, 2], kappa_max)
    n_sh = int(math.ceil(total / ds))
    n_pc = max(1, int(math.ceil(total / step - 1e-9)))
    if total <= 0.0 or NL[node] + total > max_len or n_sh > sh.shape[0] or n_nodes + n_pc > NP.shape[0]:
        return -1
    kk = _shot_samples(px, py, pz, hx, hy, hz, nx, ny, nz, kap, total, n_sh, k, goals, reach, box_lo, box_hi, sh)
    if kk < 0:
        return -1
    _shot_pieces(node, k, kk, kap, nx, ny, nz, total, n_pc, goals, NP, NH, NK, NPAR, NKAP, NDIR, NEND, NL, NTURN,
                 n_nodes)
    last = n_nodes + n_pc - 1
    key2 = _key(NP[last, 0], NP[last, 1], NP[last, 2], NH[last, 0], NH[last, 1], NH[last, 2], kk, origin, cell, hbin,
                dims, goals.shape[0] + 1)
    seen = best_g.get(key2, _ABSENT) if key2 >= 0 else _CLOSED
    if seen == _CLOSED:
        return -1
    distances_below(sh, n_sh, c_reach, sh_d, occ, start, S, origin, bucket, bdims)
    cost = 0.0
    for j in range(1, n_sh + 1):
        rb = r_start if NL[node] + total * j / n_sh < relax else rep[0]
        c = cost_at(sh_d[j - 1], sh[j - 1, 0], sh[j - 1, 1], sh[j - 1, 2], rb, rep, origin, free, fcell, fdims)
        if c == BLOCKED:
            return -1
        cost += total / n_sh * (1.0 + c)
    g2 = g + cost + w_turn * total * kap / kappa_max
    if 0.0 <= seen <= g2:
        return -1
    for j in range(1, n_sh + 1):  # the body, the path behind each sample through the pieces before it
        if j % 2 == 0 or j == n_sh:
            along = total * j / n_sh
            behind = node if along <= total / n_pc else n_nodes + int(math.ceil(along / (total / n_pc))) - 2
            rb = r_start if NL[node] + along < relax + link else rep[0]
            if not _body_clear(sh[j - 1, 0], sh[j - 1, 1], sh[j - 1, 2], behind, NP, NPAR, hist, link, rb, r_arm,
                               line, chain_pts, occ, start, S, origin, bucket, bdims, j == n_sh):
                return -1
    for q in range(n_nodes, last + 1):
        NG[q] = g + (g2 - g) * (q - n_nodes + 1) / n_pc
    NG[last] = g2
    best_g[key2] = g2
    return last


@numba.njit(cache=True)
def _search_kernel(p0, h0, k0, goals, reach, rest, kappas, dirs_c, dirs_s, cfg, rep, hist,
                   nav, nav_origin, nav_cell, arm_pts, carry, occ,
                   start, S, origin, bucket, bdims, free, fcell, fdims, box_lo, box_hi,
                   NP, NH, NK, NG, NPAR, NKAP, NDIR, NEND, NL, NTURN):  # pragma: no cover - jitted
    """Hybrid A* (see the module docstring).  Node arrays are preallocated by the caller.

    ``cfg`` = [step, samples, cell, heading_bin, epsilon, w_turn, max_expansions, max_length,
    start_relax, r_start, kappa_max, link_length, arm_clearance, length_factor, length_slack, arm_reach]
    (``r_start``: :func:`start_radius`).  ``arm_pts`` (k, 3): the arm's axis at the start, ``carry`` (8,) the
    flange there, the lathe's axis and travel (:attr:`ArmShape.carry`); a state is expanded only if the
    arm, carried along with the flange (the sixth chord point behind it), keeps ``arm_reach`` from every
    surface point (no ``arm_pts``: the flange and the point one link behind it keep ``arm_clearance``
    instead, checked with each primitive).
    A goal whose ball is smaller than the samples' spacing (``reach < step / samples``) can fall between
    two samples of every arc: from a state within ``2 step`` of it, the search also tries the arc that ends
    exactly on it (:func:`_shot`).  Returns (status, final node, expansions, n_nodes).
    """
    step = cfg[0]
    n_samp = int(cfg[1])
    cell = cfg[2]
    hbin = cfg[3]
    eps = cfg[4]
    w_turn = cfg[5]
    max_exp = int(cfg[6])
    max_len = cfg[7]
    relax = cfg[8]
    r_start = cfg[9]
    kappa_max = cfg[10]
    link = cfg[11]
    use_arm = arm_pts.shape[0] > 0
    r_arm = 0.0 if use_arm else cfg[12]  # the flange and the point behind it, only without the arm's shape
    arm_reach = cfg[15]
    line = np.empty((512, 3))
    chain_pts = np.empty((8, 3))  # the chain's points
    arm_buf = np.empty((arm_pts.shape[0], 3))  # the carried arm's points and their distances (_arm_shifted_clear)
    arm_out = np.empty(arm_pts.shape[0])
    samp = np.empty((n_samp, 3))
    samp_d = np.empty(n_samp)
    sh = np.empty((4 * n_samp + 4, 3))  # a goal shot's samples (at most 2 step * pi / 2 long)
    sh_d = np.empty(4 * n_samp + 4)
    c_reach = cost_reach(rep)
    n_goals = goals.shape[0]
    cap = NP.shape[0]
    dims = np.empty(3, dtype=np.int64)
    for c in range(3):
        dims[c] = int(math.ceil((box_hi[c] - origin[c]) / cell)) + 1
    # each state's key -> the cheapest cost to it so far, or _CLOSED once expanded (one lookup per successor)
    best_g = numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.float64)
    NP[0] = p0
    NH[0] = h0
    NK[0] = k0
    NG[0] = 0.0
    NL[0] = 0.0
    NPAR[0] = -1
    NKAP[0] = 0.0
    NDIR[0] = 0.0
    NEND[0] = step
    n_nodes = 1
    radius = 1.0 / kappa_max
    h_start = _heuristic(p0[0], p0[1], p0[2], h0[0], h0[1], h0[2], k0, k0, goals, reach, rest, nav, nav_origin,
                         nav_cell, radius)
    heap = [(h_start * eps, 0)]
    # the length bound, from the turn-then-straight estimate at the start (which for a goal inside the
    # turning circle allows a loop); states are pruned against it by a lower bound on their length to go
    len_start = _heuristic(p0[0], p0[1], p0[2], h0[0], h0[1], h0[2], k0, -2, goals, reach, rest, nav, nav_origin,
                           nav_cell, radius)
    bound = cfg[13] * len_start + cfg[14]
    best_node = 0
    best_h = h_start
    expansions = 0
    n_prims = kappas.shape[0]
    arcs = _arc_table(kappas, step, n_samp)
    while len(heap) > 0:
        f, node = heapq.heappop(heap)
        px, py, pz = NP[node, 0], NP[node, 1], NP[node, 2]
        hx, hy, hz = NH[node, 0], NH[node, 1], NH[node, 2]
        k = NK[node]
        g = NG[node]
        key = _key(px, py, pz, hx, hy, hz, k, origin, cell, hbin, dims, n_goals + 1)
        if node > 0:
            if best_g.get(key, _ABSENT) == _CLOSED:
                continue
            best_g[key] = _CLOSED
            if use_arm and not _arm_clear(px, py, pz, NPAR[node], NP, NPAR, hist, link, arm_pts, carry, arm_reach,
                                          line, chain_pts, occ, start, S, origin, bucket, bdims, arm_buf,
                                          arm_out):
                continue  # the arm, carried with the flange, would meet a sensed surface
        if k >= n_goals:
            return 0, node, expansions, n_nodes
        expansions += 1
        if expansions > max_exp:
            return 1, best_node, expansions, n_nodes
        u, w = _basis(hx, hy, hz)
        for m in range(n_prims):
            kap = kappas[m]
            nx = dirs_c[m] * u[0] + dirs_s[m] * w[0]
            ny = dirs_c[m] * u[1] + dirs_s[m] * w[1]
            nz = dirs_c[m] * u[2] + dirs_s[m] * w[2]
            cost = 0.0
            kk = k
            ok = True
            s_end = step
            ds = step / n_samp
            length = NL[node]
            j_end = 0  # the row of arcs at s_end
            for j in range(1, n_samp + 1):  # the samples
                samp[j - 1, 0], samp[j - 1, 1], samp[j - 1, 2], _, _, _ = _arc_from(
                    px, py, pz, hx, hy, hz, nx, ny, nz, kap, arcs[m, j, 0], arcs[m, j, 1], arcs[m, j, 2], arcs[m, j, 3],
                    arcs[m, j, 4])
            # every test of an arc is pure and none changes the search, so the cheap ones go first: the box
            # and the goals passed (the samples alone), the end state's cell (closed: nothing more to ask),
            # then the samples' distances to the map (the potential, blocked samples), then the body
            j_last = n_samp  # the last sample of the arc (where it passes the last goal, if it does)
            for j in range(1, n_samp + 1):
                qx, qy, qz = samp[j - 1, 0], samp[j - 1, 1], samp[j - 1, 2]
                if qx < box_lo[0] or qy < box_lo[1] or qz < box_lo[2] or qx > box_hi[0] or qy > box_hi[1] \
                        or qz > box_hi[2]:
                    ok = False
                    break
                while kk < n_goals:
                    gx = goals[kk, 0] - qx
                    gy = goals[kk, 1] - qy
                    gz = goals[kk, 2] - qz
                    if gx * gx + gy * gy + gz * gz <= reach[kk] * reach[kk]:
                        kk += 1
                    else:
                        break
                if kk >= n_goals:
                    s_end = j * ds
                    j_end = j
                    j_last = j
                    break
            if not ok or length + s_end > max_len:
                continue
            qx, qy, qz, tx, ty, tz = _arc_from(px, py, pz, hx, hy, hz, nx, ny, nz, kap, s_end, arcs[m, j_end, 1],
                                               arcs[m, j_end, 2], arcs[m, j_end, 3], arcs[m, j_end, 4])
            tn = math.sqrt(tx * tx + ty * ty + tz * tz)
            tx /= tn
            ty /= tn
            tz /= tn
            key2 = _key(qx, qy, qz, tx, ty, tz, kk, origin, cell, hbin, dims, n_goals + 1)
            seen = best_g.get(key2, _ABSENT) if key2 >= 0 else _CLOSED
            if seen == _CLOSED:
                continue
            if seen >= 0.0:  # reached already: at least as cheaply as this arc can be (its potential >= 0)?
                floor = 0.0
                for _ in range(j_last):
                    floor += ds * (1.0 + 0.0)  # the cost below with no potential: never more, in floats too
                if seen <= g + floor + w_turn * step * kap / kappa_max:
                    continue
            distances_below(samp, n_samp, c_reach, samp_d, occ, start, S, origin, bucket, bdims)
            for j in range(1, j_last + 1):
                rb = r_start if length + j * ds < relax else rep[0]
                c = cost_at(samp_d[j - 1], samp[j - 1, 0], samp[j - 1, 1], samp[j - 1, 2], rb, rep, origin, free,
                            fcell, fdims)
                if c == BLOCKED:
                    ok = False
                    break
                cost += ds * (1.0 + c)
            if not ok:
                continue
            g2 = g + cost + w_turn * step * kap / kappa_max
            if 0.0 <= seen <= g2:
                continue
            # the body, only for an arc whose end state is new or cheaper: the last link is a straight chord
            # behind the tip, inside the bends of the path (checked every other sample and at the end; the
            # flange and the arm's start at the end)
            for j in range(1, j_last + 1):
                if j % 2 == 0 or j == n_samp:
                    rb = r_start if length + j * ds < relax + link else rep[0]
                    if not _body_clear(samp[j - 1, 0], samp[j - 1, 1], samp[j - 1, 2], node, NP, NPAR, hist, link, rb,
                                       r_arm, line, chain_pts, occ, start, S, origin, bucket, bdims, j == n_samp):
                        ok = False
                        break
            if not ok:
                continue
            if s_end < step and not _body_clear(qx, qy, qz, node, NP, NPAR, hist, link, rep[0], r_arm, line,
                                                chain_pts, occ, start, S, origin, bucket, bdims, True):
                continue  # the goal was passed between two body checks: check where the path ends
            best_g[key2] = g2
            if n_nodes >= cap:
                return 1, best_node, expansions, n_nodes
            q = n_nodes
            n_nodes += 1
            NP[q, 0], NP[q, 1], NP[q, 2] = qx, qy, qz
            NH[q, 0], NH[q, 1], NH[q, 2] = tx, ty, tz
            NK[q] = kk
            NG[q] = g2
            NL[q] = NL[node] + s_end
            NPAR[q] = node
            NKAP[q] = kap
            NDIR[q] = m
            NEND[q] = s_end
            h = _heuristic(qx, qy, qz, tx, ty, tz, kk, k0, goals, reach, rest, nav, nav_origin, nav_cell, radius)
            if NL[node] + s_end + _heuristic(qx, qy, qz, tx, ty, tz, kk, -1, goals, reach, rest, nav, nav_origin,
                                             nav_cell, radius) > bound:
                continue  # even the shortest way on is too long for the body to follow
            if h < best_h:
                best_h = h
                best_node = q
            heapq.heappush(heap, (g2 + eps * h, q))
        if k < n_goals and reach[k] * n_samp < step and (px - goals[k, 0]) ** 2 + (py - goals[k, 1]) ** 2 + (
                pz - goals[k, 2]) ** 2 <= 4.0 * step * step:
            q = _shot(node, k, g, goals, reach, kappa_max, step / n_samp, step, box_lo, box_hi, max_len, relax,
                      r_start, w_turn, link, r_arm, rep, c_reach, sh, sh_d, line, chain_pts, occ, start, S, origin,
                      bucket, bdims, free, fcell, fdims, cell, hbin, dims, best_g, hist, NP, NH, NK, NG, NPAR,
                      NKAP, NDIR, NEND, NL, NTURN, n_nodes)
            if q >= 0:
                n_nodes = q + 1
                kk = NK[q]
                h = _heuristic(NP[q, 0], NP[q, 1], NP[q, 2], NH[q, 0], NH[q, 1], NH[q, 2], kk, k0, goals, reach, rest,
                               nav, nav_origin, nav_cell, radius)
                if NL[q] + _heuristic(NP[q, 0], NP[q, 1], NP[q, 2], NH[q, 0], NH[q, 1], NH[q, 2], kk, -1, goals,
                                      reach, rest, nav, nav_origin, nav_cell, radius) <= bound:
                    if h < best_h:
                        best_h = h
                        best_node = q
                    heapq.heappush(heap, (NG[q] + eps * h, q))
    return 2, best_node, expansions, n_nodes


@numba.njit(cache=True)
def _path_clear(pts, hist, every, link, r_block, r_arm, arm_pts, carry, arm_reach, occ, start, S, origin,
                bucket, bdims):  # pragma: no cover - jitted
    """True if the tip path ``pts`` keeps ``r_block`` from every surface point at each sample, and the
    body behind it (checked every ``every`` samples, the history ``hist`` behind ``pts[0]``) is clear: the
    last link, and the arm carried with the flange (or, without ``arm_pts``, the flange and the point one
    link behind it, ``r_arm``); the same checks as the search's."""
    n = pts.shape[0]
    line = np.empty((n + hist.shape[0] + 2, 3))
    chain_pts = np.empty((8, 3))  # the chain's points
    arm_buf = np.empty((arm_pts.shape[0], 3))  # the carried arm's points and their distances (_arm_shifted_clear)
    arm_out = np.empty(arm_pts.shape[0])
    for i in range(n):
        if distance_below(pts[i, 0], pts[i, 1], pts[i, 2], r_block, occ, start, S, origin, bucket,
                          bdims) < r_block:
            return False
    for i in range(every, n, every):
        m = 0
        for j in range(i, -1, -1):
            line[m] = pts[j]
            m += 1
        for j in range(hist.shape[0] - 2, -1, -1):
            line[m] = hist[j]
            m += 1
        if _chain(line, m, link, 7, chain_pts) < 7:
            continue
        if not _last_link_clear(chain_pts, pts[i, 0], pts[i, 1], pts[i, 2], r_block, occ, start, S,
                                origin, bucket, bdims):
            return False
        if arm_pts.shape[0] > 0:
            if not _arm_shifted_clear(chain_pts, arm_pts, carry, arm_reach, occ, start, S, origin,
                                      bucket, bdims, arm_buf, arm_out):
                return False
        elif not _flange_clear(chain_pts, r_arm, occ, start, S, origin, bucket, bdims):
            return False
    return True


def only_the_arm_blocks(smap: SensedMap, p0: ArrayLike, h0: ArrayLike, goals: ArrayLike, tolerances: ArrayLike, k0: int,
                        config: SearchConfig, repulsion: Repulsion, history: ArrayLike, nav: NavigationFunction | None,
                        arm: ArmShape, arm_budget: int) -> bool:
    """Whether the search from ``(p0, h0)`` reaches every goal from ``k0`` on for the serpentine alone (the flange
    still checked) but not, within ``max(config.max_expansions, arm_budget)`` expansions, with the arm's capsules:
    the arm alone blocks the way."""

    def reached(with_arm: ArmShape | None, cfg: SearchConfig) -> bool:
        return search(smap, p0, h0, goals, tolerances, k0, cfg, repulsion, history=history, nav=nav,
                      arm=with_arm).status == REACHED

    deep = replace(config, max_expansions=max(config.max_expansions, arm_budget))
    return reached(None, config) and not reached(arm, deep)


def still_clear(smap: SensedMap, plan: Plan, s: float, history: ArrayLike, config: SearchConfig,
                repulsion: Repulsion, arm: ArmShape | None = None) -> bool:
    """Whether the rest of ``plan`` from arc length ``s`` is still clear in the map as it is now (the
    tip and the body, as :func:`search` requires), the body lying along ``history`` behind it; with the
    clearances of ``plan.repulsion`` (those it was searched with), else of ``repulsion``."""
    if plan.repulsion is not None:
        repulsion = plan.repulsion
    i = int(np.searchsorted(plan.arc, s))
    pts = np.ascontiguousarray(plan.points[i:])
    if len(pts) == 0:
        return True
    hist = np.asarray(history, dtype=np.float64).reshape(-1, 3)
    spacing = float(np.median(np.diff(plan.arc))) if len(plan.arc) > 1 else 1.0
    every = max(1, int(round(config.step / max(spacing, 1e-6))))
    arm_pts, carry, reach = _arm_arrays(arm, config)
    return bool(_path_clear(pts, hist, every, config.link_length, repulsion.r_block,
                            min(config.arm_clearance, smap.config.bucket), arm_pts, carry, reach,
                            *point_index(smap)))


# ------------------------------------------------------------------------------------------ driver
class _Buffers:
    """Preallocated node arrays (reused between searches)."""

    def __init__(self, cap: int) -> None:
        self.P = np.zeros((cap, 3))
        self.H = np.zeros((cap, 3))
        self.K = np.zeros(cap, dtype=np.int64)
        self.G = np.zeros(cap)
        self.PAR = np.zeros(cap, dtype=np.int64)
        self.KAP = np.zeros(cap)
        self.DIR = np.zeros(cap)
        self.END = np.zeros(cap)
        self.L = np.zeros(cap)
        self.TURN = np.zeros((cap, 2))


_BUFFERS: dict[int, _Buffers] = {}


def primitives(config: SearchConfig) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Curvatures (M,) and turning directions (cos, sin around the heading) of the motion primitives."""
    kmax = 1.0 / config.min_turn_radius
    kap = [0.0]
    c = [1.0]
    s = [0.0]
    for frac in ((1.0, 0.5) if config.half_curvature else (1.0,)):
        for j in range(config.n_dirs):
            a = 2.0 * math.pi * j / config.n_dirs
            kap.append(frac * kmax)
            c.append(math.cos(a))
            s.append(math.sin(a))
    return np.array(kap), np.array(c), np.array(s)


@numba.njit(cache=True)
def _start_clearance(p0, hist, L, r, occ, start, S, origin, bucket, bdims):  # pragma: no cover - jitted
    """The start's clearance up to ``r`` [m]: the smaller of the tip's ``p0`` and its last link's (the chord one
    ``L`` back along ``hist``, oldest first and ending at ``p0``, between :data:`_LINK_END` of it from either end;
    none if the history is shorter) distances to the nearest surface point."""
    n = hist.shape[0]
    line = np.empty((n, 3))
    for i in range(n):
        line[i] = hist[n - 1 - i]
    line[0] = p0
    d = distance_below(p0[0], p0[1], p0[2], r, occ, start, S, origin, bucket, bdims)
    pts = np.empty((1, 3))
    if _chain(line, n, L, 1, pts) < 1:
        return d
    return min(d, _link_distance(pts[0, 0], pts[0, 1], pts[0, 2], p0[0], p0[1], p0[2], r, False, occ, start, S,
                                 origin, bucket, bdims))


def start_radius(smap: SensedMap, p0: NDArray[np.float64], hist: NDArray[np.float64], config: SearchConfig,
                 repulsion: Repulsion) -> float:
    """The clearance [m] the path keeps from sensed surfaces near its start (``SearchConfig.start_relax``):
    ``Repulsion.r_block`` if the start's tip and last link keep ``r_block + start_slack``, else their clearance
    less ``start_slack``, but not below ``body_radius + start_margin``."""
    r_block = repulsion.r_block
    near = _start_clearance(p0, hist, config.link_length, r_block + config.start_slack, *point_index(smap))
    return min(r_block, max(repulsion.body_radius + config.start_margin, near - config.start_slack))


def search(smap: SensedMap, start: ArrayLike, heading: ArrayLike, goals: ArrayLike, tolerances: ArrayLike,
           goal_index: int, config: SearchConfig, repulsion: Repulsion, history: ArrayLike | None = None,
           nav: NavigationFunction | None = None, sample: float = 0.005, arm: ArmShape | None = None) -> Plan:
    """Plan from the state (``start``, unit ``heading``) through ``goals[goal_index:]`` (see module docstring).

    ``history`` (m, 3): the path already travelled, oldest first, ending at ``start`` (the body
    lies along it; None = a straight body behind ``start``).  ``nav``: the navigation function of
    the next goal (computed here when None; see :func:`navigation_region`).  ``arm``: the robot's arm at
    the start (its shape is checked against the map as the flange moves; None: a cruder check of the
    flange alone).
    """
    p0 = np.asarray(start, dtype=np.float64)
    h0 = np.asarray(heading, dtype=np.float64)
    h0 = h0 / np.linalg.norm(h0)
    G = np.asarray(goals, dtype=np.float64).reshape(-1, 3)
    tol = np.asarray(tolerances, dtype=np.float64).reshape(-1)
    reach = config.goal_fraction * tol
    rest = np.zeros(len(G))
    for k in range(len(G) - 2, -1, -1):
        rest[k] = rest[k + 1] + max(0.0, float(np.linalg.norm(G[k + 1] - G[k])) - reach[k + 1])
    k0 = int(goal_index)
    while k0 < len(G) and float(np.linalg.norm(p0 - G[k0])) <= reach[k0]:
        k0 += 1  # already there
    if k0 < len(G) and nav is None:
        lo, hi = navigation_region(p0, G[k0], config)
        nav = navigation_function(smap, G[k0], float(reach[k0]), lo, hi, repulsion)
    if nav is None:
        nav = NavigationFunction(np.zeros(3), 1.0, np.zeros((1, 1, 1)))
    hist = np.asarray(history, dtype=np.float64).reshape(-1, 3) if history is not None else None
    if hist is None or len(hist) < 2:
        hist = np.array([p0 - 0.5 * h0, p0])
    kap, dc, ds = primitives(config)
    cap = int(min(config.max_expansions * (len(kap) + 3) + 1, 2_000_000))  # a state's arcs and a shot's 3 pieces
    buf = _BUFFERS.get(cap)
    if buf is None:
        buf = _BUFFERS[cap] = _Buffers(cap)
    arm_pts, carry, arm_reach = _arm_arrays(arm, config)
    cfg = np.array([config.step, config.samples, config.cell, config.heading_bin, config.epsilon, config.w_turn,
                    config.max_expansions, config.max_length, config.start_relax,
                    start_radius(smap, p0, hist, config, repulsion),
                    1.0 / config.min_turn_radius, config.link_length,
                    min(config.arm_clearance, smap.config.bucket), config.length_factor, config.length_slack,
                    arm_reach])
    rep = repulsion.vector()
    free, forigin, fcell, fdims = smap.free_arrays()
    box_lo = smap.origin
    box_hi = smap.origin + smap.free_dims * fcell - 1e-9
    status, last, expansions, _ = _search_kernel(
        p0, h0, k0, G, reach, rest, kap, dc, ds, cfg, rep, hist, nav.wave, nav.origin, nav.cell, arm_pts, carry,
        *point_index(smap), free, fcell, fdims,
        box_lo, box_hi, buf.P, buf.H, buf.K, buf.G, buf.PAR, buf.KAP, buf.DIR, buf.END, buf.L, buf.TURN)
    if status == PARTIAL and last == 0:
        status = NO_PATH  # no state closer to the goal than the start: no way on
    return replace(_densify(buf, int(status), int(last), int(expansions), p0, h0, k0, dc, ds, sample),
                   repulsion=repulsion)


def navigation_region(p0: NDArray[np.float64], goal: NDArray[np.float64],
                      config: SearchConfig) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The box [m] over which the navigation function to ``goal`` is computed for a search from ``p0``."""
    lo = np.minimum(p0, goal) - config.nav_margin
    hi = np.maximum(p0, goal) + config.nav_margin
    return lo, hi


def _densify(buf: _Buffers, status: int, last: int, expansions: int, p0, h0, k0: int, dc, ds,
             sample: float) -> Plan:
    """The plan of the node chain ending at ``last``: its arcs sampled every ``sample`` [m] or less."""
    P, tans, ks, exact = _densify_kernel(buf.P, buf.H, buf.K, buf.PAR, buf.DIR, buf.KAP, buf.END, buf.TURN, last,
                                         p0, h0, k0, dc, ds, sample)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    cost = float(buf.G[last]) if last > 0 else 0.0
    if status == NO_PATH:
        P, arc = P[:1], arc[:1]
        tans, ks, exact = tans[:1], ks[:1], exact[:1]
    return Plan(points=P, tangents=tans, arc=arc, goal_index=ks, status=status, cost=cost, expansions=expansions,
                stops=arc[exact])


@numba.njit(cache=True)
def _densify_kernel(NP, NH, NK, NPAR, NDIR, NKAP, NEND, NTURN, last, p0, h0, k0, dc, ds, sample):  # pragma: no cover
    """Points (N, 3), unit tangents (N, 3), goal indices (N,) and whether each sample ends a goal shot on its
    goal (N,) along the arcs from the root to node ``last``: each arc in ``ceil(length / sample)`` equal steps,
    the start state first."""
    n_chain = 0
    total = 1
    node = last
    while node > 0:
        n_chain += 1
        total += max(1, int(math.ceil(NEND[node] / sample)))
        node = NPAR[node]
    chain = np.empty(n_chain, dtype=np.int64)
    node = last
    for i in range(n_chain - 1, -1, -1):
        chain[i] = node
        node = NPAR[node]
    pts = np.empty((total, 3))
    tans = np.empty((total, 3))
    ks = np.empty(total, dtype=np.int64)
    exact = np.zeros(total, dtype=np.bool_)
    pts[0] = p0
    tans[0] = h0
    ks[0] = k0
    i = 1
    for node in chain:
        par = NPAR[node]
        px, py, pz = NP[par, 0], NP[par, 1], NP[par, 2]
        hx, hy, hz = NH[par, 0], NH[par, 1], NH[par, 2]
        m = int(NDIR[node])
        u, w = _basis(hx, hy, hz)
        c, s = (dc[m], ds[m]) if m >= 0 else (NTURN[node, 0], NTURN[node, 1])  # a primitive, or a goal shot
        nx, ny, nz = c * u[0] + s * w[0], c * u[1] + s * w[1], c * u[2] + s * w[2]
        length = NEND[node]
        count = max(1, int(math.ceil(length / sample)))
        for j in range(1, count + 1):
            x, y, z, tx, ty, tz = _arc(px, py, pz, hx, hy, hz, nx, ny, nz, NKAP[node], length * j / count)
            pts[i, 0], pts[i, 1], pts[i, 2] = x, y, z
            tn = norm3(tx, ty, tz)
            tans[i, 0], tans[i, 1], tans[i, 2] = tx / tn, ty / tn, tz / tn
            ks[i] = NK[node] if j == count else NK[par]
            exact[i] = j == count and m < 0 and NK[node] > NK[par]
            i += 1
    return pts, tans, ks, exact
