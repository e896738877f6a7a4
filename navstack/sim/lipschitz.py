"""The smallest value of a sampled function of time that changes no faster than a known rate.

A moving obstacle's clearance to a robot held still changes no faster than the obstacle moves (m/s): between
two samples ``h`` seconds apart with values at least ``la`` and ``lb``, no value is below
``min(la, lb, (la + lb - rate h) / 2)`` (the two cones of slope ``rate`` from the samples meet there).  Even
sampling alone cannot bound a miss: an obstacle that reverses between two samples (a vibration at a period
commensurate with the samples' spacing) can be seen at the same place at every sample, and a contact of half
the travel between samples, 0.5 mm for 1 mm spacing, went unseen.  :func:`sampled_minimum` samples evenly, then
halves every interval whose bound reaches a floor (0 m: a contact) until the bound clears it or the interval
is shorter than ``resolution / rate``.  Pure Python, no simulator: the caller's ``f`` does the measuring.
"""

from __future__ import annotations

from collections.abc import Callable

Sample = tuple[float, float]
"""``(value, lower)``: a measured value and a lower bound on the true one (``lower <= true <= value``)."""


def interval_bound(la: float, lb: float, rate: float, h: float) -> float:
    """The least value a function with lower bounds ``la``, ``lb`` at the ends of an interval ``h`` long, changing
    no faster than ``rate`` per unit, can take inside it."""
    return min(la, lb, 0.5 * (la + lb - rate * h))


def sampled_minimum(f: Callable[[float], Sample], t0: float, t1: float, n: int, rate: float, floor: float = 0.0,
                    resolution: float = 1e-6, max_extra: int = 1000) -> tuple[float, int]:
    """The smallest value ``f`` gives on ``[t0, t1]``, sampled at ``n + 1`` even times then wherever a miss could
    reach ``floor``.

    Args:
        f: ``t -> (value, lower)`` (:data:`Sample`).
        t0, t1: the interval (s), ``t0 < t1``.
        n: the number of even intervals first sampled (at least 1).
        rate: how fast the true value may change (units per s), at least 0.
        floor: an interval is halved while its :func:`interval_bound` is at or below this (0 m: a contact could
            hide there).
        resolution: an interval over which the value changes by at most this is not halved: a value at most
            ``resolution`` / 2 below ``floor`` may hide in it.
        max_extra: the most calls of ``f`` after the even samples.  A value that stays within a hair of
            ``floor`` over a long stretch (a mover sliding past a link a micrometre away) would need about
            ``rate (t1 - t0) / (2 gap)`` of them; past this many, the least bound of the intervals left is
            returned if it is lower than what was found: the answer may then be a contact that did not happen
            (a wrong failure), never a missed one.

    Returns:
        ``(smallest value found or bound, number of calls of f)``.
    """
    if not (t1 > t0 and n >= 1 and rate >= 0.0 and resolution > 0.0 and max_extra >= 0):
        raise ValueError(f"sampled_minimum: need t0 < t1, n >= 1, rate >= 0, resolution > 0, max_extra >= 0; got "
                         f"t0={t0!r}, t1={t1!r}, n={n!r}, rate={rate!r}, resolution={resolution!r}, "
                         f"max_extra={max_extra!r}")
    times = [t0 + (t1 - t0) * k / n for k in range(n)] + [t1]
    samples = [f(t) for t in times]
    best = min(v for v, _ in samples)
    calls = len(samples)
    todo = [(times[k], samples[k][1], times[k + 1], samples[k + 1][1]) for k in range(n)]
    while todo and best > floor:
        a, la, b, lb = todo.pop()
        if rate * (b - a) <= resolution or interval_bound(la, lb, rate, b - a) > floor:
            continue
        if calls - len(samples) >= max_extra:  # give up on the rest: their bound, never a missed contact
            left = [interval_bound(la, lb, rate, b - a)] + [interval_bound(x, y, rate, v - u) for u, x, v, y in todo
                                                            if rate * (v - u) > resolution]
            return min(best, *left), calls
        mid = 0.5 * (a + b)
        value, lower = f(mid)
        calls += 1
        best = min(best, value)
        if best <= floor:
            break  # found: the rest cannot make the answer any more of a contact
        todo += [(a, la, mid, lower), (mid, lower, b, lb)]
    return best, calls

