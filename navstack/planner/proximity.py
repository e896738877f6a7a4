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
def occupied_near(head: NDArray[np.int64]) -> NDArray[np.uint8]:  # pragma: no cover - jitted
    """1 where a bucket within ``REACH`` (Chebyshev, in buckets) of the cell holds a point slot, else 0."""
    nx, ny, nz = head.shape
    a = np.zeros((nx, ny, nz), dtype=np.uint8)
    b = np.zeros((nx, ny, nz), dtype=np.uint8)
    for i in range(nx):  # dilate along x
        for j in range(ny):
            for k in range(nz):
                if head[i, j, k] >= 0:
                    for ii in range(max(i - REACH, 0), min(i + REACH + 1, nx)):
                        a[ii, j, k] = 1
    for i in range(nx):  # then y
        for j in range(ny):
            for k in range(nz):
                if a[i, j, k]:
                    for jj in range(max(j - REACH, 0), min(j + REACH + 1, ny)):
                        b[i, jj, k] = 1
    a[:] = 0
    for i in range(nx):  # then z
        for j in range(ny):
            for k in range(nz):
                if b[i, j, k]:
                    for kk in range(max(k - REACH, 0), min(k + REACH + 1, nz)):
                        a[i, j, kk] = 1
    return a


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


