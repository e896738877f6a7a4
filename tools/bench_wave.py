"""The navigation functions of a few trials, rebuilt alone: what the planner's Dijkstra wavefront costs.

Each world's trial runs once (slither controller, field planner, seed 0) with every navigation function it builds
captured at its start: the cost grid, the goal, its reach, the grid's origin and cell (the wavefront's whole
input, the same whatever the version).  Then each is rebuilt ``--repeats`` times and its wavefront run to the end
(every reachable cell settled; a trial settles only the cells its searches ask for, 8-24 % of them), each timed
alone; printed per world: navigation functions, cells settled, the sum of their best times [ms], ns per settled
cell, and a digest of every value of every grid.  Versions that compute the same values print the same digest:
compare versions by running this tool in each (``PYTHONPATH``), alternating, in one session (the machine's
speed drifts).  Usage::

    python tools/bench_wave.py [--repeats 7] [--worlds W.json ...]

The default worlds are the paper demo, ``truss_clutter.json`` and slot-rack seed 5 (sparse goals).
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import time

import numpy as np
from _bench_worlds import HELP, bench_worlds, trial_with

import navstack.planner.potential as potential
from navstack.world import World

Wave = tuple[np.ndarray, np.ndarray, float, np.ndarray, float]
"""A navigation function's input: (cost grid, goal [m], reach [m], origin [m], cell [m])."""


def capture(world: World) -> list[Wave]:
    """Every navigation function ``world``'s trial builds (seed 0), as the input of its wavefront."""
    got: list[Wave] = []

    def recording(seed):
        def call(wave, goal, reach, origin, cell):
            got.append((wave[0].copy(), goal.copy(), float(reach), origin.copy(), float(cell)))
            return seed(wave, goal, reach, origin, cell)
        return call

    trial_with(world, potential, "_wave_seed", recording)
    return got


def _state(cost: np.ndarray, values: np.ndarray, cell: float) -> tuple:
    """``potential._wave_state`` of the version on the path (before session 46's ring of buckets it also took
    the values' array), so that this tool times older versions too."""
    if len(inspect.signature(potential._wave_state).parameters) == 3:
        return potential._wave_state(cost, values, cell)
    return potential._wave_state(cost, cell)


def rebuild(wave: Wave) -> tuple[float, np.ndarray]:
    """One navigation function built from ``wave`` and finished: (seconds, its values)."""
    cost, goal, reach, origin, cell = wave
    values = np.empty(cost.shape)
    t0 = time.perf_counter()
    state = _state(cost, values, cell)
    potential._wave_seed(state, goal, reach, origin, cell)
    nav = potential.NavigationFunction(origin, cell, values, state)
    done = nav.values
    return time.perf_counter() - t0, done


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="rebuilds of each navigation function (default 7)")
    parser.add_argument("--worlds", nargs="+", metavar="W.json", help=HELP)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    print(f"{'world':34s} {'grids':>5s} {'cells':>9s} {'best ms':>8s} {'ns/cell':>8s}  digest of the values")
    for label, world in bench_worlds(args.worlds):
        waves = capture(world)
        digest = hashlib.sha1()
        total, cells = 0.0, 0
        for wave in waves:
            best = np.inf
            for _ in range(args.repeats):
                seconds, values = rebuild(wave)
                best = min(best, seconds)
            total += best
            cells += int(np.isfinite(values).sum())
            digest.update(values.tobytes())
        print(f"{label:34s} {len(waves):5d} {cells:9d} {1e3 * total:8.1f} {1e9 * total / max(cells, 1):8.1f}  "
              f"{digest.hexdigest()[:16]}")


if __name__ == "__main__":
    main()
