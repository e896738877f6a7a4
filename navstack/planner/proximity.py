"""Proximity queries that skip empty space: the search's distance test with an occupancy mask.

The search asks :func:`navstack.planner.map.nearest_distance` a hundred times per expanded state,
mostly in open space, where it scans 27 or 125 empty buckets to answer "nothing within ``r``".
:func:`occupied_near` marks, once per search, every bucket with a stored point (live or removed)
within ``REACH`` buckets in each axis; :func:`distance_below` answers ``r`` at once for a query whose
bucket is unmarked and asks :func:`nearest_distance` otherwise.  The scan of ``nearest_distance`` never
leaves that neighbourhood for ``r <= REACH * bucket``, so the answer is the same, bit for bit.

Queries come in groups, the samples of one motion primitive a centimetre apart and the points along the
last link: :func:`distances_below` and :func:`samples_clear` answer a group from one pass over the
buckets around it (each bucket's list walked once, not once per point), with the same answers.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.planner.map import _cell, nearest_distance

__all__ = ["REACH", "distance_below", "distances_below", "occupied_near", "samples_clear"]

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
def distance_below(px, py, pz, r, occ, P, alive, head, nxt, origin, bucket, dims):  # pragma: no cover - jitted
    """:func:`nearest_distance` (same arguments, and ``occ`` from :func:`occupied_near` of ``head``),
    answering ``r`` without a scan where the mask shows no stored point near."""
    if math.ceil(r / bucket) <= REACH:  # nearest_distance's own scan reach
        i = _cell(px, origin, bucket, dims, 0)
        j = _cell(py, origin, bucket, dims, 1)
        k = _cell(pz, origin, bucket, dims, 2)
        if occ[i, j, k] == 0:
            return math.sqrt(r * r)
    return nearest_distance(px, py, pz, r, P, alive, head, nxt, origin, bucket, dims)


@numba.njit(cache=True)
def samples_clear(ax, ay, az, bx, by, bz, fracs, r, work, occ, P, alive, head, nxt, origin, bucket,
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
            if distance_below(work[t, 0], work[t, 1], work[t, 2], r, occ, P, alive, head, nxt, origin, bucket,
                              dims) < r:
                return False
        return True
    r2 = r * r
    for i in range(max(lo0 - 1, 0), min(hi0 + 2, dims[0])):
        for j in range(max(lo1 - 1, 0), min(hi1 + 2, dims[1])):
            for k in range(max(lo2 - 1, 0), min(hi2 + 2, dims[2])):
                q = head[i, j, k]
                if q < 0:
                    continue
                inside = False  # within one bucket of some point's own
                for t in range(n):
                    if abs(i - work[8 + t, 0]) <= 1.0 and abs(j - work[8 + t, 1]) <= 1.0 \
                            and abs(k - work[8 + t, 2]) <= 1.0:
                        inside = True
                        break
                if not inside:
                    continue
                while q >= 0:
                    if alive[q]:
                        for t in range(n):
                            dx = P[q, 0] - work[t, 0]
                            dy = P[q, 1] - work[t, 1]
                            dz = P[q, 2] - work[t, 2]
                            d2 = dx * dx + dy * dy + dz * dz
                            if d2 < r2 and math.sqrt(d2) < r:
                                return False
                    q = nxt[q]
    return True


@numba.njit(cache=True)
def distances_below(xs, n, r, out, occ, P, alive, head, nxt, origin, bucket, dims):  # pragma: no cover
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
            out[t] = distance_below(xs[t, 0], xs[t, 1], xs[t, 2], r, occ, P, alive, head, nxt, origin, bucket, dims)
        return
    if near > 0:
        for i in range(max(lo0 - m, 0), min(hi0 + m + 1, dims[0])):
            for j in range(max(lo1 - m, 0), min(hi1 + m + 1, dims[1])):
                for k in range(max(lo2 - m, 0), min(hi2 + m + 1, dims[2])):
                    q = head[i, j, k]
                    if q < 0:
                        continue
                    while q >= 0:
                        if alive[q]:
                            for t in range(n):
                                dx = P[q, 0] - xs[t, 0]
                                dy = P[q, 1] - xs[t, 1]
                                dz = P[q, 2] - xs[t, 2]
                                d2 = dx * dx + dy * dy + dz * dz
                                if d2 < out[t]:
                                    out[t] = d2
                        q = nxt[q]
    for t in range(n):
        out[t] = math.sqrt(out[t])
