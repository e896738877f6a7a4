"""The potential over the sensed map: Khatib's repulsion as a cost, and what unseen space costs.

The planner's field is the sum of an attraction (the length still to go to the goal, which the
search in :mod:`navstack.planner.search` measures along curvature-bounded paths, so its only
minimum is the goal) and this module's **repulsion**, felt by the tip sphere at a point ``p``
with ``d`` the distance from ``p`` to the nearest sensed surface point (:class:`SensedMap`):

* ``d < r_block`` (the tip radius plus ``margin``): **forbidden** (infinite potential);
* ``r_block <= d < r_influence``: ``w_repulse * ((r_influence - d) / (r_influence - r_block))^2``
  per metre of path, Khatib's density-independent repulsion made a cost: the path keeps to the
  middle of an opening wherever it has room;
* the cell of ``p`` not yet seen free and ``d < r_unseen``: ``w_unseen_surface`` per metre (the
  sampled surface probably continues between its samples: an opening is only an opening once a
  ray has gone through it, but it stays allowed, so the robot goes and looks when nothing
  better is known);
* otherwise, not seen free: ``w_unseen`` per metre (slightly prefer what has been seen).

:func:`cost_rate` is the numba kernel the search calls at every sample; :class:`Repulsion` holds
the parameters.  Units: metres, cost in metres of equivalent free path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.jit import kernel
from navstack.planner.proximity import distance_below
from navstack.validate import non_negative

__all__ = ["Repulsion", "cost_rate"]

BLOCKED = -1.0
"""What :func:`cost_rate` returns for a forbidden point."""


@dataclass(frozen=True)
class Repulsion:
    """Parameters of the repulsive potential (metres; weights per metre of path).

    Attributes:
        body_radius: radius of the tip [m].
        margin: smallest clearance a planned path keeps from sensed surfaces [m].
        influence: distance from a surface point below which it repels [m].
        w_repulse: cost per metre at ``d = r_block``, falling quadratically to 0 at ``influence``.
        unseen_radius: unseen space within this distance of a surface point is probably surface [m].
        w_unseen_surface: cost per metre there.
        w_unseen: cost per metre of other unseen space.
    """

    body_radius: float = 0.025
    margin: float = 0.01
    influence: float = 0.075
    w_repulse: float = 2.0
    unseen_radius: float = 0.065
    w_unseen_surface: float = 6.0
    w_unseen: float = 0.05

    def __post_init__(self) -> None:
        non_negative(self, "body_radius", "margin", "influence", "w_repulse", "unseen_radius", "w_unseen_surface",
                     "w_unseen")
        if self.influence <= self.r_block:
            raise ValueError(f"Repulsion.influence ({self.influence}) must exceed body_radius + margin "
                             f"({self.r_block})")

    @property
    def r_block(self) -> float:
        """Distance from a surface point below which the tip centre may not go [m]."""
        return self.body_radius + self.margin

    def vector(self) -> NDArray[np.float64]:
        """Parameters packed for :func:`cost_rate`."""
        return np.array([self.r_block, self.influence, self.w_repulse, self.unseen_radius,
                         self.w_unseen_surface, self.w_unseen])


@kernel
def cost_rate(px, py, pz, r_block, prm, occ, start, S, origin, bucket, bdims, free, fcell,
              fdims):  # pragma: no cover - jitted
    """Cost per metre of path at (px, py, pz), or ``BLOCKED`` (-1); ``r_block`` may be relaxed by the caller.

    ``prm`` = :meth:`Repulsion.vector` (``prm[0]``, the nominal r_block, is not used here); ``occ .. bdims``
    the map's :func:`~navstack.planner.proximity.point_index`.
    """
    d = distance_below(px, py, pz, cost_reach(prm), occ, start, S, origin, bucket, bdims)
    return cost_at(d, px, py, pz, r_block, prm, origin, free, fcell, fdims)


@numba.njit(cache=True, inline="always")
def cost_reach(prm):  # pragma: no cover - jitted
    """How far [m] :func:`cost_rate` looks for surface points: the larger of the influence and unseen radii."""
    return prm[1] if prm[1] > prm[3] else prm[3]


@kernel
def cost_at(d, px, py, pz, r_block, prm, origin, free, fcell, fdims):  # pragma: no cover - jitted
    """:func:`cost_rate` at (px, py, pz) given ``d``, its distance to the nearest surface point up to
    :func:`cost_reach` (``distance_below``)."""
    if d < r_block:
        return BLOCKED
    c = 0.0
    if d < prm[1]:
        x = (prm[1] - d) / (prm[1] - prm[0])
        if x > 1.0:
            x = 1.0
        c += prm[2] * x * x
    i = int(math.floor((px - origin[0]) / fcell))
    j = int(math.floor((py - origin[1]) / fcell))
    k = int(math.floor((pz - origin[2]) / fcell))
    seen = 0 <= i < fdims[0] and 0 <= j < fdims[1] and 0 <= k < fdims[2] and free[i, j, k] != 0
    if not seen:
        c += prm[4] if d < prm[3] else prm[5]
    return c


# ------------------------------------------------------------------------------------------ navigation function
class NavigationFunction:
    """Cost-to-go [m] to a goal over a grid: ``values[i, j, k]`` at the centre of cell (i, j, k).

    A Dijkstra wavefront (26-connected) from the cells inside the goal's ball, through cells the
    tip centre may occupy as far as the map can tell, each step costing its length times (1 +
    the unseen-surface weight where the cell is unseen and near a sensed surface): the
    potential's attraction, whose only minimum is the goal.  Cells count as blocked only if
    every point of the cell is within the blocking radius of a surface point (their centre
    within ``r_block - half diagonal``), so no free passage is ever closed (the notes: coarse
    voxels that close a 1.5-3 cm corridor mislead the planner); ``inf`` where unreachable.

    The wavefront runs **on demand**: a cell's value is final once Dijkstra has settled it, and
    Dijkstra settles cells in order of value (here a bucket of values at a time, :func:`_wave_settle`), so
    :meth:`lookup` (and the search, through :attr:`wave`) run it on only until the cell asked for is
    settled.  A search from a start at cost-to-go ``V`` rarely needs cells much above ``V``: the trials
    settle 8 % of their grids' cells
    (24 % on a slot rack; the grid spans the start and the goal with a margin all round, and is
    recomputed as the tip closes in).  The values are those of the whole wavefront, bit for bit,
    whatever the order of the questions (the same pops in the same order, only paused).
    :attr:`values` finishes it.

    Args:
        origin: (3,) the grid's lower corner [m]; cell: its cell size [m].
        values: the grid of values [m] if complete; with ``wave``, the array :attr:`values` fills.
        wave: the paused wavefront (:func:`_wave_state`), or ``None`` if ``values`` is complete.
    """

    def __init__(self, origin: NDArray[np.float64], cell: float, values: NDArray[np.float64],
                 wave: tuple | None = None) -> None:
        self.origin = np.asarray(origin, dtype=np.float64)
        self.cell = float(cell)
        self._values = np.ascontiguousarray(values, dtype=np.float64)
        self._wave = wave if wave is not None else _done_state(self._values)

    @property
    def values(self) -> NDArray[np.float64]:
        """The whole grid of values [m] (finishes the wavefront first)."""
        if self._wave[5][0] > 0:  # cells still queued
            _wave_settle(self._wave, -1)
        nx, ny, nz = self._values.shape
        self._values[...] = self._wave[1].reshape(nx + 2, ny + 2, nz + 2)[1:-1, 1:-1, 1:-1]
        return self._values

    @property
    def wave(self) -> tuple:
        """The wavefront's state for the search kernel (see :func:`_wave_state`)."""
        return self._wave

    def lookup(self, p: NDArray[np.float64]) -> float:
        """The value [m] at ``p`` (``inf`` outside the grid)."""
        idx = np.floor((np.asarray(p) - self.origin) / self.cell).astype(np.int64)
        shape = self._values.shape
        if np.any(idx < 0) or np.any(idx >= shape):
            return math.inf
        return float(wave_value(self._wave, int(idx[0]), int(idx[1]), int(idx[2])))


