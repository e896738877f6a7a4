"""The Ray backend on a simulated 2-node cluster, with a node killed mid-sweep (not run in CI).

    python tools/ray_cluster_sweep.py --out /tmp/raycluster [--count 5] [--kill-after 10]

1. ``local``: the 40 trials (4 families x ``--count`` worlds x slither / tip-only, field planner; real
   closed-loop trials) with the local backend, ``--jobs 2``;
2. ``ray``: the same 40 trials on a Ray instance started by the sweep (``num_cpus=2``);
3. ``cluster``: the same 40 trials on a ``ray.cluster_utils.Cluster`` of two nodes on this machine (a head and a
   worker node, 1 CPU each); once ``--kill-after`` lines are recorded the worker node is removed (its raylet
   and workers killed), and the sweep must still finish on the head node.

It prints trials per minute of each run and checks that every run holds each trial exactly once and that the
lines of 2 and 3 equal those of 1 apart from ``wall_time`` and ``provenance.host`` / ``.backend``. Exit 1 if
a check fails.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path


def comparable(path: Path) -> list[dict]:
    out = []
    for line in path.read_text().splitlines():
        r = json.loads(line)
        r.pop("wall_time")
        r["provenance"] = {k: v for k, v in r["provenance"].items() if k not in ("host", "backend")}
        out.append(r)
    return out


def check(name: str, path: Path, specs: list, reference: list[dict] | None) -> bool:
    lines = comparable(path)
    ids = [r["trial_id"] for r in lines]
    ok = ids == [s.trial_id for s in specs]
    print(f"  {name}: {len(lines)} lines, {len(set(ids))} distinct trials, in trial order: {ok}")
    if reference is not None:
        same = lines == reference
        print(f"  {name}: lines equal the local backend's (apart from wall_time, host, backend): {same}")
        ok = ok and same
    return ok


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--count", type=int, default=5)
    parser.add_argument("--kill-after", type=int, default=10)
    args = parser.parse_args()

    import ray
    from ray.cluster_utils import Cluster

    from navstack.sweep import SweepConfig, build_specs, run_sweep

    specs = build_specs(SweepConfig(families=("truss", "cluttered-truss", "pipe-rack", "sphere-field"),
                                    count=args.count, seed=12, controllers=("slither", "tip-only")))
    print(f"{len(specs)} trials")
    rates = {}
    for backend in ("local", "ray"):
        s = run_sweep(specs, args.out / backend, jobs=2, backend=backend, progress=False)
        rates[backend] = s.ran / s.wall_time * 60
        print(f"{backend}: {s.ran} trials in {s.wall_time:.1f} s = {rates[backend]:.1f} trials/min "
              f"({s.succeeded} succeeded, {s.errors} errors)")
    reference = comparable(args.out / "local" / "results.jsonl")
    ok = check("local", args.out / "local" / "results.jsonl", specs, None)
    ok &= check("ray", args.out / "ray" / "results.jsonl", specs, reference)

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
    worker = cluster.add_node(num_cpus=1)
    ray.init(address=cluster.address, log_to_driver=False)
    cluster.wait_for_nodes()
    print(f"cluster: {len(ray.nodes())} nodes, {ray.cluster_resources().get('CPU')} CPUs")
    out = args.out / "cluster"
    results = out / "results.jsonl"
    box: dict = {}
    t0 = time.monotonic()
    runner = threading.Thread(target=lambda: box.update(s=run_sweep(specs, out, backend="ray", progress=False)))
    runner.start()
    while runner.is_alive() and (not results.exists() or len(results.read_text().splitlines()) < args.kill_after):
        time.sleep(0.2)
    n_before = len(results.read_text().splitlines()) if results.exists() else 0
    cluster.remove_node(worker)
    print(f"cluster: worker node killed after {n_before} lines ({time.monotonic() - t0:.1f} s)")
    runner.join()
    s = box["s"]
    print(f"cluster: {s.ran} trials in {s.wall_time:.1f} s = {s.ran / s.wall_time * 60:.1f} trials/min "
          f"({s.succeeded} succeeded, {s.errors} errors: {s.error_ids})")
    ok &= check("cluster", results, specs, reference)
    ray.shutdown()
    cluster.shutdown()
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
