"""Before/after benchmark of the controller step in one process: an older commit's controller vs this one.

Two runs of ``tools/bench_control.py`` on a shared, loaded machine can differ by 30 % on their own; this
compares in pairs instead.  The older commit's ``navstack`` package is exported (``git archive``) into a
temporary folder and imported as ``navstack_before``; both controllers then follow the 90 deg turn of
``tests/test_control.py`` side by side, in blocks of 50 steps that alternate which one runs first.  Prints
both medians per step and the median of the per-block ratios (after / before), and checks that both
give the same theta_d.

    python tools/bench_control_ab.py 8c68b31 [--rounds 5] [--hz 60]
"""

from __future__ import annotations

import argparse
import importlib
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from bench_control import _turn_commands  # noqa: E402

from navstack import jpl_serpentine  # noqa: E402
from navstack.control import ControlConfig, SlitherController  # noqa: E402


def _export(rev: str, dest: Path) -> None:
    """``navstack/`` of commit ``rev`` as the package ``navstack_before`` under ``dest``."""
    archive = dest / "before.tar"
    with archive.open("wb") as f:
        subprocess.run(["git", "-C", str(ROOT), "archive", rev, "navstack"], stdout=f, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(dest, filter="data")
    pkg = dest / "navstack"
    for path in pkg.rglob("*.py"):
        path.write_text(re.sub(r"\bnavstack\b(?=[.\s])", "navstack_before", path.read_text()))
    pkg.rename(dest / "navstack_before")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev", help="the older commit (e.g. 8c68b31)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--hz", type=float, default=60.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        _export(args.rev, Path(tmp))
        sys.path.insert(0, tmp)
        old = importlib.import_module("navstack_before.control")
        old_chain = importlib.import_module("navstack_before").jpl_serpentine()
        chain = jpl_serpentine()
        q0 = chain.q_default
        dt = 1.0 / args.hz
        xs, vs = _turn_commands(chain.points_and_jacobians(q0)[0][0], 0.05, dt)
        before, after, ratios = [], [], []
        for rnd in range(args.rounds + 1):  # round 0 compiles and warms up
            a = old.SlitherController(old_chain, old.ControlConfig(dt=dt), q0)
            b = SlitherController(chain, ControlConfig(dt=dt), q0)
            for b0 in range(0, len(xs) - 50, 50):
                times = {}
                for name, ctl in (("a", a), ("b", b)) if (b0 // 50) % 2 == 0 else (("b", b), ("a", a)):
                    t0 = time.perf_counter_ns()
                    for i in range(b0, b0 + 50):
                        ctl.step(xs[i], vs[i])
                    times[name] = (time.perf_counter_ns() - t0) / 50 / 1e3
                if rnd:
                    before.append(times["a"])
                    after.append(times["b"])
                    ratios.append(times["b"] / times["a"])
            worst = float(np.abs(a.theta_d - b.theta_d).max())
        print(f"controller step at {args.hz:g} Hz, {len(ratios)} pairs of 50-step blocks; median per step:")
        print(f"  before ({args.rev}): {statistics.median(before):7.2f} us")
        print(f"  after  (this tree) : {statistics.median(after):7.2f} us")
        print(f"  median paired ratio after/before = {statistics.median(ratios):.3f}; "
              f"|theta_d difference| at the end {worst:.1e}")


if __name__ == "__main__":
    main()
