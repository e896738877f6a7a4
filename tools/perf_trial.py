"""One closed-loop trial to profile with Linux ``perf``, numba's compiled functions named.

``perf`` sees numba's machine code as anonymous ``[JIT]`` addresses.  This tool runs a warm-up trial
(compiling every kernel the trial uses, into a fresh numba cache so that each compiled library still holds
its LLVM module), writes ``/tmp/perf-<pid>.map`` naming every function of every compiled library of the
``navstack`` modules (``perf report`` reads that file for ``[JIT]`` addresses), then runs the trial again
and prints the measured trial's window on ``perf``'s monotonic clock.  Usage::

    perf record -k mono -e cpu-clock -F 4000 -o perf.data python tools/perf_trial.py worlds/truss_clutter.json
    perf report -i perf.data --time <window printed> --no-children --sort dso,symbol

A library holds its callees' code too (numba links them in), so a function called from several kernels
appears under each caller's copy; LLVM may also inline it into its caller.  Issue 11's seventh round found
with it that numba's reference counting of array arguments (``NRT_incref`` / ``NRT_decref``) was 22 % of
the planner's search (``navstack/jit.py``).  ``--generate FAMILY SEED`` profiles a generated world instead.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time


def _symbols() -> list[tuple[int, str]]:
    """(address, LLVM name) of every defined function of every compiled overload in the navstack modules."""
    import numba

    out = set()
    for name, module in list(sys.modules.items()):
        if not name.startswith("navstack") or module is None:
            continue
        for value in list(vars(module).values()):
            if not isinstance(value, numba.core.registry.CPUDispatcher):
                continue
            for cres in value.overloads.values():
                library = cres.library
                try:
                    functions = list(library._final_module.functions)  # absent for a library loaded from cache
                except Exception:
                    continue
                for fn in functions:
                    if not fn.is_declaration:
                        address = library.get_pointer_to_function(fn.name)
                        if address:
                            out.add((address, fn.name))
    return sorted(out)


def write_perf_map(path: str) -> int:
    """Write the ``perf`` map of :func:`_symbols` to ``path`` (each function up to the next one's address, at
    most 1 MiB); returns how many functions it names."""
    symbols = _symbols()
    with open(path, "w") as fh:
        for (address, name), nxt in zip(symbols, symbols[1:] + [(symbols[-1][0] + 65536, "")], strict=True):
            fh.write(f"{address:x} {min(nxt[0] - address, 1 << 20):x} {name[:200].replace(' ', '_')}\n")
    return len(symbols)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("world", nargs="?", help="a world file")
    ap.add_argument("--generate", nargs=2, metavar=("FAMILY", "SEED"), help="a generated world instead")
    ap.add_argument("--seed", type=int, default=0, help="the trial's seed")
    args = ap.parse_args()
    if (args.world is None) == (args.generate is None):
        ap.error("give a world file or --generate FAMILY SEED")
    cache = tempfile.mkdtemp(prefix="navstack-perf-")
    os.environ["NUMBA_CACHE_DIR"] = cache  # compile afresh, so that each library keeps its LLVM module
    try:
        profile(args)
    finally:
        shutil.rmtree(cache, ignore_errors=True)


def profile(args: argparse.Namespace) -> None:
    """The warm-up trial, the map, the measured trial (module docstring)."""
    from navstack.trial import TrialConfig, run_trial

    if args.generate:
        from navstack.generate import generate_world

        world = generate_world(args.generate[0], int(args.generate[1]))
    else:
        from navstack.world import load_world

        world = load_world(args.world)
    run_trial(world, seed=args.seed, config=TrialConfig())  # compiles every kernel the trial uses
    count = write_perf_map(f"/tmp/perf-{os.getpid()}.map")
    start = time.clock_gettime(time.CLOCK_MONOTONIC)
    result = run_trial(world, seed=args.seed, config=TrialConfig())
    end = time.clock_gettime(time.CLOCK_MONOTONIC)
    print(f"{count} compiled functions named in /tmp/perf-{os.getpid()}.map")
    print(f"trial: {result.reason}, {result.steps} steps, {1e3 * result.wall_time / max(result.steps, 1):.2f} ms "
          f"per control step")
    print(f"window: {start:.6f},{end:.6f}")


if __name__ == "__main__":
    main()
