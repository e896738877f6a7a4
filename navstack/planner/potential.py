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
    Dijkstra settles cells in order of value, so :meth:`lookup` (and the search, through
    :attr:`wave`) run it on only until the cell asked for is settled.  A search from a start at
    cost-to-go ``V`` rarely needs cells much above ``V``: the trials settle 8 % of their grids' cells
    (24 % on a slot rack; the grid spans the start and the goal with a margin all round, and is
    recomputed as the tip closes in).  The values are those of the whole wavefront, bit for bit,
    whatever the order of the questions (the same pops in the same order, only paused).
    :attr:`values` finishes it.

    Args:
        origin: (3,) the grid's lower corner [m]; cell: its cell size [m].
        values: the grid of values [m]: final where settled, ``inf`` where never reached.
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
        if self._wave[5][0] > 0:  # cells still queued (the heap's size)
            _wave_settle(self._wave, -1)
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


@numba.njit(cache=True, inline="always")
def _sift_up(keys, cells, pos, i):  # pragma: no cover - jitted
    """Move heap entry ``i`` up to its place; ``pos[cell]`` tracks each cell's entry."""
    key = keys[i]
    cell = cells[i]
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        cells[i] = cells[parent]
        pos[cells[i]] = i
        i = parent
    keys[i] = key
    cells[i] = cell
    pos[cell] = i


@numba.njit(cache=True, inline="always")
def _pop_min(keys, cells, pos, n):  # pragma: no cover - jitted
    """Remove the smallest entry of the heap ``keys[:n]``; returns (key, cell, new size)."""
    key0 = keys[0]
    cell0 = cells[0]
    pos[cell0] = -2  # done
    n -= 1
    if n == 0:
        return key0, cell0, n
    key = keys[n]
    cell = cells[n]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and keys[c + 1] < keys[c]:
            c += 1
        if keys[c] >= key:
            break
        keys[i] = keys[c]
        cells[i] = cells[c]
        pos[cells[i]] = i
        i = c
    keys[i] = key
    cells[i] = cell
    pos[cell] = i
    return key0, cell0, n


def _wave_state(cost: NDArray[np.float64], out: NDArray[np.float64], cell: float) -> tuple:
    """The paused wavefront: (cost, flat values, heap keys, heap cells, heap position per cell, [heap size],
    step lengths [m]), over ``cost`` (per-metre weight, < 0 = blocked) with the values in ``out``."""
    ncell = cost.size
    d = np.array([(di * di + dj * dj + dk * dk) for di in (-1, 0, 1) for dj in (-1, 0, 1) for dk in (-1, 0, 1)])
    steps = cell * np.sqrt(d.astype(np.float64))
    return (cost, out.reshape(ncell), np.empty(ncell), np.empty(ncell, dtype=np.int64),
            np.full(ncell, -1, dtype=np.int64), np.zeros(1, dtype=np.int64), steps)


def _done_state(values: NDArray[np.float64]) -> tuple:
    """The state of a finished wavefront over ``values`` (nothing left to settle)."""
    state = _wave_state(np.zeros(values.shape), values, 1.0)
    state[4][:] = -2
    return state


@kernel
def _wave_seed(wave, goal, reach, origin, cell):  # pragma: no cover - jitted
    """Start the wavefront: every value ``inf`` but the cells within ``reach`` of ``goal`` (0, queued), and
    the goal's own cell (a ball smaller than a cell may hold no cell's centre: the wave was then empty)."""
    cost, flat, keys, cells, pos, heap, _ = wave
    nx, ny, nz = cost.shape
    flat[:] = np.inf
    pos[:] = -1
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
                    idx = (i * ny + j) * nz + k
                    flat[idx] = 0.0
                    keys[n] = 0.0
                    cells[n] = idx
                    _sift_up(keys, cells, pos, n)
                    n += 1
    heap[0] = n


@kernel
def _wave_settle(wave, target):  # pragma: no cover - jitted
    """Run the wavefront on until cell ``target`` (flat index) is settled or nothing is left (``target < 0``:
    to the end).  An indexed binary heap (each cell at most once, its key lowered in place); the values are the
    unique solution of the relaxation equations (positive steps), so they do not depend on the order of ties."""
    cost, flat, keys, cells, pos, heap, steps = wave
    nx, ny, nz = cost.shape
    n = heap[0]
    while n > 0 and (target < 0 or pos[target] != -2):
        d, idx, n = _pop_min(keys, cells, pos, n)
        k = idx % nz
        j = (idx // nz) % ny
        i = idx // (ny * nz)
        c0 = cost[i, j, k]
        for di in range(-1, 2):
            ii = i + di
            if ii < 0 or ii >= nx:
                continue
            for dj in range(-1, 2):
                jj = j + dj
                if jj < 0 or jj >= ny:
                    continue
                for dk in range(-1, 2):
                    kk = k + dk
                    if kk < 0 or kk >= nz or (di == 0 and dj == 0 and dk == 0):
                        continue
                    c = cost[ii, jj, kk]
                    if c < 0.0:
                        continue
                    nb = (ii * ny + jj) * nz + kk
                    nd = d + steps[(di + 1) * 9 + (dj + 1) * 3 + dk + 1] * (1.0 + 0.5 * (c + c0))
                    if nd < flat[nb]:
                        flat[nb] = nd
                        p = pos[nb]
                        if p == -1:
                            keys[n] = nd
                            cells[n] = nb
                            _sift_up(keys, cells, pos, n)
                            n += 1
                        elif p >= 0:  # queued: lower its key (a finished cell, -2, is never improved)
                            keys[p] = nd
                            _sift_up(keys, cells, pos, p)
    heap[0] = n


@numba.njit(cache=True, inline="always")
def wave_value(wave, i, j, k):  # pragma: no cover - jitted
    """The final value of cell (i, j, k), running the wavefront on as far as that needs (a blocked cell is
    never reached: ``inf`` at once)."""
    cost = wave[0]
    idx = (i * cost.shape[1] + j) * cost.shape[2] + k
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
    wave = _wave_state(cost, out, fcell)
    _wave_seed(wave, np.asarray(goal, dtype=np.float64), float(reach), origin, fcell)
    return NavigationFunction(origin, fcell, out, wave)  # settled on demand
