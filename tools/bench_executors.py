"""Measure the pool libraries the local backend could use (why navstack.executors uses pebble, one worker per
pool). Not run in CI.

    python tools/bench_executors.py [--reps 5]          # loky is measured if installed (pip install loky)

For each of concurrent.futures.ProcessPoolExecutor, loky, a shared pebble ProcessPool and
navstack.executors.WorkerPool (2 workers each, spawn):

* overhead: 400 tasks that do nothing, tasks per second;
* crash isolation: ``--reps`` x 60 tasks of which every third kills its worker at once (``os._exit(7)``);
  counted: good tasks reported as failed (lost to another task's crash), crashing tasks reported as failed,
  and every (task, outcome) pair (``ProcessExpired``: pebble names the worker's death on that very task).

pebble is the only library with a per-task timeout (a hung task's worker is killed and replaced); that part
is covered by tests/test_executors.py.
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures as cf
import multiprocessing as mp
import os
import time


def task(kind: str) -> str:
    if kind == "crash":
        os._exit(7)
    return kind


def _collect(futs: list[cf.Future]) -> list[str]:
    out = []
    for f in futs:
        try:
            out.append(f.result(timeout=120))
        except Exception as exc:  # noqa: BLE001 - what each library reports is the measurement
            out.append(type(exc).__name__)
    return out


def run_cf(kinds: list[str]) -> list[str]:
    ex = cf.ProcessPoolExecutor(2, mp_context=mp.get_context("spawn"))
    try:
        return _collect([ex.submit(task, k) for k in kinds])
    finally:
        ex.shutdown(wait=False, cancel_futures=True)


def run_loky(kinds: list[str]) -> list[str]:
    from loky import get_reusable_executor

    ex = get_reusable_executor(max_workers=2)
    try:
        return _collect([ex.submit(task, k) for k in kinds])
    finally:
        ex.shutdown(kill_workers=True)


def run_pebble(kinds: list[str]) -> list[str]:
    import pebble

    with pebble.ProcessPool(max_workers=2, context=mp.get_context("spawn")) as pool:
        return _collect([pool.schedule(task, (k,)) for k in kinds])


def runner(world: str, *, controller: str, planner: str, seed: int, out_dir: object = None) -> dict:
    """A navstack runner whose world file names what to do."""
    kind = open(world).read().strip()
    if kind == "crash":
        os._exit(7)
    return {"success": True, "reason": "reached"}


def run_workerpool(kinds: list[str]) -> list[str]:
    from navstack.executors import TrialJob, WorkerPool
    from navstack.sweep import TrialSpec

    pool = WorkerPool(2, runner=runner)
    try:
        futs = []
        for i, k in enumerate(kinds):
            spec = TrialSpec(trial_id=f"t{i}", world_id=f"w{i}", world_file=f"/nonexistent/w{i}.json",
                             controller="slither", planner="field", seed=i, index=i)
            futs.append(pool.submit(TrialJob(spec=spec, world_text=k, runner=runner), 120.0))
        return ["ok" if r["result"] else ("ProcessExpired" if "exit code 7" in r["error"] else r["error"])
                for r in _collect(futs)]
    finally:
        pool.close(cancel=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reps", type=int, default=5)
    args = parser.parse_args()
    libs = {"concurrent.futures": run_cf, "loky": run_loky, "pebble (shared pool)": run_pebble,
            "navstack WorkerPool": run_workerpool}
    for name, fn in libs.items():
        try:
            t = time.monotonic()
            fn(["ok"] * 400)
        except ImportError:
            print(f"{name}: not installed")
            continue
        rate = 400 / (time.monotonic() - t)
        counts: collections.Counter = collections.Counter()
        for _ in range(args.reps):
            kinds = ["crash" if i % 3 == 2 else "ok" for i in range(60)]
            for k, o in zip(kinds, fn(kinds), strict=True):
                counts[(k, o)] += 1
        good = sum(v for (k, _), v in counts.items() if k == "ok")
        lost = sum(v for (k, o), v in counts.items() if k == "ok" and o != "ok")
        crashes = sum(v for (k, _), v in counts.items() if k == "crash")
        failed = sum(v for (k, o), v in counts.items() if k == "crash" and o != "ok")
        print(f"{name}: {rate:.0f} no-op tasks/s; {args.reps} x 60 tasks, every third crashing: good tasks "
              f"failed {lost}/{good}, crashing tasks reported failed {failed}/{crashes}; all (task, outcome) "
              f"counts {dict(counts)}")


if __name__ == "__main__":
    main()