@kernel
def _rasterize(P, alive, n, origin, cell, dims, radius, out, value):  # pragma: no cover - jitted
    """Set ``out`` to ``value`` at every cell whose centre is within ``radius`` of a live point.

    Each cell is tested as ``x * x + y * y + z * z <= radius ** 2`` (offsets from the point).  A row or column
    whose partial sum already exceeds it is skipped (adding squares never lowers a float sum), and a column's
    cells that pass are consecutive (the offset grows monotonically along it), so its scan stops at the first
    cell past them: the same cells as testing every one in the cube around the point."""
    m = int(math.ceil(radius / cell)) + 1
    r2 = radius * radius
    for q in range(n):
        if not alive[q]:
            continue
        ci = int(math.floor((P[q, 0] - origin[0]) / cell))
        cj = int(math.floor((P[q, 1] - origin[1]) / cell))
        ck = int(math.floor((P[q, 2] - origin[2]) / cell))
        for i in range(max(ci - m, 0), min(ci + m + 1, dims[0])):
            x = origin[0] + (i + 0.5) * cell - P[q, 0]
            xx = x * x
            if xx > r2:
                continue
            for j in range(max(cj - m, 0), min(cj + m + 1, dims[1])):
                y = origin[1] + (j + 0.5) * cell - P[q, 1]
                s = xx + y * y
                if s > r2:
                    continue
                inside = False
                for k in range(max(ck - m, 0), min(ck + m + 1, dims[2])):
                    z = origin[2] + (k + 0.5) * cell - P[q, 2]
                    if s + z * z <= r2:
                        out[i, j, k] = value
                        inside = True
                    elif inside:
                        break


