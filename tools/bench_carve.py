"""The sensed map's carving of a few trials, replayed alone: what one reading's free space and clean pass cost.

Each world's trial runs once (slither controller, field planner, seed 0) with its calls of the map's ``_carve``
kernel captured: every ``--every``-th call (default: enough to keep at most 200) with every array copied before
the call (the map as the call found it) and a digest of each array after it.  Then the captured calls are
replayed on fresh copies, ``--repeats`` times, each call timed alone (the copies made outside the timer, so
a call finds the map's arrays in the caches, which a trial's call may not: compare versions, not trials); printed
per world: calls captured of the trial's, and the median and best over the repeats of the mean time per call [us].
Every replay must return the trial's own answer (removed and contradicted counts) and leave every array as the
trial's call left it (the per-ray ``visit`` scratch apart), else the tool says so: the kernel is deterministic in
its inputs.  Usage::

    python tools/bench_carve.py [--repeats 7] [--every N] [--worlds W.json ...]

The default worlds are the paper demo, ``truss_clutter.json`` and slot-rack seed 5 (sparse goals).  Compare
versions by running this tool in each, alternating, in one session: the machine's speed drifts.
"""

from __future__ import annotations

import argparse
import hashlib
import statistics
import time

import numpy as np
from _bench_worlds import HELP, bench_worlds, trial_with

import navstack.planner.map as map_module

VISIT = 15
"""``_carve``'s argument index of ``visit``, the per-ray scratch tag of each bucket (not compared)."""
MAX_CALLS = 200
"""Calls kept per world by default: each keeps a copy of the map's arrays (a few MB)."""


def _copy(args: list) -> list:
    return [a.copy() if isinstance(a, np.ndarray) else a for a in args]


def _digest(args: list) -> list:
    """Each array argument's bytes hashed (``visit`` left out), other arguments as they are."""
    return [None if k == VISIT else hashlib.sha1(a.tobytes()).hexdigest() if isinstance(a, np.ndarray) else a
            for k, a in enumerate(args)]


def capture(world, every: int | None) -> tuple[int, list[tuple[list, list, tuple]]]:
    """``world``'s trial's ``_carve`` calls: how many in all, and every ``every``-th (default: a first run's
    count thinned to at most ``MAX_CALLS``) as (arguments before, digests after, returned value)."""
    calls: list[tuple[list, list, tuple]] = []
    n = 0
    step = 0  # 0: count only

    def recording(kernel):
        def call(*args):
            nonlocal n
            keep = step > 0 and n % step == 0
            n += 1
            before = _copy(list(args)) if keep else None
            out = kernel(*args)
            if keep:
                calls.append((before, _digest(list(args)), out))
            return out

        return call

    if every is None:
        trial_with(world, map_module, "_carve", recording)
        step, n = max(1, -(-n // MAX_CALLS)), 0
    else:
        step = every
    trial_with(world, map_module, "_carve", recording)
    return n, calls


def replay(calls: list[tuple[list, list, tuple]]) -> float:
    """One replay of ``calls``, each on fresh copies and timed alone, checked against the trial's; mean seconds
    per call."""
    elapsed = 0.0
    for n, (before, after, out) in enumerate(calls):
        args = _copy(before)
        t0 = time.perf_counter()
        got = map_module._carve(*args)
        elapsed += time.perf_counter() - t0
        if got != out or _digest(args) != after:
            raise SystemExit(f"error: replayed call {n} differs from the trial's")
    return elapsed / max(len(calls), 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="replays per world (default 7)")
    parser.add_argument("--every", type=int, help=f"keep every N-th call (default: at most {MAX_CALLS} calls)")
    parser.add_argument("--worlds", nargs="+", metavar="W.json", help=HELP)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    if args.every is not None and args.every < 1:
        parser.error("--every must be at least 1")
    print(f"{'world':34s} {'calls':>11s} {'median us':>10s} {'best us':>8s}")
    for label, world in bench_worlds(args.worlds):
        total, calls = capture(world, args.every)
        times = [replay(calls) * 1e6 for _ in range(args.repeats)]
        print(f"{label:34s} {len(calls):4d} of {total:4d} {statistics.median(times):10.1f} {min(times):8.1f}")


if __name__ == "__main__":
    main()
