"""Proximity queries that skip empty space: the search's distance test with an occupancy mask.

The search asks :func:`navstack.planner.map.nearest_distance` a hundred times per expanded state,
mostly in open space, where it scans 27 or 125 empty buckets to answer "nothing within ``r``".
:func:`occupied_near` marks, once per search, every bucket with a stored point (live or removed)
within ``REACH`` buckets in each axis; :func:`distance_below` answers ``r`` at once for a query whose
bucket is unmarked and asks :func:`nearest_distance` otherwise.  The scan of ``nearest_distance`` never
leaves that neighbourhood for ``r <= REACH * bucket``, so the answer is the same, bit for bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.planner.map import _cell, nearest_distance

__all__ = ["REACH", "distance_below", "occupied_near"]

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