_NEIGHBOURS = np.array([(di, dj, dk) for di in (-1, 0, 1) for dj in (-1, 0, 1) for dk in (-1, 0, 1)
                        if (di, dj, dk) != (0, 0, 0)])
"""The 26 neighbours' (di, dj, dk), in the order the wavefront relaxes them."""


def _wave_state(cost: NDArray[np.float64], cell: float) -> tuple:
    """The paused wavefront over ``cost`` (per-metre weight, < 0 = blocked).

    Held on the grid padded by one blocked cell all round, so that a neighbour needs no bounds test; the queue
    is a ring of buckets (Dial's), each a doubly linked list of cells.  A bucket spans a quarter of the
    shortest step's cost (a step costs its length times at least 1, so at least ``cell``), so no cell can
    lower another of its own bucket (:func:`_wave_settle`), and the ring spans the dearest step and more.
    The tuple: (cost, values, next cell, previous cell, bucket per cell, [cells queued, current bucket],
    the 26 neighbours' step lengths [m], padded costs, the 26 neighbours' flat offsets, the buckets' first
    cells, [bucket width [m]]); values, links, buckets and padded costs are flat over the padded grid; a
    cell's bucket is -1 before it is queued and -2 once settled.  Values, buckets and first cells are left
    unset: :func:`_wave_seed` starts them.
    """
    nx, ny, nz = cost.shape
    padded = np.full((nx + 2, ny + 2, nz + 2), -1.0)
    padded[1:-1, 1:-1, 1:-1] = cost
    n_pad = padded.size
    d2 = (_NEIGHBOURS * _NEIGHBOURS).sum(axis=1)
    steps = cell * np.sqrt(d2.astype(np.float64))
    offsets = (_NEIGHBOURS[:, 0] * (ny + 2) + _NEIGHBOURS[:, 1]) * (nz + 2) + _NEIGHBOURS[:, 2]
    width = 0.25 * cell
    dearest = float(steps.max()) * (1.0 + max(float(cost.max(initial=0.0)), 0.0))
    n_buckets = int(math.ceil(dearest / width)) + 4
    ints = np.empty((3, n_pad), dtype=np.int64)  # links and buckets: set by the seed (_wave_seed)
    return (cost, np.empty(n_pad), ints[0], ints[1], ints[2], np.zeros(2, dtype=np.int64), steps,
            padded.reshape(n_pad), offsets.astype(np.int64), np.empty(n_buckets, dtype=np.int64), np.array([width]))


