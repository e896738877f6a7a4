"""A trial's settings as a file: :class:`~navstack.trial.TrialConfig` read from, and written as, JSON.

``navstack run --settings FILE`` and ``navstack trials --settings FILE`` take a JSON object of *overrides*:
the same nesting and names as :class:`~navstack.trial.TrialConfig` and the dataclasses it holds, only the
values to change, e.g. ``{"sensor": {"max_range": 0.5}, "field_planner": {"repulsion": {"margin": 0.02}}}``.
``navstack settings`` prints every setting with its default (or, given a file, the settings it makes).

Every key must name a setting (a typo must not be silently ignored) and every value must have the setting's
type: a number for a float (an integer is taken as a float; a bool is not a number), an integer for an int,
``true``/``false`` for a bool, a string for a string, a list of numbers for a tuple, ``null`` only where the
setting may be ``None``.  Then each dataclass checks its own values (ranges, consistency) as it does in code.
Every error is a :class:`SettingsError` naming the file and the JSON path of the setting.

Units are those of the dataclasses' docstrings (metres, seconds, radians).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navstack.trial import TrialConfig

__all__ = ["MAX_SETTINGS_BYTES", "SettingsError", "load_settings", "settings_digest", "settings_from_dict",
           "settings_to_dict"]

MAX_SETTINGS_BYTES = 1 << 20
"""A settings file larger than this (1 MiB) is refused before it is parsed."""

MAX_INT = 2**31 - 1
"""The largest integer setting (counts and budgets; what the simulator's and the compiled code's ints hold)."""

FROM_THE_WORLD = ("sensor.body_radius", "field_planner.repulsion.body_radius", "reactive_planner.body_radius")
"""Values a trial takes from its world (``robot.serpentine_radius``, :meth:`TrialConfig.for_robot`): a file may
repeat their defaults (``navstack settings`` prints them) but not change them, since the world's would replace it."""


class SettingsError(ValueError):
    """A settings file or object that cannot be read as :class:`~navstack.trial.TrialConfig` overrides."""


def settings_to_dict(config: TrialConfig) -> dict[str, Any]:
    """Every setting of ``config``, nested as the dataclasses are, JSON-ready (tuples as lists)."""
    return json.loads(json.dumps(dataclasses.asdict(config)))


def settings_digest(config: TrialConfig) -> str:
    """SHA-256 (hex) of ``config``'s settings as canonical JSON (sorted keys): equal settings, equal digests."""
    text = json.dumps(settings_to_dict(config), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def settings_from_dict(data: Any, where: str = "settings") -> TrialConfig:
    """:class:`~navstack.trial.TrialConfig` with the overrides ``data`` (a nested dict) applied to the defaults.

    ``where`` names the source in errors (a file name).  Raises :class:`SettingsError`.
    """
    if not isinstance(data, Mapping):
        raise SettingsError(f"{where}: expected a JSON object of settings, got {_kind(data)}")
    return _apply(TrialConfig(), data, where, "")


def load_settings(path: str | os.PathLike[str]) -> TrialConfig:
    """The :class:`~navstack.trial.TrialConfig` a settings file makes (module docstring); :class:`SettingsError`
    naming the file (unreadable, too large, not JSON, a bad setting)."""
    file = Path(path)
    try:
        st = file.stat()
        if not stat.S_ISREG(st.st_mode):  # a folder, or a pipe whose read would wait for a writer
            raise SettingsError(f"{file}: expected a settings file (a JSON object), not a folder or a device")
        if st.st_size > MAX_SETTINGS_BYTES:
            raise SettingsError(f"{file}: larger than {MAX_SETTINGS_BYTES} bytes; a settings file is a few lines")
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SettingsError(f"{file}: cannot read the settings file: {exc}") from exc
    try:
        data = json.loads(text, parse_constant=_no_constant, object_pairs_hook=_no_repeats)
    except (json.JSONDecodeError, ValueError, RecursionError) as exc:
        raise SettingsError(f"{file}: invalid JSON: {exc}") from exc
    return settings_from_dict(data, str(file))


def _no_constant(name: str) -> None:
    raise ValueError(f"{name} is not a number JSON allows")


def _no_repeats(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object, refusing a key given twice (which one was meant?)."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"the key {key!r} is given twice in one object")
        out[key] = value
    return out


def _apply(obj: Any, data: Mapping[str, Any], where: str, path: str) -> Any:
    """``obj`` (a dataclass instance) with ``data``'s overrides, recursively; the dataclass validates."""
    fields = {f.name: f for f in dataclasses.fields(obj)}
    changes: dict[str, Any] = {}
    for key, value in data.items():
        at = f"{path}.{key}" if path else str(key)
        if key not in fields:
            raise SettingsError(f"{where}: {at}: unknown setting; expected one of {', '.join(sorted(fields))}")
        if at in FROM_THE_WORLD and value != getattr(obj, key):  # as printed (the default): harmless
            raise SettingsError(f"{where}: {at}: not a setting: every trial takes it from its world's "
                                "robot.serpentine_radius")
        current = getattr(obj, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, Mapping):
                raise SettingsError(f"{where}: {at}: expected an object of settings, got {_kind(value)}")
            changes[key] = _apply(current, value, where, at)
        else:
            changes[key] = _value(current, value, str(fields[key].type), where, at)
    try:
        return dataclasses.replace(obj, **changes)
    except (ValueError, TypeError) as exc:
        raise SettingsError(f"{where}: {path or 'settings'}: {exc}") from exc


def _value(current: Any, value: Any, annotation: str, where: str, at: str) -> Any:
    """``value`` checked against the type of the setting's default ``current`` (and ``None`` if allowed)."""
    if value is None:
        if "None" in annotation:
            return None
        raise SettingsError(f"{where}: {at}: null is not allowed here; expected {_expected(current)}")
    if isinstance(current, bool) or annotation.startswith("bool"):
        ok = isinstance(value, bool)
    elif isinstance(current, int) and not annotation.startswith("float"):
        ok = isinstance(value, int) and not isinstance(value, bool)
        if ok and abs(value) > MAX_INT:
            raise SettingsError(f"{where}: {at}: {value} is out of range: at most {MAX_INT} in size")
    elif isinstance(current, (int, float)) or annotation.startswith("float"):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        value = float(value) if ok else value
    elif isinstance(current, str):
        ok = isinstance(value, str)
    elif isinstance(current, tuple):
        ok = isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                             and math.isfinite(v) for v in value)
        value = tuple(float(v) for v in value) if ok else value
    else:  # a setting of a kind this reader does not know: refuse rather than guess
        raise SettingsError(f"{where}: {at}: this setting cannot be set from a file")
    if not ok:
        raise SettingsError(f"{where}: {at}: expected {_expected(current)}, got {_kind(value)}")
    return value


def _expected(current: Any) -> str:
    if isinstance(current, bool):
        return "true or false"
    if isinstance(current, int):
        return "an integer"
    if isinstance(current, float):
        return "a finite number"
    if isinstance(current, tuple):
        return "a list of finite numbers"
    return "a string" if isinstance(current, str) else type(current).__name__


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value[:40]!r}"
    if isinstance(value, list):
        return "an array"
    return "an object" if isinstance(value, Mapping) else type(value).__name__
