"""The search's state table (navstack/planner/states.py) against a Python dict, through growth and collisions."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from navstack.planner.states import EMPTY, best_of, close, is_closed, new_table, set_best


@numba.njit(cache=True)
def _replay(ops, keys, costs, bits):
    """Run ``ops`` (0: set_best, 1: close, 2: ask) on a fresh table of ``2 ** bits`` slots; per op the answers
    (closed, best) before it, and the final table."""
    table = new_table(bits)
    closed_out = np.zeros(ops.shape[0], dtype=np.bool_)
    best_out = np.empty(ops.shape[0])
    for t in range(ops.shape[0]):
        closed_out[t] = is_closed(table, keys[t])
        best_out[t] = best_of(table, keys[t])
        if ops[t] == 0:
            table = set_best(table, keys[t], costs[t])
        elif ops[t] == 1:
            table = close(table, keys[t])
    return closed_out, best_out, table


def _reference(ops, keys, costs):
    best: dict[int, float] = {}
    closed: dict[int, bool] = {}
    closed_out, best_out = [], []
    for op, key, cost in zip(ops.tolist(), keys.tolist(), costs.tolist(), strict=True):
        closed_out.append(key in closed)
        best_out.append(best.get(key, math.inf))
        if op == 0:
            best[key] = cost
        elif op == 1:
            closed[key] = True
    return np.array(closed_out), np.array(best_out), best, closed


@pytest.mark.parametrize("seed, key_range, bits", [(0, 50, 2), (1, 5000, 2), (2, 2**40, 4), (3, 2**62, 12)])
def test_table_answers_as_a_dict_does(seed, key_range, bits):
    """Every answer (closed? cheapest cost?) the dict's, over thousands of mixed operations; a table started at 4
    or 16 slots grows many times on the way, and few keys over a large table collide rarely, many over a small
    range often."""
    rng = np.random.default_rng(seed)
    n = 6000
    ops = rng.integers(0, 3, n)
    keys = rng.integers(0, key_range, n)
    costs = rng.uniform(0.0, 10.0, n)
    closed_out, best_out, table = _replay(ops, keys, costs, bits)
    ref_closed, ref_best, best, closed = _reference(ops, keys, costs)
    np.testing.assert_array_equal(closed_out, ref_closed)
    np.testing.assert_array_equal(best_out, ref_best)
    tk, tb, tc, meta = table
    stored = tk != EMPTY
    assert meta[0] == stored.sum() == len(set(best) | set(closed))
    assert 2 * meta[0] <= tk.size and tk.size == 1 << (64 - meta[1])  # at most half full
    got = {int(k): float(b) for k, b in zip(tk[stored], tb[stored], strict=True) if b < math.inf}
    assert got == best
    assert {int(k) for k in tk[stored & tc]} == set(closed)


def test_keys_of_one_slot_probe_on():
    """Six keys whose hashes land in one slot of a 16-slot table (found by trying keys in turn): each is stored
    in the next free slot along and found again, and a key not stored is not found."""
    bits = 4
    table = new_table(bits)
    shift = 64 - bits
    mult = -7046029254386353131
    slots = {}
    same = []
    for key in range(200000):
        h = ((key * mult + 2**63) % 2**64 - 2**63) >> shift & ((1 << bits) - 1)
        slots.setdefault(h, []).append(key)
        if len(slots[h]) == 6:
            same = slots[h]
            break
    assert len(same) == 6
    for i, key in enumerate(same):
        table = set_best(table, key, float(i))
    for i, key in enumerate(same):
        assert best_of(table, key) == float(i)
        assert not is_closed(table, key)
    assert best_of(table, max(same) + 1) == math.inf
