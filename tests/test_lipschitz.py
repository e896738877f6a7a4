"""The sampled minimum of a rate-bounded function (navstack.sim.lipschitz), against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navstack.sim.lipschitz import interval_bound, sampled_minimum


def exact(g):
    return lambda t: (g(t), g(t))


def test_the_interval_bound_is_where_the_two_cones_meet_and_never_above_an_end():
    assert interval_bound(1.0, 1.0, 2.0, 0.5) == pytest.approx(0.5)
    assert interval_bound(1.0, 0.2, 1.0, 0.1) == pytest.approx(0.2)  # the cones meet outside: the lower end
    rng = np.random.default_rng(0)
    for _ in range(200):  # no rate-bounded function through the ends goes below it (piecewise-linear probes)
        la, lb, rate, h = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.1, 5), rng.uniform(0.01, 1)
        t = np.linspace(0.0, h, 201)
        lowest = np.maximum(la - rate * t, lb - rate * (h - t)).min()  # the lowest such function
        assert interval_bound(la, lb, rate, h) <= lowest + 1e-12


def test_a_vibration_seen_at_its_zero_crossings_is_found():
    """A review's case: a sphere 0.1 mm from a link vibrating 0.318 mm at 990 Hz; the even samples fall on
    the zero crossings, so even sampling saw 0.1 mm at every one and the 0.218 mm contact went unseen."""
    amp, period, gap = 0.318e-3, 1.0 / 990.0, 0.1e-3
    rate = 2.0 * math.pi * amp / period
    g = lambda t: gap - amp * math.sin(2.0 * math.pi * t / period)  # noqa: E731
    n = math.ceil(rate * (1.0 / 30.0) / 1e-3)
    assert n == 66 and all(abs(g(k / 30.0 / n) - gap) < 1e-12 for k in range(n + 1))  # aliased
    best, calls = sampled_minimum(exact(g), 0.0, 1.0 / 30.0, n, rate)
    assert best <= 0.0 and calls > n + 1
    coarse = min(g(k / 30.0 / n) for k in range(n + 1))
    assert coarse == pytest.approx(gap)  # what sampling alone reported


def test_no_contact_costs_nothing_more_when_the_bound_clears_the_floor():
    g = lambda t: 0.01 + 0.001 * math.sin(40.0 * t)  # noqa: E731  stays 9 mm clear
    best, calls = sampled_minimum(exact(g), 0.0, 0.1, 10, rate=0.04)
    assert calls == 11 and best == pytest.approx(min(g(k / 100) for k in range(11)))


def test_a_graze_between_samples_is_found_down_to_the_resolution():
    """A V-shaped dip to -d between two samples; found for d above the resolution, never a false contact."""
    rate = 1.0
    for d in (1e-4, 1e-5, 2e-6):
        g = lambda t, d=d: abs(t - 0.0123) * rate - d  # noqa: E731
        best, _ = sampled_minimum(exact(g), 0.0, 0.05, 5, rate, resolution=1e-6)
        assert best <= 0.0, d
    g = lambda t: abs(t - 0.0123) * rate + 1e-6  # noqa: E731  the closest approach 1 um clear
    best, calls = sampled_minimum(exact(g), 0.0, 0.05, 5, rate, resolution=1e-6)
    assert best > 0.0 and calls < 200


def test_lower_bounds_are_used_for_the_intervals():
    """f's value may read high (PyBullet's rounded corners): intervals are judged by the lower bounds."""
    g = lambda t: 0.0005 + abs(t - 0.5) * 0.01  # noqa: E731  true values, 0.5 mm clear at best
    high = lambda t: (g(t) + 0.0007, g(t))  # noqa: E731  reads 0.7 mm high, lower bound exact
    best, calls = sampled_minimum(high, 0.0, 1.0, 4, rate=0.01)
    assert best > 0.0 and calls == 5  # bounds (0.5 mm + ...) clear 0: nothing to refine


@pytest.mark.parametrize("bad", [dict(t0=1.0, t1=1.0), dict(n=0), dict(rate=-1.0), dict(resolution=0.0),
                                 dict(t1=float("nan"))])
def test_bad_arguments_are_named(bad):
    args = dict(t0=0.0, t1=1.0, n=2, rate=1.0, resolution=1e-6) | bad
    with pytest.raises(ValueError, match="sampled_minimum"):
        sampled_minimum(exact(lambda t: 1.0), args["t0"], args["t1"], args["n"], args["rate"],
                        resolution=args["resolution"])


def test_past_max_extra_a_possible_contact_is_counted_never_missed():
    """A value a hair above the floor for the whole interval (a mover sliding past a link 1 um away) cannot be
    cleared by the speed bound without about rate * T / (2 gap) samples; past max_extra the least bound left is
    returned: a contact that may not have happened, never one missed (a review's slowdown: 171,009 PyBullet
    queries for one control step)."""
    g = lambda t: 1e-6  # noqa: E731
    best, calls = sampled_minimum(exact(g), 0.0, 1.0 / 30.0, 167, rate=5.0, max_extra=300)
    assert calls == 168 + 300 and -0.5e-3 <= best <= 0.0
    best, calls = sampled_minimum(exact(lambda t: 3e-4), 0.0, 1.0 / 30.0, 167, rate=5.0, max_extra=300)
    assert best == 3e-4 and calls <= 168 + 300  # 0.3 mm clears the bound within the budget
    with pytest.raises(ValueError, match="max_extra"):
        sampled_minimum(exact(g), 0.0, 1.0, 2, 1.0, max_extra=-1)
