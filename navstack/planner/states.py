"""The search's record of the states it has met: per state key, the cheapest cost found and whether it is closed.

The hybrid A* of :mod:`navstack.planner.search` asks two or three questions of this record for every arc it
tries (is the end state closed? reached already, and how cheaply?), a few hundred thousand per slot-rack search.
numba's typed dict answered them through a call into its C helper library per question.  This is the same
mapping in the search's own arrays: open addressing with linear probing, the slot found by Fibonacci hashing
(the key times 2^64 / golden ratio, its top bits), the arrays doubled when half full.  A table is the tuple
``(keys, best, closed, meta)``: ``keys`` (int64, :data:`EMPTY` where free), ``best`` (float64, ``inf`` where no
cost is recorded), ``closed`` (bool), ``meta`` = [keys stored, 64 - log2(slots)].  Keys are ``>= 0``.

A question's answer is the dict's, so the search is the same search: it keeps the same arcs in the same order.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["EMPTY", "best_of", "close", "is_closed", "new_table", "set_best"]

EMPTY = -1
"""The key of a free slot."""

_GOLDEN = -7046029254386353131
"""2^64 / golden ratio (0x9E3779B97F4A7C15) as a signed 64-bit integer: Fibonacci hashing's multiplier."""


@numba.njit(cache=True)
def new_table(bits):  # pragma: no cover - jitted
    """An empty table of ``2 ** bits`` slots (``bits`` >= 2)."""
    n = 1 << bits
    return (np.full(n, EMPTY, dtype=np.int64), np.full(n, np.inf), np.zeros(n, dtype=np.bool_),
            np.array([0, 64 - bits], dtype=np.int64))


@numba.njit(cache=True, inline="always")
def _slot(keys, shift, key):  # pragma: no cover - jitted
    """The slot holding ``key``, or the free slot where it would go."""
    mask = keys.shape[0] - 1
    i = ((key * _GOLDEN) >> shift) & mask  # the product wraps (mod 2^64); its top bits
    while keys[i] != key and keys[i] != EMPTY:
        i = (i + 1) & mask
    return i


@numba.njit(cache=True, inline="always")
def is_closed(table, key):  # pragma: no cover - jitted
    """True if ``key`` has been closed."""
    keys, _, closed, meta = table
    i = _slot(keys, meta[1], key)
    return keys[i] == key and closed[i]


@numba.njit(cache=True, inline="always")
def best_of(table, key):  # pragma: no cover - jitted
    """The cheapest cost recorded for ``key`` (``inf`` if none)."""
    keys, best, _, meta = table
    return best[_slot(keys, meta[1], key)]  # a free slot holds inf


@numba.njit(cache=True)
def _grown(table):  # pragma: no cover - jitted
    """The table's entries in a table of twice as many slots."""
    keys, best, closed, meta = table
    out = new_table(64 - meta[1] + 1)
    ok, ob, oc, om = out
    for i in range(keys.shape[0]):
        if keys[i] != EMPTY:
            j = _slot(ok, om[1], keys[i])
            ok[j], ob[j], oc[j] = keys[i], best[i], closed[i]
    om[0] = meta[0]
    return out


@numba.njit(cache=True, inline="always")
def _entry(table, key):  # pragma: no cover - jitted
    """The table (grown first if half full) and the slot of ``key`` in it, the key stored there."""
    keys, _, _, meta = table
    i = _slot(keys, meta[1], key)
    if keys[i] == key:
        return table, i
    if 2 * (meta[0] + 1) > keys.shape[0]:
        table = _grown(table)
        keys, _, _, meta = table
        i = _slot(keys, meta[1], key)
    keys[i] = key
    meta[0] += 1
    return table, i


@numba.njit(cache=True, inline="always")
def set_best(table, key, cost):  # pragma: no cover - jitted
    """Record ``cost`` as the cheapest for ``key``; returns the table (a new one when it had to grow)."""
    table, i = _entry(table, key)
    table[1][i] = cost
    return table


@numba.njit(cache=True, inline="always")
def close(table, key):  # pragma: no cover - jitted
    """Mark ``key`` closed; returns the table (a new one when it had to grow)."""
    table, i = _entry(table, key)
    table[2][i] = True
    return table
