"""The worlds the speed benchmarks run by default (bench_floor.py, bench_search.py, bench_stages.py)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

from navstack.world import World, WorldError, load_world

ROOT = Path(__file__).resolve().parents[1]
HELP = "world files (default: the paper demo, truss_clutter.json and slot-rack seed 5)"


def bench_worlds(paths: list[str] | None) -> list[tuple[str, World]]:
    """(label, world) for each file in ``paths``; by default the paper demo, ``truss_clutter.json`` and
    slot-rack seed 5 (sparse goals)."""
    if paths:
        try:
            return [(Path(p).stem, load_world(p)) for p in paths]
        except WorldError as e:  # a bad or missing file: its message, not a traceback
            raise SystemExit(f"error: {e}") from None
    from navstack.generate import generate_world

    return [("paper_truss (demo)", load_world(ROOT / "worlds" / "paper_truss.json")),
            ("truss_clutter", load_world(ROOT / "worlds" / "truss_clutter.json")),
            ("slot-rack seed 5 (sparse goals)", generate_world("slot-rack", 5))]


def trial_with(world: World, module: ModuleType, name: str, wrap: Callable) -> None:
    """Run ``world``'s trial (slither controller, field planner, seed 0) with ``module.name`` replaced by
    ``wrap(original)``, restored after; a failed trial stops the tool with its error."""
    from navstack.trial import run_trial

    original = getattr(module, name)
    setattr(module, name, wrap(original))
    try:
        result = run_trial(world, seed=0)
    finally:
        setattr(module, name, original)
    if result.reason == "error":
        raise SystemExit(f"error: the trial on {world.name} failed: {result.error}")
