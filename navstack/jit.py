"""Compiled functions that take arrays and allocate none: ``numba.njit`` without reference counting.

Numba's runtime (NRT) counts the references to every array a compiled function receives: a call from one
compiled function to another increments and decrements the count of each array argument, with atomic
instructions (``NRT_incref`` / ``NRT_decref``).  The planner's search calls its distance tests, body checks
and heuristic tens of times per expanded state, with six to twelve arrays each: the counting was 22 % of the
search's time (``perf`` on a slot rack's recorded searches, with a map of numba's compiled symbols).

A function that allocates nothing needs none of it.  :func:`kernel` compiles such a function with the runtime
off for it (numba's ``_nrt=False``); numba refuses to compile one that allocates (a typing error), so the
option cannot hide a leak.  The machine code is otherwise the same, and so are the results.  Where a numba
version no longer knows the option, :func:`kernel` is plain ``numba.njit``: slower, the same results.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba
from numba.core.options import DefaultOptions

__all__ = ["kernel"]

NO_REFCOUNT: dict[str, Any] = {"_nrt": False} if hasattr(DefaultOptions, "_nrt") else {}
"""The option that turns numba's reference counting off for one function, where numba has it."""


def kernel(function: Callable | None = None, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)`` without reference counting (module docstring), for a function that
    takes arrays and allocates none.  Use as ``@kernel`` or ``@kernel(...)``."""
    jit = numba.njit(cache=True, **NO_REFCOUNT, **options)
    return jit if function is None else jit(function)
