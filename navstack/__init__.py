"""navstack: sensor-based slithering control of the JPL serpentine robot.

Library entry points (interfaces.md section 5):

* :func:`jpl_serpentine` - the 20-DOF robot model of the paper's Figure 2,
* :func:`load_world` / :class:`WorldError` - world files (``navstack-world/1``),
* :func:`run_trial` - one closed-loop trial, as ``navstack run`` runs it.

The names are imported lazily (PEP 562), so ``import navstack.control`` or
``import navstack.planner`` loads the pure-numpy core alone, without PyBullet.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from navstack.numba_cache import configure as _configure_numba_cache

_configure_numba_cache()  # before any kernel is compiled or loaded: numba's cache keyed by the kernels' sources

if TYPE_CHECKING:
    from navstack.jpl import jpl_serpentine
    from navstack.kinematics import Chain
    from navstack.trial import TrialResult, run_trial
    from navstack.world import World, WorldError, load_world

_EXPORTS = {
    "jpl_serpentine": "navstack.jpl",
    "Chain": "navstack.kinematics",
    "TrialResult": "navstack.trial",
    "run_trial": "navstack.trial",
    "World": "navstack.world",
    "WorldError": "navstack.world",
    "load_world": "navstack.world",
}

__all__ = ["Chain", "TrialResult", "World", "WorldError", "jpl_serpentine", "load_world", "run_trial"]
__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'navstack' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