def _done_state(values: NDArray[np.float64]) -> tuple:
    """The state of a finished wavefront over ``values`` (nothing left to settle)."""
    state = _wave_state(np.zeros(values.shape), 1.0)
    nx, ny, nz = values.shape
    state[1][:] = np.inf
    state[1].reshape(nx + 2, ny + 2, nz + 2)[1:-1, 1:-1, 1:-1] = values
    state[4][:] = -2  # every cell settled, none queued
    return state


@numba.njit(cache=True, inline="always")
def _padded_index(cost, i, j, k):  # pragma: no cover - jitted
    """The flat index on the padded grid of cell (i, j, k) of ``cost``'s grid."""
    return ((i + 1) * (cost.shape[1] + 2) + j + 1) * (cost.shape[2] + 2) + k + 1


@numba.njit(cache=True, inline="always")
def _bucket_of(wave, value):  # pragma: no cover - jitted
    """The ring's bucket of ``value`` [m]."""
    return int(value / wave[10][0]) % wave[9].shape[0]


@numba.njit(cache=True, inline="always")
def _enqueue(wave, c, b):  # pragma: no cover - jitted
    """Put cell ``c`` first in bucket ``b``."""
    nxt, prv, bucket, heads = wave[2], wave[3], wave[4], wave[9]
    h = heads[b]
    nxt[c] = h
    prv[c] = -1
    if h >= 0:
        prv[h] = c
    heads[b] = c
    bucket[c] = b


@numba.njit(cache=True, inline="always")
def _unlink(wave, c):  # pragma: no cover - jitted
    """Take cell ``c`` out of its bucket."""
    nxt, prv, bucket, heads = wave[2], wave[3], wave[4], wave[9]
    if prv[c] >= 0:
        nxt[prv[c]] = nxt[c]
    else:
        heads[bucket[c]] = nxt[c]
    if nxt[c] >= 0:
        prv[nxt[c]] = prv[c]


@kernel
def _wave_seed(wave, goal, reach, origin, cell):  # pragma: no cover - jitted
    """Start the wavefront: every value ``inf`` but the cells within ``reach`` of ``goal`` (0, queued), and
    the goal's own cell (a ball smaller than a cell may hold no cell's centre: the wave was then empty)."""
    cost, flat, bucket, meta, heads = wave[0], wave[1], wave[4], wave[5], wave[9]
    nx, ny, nz = cost.shape
    flat[:] = np.inf
    bucket[:] = -1
    heads[:] = -1
    n = 0
    gi = int(math.floor((goal[0] - origin[0]) / cell))
    gj = int(math.floor((goal[1] - origin[1]) / cell))
    gk = int(math.floor((goal[2] - origin[2]) / cell))
    m = int(math.ceil(reach / cell)) + 1
    for i in range(max(gi - m, 0), min(gi + m + 1, nx)):
        for j in range(max(gj - m, 0), min(gj + m + 1, ny)):
            for k in range(max(gk - m, 0), min(gk + m + 1, nz)):
                x = origin[0] + (i + 0.5) * cell - goal[0]
                y = origin[1] + (j + 0.5) * cell - goal[1]
                z = origin[2] + (k + 0.5) * cell - goal[2]
                own = i == gi and j == gj and k == gk
                if (own or x * x + y * y + z * z <= (reach + 0.5 * cell) ** 2) and cost[i, j, k] >= 0.0:
                    idx = _padded_index(cost, i, j, k)
                    flat[idx] = 0.0
                    _enqueue(wave, idx, _bucket_of(wave, 0.0))
                    n += 1
    meta[0] = n
    meta[1] = 0


