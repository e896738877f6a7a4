"""navstack.jit.kernel: numba without reference counting, for functions that allocate nothing."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from navstack.jit import NO_REFCOUNT, kernel


def test_this_numba_has_the_option_the_search_relies_on_for_speed():
    # without it kernel() is plain numba.njit: the same results, the search about a third slower (navstack/jit.py)
    assert NO_REFCOUNT == {"_nrt": False}


def test_a_kernel_reads_and_writes_arrays_and_calls_another():
    @kernel
    def total(a):
        s = 0.0
        for x in a:
            s += x
        return s

    @kernel(inline="never")
    def fill(out, a):
        for i in range(out.shape[0]):
            out[i] = total(a) + i

    out = np.zeros(4)
    a = np.arange(5.0)
    fill(out, a)
    assert out.tolist() == [10.0, 11.0, 12.0, 13.0]
    assert a.tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_a_kernel_that_allocates_is_refused_at_compile_time():
    @kernel
    def zeros(n):
        return np.zeros(n)

    with pytest.raises(numba.core.errors.TypingError):
        zeros(3)


def test_the_planners_hot_kernels_are_compiled_without_reference_counting():
    from navstack.planner import potential, proximity, search

    for fn in (proximity.distances_below, proximity.segment_distance_below, proximity._quiet, proximity.distance_below,
               search._body_clear, search._link_distance, search._last_link_clear, search._heuristic, potential.cost_at,
               potential._wave_settle):
        assert fn.targetoptions.get("_nrt") is False, fn.__name__
