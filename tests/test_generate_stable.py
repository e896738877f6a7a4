"""The four original families give byte-identical worlds after the generator became a package.

``tests/data/old_family_worlds.json`` holds the SHA-256 of ``save_world``'s bytes for 10 seeds x 3
difficulties (0, 0.5, 1) of ``truss``, ``cluttered-truss``, ``pipe-rack`` and ``sphere-field``, written by
the single-module generator (commit 8c68b31) before the split.  The quick test re-generates seeds 0-2;
the slow one all 120 worlds (about 20 s on the 2-core machine).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from navstack.generate import generate_world
from navstack.world import save_world

SAVED = json.loads((Path(__file__).parent / "data" / "old_family_worlds.json").read_text())
OLD = ("truss", "cluttered-truss", "pipe-rack", "sphere-field")


def _digest(family: str, seed: int, difficulty: float, folder: Path) -> tuple[str, str]:
    w = generate_world(family, seed, difficulty)
    f = folder / f"{w.name}.json"
    save_world(w, f)
    return w.name, hashlib.sha256(f.read_bytes()).hexdigest()


def test_fixture_covers_ten_seeds_three_difficulties_per_old_family():
    assert len(SAVED) == 120
    assert {name.rsplit("-s", 1)[0] for name in SAVED} == set(OLD)


@pytest.mark.parametrize("family", OLD)
def test_old_families_unchanged_quick(family, tmp_path):
    for seed in range(3):
        for difficulty in (0.0, 0.5, 1.0):
            name, digest = _digest(family, seed, difficulty, tmp_path)
            assert SAVED[name] == digest, f"{name} differs from the saved output of the old generator"


@pytest.mark.slow
def test_old_families_unchanged_all(tmp_path):
    for family in OLD:
        for seed in range(10):
            for difficulty in (0.0, 0.5, 1.0):
                name, digest = _digest(family, seed, difficulty, tmp_path)
                assert SAVED[name] == digest, f"{name} differs from the saved output of the old generator"