@kernel
def _wave_settle(wave, target):  # pragma: no cover - jitted
    """Run the wavefront on until cell ``target`` (flat index on the padded grid) is settled or nothing is left
    (``target < 0``: to the end).

    Dijkstra's algorithm with a ring of buckets for its queue (Dial's): the cells of the lowest bucket are
    settled in any order.  That gives Dijkstra's values bit for bit: a step costs at least 4 bucket widths
    (:func:`_wave_state`), so a cell settled from bucket ``b`` (value below ``b + 1`` widths, up to rounding)
    cannot be lowered by any cell still queued (values from ``b`` widths on) plus a step, and a queued cell
    is always ahead of the current bucket and less than the ring's span ahead.  Each value is then the
    least over its neighbours of (their value + the step's cost), computed as one expression: the unique
    solution of the relaxation equations, whatever the order of ties or of a bucket's cells.  The padding's
    blocked cells stand for the grid's edge."""
    flat, bucket, meta, steps = wave[1], wave[4], wave[5], wave[6]
    cost, offsets, heads = wave[7], wave[8], wave[9]
    n_buckets = heads.shape[0]
    n = meta[0]
    cur = meta[1]
    while n > 0 and (target < 0 or bucket[target] != -2):
        while heads[cur] < 0:
            cur += 1
            if cur == n_buckets:
                cur = 0
        idx = heads[cur]
        _unlink(wave, idx)
        bucket[idx] = -2
        n -= 1
        d = flat[idx]
        c0 = cost[idx]
        for t in range(26):
            nb = idx + offsets[t]
            c = cost[nb]
            if c < 0.0:
                continue
            nd = d + steps[t] * (1.0 + 0.5 * (c + c0))
            if nd < flat[nb]:
                flat[nb] = nd
                b = bucket[nb]
                to = _bucket_of(wave, nd)
                if b == -1:
                    _enqueue(wave, nb, to)
                    n += 1
                elif b >= 0 and to != b:  # queued: to its lower bucket
                    _unlink(wave, nb)
                    _enqueue(wave, nb, to)
    meta[0] = n
    meta[1] = cur


@numba.njit(cache=True, inline="always")
def wave_value(wave, i, j, k):  # pragma: no cover - jitted
    """The final value of cell (i, j, k), running the wavefront on as far as that needs (a blocked cell is
    never reached: ``inf`` at once)."""
    cost = wave[0]
    idx = _padded_index(cost, i, j, k)
    if wave[5][0] > 0 and wave[4][idx] != -2 and cost[i, j, k] >= 0.0:
        _wave_settle(wave, idx)
    return wave[1][idx]


def navigation_function(smap, goal: NDArray[np.float64], reach: float, lo: NDArray[np.float64],
                        hi: NDArray[np.float64], repulsion: Repulsion) -> NavigationFunction:
    """The :class:`NavigationFunction` to ``goal`` (ball of radius ``reach``) over the box ``lo .. hi`` [m].

    The grid is the map's seen-free grid (same cells), clipped to the box.
    """
    free, forigin, fcell, fdims = smap.free_arrays()
    i0 = np.clip(np.floor((lo - forigin) / fcell).astype(np.int64), 0, fdims - 1)
    i1 = np.clip(np.ceil((hi - forigin) / fcell).astype(np.int64), 0, fdims)
    origin = forigin + i0 * fcell
    dims = np.maximum(i1 - i0, 1)
    seen = free[i0[0]: i0[0] + dims[0], i0[1]: i0[1] + dims[1], i0[2]: i0[2] + dims[2]]
    near = np.zeros(tuple(dims), dtype=np.float64)
    P, alive = smap.arrays()[:2]
    n = smap.n_slots
    _rasterize(P, alive, n, origin, fcell, dims, repulsion.unseen_radius, near, repulsion.w_unseen_surface)
    cost = np.where(seen != 0, 0.0, np.maximum(near, repulsion.w_unseen))
    half_diag = 0.5 * math.sqrt(3.0) * fcell
    _rasterize(P, alive, n, origin, fcell, dims, max(repulsion.r_block - half_diag, 0.0), cost, -1.0)
    out = np.empty(tuple(dims))
    wave = _wave_state(cost, fcell)
    _wave_seed(wave, np.asarray(goal, dtype=np.float64), float(reach), origin, fcell)
    return NavigationFunction(origin, fcell, out, wave)  # settled on demand
