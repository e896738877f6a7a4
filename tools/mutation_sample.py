"""Keep a seeded random sample of a cosmic-ray session's pending mutants; mark the rest skipped.

    python tools/mutation_sample.py SESSION N [--seed S]

For a module whose tests are too slow to run against every mutant: the kill rate of a uniform sample is an
unbiased estimate of the module's (``cr-rate --estimate`` gives its confidence interval). Run after the
filters and before ``cosmic-ray exec`` (tools/mutation.sh does, with ``SAMPLE=N``).
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
    args = ap.parse_args(argv)
    with use_db(args.session, WorkDB.Mode.open) as db:
        pending = sorted(item.job_id for item in db.pending_work_items)
        keep = set(random.Random(args.seed).sample(pending, min(args.n, len(pending))))
        for job in pending:
            if job not in keep:
                db.set_result(job, WorkResult(output="not in the sample", worker_outcome=WorkerOutcome.SKIPPED))
    print(f"{len(keep)} of {len(pending)} pending mutants kept (seed {args.seed})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
