"""Checks of configuration fields, with one wording for every configuration dataclass.

Each function reads fields of ``obj`` (a dataclass, in its ``__post_init__``) by name and raises
:class:`ValueError` naming the class and the field::

    SteeringConfig.v_max must be a positive number, got 'fast'

so a bad value is refused where the configuration is built, never later as a ``TypeError`` from arithmetic on a
string or ``None``.  A **number** is an ``int`` or a ``float``, a numpy integer or floating scalar included, and
never a ``bool`` (``True`` is no speed); it is finite unless a function says otherwise (NaN never is a valid
value).  An **integer** is an ``int`` or a numpy integer, never a ``bool``.  A **flag** is ``True`` or
``False`` (a numpy ``bool_`` included).  The values are checked, not converted: the configuration keeps what it
was given.

Example::

    def __post_init__(self) -> None:
        positive(self, "v_max", "v_min")
        integer(self, "stop_window", lo=1)
        flag(self, "enabled")
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["MAX_SEED", "fail", "finite", "flag", "in_range", "instance", "integer", "is_integer", "is_number",
           "is_seed", "non_negative", "positive"]

MAX_SEED = 2**63 - 1
"""The largest seed taken (``run``, ``trials``, ``generate``): seeds are written to result.json, results.jsonl and
world files, whose readers hold integers as int64 (or doubles); ``--seed 99999999999999999999999`` was written as
a 77-bit integer (a review's case, session 40)."""


def is_number(v: object) -> bool:
    """Whether ``v`` is a real number: an ``int`` or ``float`` (numpy scalars included), not a ``bool``."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def is_integer(v: object) -> bool:
    """Whether ``v`` is an integer: an ``int`` or a numpy integer, not a ``bool``."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def is_seed(v: object) -> bool:
    """Whether ``v`` is a seed: an integer from 0 to :data:`MAX_SEED`."""
    return is_integer(v) and 0 <= v <= MAX_SEED  # type: ignore[operator]


def fail(obj: object, name: str, what: str) -> ValueError:
    """The error for field ``name`` of ``obj``: ``"<Class>.<name> must be <what>, got <repr>"`` (to raise)."""
    return ValueError(f"{type(obj).__name__}.{name} must be {what}, got {getattr(obj, name)!r}")


def _as_float(v: object, inf_ok: bool) -> float | None:
    """``v`` as a float if it is a number that is finite (or +-inf where ``inf_ok``); otherwise None."""
    if not is_number(v):
        return None
    try:
        x = float(v)  # type: ignore[arg-type]
    except OverflowError:  # an int beyond the float range: infinite as far as a float goes
        x = math.inf if v > 0 else -math.inf  # type: ignore[operator]
    if math.isnan(x) or (math.isinf(x) and not inf_ok):
        return None
    return x


def _check(obj: object, names: tuple[str, ...], what: str, ok: Callable[[float], bool], *,
           inf_ok: bool = False, none_ok: bool = False) -> None:
    """Each field in ``names`` is a number (finite unless ``inf_ok``; or None if ``none_ok``) for which ``ok``
    holds; otherwise :func:`fail` with ``what``."""
    for name in names:
        v = getattr(obj, name)
        if v is None and none_ok:
            continue
        x = _as_float(v, inf_ok)
        if x is None or not ok(x):
            raise fail(obj, name, what)


def positive(obj: object, *names: str, inf_ok: bool = False) -> None:
    """Each field is a finite number > 0 ("a positive number"); with ``inf_ok``, ``inf`` too."""
    what = "a positive number or inf" if inf_ok else "a positive number"
    _check(obj, names, what, lambda x: x > 0.0, inf_ok=inf_ok)


def non_negative(obj: object, *names: str, none_ok: bool = False) -> None:
    """Each field is a finite number >= 0 ("a number >= 0"); with ``none_ok``, ``None`` too."""
    what = "None or a number >= 0" if none_ok else "a number >= 0"
    _check(obj, names, what, lambda x: x >= 0.0, none_ok=none_ok)


def finite(obj: object, *names: str) -> None:
    """Each field is a finite number of any sign ("a finite number")."""
    _check(obj, names, "a finite number", lambda x: True)


def _bound(x: float) -> str:
    """A bound for a message: short (``0.5``, ``1e+06``) where that is exact, else every digit (``pi``)."""
    short = f"{x:g}"
    return short if float(short) == x else repr(float(x))


def in_range(obj: object, *names: str, lo: float, hi: float, lo_open: bool = False, hi_open: bool = False,
             unit: str = "", what: str | None = None) -> None:
    """Each field is a finite number in the interval from ``lo`` to ``hi``, each end included unless open
    ("a number in (0, 1]"; ``unit``, such as ``" [m]"``, is appended to the message; ``what`` replaces the
    description where a message's wording is kept for its readers, as the command line's)."""
    if what is None:
        what = f"a number in {'(' if lo_open else '['}{_bound(lo)}, {_bound(hi)}{')' if hi_open else ']'}{unit}"

    def ok(x: float) -> bool:
        return (x > lo if lo_open else x >= lo) and (x < hi if hi_open else x <= hi)

    _check(obj, names, what, ok)


def integer(obj: object, *names: str, lo: int | None = None, hi: int | None = None) -> None:
    """Each field is an integer, at least ``lo`` and at most ``hi`` where given ("an integer >= 1",
    "an integer in [160, 1920]", "an integer")."""
    if hi is not None:
        what = f"an integer in [{lo}, {hi}]" if lo is not None else f"an integer <= {hi}"
    else:
        what = f"an integer >= {lo}" if lo is not None else "an integer"
    for name in names:
        v = getattr(obj, name)
        if not is_integer(v) or (lo is not None and v < lo) or (hi is not None and v > hi):
            raise fail(obj, name, what)


def flag(obj: object, *names: str) -> None:
    """Each field is ``True`` or ``False`` (a numpy ``bool_`` included; not 0 or 1)."""
    for name in names:
        if not isinstance(getattr(obj, name), (bool, np.bool_)):
            raise fail(obj, name, "True or False")


def instance(obj: object, name: str, cls: type) -> None:
    """The field is an instance of ``cls`` ("an EstimatorConfig")."""
    if not isinstance(getattr(obj, name), cls):
        article = "an" if cls.__name__[:1] in "AEIOU" else "a"
        raise fail(obj, name, f"{article} {cls.__name__}")
