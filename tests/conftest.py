"""Test-session setup: numba's on-disk cache, keyed by the navstack sources.

numba's ``cache=True`` keys a cached kernel by its own file's path and timestamp only. A kernel that calls
(or inlines) a jitted function from *another* file is not recompiled when that callee changes: with a warm
cache a deliberate bug in ``navstack/path.py`` went unnoticed by the controller's closed-loop test.

So the test suite points ``NUMBA_CACHE_DIR`` at a directory named by a hash of the sources compiled code
can depend on: every ``navstack`` module that uses numba and every navstack module those import,
transitively (lazy imports included). A jitted function sees only its own module's globals, so an edit
anywhere in that closure starts from an empty cache (one cold compile of the kernels a test run uses, about
15 s of CPU for every kernel), while an edit elsewhere (``trial.py``, ``estimate.py``, ``sweep.py``, ...) keeps
the warm cache. This module runs before any test module imports navstack; the environment variable also
reaches the subprocesses the tests start (sweep workers, CLI runs). ``NAVSTACK_NUMBA_CACHE_ROOT`` overrides
where the keyed directories live (default ``.pytest_cache/numba/`` in the repository); the most recent few
are kept, older ones removed.

Why not simply switch numba's cache off under pytest: every pytest process and every process it starts
(sweep workers, CLI runs) would then compile cold. Measured on the 2-core machine, tests/test_control.py,
test_path.py, test_kinematics.py, test_generate.py and test_trial_accounting.py take 32.6 s of CPU from an
empty cache against 17.7 s from a warm one, in one process; the keyed cache pays that once per kernel edit.
"""

from __future__ import annotations

import ast
import hashlib
import os
import re
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "navstack"
KEEP = 4
"""Keyed cache directories kept besides the current one."""


def _navstack_imports(path: Path, pkg: Path) -> set[Path]:
    """The navstack source files ``path`` imports anywhere (top level, in functions, under TYPE_CHECKING)."""
    own_pkg = ["navstack", *path.relative_to(pkg).parent.parts]  # the package holding ``path``
    names: list[list[str]] = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names += [a.name.split(".") for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = own_pkg[: len(own_pkg) - node.level + 1] if node.level else []
            mod = base + (node.module.split(".") if node.module else [])
            names.append(mod)
            names += [[*mod, a.name] for a in node.names]  # ``from navstack import jpl`` names a module
    out: set[Path] = set()
    for parts in names:
        if parts[:1] != ["navstack"] or len(parts) < 2:
            continue
        base = pkg.joinpath(*parts[1:])
        for candidate in (base.with_suffix(".py"), base / "__init__.py"):
            if candidate.is_file():
                out.add(candidate)
    return out


def compiled_sources(pkg: Path = PKG) -> list[Path]:
    """The navstack files that use numba, and every navstack file they import, transitively."""
    todo = [p for p in pkg.rglob("*.py") if re.search(r"^\s*(import numba|from numba)", p.read_text(), re.M)]
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path not in seen:
            seen.add(path)
            todo += _navstack_imports(path, pkg) - seen
    return sorted(seen)


def source_hash(pkg: Path = PKG) -> str:
    """A hash of the relative path and content of every file of :func:`compiled_sources`."""
    h = hashlib.sha256()
    for path in compiled_sources(pkg):
        h.update(path.relative_to(pkg).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _cache_dir() -> Path:
    root = Path(os.environ.get("NAVSTACK_NUMBA_CACHE_ROOT", ROOT / ".pytest_cache" / "numba"))
    here = root / f"src-{source_hash()}"
    here.mkdir(parents=True, exist_ok=True)
    os.utime(here)
    old = sorted((p for p in root.glob("src-*") if p != here and p.is_dir()), key=lambda p: p.stat().st_mtime)
    for stale in old[: max(0, len(old) - KEEP)]:
        shutil.rmtree(stale, ignore_errors=True)
    return here


NUMBA_CACHE_DIR = str(_cache_dir())
os.environ["NUMBA_CACHE_DIR"] = NUMBA_CACHE_DIR
if "numba" in sys.modules:  # a plugin imported numba first: its config has already read the environment
    import numba.core.config

    numba.core.config.CACHE_DIR = NUMBA_CACHE_DIR
if "navstack" in sys.modules:
    raise RuntimeError("navstack was imported before tests/conftest.py set NUMBA_CACHE_DIR; the numba cache "
                       "could be stale")


def pytest_collection_modifyitems(config, items) -> None:
    """Modules holding a ``slow`` test run first, each module's tests kept together and in their own order.

    Under ``pytest -n auto --dist worksteal`` (the README's test command) a worker that runs out of tests takes
    pending ones from the other; a closed-loop test of minutes started last would leave one core idle while it
    runs (the suite took 10 min 47 s on two workers in that order, against 16 min 51 s on one). Started first,
    the long tests overlap everything else. A module's tests stay contiguous, so a worker does not tear down and
    rebuild its module-scoped fixtures between them (a steal may still split a module between the two workers).
    """
    modules: dict[str, list] = {}
    for item in items:
        module = getattr(item, "module", None)  # absent from items that are not Python functions
        modules.setdefault(module.__name__ if module is not None else item.nodeid, []).append(item)
    ordered = sorted(modules.values(), key=lambda group: not any(i.get_closest_marker("slow") for i in group))
    items[:] = [item for group in ordered for item in group]
