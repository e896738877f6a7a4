"""The worlds the speed benchmarks run by default (bench_floor.py, bench_search.py, bench_stages.py)."""

from __future__ import annotations

from pathlib import Path

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
