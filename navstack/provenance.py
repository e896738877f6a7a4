"""What produced a result: the ``provenance`` object on every line of ``results.jsonl`` (interfaces.md section 4).

``provenance(backend)`` returns ``{"navstack", "commit", "python", "pybullet", "numpy", "host", "backend"}``:

* ``navstack``: ``navstack.__version__`` of the source that ran the trial;
* ``commit``: the git commit (40 hex digits) of that source when it is a git checkout in which navstack's own
  files are tracked and none of them differs from that commit, else ``None`` (an installed wheel, no ``git``,
  navstack inside someone else's repo, or edited, added or removed files in the package: the source that ran
  is then no commit, and naming the one it started from would credit it with results it did not give);
* ``python``, ``pybullet``, ``numpy``: versions (``None`` when a package is not installed); PyBullet is not
  imported for this, its installed distribution's metadata is read;
* ``host``: ``socket.gethostname()`` of the process that ran the trial;
* ``backend``: the sweep's executor (``local`` or ``ray``), filled in by the driver.

Everything but ``backend`` is computed once per process (the workers call it, so on a cluster each line names
the machine and the software that really ran it).
"""

from __future__ import annotations

import functools
import platform
import socket
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

PROVENANCE_KEYS = ("navstack", "commit", "python", "pybullet", "numpy", "host", "backend")
VERSION_KEYS = ("navstack", "commit", "python", "pybullet", "numpy")
"""The keys that identify the software; a sweep whose lines differ in these mixes versions."""

GIT_TIMEOUT = 10.0
"""Seconds ``git`` may take to answer (a hung network file system must not hang a worker)."""


def _git(folder: Path, *args: str) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True,
                             timeout=GIT_TIMEOUT, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def source_commit(package_dir: str | Path | None = None) -> str | None:
    """The git commit of navstack's source folder ``package_dir`` (default: this package), or ``None``.

    ``None`` unless ``package_dir/__init__.py`` is tracked by the enclosing git repository, so a navstack
    installed into some other project's checkout is not credited with that project's commit; ``None`` too when
    a file in ``package_dir`` differs from that commit (``git status``: edited, staged, removed, or new and not
    ignored).
    """
    folder = Path(package_dir) if package_dir is not None else Path(__file__).resolve().parent
    if _git(folder, "ls-files", "--error-unmatch", "__init__.py") is None:
        return None
    if _git(folder, "status", "--porcelain", "--", ".") != "":  # (None: git failed; "": clean)
        return None
    commit = _git(folder, "rev-parse", "HEAD")
    if commit is None or len(commit) != 40 or any(c not in "0123456789abcdef" for c in commit):
        return None
    return commit


def _dist_version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


@functools.lru_cache(maxsize=1)
def _this_process() -> tuple[tuple[str, Any], ...]:
    from navstack import __version__

    return (("navstack", __version__), ("commit", source_commit()), ("python", platform.python_version()),
            ("pybullet", _dist_version("pybullet")), ("numpy", _dist_version("numpy")),
            ("host", socket.gethostname()))


def provenance(backend: str | None = None) -> dict[str, Any]:
    """This process's provenance (see the module docstring) with ``backend`` set (a new dict each call)."""
    return {**dict(_this_process()), "backend": backend}


def version_key(prov: Any) -> tuple[Any, ...] | None:
    """The software identity of a line's ``provenance`` (``VERSION_KEYS`` values), ``None`` if it has none."""
    if not isinstance(prov, dict):
        return None
    return tuple(prov.get(k) for k in VERSION_KEYS)
