"""Proximity queries that skip empty space: the search's distance test with an occupancy mask.

The search asks :func:`navstack.planner.map.nearest_distance` a hundred times per expanded state,
mostly in open space, where it scans 27 or 125 empty buckets to answer "nothing within ``r``".
:func:`occupied_near` marks, once per search, every bucket with a stored point (live or removed)
within ``REACH`` buckets in each axis; :func:`distance_below` answers ``r`` at once for a query whose
bucket is unmarked and scans otherwise (:func:`nearest_in`).  The scan of ``nearest_distance`` never
leaves that neighbourhood for ``r <= REACH * bucket``, so the answer is the same, bit for bit.

Queries come in groups, the samples of one motion primitive a centimetre apart and the points along the
last link: :func:`distances_below` and :func:`samples_clear` answer a group from one pass over the
buckets around it (each bucket walked once, not once per point), with the same answers.

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

from navstack.planner.map import SensedMap, _cell

__all__ = ["REACH", "distance_below", "distances_below", "nearest_in", "occupied_near", "point_index",
           "samples_clear"]

REACH = 2
"""Buckets of neighbourhood the mask covers (queries up to ``REACH * bucket`` use it)."""


@numba.njit(cache=True)
def _dilate(src, dst, axis):  # pragma: no cover - jitted
    """``dst`` = 1 within ``REACH`` cells along ``axis`` of every nonzero cell of ``src`` (``dst`` zeroed first)."""
    dst[:] = 0
    nx, ny, nz = src.shape
    di, dj, dk = int(axis == 0), int(axis == 1), int(axis == 2)
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if src[i, j, k]:
                    for t in range(-REACH, REACH + 1):
                        ii, jj, kk = i + t * di, j + t * dj, k + t * dk
                        if 0 <= ii < nx and 0 <= jj < ny and 0 <= kk < nz:
                            dst[ii, jj, kk] = 1


@numba.njit(cache=True)
def occupied_near(head: NDArray[np.int64]) -> NDArray[np.uint8]:  # pragma: no cover - jitted
    """1 where a bucket within ``REACH`` (Chebyshev, in buckets) of the cell holds a point slot, else 0: the
    filled buckets dilated along x, then y, then z."""
    a = (head >= 0).astype(np.uint8)
    b = np.empty_like(a)
    _dilate(a, b, 0)
    _dilate(b, a, 1)
    _dilate(a, b, 2)
    return b


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
    (:func:`occupied_near`'s mask, the live points in bucket order); valid until the map changes."""
    P, alive, head, nxt, origin, bucket, dims = smap.arrays()
    start, S = _rows(P, alive, head, nxt)
    return occupied_near(head), start, S, origin, bucket, dims


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


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def distance_below(px, py, pz, r, occ, start, S, origin, bucket, dims):  # pragma: no cover - jitted
    """:func:`nearest_in` (the snapshot ``occ, start, S, origin, bucket, dims`` of :func:`point_index`),
    answering ``r`` without a scan where the mask shows no stored point near."""
    if math.ceil(r / bucket) <= REACH:  # the scan's own reach
        i = _cell(px, origin, bucket, dims, 0)
        j = _cell(py, origin, bucket, dims, 1)
        k = _cell(pz, origin, bucket, dims, 2)
        if occ[i, j, k] == 0:
            return math.sqrt(r * r)
    return nearest_in(px, py, pz, r, start, S, origin, bucket, dims)


@numba.njit(cache=True)
def samples_clear(ax, ay, az, bx, by, bz, fracs, r, work, occ, start, S, origin, bucket,
                  dims):  # pragma: no cover - jitted
    """True if every point ``a + f (b - a)``, ``f`` in ``fracs`` (at most 8), keeps ``r`` from every live point:
    ``distance_below(x, r) >= r`` at each, the same answer, from one scan of their buckets' neighbourhoods
    (each bucket visited once, not once per point).  For ``r`` under a bucket (each point's scan covers the
    27 buckets around its own; a point outside them is farther than a bucket); else point by point.
    ``work``: (16, 3) scratch."""
    n = fracs.shape[0]
    near = 0
    lo0, lo1, lo2 = dims[0], dims[1], dims[2]
    hi0, hi1, hi2 = -1, -1, -1
    for t in range(n):
        f = fracs[t]
        x, y, z = ax + f * (bx - ax), ay + f * (by - ay), az + f * (bz - az)
        i = _cell(x, origin, bucket, dims, 0)
        j = _cell(y, origin, bucket, dims, 1)
        k = _cell(z, origin, bucket, dims, 2)
        work[t, 0], work[t, 1], work[t, 2] = x, y, z
        work[8 + t, 0], work[8 + t, 1], work[8 + t, 2] = i, j, k
        lo0, lo1, lo2 = min(lo0, i), min(lo1, j), min(lo2, k)
        hi0, hi1, hi2 = max(hi0, i), max(hi1, j), max(hi2, k)
        if occ[i, j, k] != 0:
            near += 1
    if near == 0:
        return True
    if r >= bucket - 1e-6:
        for t in range(n):
            if distance_below(work[t, 0], work[t, 1], work[t, 2], r, occ, start, S, origin, bucket, dims) < r:
                return False
        return True
    r2 = r * r
    for i in range(max(lo0 - 1, 0), min(hi0 + 2, dims[0])):
        for j in range(max(lo1 - 1, 0), min(hi1 + 2, dims[1])):
            for k in range(max(lo2 - 1, 0), min(hi2 + 2, dims[2])):
                b = (i * dims[1] + j) * dims[2] + k
                if start[b] == start[b + 1]:
                    continue
                inside = False  # within one bucket of some point's own
                for t in range(n):
                    if abs(i - work[8 + t, 0]) <= 1.0 and abs(j - work[8 + t, 1]) <= 1.0 \
                            and abs(k - work[8 + t, 2]) <= 1.0:
                        inside = True
                        break
                if not inside:
                    continue
                for q in range(start[b], start[b + 1]):
                    for t in range(n):
                        dx = S[q, 0] - work[t, 0]
                        dy = S[q, 1] - work[t, 1]
                        dz = S[q, 2] - work[t, 2]
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 < r2 and math.sqrt(d2) < r:
                            return False
    return True


@numba.njit(cache=True)
def distances_below(xs, n, r, out, occ, start, S, origin, bucket, dims):  # pragma: no cover
    """``out[t] = distance_below(xs[t], r)`` for ``t < n``, bit for bit, from one scan of the buckets around
    all ``n`` points (each visited once; a point's own scan covers the buckets within ``ceil(r / bucket)`` of
    its own, and every point outside them is farther than ``r``).  :func:`samples_clear` is the same pass for a
    yes-or-no answer: it stops at the first point within ``r`` and skips buckets beyond every sample's own
    neighbourhood, which pays on a 0.13 m chord but not on a primitive's samples 1 cm apart."""
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
            for j in range(max(lo1 - m, 0), min(hi1 + m + 1, dims[1])):
                base = (i * dims[1] + j) * dims[2]  # the column's buckets k0 .. k1 - 1
                for t in range(n):
                    out[t] = _run_min(S, start[base + k0], start[base + k1], xs[t, 0], xs[t, 1], xs[t, 2], out[t])
    for t in range(n):
        out[t] = math.sqrt(out[t])
