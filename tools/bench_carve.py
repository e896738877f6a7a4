"""The sensed map's carving of a few trials, replayed alone: what one reading's free space and clean pass cost.

Each world's trial runs once (slither controller, field planner, seed 0) with every call of the map's
``_carve`` kernel captured (every array copied before the call: the map as the call found it).  Then the
captured calls are replayed in order on fresh copies, ``--repeats`` times, and each replay's mean time per
call is taken; printed per world: calls, and the median and best over the repeats [us per call].  Every
replay must return the trial's own answer (removed and contradicted counts) and leave every array as the
trial's call left it (the per-ray ``visit`` scratch apart), else the tool says so: the kernel is deterministic
in its inputs.  Usage::

    python tools/bench_carve.py [--repeats 7] [--worlds W.json ...]

The default worlds are the paper demo, ``truss_clutter.json`` and slot-rack seed 5 (sparse goals).  Compare
versions by running this tool in each, alternating, in one session: the machine's speed drifts.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _bench_worlds import HELP, bench_worlds

import navstack.planner.map as map_module
from navstack.trial import run_trial

VISIT = 15
"""``_carve``'s argument index of ``visit``, the per-ray scratch tag of each bucket (not compared)."""


def _copy(args: list) -> list:
    return [a.copy() if isinstance(a, np.ndarray) else a for a in args]


def capture(world) -> list[tuple[list, list, tuple]]:
    """Every ``_carve`` call of ``world``'s trial: (arguments before, arguments after, returned value)."""
    kernel = map_module._carve
    calls = []

    def wrapped(*args):
        before = _copy(list(args))
        out = kernel(*args)
        calls.append((before, _copy(list(args)), out))
        return out

    map_module._carve = wrapped
    try:
        run_trial(world, seed=0)
    finally:
        map_module._carve = kernel
    return calls


def replay(calls: list[tuple[list, list, tuple]]) -> float:
    """One replay of ``calls`` on fresh copies, checked against the trial's; mean seconds per call."""
    fresh = [_copy(before) for before, _, _ in calls]
    t0 = time.perf_counter()
    outs = [map_module._carve(*args) for args in fresh]
    elapsed = time.perf_counter() - t0
    for n, ((_, after, out), args, got) in enumerate(zip(calls, fresh, outs, strict=True)):
        same = got == out and all(not isinstance(a, np.ndarray) or k == VISIT or np.array_equal(a, b, equal_nan=True)
                                  for k, (a, b) in enumerate(zip(args, after, strict=True)))
        if not same:
            raise SystemExit(f"error: replayed call {n} differs from the trial's")
    return elapsed / max(len(calls), 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="replays per world (default 7)")
    parser.add_argument("--worlds", nargs="+", metavar="W.json", help=HELP)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    print(f"{'world':34s} {'calls':>6s} {'median us':>10s} {'best us':>8s}")
    for label, world in bench_worlds(args.worlds):
        calls = capture(world)
        times = [replay(calls) * 1e6 for _ in range(args.repeats)]
        print(f"{label:34s} {len(calls):6d} {statistics.median(times):10.1f} {min(times):8.1f}")


if __name__ == "__main__":
    main()
