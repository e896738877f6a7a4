"""Cost of ``navstack animate`` on a 25-second trial (issue 13's target: under 20 s on the 2-core machine).

Runs the paper's truss demo with the ``tip-only`` controller (22.9 s simulated, links in contact for the red
links), holds its last pose to 25 s, and animates it with the default configuration (768x432, 15 fps),
printing the wall time and the CPU time (ffmpeg included).  Usage::

    python tools/bench_animate.py [--keep DIR]
"""

from __future__ import annotations

import argparse
import resource
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from navstack.animate import animate_stats
from navstack.trial import run_trial
from navstack.truss import paper_truss_world


def make_run(folder: Path, seconds: float = 25.0) -> Path:
    """The tip-only demo trial in ``folder``, its trajectory extended to ``seconds`` by holding the last pose."""
    run_trial(paper_truss_world(), controller="tip-only", planner="field", out_dir=folder)
    data = dict(np.load(folder / "trajectory.npz"))
    dt = float(data["t"][1] - data["t"][0])
    extra = int(round(seconds / dt)) + 1 - len(data["t"])
    if extra > 0:
        data = {k: np.concatenate([v, np.repeat(v[-1:], extra, axis=0)]) for k, v in data.items()}
        data["t"] = np.arange(len(data["t"])) * dt
    np.savez(folder / "trajectory.npz", **data)
    return folder


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keep", help="folder to keep the run and its animation in (default: a temporary one)")
    args = ap.parse_args()
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-animate-"))
    try:
        make_run(folder)
        cpu0 = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        stats = animate_stats(folder)
        wall = time.perf_counter() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = sum(b.ru_utime + b.ru_stime - a.ru_utime - a.ru_stime for a, b in zip(cpu0, cpu1, strict=True))
        c = stats.config
        print(f"25.0 s trial: {stats.frames} frames {c.width}x{c.height} at {c.fps:g} fps in {wall:.1f} s wall, "
              f"{cpu:.1f} s CPU (ffmpeg included); load average {', '.join(f'{x:.1f}' for x in _load())}")
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)


def _load() -> tuple[float, float, float]:
    import os

    return os.getloadavg()


if __name__ == "__main__":
    main()
