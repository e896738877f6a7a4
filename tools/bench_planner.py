"""Planner step cost: the sensing planner (``field``) next to the earlier reactive one, in the same run.

Runs closed-loop trials (slither controller) on a few worlds with each planner and times every call of
the planner's ``step`` (sensing fusion, map, replanning, steering) with ``time.perf_counter``; the
simulator, the ray cast and the range filter are outside the timed call.  Prints, per world and planner,
the outcome, the number of steps, the median, 90th and 99th percentile and the largest step [us], and the
ratio of the medians.  Usage::

    python tools/bench_planner.py [--worlds W1.json W2.json ...] [--seed N]

Timing varies with the machine's load: compare planners within one run, not across runs.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from navstack.registry import PLANNERS, load
from navstack.trial import run_trial

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_WORLDS = ("paper_truss.json", "truss_clutter.json", "slot_rack.json", "sparse_truss.json")


def timed_run(world: Path, planner: str, seed: int) -> tuple[str, np.ndarray]:
    """Run one trial with ``planner``; the outcome and every step's duration [s]."""
    factory = load(PLANNERS[planner].factory)
    times: list[float] = []

    def make(ctx):
        inner = factory(ctx)
        step = inner.step

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            out = step(*args, **kwargs)
            times.append(time.perf_counter() - t0)
            return out

        inner.step = timed
        return inner

    import navstack.trial as trial_module

    name = PLANNERS[planner].factory.split(":")[1]
    original = getattr(trial_module, name)
    setattr(trial_module, name, make)
    try:
        result = run_trial(world, planner=planner, seed=seed)
    finally:
        setattr(trial_module, name, original)
    return f"{result.reason} {result.goals_reached}", np.array(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=[str(ROOT / "worlds" / w) for w in DEFAULT_WORLDS])
    ap.add_argument("--planners", nargs="+", default=["field", "reactive"])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    run_trial(ROOT / "worlds" / "paper_truss.json", planner="field", seed=args.seed)  # compile the kernels first
    print(f"{'world':22s} {'planner':9s} {'outcome':12s} {'steps':>6s} {'median':>8s} {'p90':>8s} {'p99':>9s} "
          f"{'max':>9s}  [us]")
    for w in args.worlds:
        medians = {}
        for planner in args.planners:
            outcome, t = timed_run(Path(w), planner, args.seed)
            us = t * 1e6
            medians[planner] = float(np.median(us))
            print(f"{Path(w).stem:22s} {planner:9s} {outcome:12s} {len(us):6d} {np.median(us):8.0f} "
                  f"{np.percentile(us, 90):8.0f} {np.percentile(us, 99):9.0f} {us.max():9.0f}")
        if len(medians) == 2:
            a, b = args.planners
            print(f"{'':22s} median {a}/{b} = {medians[a] / medians[b]:.2f}")


if __name__ == "__main__":
    main()
