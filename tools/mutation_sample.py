"""Keep a seeded random sample of a cosmic-ray session's pending mutants; mark the rest skipped.

    python tools/mutation_sample.py SESSION N [--seed S] [--exclude EARLIER_SESSION ...]

For a module whose tests are too slow to run against every mutant: the kill rate of a uniform sample is an
unbiased estimate of the module's (``cr-rate --estimate`` gives its confidence interval). Run after the
filters and before ``cosmic-ray exec`` (tools/mutation.sh does, with ``SAMPLE=N``; ``EXCLUDE="S1 S2"`` passes
``--exclude``). ``--exclude``: the mutants an earlier session of the same module tested (the same operator at
the same place of the same source) are marked skipped first, so a new sample, or ``N`` large, takes only the
rest.
"""

from __future__ import annotations

import argparse
import random

from cosmic_ray.work_db import WorkDB, use_db
from cosmic_ray.work_item import WorkerOutcome, WorkResult


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("session")
    ap.add_argument("n", type=int)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--exclude", nargs="*", default=[], metavar="SESSION",
                    help="earlier sessions of the module: the mutants they tested are skipped")
    args = ap.parse_args(argv)
    done = set()
    for earlier in args.exclude:
        with use_db(earlier, WorkDB.Mode.open) as db:
            done |= {_where(item) for item, result in db.completed_work_items
                     if result.worker_outcome != WorkerOutcome.SKIPPED}
    with use_db(args.session, WorkDB.Mode.open) as db:
        tested = [item.job_id for item in db.pending_work_items if _where(item) in done]
        for job in tested:
            db.set_result(job, WorkResult(output="tested in an earlier session", worker_outcome=WorkerOutcome.SKIPPED))
        if args.exclude:
            print(f"{len(tested)} pending mutants skipped: tested in {', '.join(args.exclude)}")
        pending = sorted(item.job_id for item in db.pending_work_items)
        keep = set(random.Random(args.seed).sample(pending, min(args.n, len(pending))))
        for job in pending:
            if job not in keep:
                db.set_result(job, WorkResult(output="not in the sample", worker_outcome=WorkerOutcome.SKIPPED))
    print(f"{len(keep)} of {len(pending)} pending mutants kept (seed {args.seed})")
    return 0


def _where(item) -> tuple:
    """What a mutant is, the same in every session of a module: each mutation's file, operator, place and
    occurrence."""
    return tuple((str(m.module_path), m.operator_name, tuple(m.start_pos), tuple(m.end_pos), m.occurrence)
                 for m in item.mutations)


if __name__ == "__main__":
    raise SystemExit(main())
