"""The test suite's numba cache is keyed by the sources compiled code can see (tests/conftest.py)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
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


# ---------------------------------------------------------------------- the library's own keyed cache


def test_the_library_hashes_the_sources_kernels_can_see():
    from navstack import numba_cache

    assert set(numba_cache.KERNEL_SOURCES) == {p.relative_to(PKG).as_posix() for p in compiled_sources()}


def test_configure_keys_the_folder_keeps_a_set_one_and_removes_stale_ones(tmp_path, monkeypatch):
    from navstack import numba_cache

    monkeypatch.setattr(numba.core.config, "CACHE_DIR", numba.core.config.CACHE_DIR)  # restored afterwards
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/somewhere/else")
    assert numba_cache.configure(tmp_path) == "/somewhere/else" and not list(tmp_path.iterdir())
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    stale, recent = tmp_path / "src-0000000000000000", tmp_path / "src-1111111111111111"
    for folder, age_days in ((stale, 31), (recent, 29)):
        folder.mkdir()
        os.utime(folder, (time.time() - age_days * 86400,) * 2)
    here = numba_cache.configure(tmp_path)
    assert here == str(tmp_path / f"src-{numba_cache.source_key()}")
    assert os.environ["NUMBA_CACHE_DIR"] == numba.core.config.CACHE_DIR == here
    assert not stale.exists() and recent.is_dir()
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert numba_cache.configure(blocked) is None and "NUMBA_CACHE_DIR" not in os.environ  # numba's default


def test_a_kernel_is_recompiled_when_a_kernel_it_calls_in_another_file_changes(tmp_path):
    """``Plan.state``'s kernel (planner/search.py) calls ``norm3`` (fused.py): with numba's own cache, an edit to
    ``norm3`` left the cached caller as it was; importing navstack keys the cache by both files."""
    src = tmp_path / "src"
    shutil.copytree(PKG, src / "navstack", ignore=shutil.ignore_patterns("__pycache__"))
    script = ("import numpy as np\nfrom navstack.planner.search import Plan\n"
              "plan = Plan(points=np.array([[0, 0, 0], [1, 0, 0.0]]), tangents=np.array([[1, 0, 0], [0, 1, 0.0]]),"
              " arc=np.array([0, 1.0]), goal_index=np.array([0, 0]), status=0, cost=1.0, expansions=0)\n"
              "print(plan.state(0.5)[1][0])\n")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(src), NAVSTACK_NUMBA_CACHE_ROOT=str(tmp_path / "cache"))

    def tangent_x() -> float:
        out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True,
                             check=True)
        return float(out.stdout)

    assert abs(tangent_x() - 0.5**0.5) < 1e-12
    fused = src / "navstack" / "fused.py"
    text = fused.read_text()
    assert text.count("    return math.sqrt(fma(z, z, fma(y, y, x * x)))") == 1
    fused.write_text(text.replace("    return math.sqrt(fma(z, z, fma(y, y, x * x)))",
                                  "    return 2.0 * math.sqrt(fma(z, z, fma(y, y, x * x)))"))
    assert abs(tangent_x() - 0.5 * 0.5**0.5) < 1e-12  # the caller compiled afresh with the edited norm3
    assert len(list((tmp_path / "cache").glob("src-*"))) == 2
