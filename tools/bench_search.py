"""The planner's searches of a few trials, replayed alone: how long the hybrid A* takes, without the rest.

Each world's trial runs once (slither controller, field planner, seed 0) with every call of the search
kernel captured: its inputs copied before the call, its outputs after.  Then each search is called again
``--repeats`` times on its copied inputs, and the best time of each is summed.  Every replay must give the
trial's own answer (status, final node, expansions and every node array), else the tool says so: a kernel
is deterministic in its inputs.  Printed per world: searches, total best-of-N time [ms], expansions, time
per expansion [us], the share of the time in searches that spent their whole expansion budget, and the
searches' time inside a trial: the same trial run again with the kernel's calls only timed (no copies), the
median over ``--repeats`` runs.  The replays and the trial can disagree: a change that made the replays 2-10 %
faster made the searches 10 % slower in the trial (issue 11, ninth round: the search's own hash table, its
arrays' reference counts), so a change is judged by both.  Usage::

    python tools/bench_search.py [--repeats 3] [--every N] [--worlds W.json ...]

The default worlds are the paper demo, ``truss_clutter.json`` and slot-rack seed 5 (sparse goals).  Compare
versions by running this tool in each, alternating, in one session: the machine's speed drifts.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import time

import numpy as np
from _bench_worlds import HELP, bench_worlds, trial_with

import navstack.planner.search as search_module
from navstack.trial import TrialConfig, run_trial
from navstack.world import World

NODE_ARRAYS = 10
"""The kernel's last arguments: the node arrays it fills (positions, headings, ..., lengths)."""


def capture(world: World, every: int = 1) -> list[tuple[tuple, tuple, list[np.ndarray]]]:
    """Run ``world``'s trial; every ``every``-th search kernel call as (inputs copied before, outputs, node arrays
    after)."""
    calls = []
    seen = [0]

    def recording(kernel):
        def call(*args):
            seen[0] += 1
            if (seen[0] - 1) % every:
                return kernel(*args)
            before = copy.deepcopy(args)
            out = kernel(*args)
            calls.append((before, tuple(out), [np.array(a[: out[3]]) for a in args[-NODE_ARRAYS:]]))
            return out
        return call

    trial_with(world, search_module, "_search_kernel", recording)
    return calls


def in_trial(world: World, repeats: int) -> float:
    """The median over ``repeats`` trials of ``world`` of the time [s] spent in the search kernel's calls (timed
    alone, nothing copied)."""
    spent = [0.0]

    def timed(kernel):
        def call(*args):
            t = time.perf_counter()
            out = kernel(*args)
            spent[0] += time.perf_counter() - t
            return out
        return call

    totals = []
    for _ in range(repeats):
        spent[0] = 0.0
        trial_with(world, search_module, "_search_kernel", timed)
        totals.append(spent[0])
    return statistics.median(totals)


def replay(calls, repeats: int) -> tuple[float, int, float, int]:
    """(total best time [s], expansions, time in budget-spent searches [s], mismatches)."""
    total = spent = 0.0
    expansions = mismatches = 0
    for inputs, outputs, nodes in calls:
        best = np.inf
        for _ in range(repeats):
            args = copy.deepcopy(inputs)
            t = time.perf_counter()
            out = tuple(search_module._search_kernel(*args))
            best = min(best, time.perf_counter() - t)
            filled = [a[: out[3]] for a in args[-NODE_ARRAYS:]]
            same = out == outputs and all(np.array_equal(a, b) for a, b in zip(filled, nodes, strict=True))
            mismatches += not same
        total += best
        expansions += outputs[2]
        budget = int(inputs[9][6])  # cfg = [step, samples, cell, heading_bin, epsilon, w_turn, max_expansions, ...]
        if outputs[0] == search_module.PARTIAL and outputs[2] > budget:
            spent += best
    return total, expansions, spent, mismatches


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=None, help=HELP)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--every", type=int, default=1,
                    help="replay every N-th search only (each copy holds the map: a trial of hundreds of searches)")
    args = ap.parse_args()
    if args.repeats < 1 or args.every < 1:
        ap.error("--repeats and --every must be at least 1")
    worlds = bench_worlds(args.worlds)
    run_trial(worlds[0][1], seed=0, config=TrialConfig())  # compile and load everything once
    print(f"{'world':34s} {'searches':>8s} {'best-of-' + str(args.repeats) + ' ms':>12s} {'expansions':>10s} "
          f"{'us/exp':>7s} {'budget spent':>12s} {'in trial ms':>11s}")
    for label, world in worlds:
        calls = capture(world, args.every)
        total, expansions, spent, mismatches = replay(calls, args.repeats)
        trial = in_trial(world, args.repeats)
        print(f"{label:34s} {len(calls):8d} {1e3 * total:12.1f} {expansions:10d} "
              f"{1e6 * total / max(expansions, 1):7.1f} {100 * spent / max(total, 1e-12):11.0f}% "
              f"{1e3 * trial:11.1f}", flush=True)
        if mismatches:
            print(f"  {mismatches} replays differ from the trial's own search: the kernel is not deterministic")


if __name__ == "__main__":
    main()
