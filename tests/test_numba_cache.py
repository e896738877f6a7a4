"""The test suite's numba cache is keyed by the sources compiled code can see (tests/conftest.py)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numba.core.config
from conftest import NUMBA_CACHE_DIR, PKG, compiled_sources, source_hash


def test_the_suite_uses_the_keyed_cache_directory():
    assert os.environ["NUMBA_CACHE_DIR"] == NUMBA_CACHE_DIR == numba.core.config.CACHE_DIR
    assert Path(NUMBA_CACHE_DIR).name == f"src-{source_hash()}"


def test_every_file_with_kernels_and_what_they_import_is_hashed():
    names = {p.relative_to(PKG).as_posix() for p in compiled_sources()}
    assert {"kinematics.py", "path.py", "control/fast.py", "generate/geometry.py", "estimate.py",
            "fused.py"} <= names  # numba kernels, and the intrinsic they call
    assert {"jpl.py", "world.py"} <= names  # modules whose globals kernels may read
    assert "trial.py" not in names and "report.py" not in names  # no kernel can see these


def test_an_edit_to_a_callee_changes_the_key(tmp_path):
    pkg = tmp_path / "navstack"
    shutil.copytree(PKG, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = source_hash(pkg)
    assert before == source_hash(PKG)
    path = pkg / "path.py"
    path.write_text(path.read_text().replace("    return n + 1\n", "    return n + 2\n", 1))
    assert source_hash(pkg) != before
    trial = pkg / "trial.py"
    path.write_text((PKG / "path.py").read_text())
    trial.write_text(trial.read_text() + "\n# a comment\n")
    assert source_hash(pkg) == before  # trial.py is outside every kernel's reach
