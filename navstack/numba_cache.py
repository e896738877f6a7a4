"""numba's on-disk cache, keyed by the sources compiled code can see.

numba's ``cache=True`` keys a cached kernel by its own file's path and timestamp only. A kernel that calls (or
inlines) a jitted function from *another* file is not recompiled when that callee changes: after an edit to
``planner/potential.py``'s ``cost_at``, the search kernels in ``planner/search.py`` that call it were loaded from
the cache as they were, and a run measured the code before the edit.

So importing navstack points ``NUMBA_CACHE_DIR`` at a folder named by a hash of :data:`KERNEL_SOURCES` (every
navstack module that uses numba and every navstack module those import, transitively: a jitted function sees
only its own module's globals). An edit there starts from an empty cache (numba compiles the kernels a run uses
once, about 40 s of CPU for all of them); an edit elsewhere keeps the warm cache, and so does an installed
release, whose sources do not change.

* Where: ``NAVSTACK_NUMBA_CACHE_ROOT`` if set, else ``$XDG_CACHE_HOME/navstack/numba`` (``~/.cache/...``); one
  ``src-<hash>`` folder per source state, and folders not used for :data:`STALE_DAYS` days are removed.
* A ``NUMBA_CACHE_DIR`` already set (by the user, by the test suite, or by the navstack process that started this
  one: sweep workers inherit it) is left as it is.
* The variable is set for the whole process (numba has one cache folder per process), so other numba code run
  in it caches there too, keyed by its own files as usual.
* Where no folder can be made, nothing is set: numba's own cache (in ``__pycache__``), as before.

``tests/test_numba_cache.py`` checks :data:`KERNEL_SOURCES` against the import closure computed from the sources.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import sys
import time
from pathlib import Path

PKG = Path(__file__).resolve().parent
KERNEL_SOURCES = (
    "control/damping.py", "control/equation4.py", "control/fast.py", "control/solver.py",
    "control/tasks/__init__.py", "control/tasks/base.py", "control/tasks/limits.py", "control/tasks/posture.py",
    "control/tasks/slither.py", "control/tasks/tip.py", "estimate.py", "fused.py", "generate/geometry.py", "jit.py",
    "jpl.py", "kinematics.py", "mesh_file.py", "path.py", "planner/grazing.py", "planner/map.py", "planner/opening.py",
    "planner/potential.py", "planner/proximity.py", "planner/search.py", "ply_faces.py", "self_contact.py",
    "sensing.py",
    "sim/_bullet.py", "sim/body.py", "sim/exact_distance.py", "sim/lipschitz.py", "sim/mesh_depth.py",
    "sim/mesh_inside.py", "sim/mesh_walls.py", "sim/mover_sweep.py", "sim/scene.py", "sim/servo.py", "urdf.py",
    "validate.py", "world.py",
)
"""navstack's modules with numba kernels and every navstack module they import, transitively (paths relative
to the package)."""

STALE_DAYS = 30.0
"""A keyed folder not used for this many days is removed (long enough that no running process still uses it)."""


def source_key(pkg: Path = PKG) -> str:
    """A hash (16 hex digits) of the relative path and content of every file of :data:`KERNEL_SOURCES` in ``pkg``
    (a missing file counts as empty)."""
    h = hashlib.sha256()
    for name in KERNEL_SOURCES:
        h.update(name.encode())
        h.update(b"\0")
        with contextlib.suppress(OSError):
            h.update((pkg / name).read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


def default_root() -> Path:
    """Where the keyed folders go: ``NAVSTACK_NUMBA_CACHE_ROOT``, else the user's cache folder."""
    root = os.environ.get("NAVSTACK_NUMBA_CACHE_ROOT")
    if root:
        return Path(root).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "navstack" / "numba"


def configure(root: Path | None = None, now: float | None = None) -> str | None:
    """Point numba's cache at this source state's folder under ``root`` (default :func:`default_root`) unless
    ``NUMBA_CACHE_DIR`` is already set; return the folder in use (``None``: numba's default)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.environ["NUMBA_CACHE_DIR"]
    try:
        root = default_root() if root is None else root
        here = root / f"src-{source_key()}"
        here.mkdir(parents=True, exist_ok=True)
        os.utime(here)
    except (OSError, RuntimeError):  # RuntimeError: no home folder
        return None
    now = time.time() if now is None else now
    for old in root.glob("src-*"):
        with contextlib.suppress(OSError):
            if old != here and old.is_dir() and now - old.stat().st_mtime > STALE_DAYS * 86400.0:
                shutil.rmtree(old, ignore_errors=True)
    os.environ["NUMBA_CACHE_DIR"] = str(here)
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba imported first: its config has already read the environment
        config.CACHE_DIR = str(here)
    return str(here)
