"""Worlds for measuring how much truss misplacement the sensor-based planner tolerates.

Writes the paper's truss displaced from its drawing by ``--offsets`` metres in ``--directions`` directions
of the entry face's plane (world y-z; the lathe bed inserts along x), goals left at the drawn positions.
Each world's ``family`` is ``offset-<cm>cm``, so a report groups success by offset:

    python tools/misplacement.py --out /tmp/misplaced/worlds
    navstack trials --worlds /tmp/misplaced/worlds --planner field --planner scripted --out /tmp/misplaced/sweep
    navstack report /tmp/misplaced/sweep

A goal inside the opening stays reachable within its 0.02 m tolerance while the offset is below about the
opening's free radius (incircle 0.146 m - member 0.02 m - serpentine 0.025 m ~ 0.10 m), so offsets up to
0.08 m are solvable in principle; the blind ``scripted`` planner is the peer that trusts the drawing.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from navstack.truss import paper_truss_world
from navstack.world import save_world, world_from_dict


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="folder for the world files")
    ap.add_argument("--offsets", type=float, nargs="+", default=[0.0, 0.02, 0.04, 0.06, 0.08],
                    help="truss offsets from the drawing [m]")
    ap.add_argument("--directions", type=int, default=8, help="directions per offset in the y-z plane")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    n = 0
    for off in args.offsets:
        dirs = [0.0] if off == 0 else [2 * math.pi * k / args.directions for k in range(args.directions)]
        for k, a in enumerate(dirs):
            shift = off * np.array([0.0, math.cos(a), math.sin(a)])
            d = paper_truss_world(truss_offset=shift, name=f"truss-offset-{off * 100:.0f}cm-dir{k}")
            d["family"] = f"offset-{off * 100:02.0f}cm"
            save_world(world_from_dict(d), out / f"offset{off * 100:02.0f}_dir{k}.json")
            n += 1
    print(f"wrote {n} worlds to {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
