"""Proximity queries that skip empty space: the search's distance test with an occupancy mask.

The search asks :func:`navstack.planner.map.nearest_distance` a hundred times per expanded state,
mostly in open space, where it scans 27 or 125 empty buckets to answer "nothing within ``r``".
:func:`occupied_near` marks, once per search, every bucket with a live point
within ``REACH`` buckets in each axis, and apart every bucket with one in its 3 x 3 x 3 neighbourhood;
:func:`distance_below` answers ``r`` at once for a query whose bucket is unmarked and scans otherwise
(:func:`nearest_in`).  The scan of ``nearest_distance`` never leaves that neighbourhood for ``r <= REACH *
bucket``, so the answer is the same, bit for bit.

Queries come in groups: the samples of one motion primitive a centimetre apart, which
:func:`distances_below` answers from one pass over the buckets around them (each bucket walked once, not once
per point, a long run of them cut to the heights that can hold a nearer point), the same answers; and a link,
a segment whose exact distance to the nearest point :func:`segment_distance_below` finds from the buckets
around a few samples along it.

A search asks its questions of a map that does not change while it runs, so it asks them of a snapshot,
:func:`point_index`: the live points copied out bucket by bucket, in the buckets' order (compressed
sparse rows), so a run of buckets along z is one contiguous run of points, with no list to follow and
no removed points to skip.  A minimum does not depend on the order its terms come in, so every answer is
:func:`navstack.planner.map.nearest_distance`'s over the map's lists, bit for bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.jit import kernel
from navstack.planner.map import SensedMap, _cell

__all__ = ["ADJACENT", "REACH", "distance_below", "distances_below", "filled_buckets", "nearest_in", "occupied_near",
           "point_index", "segment_distance_below", "sets_closer_than"]

REACH = 2
"""Buckets of neighbourhood the mask covers (queries up to ``REACH * bucket`` use it)."""


ADJACENT = 2
"""The mask's second bit: a bucket within one bucket of the cell holds a live point (its 3 x 3 x 3
buckets, what a query closer than a bucket scans)."""


@numba.njit(cache=True)
def _dilate1(src, dst, axis):  # pragma: no cover - jitted
    """``dst`` = ``src`` or-ed with its neighbours one cell either way along ``axis`` (clipped at the faces): a
    gather with the innermost loop over contiguous cells, whatever the axis."""
    nx, ny, nz = src.shape
    for i in range(nx):
        for j in range(ny):
            if axis == 2:
                dst[i, j, 0] = src[i, j, 0] | src[i, j, min(1, nz - 1)]
                for k in range(1, nz - 1):
                    dst[i, j, k] = src[i, j, k - 1] | src[i, j, k] | src[i, j, k + 1]
                if nz > 1:
                    dst[i, j, nz - 1] = src[i, j, nz - 2] | src[i, j, nz - 1]
                continue
            if axis == 0:
                a, b = src[max(i - 1, 0), j], src[min(i + 1, nx - 1), j]
            else:
                a, b = src[i, max(j - 1, 0)], src[i, min(j + 1, ny - 1)]
            c = src[i, j]
            d = dst[i, j]
            for k in range(nz):
                d[k] = a[k] | c[k] | b[k]


@numba.njit(cache=True)
def occupied_near(filled: NDArray[np.bool_]) -> NDArray[np.uint8]:  # pragma: no cover - jitted
    """Per bucket: 1 if a bucket within ``REACH`` (Chebyshev, in buckets) of it is ``filled``, plus
    :data:`ADJACENT` if one within a single bucket is; else 0.  The filled buckets dilated by one along x,
    then y, then z, and that again, ``REACH - 1`` times (a box dilated by a box is the larger box)."""
    a = filled.astype(np.uint8)
    b = np.empty_like(a)
    _dilate1(a, b, 0)
    _dilate1(b, a, 1)
    adjacent = np.empty_like(a)
    _dilate1(a, adjacent, 2)  # within one bucket
    near = adjacent
    for _ in range(REACH - 1):  # each round one bucket farther
        out = np.empty_like(a)
        _dilate1(near, b, 0)
        _dilate1(b, a, 1)
        _dilate1(a, out, 2)
        near = out
    fn, fa = near.reshape(near.size), adjacent.reshape(adjacent.size)
    for q in range(fn.size):
        fn[q] = fn[q] | (ADJACENT * fa[q])
    return near


@numba.njit(cache=True)
def _rows(P, alive, head, nxt):  # pragma: no cover - jitted
    """The live points bucket by bucket: ``start`` (buckets + 1,), bucket ``b``'s points being
    ``S[start[b]:start[b + 1]]`` (buckets in C order of ``head``), and ``S`` (live points, 3) [m]."""
    nb = head.size
    flat = head.reshape(nb)
    start = np.zeros(nb + 1, dtype=np.int64)
    for b in range(nb):
        c = 0
        q = flat[b]
        while q >= 0:
            if alive[q]:
                c += 1
            q = nxt[q]
        start[b + 1] = start[b] + c
    S = np.empty((start[nb], 3))
    for b in range(nb):
        c = start[b]
        q = flat[b]
        while q >= 0:
            if alive[q]:
                S[c, 0], S[c, 1], S[c, 2] = P[q, 0], P[q, 1], P[q, 2]
                c += 1
            q = nxt[q]
    return start, S


def point_index(smap: SensedMap) -> tuple:
    """A snapshot of ``smap`` for the proximity kernels: ``(occ, start, S, origin, bucket, bucket_dims)``
    (:func:`occupied_near`'s mask of the buckets holding live points, the live points in bucket order); valid
    until the map changes.  Kept with the map for its :attr:`~navstack.planner.map.SensedMap.revision`: the
    searches of one control step (the plan's check, a search and its retry, an escape's candidates) share it.
    Read-only for the kernels."""
    cached = smap.snapshot
    if cached is not None and cached[0] == smap.revision:
        return cached[1]
    P, alive, head, nxt, origin, bucket, dims = smap.arrays()
    start, S = _rows(P, alive, head, nxt)
    index = occupied_near(filled_buckets(start, head.shape)), start, S, origin, bucket, dims
    smap.snapshot = (smap.revision, index)
    return index


def filled_buckets(start: NDArray[np.int64], shape: tuple) -> NDArray[np.bool_]:
    """Which buckets of the snapshot (:func:`point_index`'s ``start``, buckets of ``shape``) hold a point."""
    return (start[1:] != start[:-1]).reshape(shape)


_SLACK = 1e-9
"""Distance [m] by which the geometric pruning of :func:`distances_below` errs on the side of scanning: far
above the rounding of squared distances over metres, so a point it skips is never nearer than the minimum."""


@numba.njit(cache=True, inline="always")
def _slab(i, origin, bucket, dims, axis):  # pragma: no cover - jitted
    """The coordinates [m] that bucket row ``i`` along ``axis`` holds: the edge rows also hold every point
    beyond the box (:func:`navstack.planner.map._cell` clips), so they are open outwards."""
    lo = origin[axis] + i * bucket if i > 0 else -np.inf
    hi = origin[axis] + (i + 1) * bucket if i < dims[axis] - 1 else np.inf
    return lo, hi


@numba.njit(cache=True, inline="always")
def _gap(x, lo, hi):  # pragma: no cover - jitted
    """How far [m] ``x`` lies outside [lo, hi] (0 inside), less :data:`_SLACK` (never below 0)."""
    g = lo - x if x < lo else (x - hi if x > hi else 0.0)
    return g - _SLACK if g > _SLACK else 0.0


_PRUNE_RUN = 16
"""Points in a column's run above which :func:`distances_below` narrows it first (measured on recorded
searches: narrowing costs about as much as scanning a few points for five samples)."""


@numba.njit(cache=True, inline="always")
def _narrow(xs, n, best, i, j, k0, k1, base, start, origin, bucket, dims):  # pragma: no cover - jitted
    """The part ``a .. b`` of column (i, j)'s run over buckets ``k0 .. k1 - 1`` whose buckets can hold a point
    nearer to some ``xs[t]`` than ``sqrt(best[t])``: the heights within reach over the column's gap, kept
    :data:`_SLACK` wide, so no point it leaves out is nearer (an empty run when there are none)."""
    xlo, xhi = _slab(i, origin, bucket, dims, 0)
    ylo, yhi = _slab(j, origin, bucket, dims, 1)
    zlo, zhi = np.inf, -np.inf
    for t in range(n):
        gx = _gap(xs[t, 0], xlo, xhi)
        gy = _gap(xs[t, 1], ylo, yhi)
        w2 = best[t] - (gx * gx + gy * gy)
        if w2 > 0.0:
            w = math.sqrt(w2) + _SLACK
            zlo = min(zlo, xs[t, 2] - w)
            zhi = max(zhi, xs[t, 2] + w)
    if zlo > zhi:
        return 0, 0
    a = max(k0, _cell(zlo, origin, bucket, dims, 2))
    b = min(k1, _cell(zhi, origin, bucket, dims, 2) + 1)
    if a >= b:
        return 0, 0
    return start[base + a], start[base + b]


@numba.njit(cache=True, inline="always")
def _run_min(S, a, b, x, y, z, best):  # pragma: no cover - jitted
    """The smallest of ``best`` and the squared distances [m^2] from (x, y, z) to the points ``S[a:b]``."""
    for q in range(a, b):
        dx = S[q, 0] - x
        dy = S[q, 1] - y
        dz = S[q, 2] - z
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < best:
            best = d2
    return best


@kernel
def nearest_in(px, py, pz, r, start, S, origin, bucket, dims):  # pragma: no cover - jitted
    """:func:`navstack.planner.map.nearest_distance` over the snapshot of :func:`point_index`: the distance [m]
    to the nearest point of the buckets within ``ceil(r / bucket)`` of (px, py, pz)'s, exact below ``r``,
    else ``r``."""
    bx = _cell(px, origin, bucket, dims, 0)
    by = _cell(py, origin, bucket, dims, 1)
    bz = _cell(pz, origin, bucket, dims, 2)
    m = int(math.ceil(r / bucket))
    best = r * r
    k0 = max(bz - m, 0)
    k1 = min(bz + m + 1, dims[2])
    for i in range(max(bx - m, 0), min(bx + m + 1, dims[0])):
        for j in range(max(by - m, 0), min(by + m + 1, dims[1])):
            base = (i * dims[1] + j) * dims[2]  # the column's buckets k0 .. k1 - 1
            best = _run_min(S, start[base + k0], start[base + k1], px, py, pz, best)
    return math.sqrt(best)


@kernel
def distance_below(px, py, pz, r, occ, start, S, origin, bucket, dims):  # pragma: no cover - jitted
    """:func:`nearest_in` (the snapshot ``occ, start, S, origin, bucket, dims`` of :func:`point_index`),
    answering ``r`` without a scan where the mask shows no live point near."""
    if math.ceil(r / bucket) <= REACH:  # the scan's own reach
        i = _cell(px, origin, bucket, dims, 0)
        j = _cell(py, origin, bucket, dims, 1)
        k = _cell(pz, origin, bucket, dims, 2)
        if occ[i, j, k] == 0:
            return math.sqrt(r * r)
    return nearest_in(px, py, pz, r, start, S, origin, bucket, dims)


@kernel(inline="always")
def _quiet(x, y, z, occ, origin, bucket, dims):  # pragma: no cover - jitted
    """Whether the mask shows no point within ``REACH`` buckets of the bucket holding (x, y, z)."""
    return occ[_cell(x, origin, bucket, dims, 0), _cell(y, origin, bucket, dims, 1), _cell(z, origin, bucket, dims,
                                                                                            2)] == 0


@kernel
def segment_distance_below(ax, ay, az, bx, by, bz, r, first, occ, start, S, origin, bucket,
                           dims):  # pragma: no cover - jitted
    """The distance [m] from the segment a-b to the nearest live point, exact below ``r``, else ``r``; with
    ``first``, the first distance found below ``r`` instead (enough to tell that the segment does not keep
    ``r``).  Each point's distance is to the segment itself, not to samples along it.  Scanned: the buckets
    within ``m`` of samples along the segment spaced so that every point within ``r`` of it is nearer than
    ``m`` buckets to a sample (within ``sqrt(r^2 + (h / 2)^2) < m * bucket`` of the nearest sample, ``h`` their
    spacing), so in its ``(2 m + 1)^3`` buckets; those whose mask shows no point that near are skipped."""
    m = int(math.floor(r / bucket)) + 1
    if m * bucket < 1.05 * r:
        m += 1  # a roomier neighbourhood rather than samples a few millimetres apart
    reach = m * bucket
    dx, dy, dz = bx - ax, by - ay, bz - az
    dd = dx * dx + dy * dy + dz * dz
    length = math.sqrt(dd)
    if 0.25 * length + r < REACH * bucket:  # each half's points within r lie within REACH buckets of its middle
        if _quiet(ax + 0.25 * dx, ay + 0.25 * dy, az + 0.25 * dz, occ, origin, bucket, dims) and _quiet(
                ax + 0.75 * dx, ay + 0.75 * dy, az + 0.75 * dz, occ, origin, bucket, dims):
            return math.sqrt(r * r)  # none: what the scan would return
    h = 1.98 * math.sqrt(reach * reach - r * r)  # (2 sqrt(reach^2 - r^2), less 1 %)
    n = max(1, int(math.ceil(length / h)))
    r2 = r * r
    best = r2
    pi, pj, pk = -(1 << 40), -(1 << 40), -(1 << 40)  # the previous sample's bucket (none yet)
    for t in range(n + 1):
        f = t / n
        x, y, z = ax + f * dx, ay + f * dy, az + f * dz
        i = _cell(x, origin, bucket, dims, 0)
        j = _cell(y, origin, bucket, dims, 1)
        k = _cell(z, origin, bucket, dims, 2)
        if (m == 1 and occ[i, j, k] & ADJACENT == 0) or (m == REACH and occ[i, j, k] == 0):
            pi, pj, pk = i, j, k  # no point within m buckets: its box is empty, as good as scanned
            continue
        k0 = max(k - m, 0)
        k1 = min(k + m + 1, dims[2])
        for ii in range(max(i - m, 0), min(i + m + 1, dims[0])):
            for jj in range(max(j - m, 0), min(j + m + 1, dims[1])):
                base = (ii * dims[1] + jj) * dims[2]  # the column's buckets k0 .. k1 - 1
                a, b = k0, k1
                c0, c1 = k0, k0  # the heights the previous sample's box scanned in this column
                if abs(ii - pi) <= m and abs(jj - pj) <= m:
                    c0, c1 = max(pk - m, k0), min(pk + m + 1, k1)
                if c0 < c1:  # scan only the heights below and above them (the boxes are the same size)
                    if c0 > k0:
                        b = c0
                    else:
                        a, b = c1, k1
                for q in range(start[base + a], start[base + b]):
                    wx, wy, wz = S[q, 0] - ax, S[q, 1] - ay, S[q, 2] - az
                    u = (wx * dx + wy * dy + wz * dz) / dd if dd > 0.0 else 0.0
                    u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
                    ex, ey, ez = wx - u * dx, wy - u * dy, wz - u * dz
                    d2 = ex * ex + ey * ey + ez * ez
                    if d2 < best:
                        best = d2
                        if first and math.sqrt(d2) < r:
                            return math.sqrt(d2)
        pi, pj, pk = i, j, k
    return math.sqrt(best)


@kernel
def distances_below(xs, n, r, out, occ, start, S, origin, bucket, dims):  # pragma: no cover
    """``out[t] = distance_below(xs[t], r)`` for ``t < n``, bit for bit, from one scan of the buckets around
    all ``n`` points (each visited once; a point's own scan covers the buckets within ``ceil(r / bucket)`` of
    its own, and every point outside them is farther than ``r``)."""
    m = int(math.ceil(r / bucket))
    r2 = r * r
    near = 0
    lo0, lo1, lo2 = dims[0], dims[1], dims[2]
    hi0, hi1, hi2 = -1, -1, -1
    for t in range(n):
        i = _cell(xs[t, 0], origin, bucket, dims, 0)
        j = _cell(xs[t, 1], origin, bucket, dims, 1)
        k = _cell(xs[t, 2], origin, bucket, dims, 2)
        lo0, lo1, lo2 = min(lo0, i), min(lo1, j), min(lo2, k)
        hi0, hi1, hi2 = max(hi0, i), max(hi1, j), max(hi2, k)
        out[t] = r2
        if m > REACH or occ[i, j, k] != 0:
            near += 1
    if near > 0 and m * bucket < r + 1e-6:  # too tight to tell the neighbourhoods apart: point by point
        for t in range(n):
            out[t] = distance_below(xs[t, 0], xs[t, 1], xs[t, 2], r, occ, start, S, origin, bucket, dims)
        return
    if near > 0:
        k0 = max(lo2 - m, 0)
        k1 = min(hi2 + m + 1, dims[2])
        for i in range(max(lo0 - m, 0), min(hi0 + m + 1, dims[0])):
            xlo, xhi = _slab(i, origin, bucket, dims, 0)
            for j in range(max(lo1 - m, 0), min(hi1 + m + 1, dims[1])):
                base = (i * dims[1] + j) * dims[2]  # the column's buckets k0 .. k1 - 1
                a, b = start[base + k0], start[base + k1]
                if a == b:
                    continue
                if b - a > _PRUNE_RUN:  # a long run: keep to the heights where a nearer point can be
                    a, b = _narrow(xs, n, out, i, j, k0, k1, base, start, origin, bucket, dims)
                ylo, yhi = _slab(j, origin, bucket, dims, 1)
                for t in range(n):
                    gx = _gap(xs[t, 0], xlo, xhi)
                    gy = _gap(xs[t, 1], ylo, yhi)
                    if gx * gx + gy * gy < out[t]:  # else no point of the column is nearer than its best
                        out[t] = _run_min(S, a, b, xs[t, 0], xs[t, 1], xs[t, 2], out[t])
    for t in range(n):
        out[t] = math.sqrt(out[t])


@numba.njit(cache=True)
def sets_closer_than(a, b, r):  # pragma: no cover - jitted
    """True if some point of ``a`` (N, 3) lies within ``r`` [m] of some point of ``b`` (M, 3): the smallest
    distance below ``r``, each squared distance summed in numpy's order (``((a[:, None] - b[None]) ** 2).sum(2)``,
    x and y first), so the answer is numpy's."""
    best = np.inf
    for i in range(a.shape[0]):
        for j in range(b.shape[0]):
            dx = a[i, 0] - b[j, 0]
            dy = a[i, 1] - b[j, 1]
            dz = a[i, 2] - b[j, 2]
            d2 = dx * dx + dy * dy + dz * dz
            if d2 < best:
                best = d2
    return a.shape[0] > 0 and b.shape[0] > 0 and math.sqrt(best) < r
