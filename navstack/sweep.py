"""Randomized trial sweeps: many closed-loop trials in parallel, locally or on a Ray cluster, with resume.

``navstack trials`` (interfaces.md section 4) runs every combination of world x controller x planner
(x repetition) and appends one JSON line per finished trial to ``DIR/results.jsonl``.

Trial list
    :func:`build_specs` turns a :class:`SweepConfig` into a deterministic list of :class:`TrialSpec`, each
    with a stable ``trial_id``. Generated worlds come from ``navstack.generate.generate_world(family,
    world_seed, difficulty)`` where ``world_seed`` is derived (SHA-256, not Python's salted ``hash``) from
    ``(seed, family, index)`` only, so the same index gives the same layout at every difficulty and the same
    seed always gives the same worlds. The trial's noise seed is derived the same way and is shared by all
    controllers and planners on one world (paired comparison). The list is ordered by index first, so an
    interrupted sweep has covered every family / difficulty / controller about equally. ``--retract``
    (``SweepConfig.retract``) asks the generator for worlds the robot must back out of
    (``generate_world(..., retract=True)``, interfaces.md section 2a): same seeds, ids ending in ``__retract``.

Outputs in ``DIR`` (only this process, the driver, writes them; workers return data). ``DIR`` may not be the
``--worlds`` folder (its ``sweep.json`` would be listed as a world by the next run); a subfolder is fine.
    * ``sweep.json``: the trial list (and the config / command that made it). A rerun whose trial list differs
      is refused with :class:`SweepError`; use a new ``--out`` directory instead.
    * ``results.jsonl``: one line per finished trial: the ``result.json`` fields of interfaces.md section 3
      plus ``trial_id``, ``family``, ``difficulty``, ``index``, ``world_id``, ``world_file``, ``world_seed``
      and ``provenance`` (:mod:`navstack.provenance`), one ``os.write`` of a whole line followed by ``fsync``.
      Lines appear in completion order while the sweep runs; when every trial is done the file is rewritten
      (atomically, via ``os.replace``) in trial-list order, so a completed sweep's file is identical for
      identical inputs except for ``wall_time`` (and ``provenance``'s ``host`` and ``backend`` when run
      elsewhere). Non-finite floats are written as ``null`` (strict JSON).
    * ``worlds/<world_id>.json``: each generated world, as the trial loaded it; rerun one by hand with
      ``navstack run DIR/worlds/<world_id>.json --controller C --planner P --seed S`` (values from its line).
    * ``workers.log``: the local worker processes' stdout/stderr (PyBullet banners, prints), kept off the
      terminal (Ray keeps its workers' output in its own logs).
    * ``sweep.lock``: held (``flock``) while a sweep runs, so a second sweep on the same ``DIR`` is refused.
    * ``trials/<trial_id>/`` (only with ``keep_trajectories``): each trial's ``result.json`` and trajectory (a
      ``trial_id`` over 200 bytes is cut and ends in a hash: :func:`trial_folder`).
      With ``animate_failures`` the folders of the trials that failed (not ``error``) are kept, with an
      ``animation.mp4`` made by the driver (:func:`navstack.animate.animate_run`), and their results line gets
      ``animation`` (the file, relative to ``DIR``), which the report links.

Resume and crash safety
    A rerun on the same ``DIR`` skips every ``trial_id`` already in ``results.jsonl``. A line is only written
    once a trial has finished, so a Ctrl-C, ``kill`` or power loss never records a trial twice, and a
    recorded trial is never lost. If the driver was killed in the middle of writing a line, the file ends
    with an unterminated line: on resume (and in :func:`read_results`) a last line that lacks its final
    newline and is not valid JSON (also: nested too deeply) is recognised as such a truncated write and
    dropped (the file is truncated back to the last complete line, and that trial runs again); a complete
    last line without its newline is kept and terminated before anything is appended. Any other malformed
    line (also one holding ``NaN`` or ``Infinity``, which the writer never writes) is an error naming the
    file and line: it is never silently discarded.

Failures
    A trial whose runner raises, whose worker process dies, which exceeds ``trial_timeout`` seconds of wall
    clock (the worker is killed and a fresh one started), whose Ray task fails after Ray's retries, or whose
    world file (``--worlds``) cannot be read or is not valid JSON (the line names the file, line and column)
    is recorded with ``success: false``, ``reason: "error"`` and an ``error`` message; the sweep goes on.
    Such lines count as finished: a resume does not retry them (start a new ``DIR`` to retry). Unknown
    metrics of error lines are ``null``. The wall-clock limit starts when a started worker takes the trial,
    so a slow worker start is never charged to a trial. Workers that cannot start at all (the runner does not
    import) stop the sweep with :class:`SweepWorkerError` instead of being restarted forever.

Processes
    See :mod:`navstack.executors`: worker processes are spawned (PyBullet is only ever created inside
    workers), ignore SIGINT (the driver handles Ctrl-C and SIGTERM, stops them and keeps what finished) and
    exit by themselves if the driver disappears (``SIGKILL`` of the driver).
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import contextlib
import dataclasses
import functools
import hashlib
import json
import math
import os
import pickle
import shlex
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from navstack.executors import BACKENDS, SweepWorkerError, error_reply
from navstack.validate import is_seed

if TYPE_CHECKING:
    from navstack.executors import TrialJob

__all__ = ["SweepConfig", "SweepError", "SweepSummary", "SweepWorkerError", "TrialSpec", "build_specs",
           "read_results", "run_sweep"]

SWEEP_FORMAT = "navstack-sweep/1"
DEFAULT_TRIAL_TIMEOUT = 600.0
"""Default per-trial wall-clock limit (s), counted from the moment a started worker takes the trial."""

RESULTS_NAME = "results.jsonl"
SWEEP_NAME = "sweep.json"
WORLDS_DIR = "worlds"
LOG_NAME = "workers.log"
LOCK_NAME = "sweep.lock"
MAX_TRIALS = 1_000_000
"""The most trials one sweep may list (its ``sweep.json`` then holds about 300 MB; ``--count 100000000`` ran
out of memory before its first trial): split larger studies into several sweeps."""
MAX_DIFFICULTY = 1e9
"""A world file's ``extra.difficulty`` beyond +-this reads as absent (``navstack report`` refuses larger numbers:
:data:`navstack.report.MAX_VALUE`)."""
METRIC_KEYS = ("tip_error_max", "slither_deviation_max", "min_clearance", "contacts")

Runner = Callable[..., Any]
Generator = Callable[..., Any]


class SweepError(ValueError):
    """Bad sweep input or an output directory that cannot be used (message says what and where)."""


# --------------------------------------------------------------------------------------------------------
# Trial specs
# --------------------------------------------------------------------------------------------------------


def derive_seed(*parts: object) -> int:
    """A seed in [0, 2**31) from ``parts``: SHA-256 of their ``repr`` (stable across runs and platforms)."""
    digest = hashlib.sha256(repr(parts).encode("utf-8")).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF


@dataclass(frozen=True)
class TrialSpec:
    """One trial of a sweep.

    ``world_file`` is relative to the sweep directory for generated worlds (``worlds/<world_id>.json``,
    written by the driver) and an absolute path for ``--worlds`` files. ``world_seed`` is ``None`` for a
    world read from a file. ``difficulty`` is dimensionless (the generator's scale), ``None`` if unknown.
    ``retract``: the world asks the robot to back out after the last goal (interfaces.md section 2a); left
    out of :meth:`to_dict` when false, so trial lists from before the flag existed still match.
    ``settings``: the SHA-256 of the trial's settings (``--settings``, :func:`navstack.settings.settings_digest`)
    when they are not the defaults; left out of :meth:`to_dict` when ``None``, likewise.
    """

    trial_id: str
    world_id: str
    world_file: str
    controller: str
    planner: str
    seed: int
    index: int
    family: str | None = None
    difficulty: float | None = None
    world_seed: int | None = None
    retract: bool = False
    settings: str | None = None

    @property
    def generated(self) -> bool:
        """True when the world is generated by the worker (not read from a user's file)."""
        return self.world_seed is not None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (inverse of :meth:`from_dict`)."""
        data = dataclasses.asdict(self)
        if not self.retract:
            del data["retract"]
        if self.settings is None:
            del data["settings"]
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrialSpec:
        """Inverse of :meth:`to_dict`; raises :class:`SweepError` for missing or unknown keys."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - names
        missing = {f.name for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING} - set(data)
        if unknown or missing:
            raise SweepError(f"trial spec {data!r}: unknown keys {sorted(unknown)}, "
                             f"missing keys {sorted(missing)}")
        return cls(**data)


@dataclass(frozen=True)
class SweepConfig:
    """What ``navstack trials`` runs.

    Exactly one world source: ``families`` (generate ``count`` worlds per family and difficulty from
    ``seed``) or ``worlds_dir`` (every ``*.json`` file directly in that folder, the suffix in any case
    (``B.JSON``: a Windows export was left out without a word, a review's case), and every dangling symbolic
    link so named (its trials are ``error`` lines), sorted by name, each run ``count`` times with different
    noise seeds). ``difficulties`` are passed to the generator (ignored for ``worlds_dir``; there the
    difficulty is read from the world's ``extra.difficulty`` when it is a number in [-1e9, 1e9]).
    ``retract`` (generated worlds only): generate worlds the robot must back out of.
    ``settings``: the SHA-256 of the trials' settings when they are not the defaults (``--settings``), stored in
    every trial of the list (a rerun with other settings is another sweep, refused on the same folder).
    """

    families: tuple[str, ...] = ()
    count: int = 1
    seed: int = 0
    difficulties: tuple[float, ...] = (0.5,)
    worlds_dir: str | None = None
    controllers: tuple[str, ...] = ("slither",)
    planners: tuple[str, ...] = ("field",)
    retract: bool = False
    settings: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "families", tuple(self.families))
        object.__setattr__(self, "difficulties", tuple(float(d) + 0.0 for d in self.difficulties))  # -0.0 -> 0.0
        object.__setattr__(self, "controllers", tuple(self.controllers))
        object.__setattr__(self, "planners", tuple(self.planners))
        if bool(self.families) == (self.worlds_dir is not None):
            raise SweepError("sweep config: give exactly one of families (--generate) "
                             "or worlds_dir (--worlds)")
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise SweepError(f"sweep config: count must be an integer >= 1, got {self.count!r}")
        if not (isinstance(self.seed, int) and is_seed(self.seed)):
            raise SweepError(f"sweep config: seed must be an integer from 0 to 2**63 - 1, got {self.seed!r}")
        if not isinstance(self.retract, bool):
            raise SweepError(f"sweep config: retract must be true or false, got {self.retract!r}")
        if self.retract and not self.families:
            raise SweepError("sweep config: retract applies to generated worlds (--generate); a world file "
                             "says \"retract\": true itself")
        if self.settings is not None and not (isinstance(self.settings, str) and len(self.settings) == 64):
            raise SweepError(f"sweep config: settings must be a SHA-256 hex digest or None, got {self.settings!r}")
        for name in ("families", "difficulties", "controllers", "planners"):
            values = getattr(self, name)
            if name != "families" and not values:
                raise SweepError(f"sweep config: {name} must not be empty")
            if len(set(values)) != len(values):
                raise SweepError(f"sweep config: {name} has duplicates: {list(values)}")
        for d in self.difficulties:
            if not math.isfinite(d) or not 0 <= d <= 1:
                raise SweepError(f"sweep config: difficulty must be in [0, 1], got {d!r}")
        for f in self.families:
            if not f or "__" in f or "/" in f or f != f.strip():
                raise SweepError(f"sweep config: bad family name {f!r} (non-empty, no '/', no '__')")
        from navstack.registry import CONTROLLERS, PLANNERS

        for c in self.controllers:
            if c not in CONTROLLERS:
                raise SweepError(f"sweep config: unknown controller {c!r}; "
                                 f"expected one of {list(CONTROLLERS)}")
        for p in self.planners:
            if p not in PLANNERS:
                raise SweepError(f"sweep config: unknown planner {p!r}; expected one of {list(PLANNERS)}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self).items()}


def _known_families() -> tuple[str, ...]:
    """The registered world families (:mod:`navstack.registry`)."""
    from navstack.registry import family_names

    return family_names()


def _generator_supports_retract(generator: Generator | None = None) -> bool:
    """Whether ``generator`` (default ``navstack.generate.generate_world``) takes a ``retract`` argument."""
    import inspect

    if generator is None:
        from navstack.generate import generate_world as generator
    return "retract" in inspect.signature(generator).parameters


def _world_file_info(path: Path) -> tuple[str | None, float | None, bool]:
    """(family, difficulty, retract) of a world file, read without validation (the trial validates).

    A file that cannot be read or parsed (also: nested too deeply, an integer too long to parse) gives
    ``(None, None, False)``: its trials are recorded as ``error`` lines when the sweep reaches them (the rest
    of the sweep runs). A field of another type, and a difficulty that is not a number in [-1e9, 1e9]
    (:data:`MAX_DIFFICULTY`), read as absent; a non-finite one (NaN, 1e400, a 400-digit integer) also makes
    the trial an ``error`` line, as the world check names the field."""
    try:
        data = _json_object(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):  # ValueError: bad UTF-8
        return None, None, False
    if data is None:
        return None, None, False
    family = data.get("family") if isinstance(data.get("family"), str) else None
    retract = data.get("retract") is True
    extra = data.get("extra")
    difficulty = extra.get("difficulty") if isinstance(extra, dict) else None
    if difficulty is None and isinstance(extra, dict) and isinstance(extra.get("generator"), dict):
        difficulty = extra["generator"].get("difficulty")  # a world written by navstack generate
    if isinstance(difficulty, bool) or not isinstance(difficulty, int | float):
        return family, None, retract
    try:
        value = float(difficulty)
    except OverflowError:  # an integer beyond the float range
        return family, None, retract
    return family, (value if -MAX_DIFFICULTY <= value <= MAX_DIFFICULTY else None), retract


def build_specs(config: SweepConfig) -> list[TrialSpec]:
    """The deterministic trial list of ``config`` (same config, same list, same ``trial_id`` values).

    Generated: ``trial_id = "<family>__d<difficulty>__<index:04d>__<controller>__<planner>"``, with
    ``__retract`` after the index when ``config.retract``. Files: ``trial_id = "<file
    stem>__<repetition:03d>__<controller>__<planner>"``.
    Raises :class:`SweepError` for unknown families, an empty worlds folder, colliding ids, or ``retract``
    with a generator that does not support it.
    """
    specs: list[TrialSpec] = []
    if config.families:
        known = _known_families()
        for fam in config.families:
            if fam not in known:
                raise SweepError(f"--generate: unknown world family {fam!r}; expected one of {list(known)}")
        if config.retract and not _generator_supports_retract():
            raise SweepError("--retract: this navstack's world generator cannot make retraction worlds yet "
                             "(navstack.generate.generate_world has no 'retract' argument)")
        _check_total(config, len(config.families) * len(config.difficulties))
        for index in range(config.count):
            for fam in config.families:
                world_seed = derive_seed("world", config.seed, fam, index)
                trial_seed = derive_seed("trial", config.seed, fam, index)
                for diff in config.difficulties:
                    world_id = f"{fam}__d{diff!r}__{index:04d}" + ("__retract" if config.retract else "")
                    for planner in config.planners:
                        for controller in config.controllers:
                            specs.append(TrialSpec(
                                trial_id=f"{world_id}__{controller}__{planner}", world_id=world_id,
                                world_file=f"{WORLDS_DIR}/{world_id}.json", controller=controller,
                                planner=planner, seed=trial_seed, index=index, family=fam,
                                difficulty=diff, world_seed=world_seed, retract=config.retract,
                                settings=config.settings))
    else:
        try:
            folder = Path(config.worlds_dir).expanduser().resolve()  # type: ignore[arg-type]
        except (OSError, RuntimeError) as exc:  # RuntimeError: a loop of symbolic links (Python < 3.13)
            raise SweepError(f"--worlds: {config.worlds_dir}: {exc}") from exc
        if not folder.is_dir():
            raise SweepError(f"--worlds: {folder} is not a directory")
        # a dangling symbolic link is listed too (its trials become error lines, as for an unreadable file)
        files = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".json"
                       and (p.is_file() or (p.is_symlink() and not p.exists())))
        if not files:
            raise SweepError(f"--worlds: no *.json world files in {folder}")
        named: dict[str, Path] = {}
        for p in files:  # a.json and a.JSON: one world id, one trial id
            if named.setdefault(p.stem, p) is not p:
                raise SweepError(f"--worlds: {named[p.stem]} and {p.name} would both be world '{p.stem}'; rename one")
        _check_utf8_names(files)
        _check_total(config, len(files))
        infos = [(p, *_world_file_info(p)) for p in files]
        for rep in range(config.count):
            for path, fam, diff, retract in infos:
                trial_seed = derive_seed("trial", config.seed, path.stem, rep)
                world_id = path.stem
                for planner in config.planners:
                    for controller in config.controllers:
                        specs.append(TrialSpec(
                            trial_id=f"{world_id}__{rep:03d}__{controller}__{planner}", world_id=world_id,
                            world_file=str(path), controller=controller, planner=planner, seed=trial_seed,
                            index=rep, family=fam, difficulty=diff, world_seed=None, retract=retract,
                            settings=config.settings))
    _check_unique(specs)
    return specs


def _check_utf8_names(files: Sequence[Path]) -> None:
    """Refuse world file paths that are not UTF-8: their ``trial_id`` and ``world_file`` would hold lone
    surrogates, which strict JSON readers of results.jsonl refuse (an audit, session 33)."""
    for path in files:
        try:
            str(path).encode("utf-8")
        except UnicodeEncodeError:
            raise SweepError(f"--worlds: {os.fsencode(path)!r}: the path is not valid UTF-8, so its trials could not "
                             "be named in results.jsonl; rename the file (or folder)") from None


def _check_total(config: SweepConfig, worlds_per_count: int) -> None:
    """Refuse a sweep of more than :data:`MAX_TRIALS` trials before listing them."""
    total = config.count * worlds_per_count * len(config.planners) * len(config.controllers)
    if total > MAX_TRIALS:
        raise SweepError(f"--count: {config.count} gives {total:,} trials, more than the {MAX_TRIALS:,} one sweep may "
                         f"hold; split the study into several sweeps (different --seed or --out)")


def _check_unique(specs: Sequence[TrialSpec]) -> None:
    seen: set[str] = set()
    for s in specs:
        if s.trial_id in seen:
            raise SweepError(f"duplicate trial_id {s.trial_id!r} in the trial list")
        seen.add(s.trial_id)


# --------------------------------------------------------------------------------------------------------
# results.jsonl
# --------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ResultsFile:
    """Parsed ``results.jsonl``: ``records`` in file order, ``line_numbers`` (1-based) of each record,
    ``valid_bytes`` = length of the well-formed prefix, ``truncated_tail`` = an unterminated, unparseable last
    line was found (a write interrupted by a kill) and left out."""

    path: Path
    records: list[dict[str, Any]]
    line_numbers: list[int]
    valid_bytes: int
    truncated_tail: bool


def read_results(path: str | Path) -> ResultsFile:
    """Read ``results.jsonl``: one JSON object per line; blank lines are skipped.

    A final line without its newline that does not parse is a truncated write (see the module docstring):
    it is reported via ``truncated_tail`` and left out. Any other bad line raises :class:`SweepError`
    naming the file and line. A missing file reads as empty.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return ResultsFile(path, [], [], 0, False)
    except OSError as exc:
        raise SweepError(f"{path}: cannot read: {exc}") from exc
    records: list[dict[str, Any]] = []
    numbers: list[int] = []
    pos = 0
    lineno = 0
    while pos < len(data):
        lineno += 1
        nl = data.find(b"\n", pos)
        terminated = nl >= 0
        end = nl + 1 if terminated else len(data)
        raw = data[pos:end]
        if raw.strip():
            try:
                # (the line's end left out: a line cut inside a string then reads "Unterminated string", not
                # "Invalid control character")
                obj = json.loads(raw.rstrip(b"\r\n").decode("utf-8"), parse_constant=_refuse_constant)
                if not isinstance(obj, dict):
                    raise ValueError(f"expected a JSON object, got {type(obj).__name__}")
            except (ValueError, RecursionError) as exc:  # RecursionError: nested too deeply
                if not terminated and not isinstance(exc, _NonJSONConstant):
                    return ResultsFile(path, records, numbers, pos, True)
                why = "nested too deeply" if isinstance(exc, RecursionError) else exc
                raise SweepError(f"{path}, line {lineno}: malformed result line ({why})") from exc
            if not terminated:  # complete JSON but missing newline: keep it, the writer will fix the ending
                records.append(obj)
                numbers.append(lineno)
                return ResultsFile(path, records, numbers, len(data), False)
            records.append(obj)
            numbers.append(lineno)
        pos = end
    return ResultsFile(path, records, numbers, len(data), False)


class _NonJSONConstant(ValueError):
    pass


def _refuse_constant(name: str) -> Any:
    """``NaN`` / ``Infinity`` are not JSON and the writer never writes them: a line holding one is malformed,
    never a truncated write."""
    raise _NonJSONConstant(f"{name} is not valid JSON")


def _encode(record: dict[str, Any]) -> bytes:
    return (json.dumps(record, allow_nan=False, separators=(", ", ": ")) + "\n").encode("utf-8")


class _ResultsWriter:
    """Append-only writer: one ``os.write`` per line, then ``fsync``."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

    def append(self, record: dict[str, Any]) -> None:
        data = _encode(record)
        view = memoryview(data)
        while view:
            n = os.write(self.fd, view)
            view = view[n:]
        os.fsync(self.fd)

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    with contextlib.suppress(OSError):  # make the rename itself durable
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


# --------------------------------------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------------------------------------


@dataclass
class SweepSummary:
    """What :func:`run_sweep` did. Counts of this invocation except ``total`` / ``recorded``."""

    out_dir: Path
    results_path: Path
    total: int
    skipped: int
    ran: int = 0
    succeeded: int = 0
    errors: int = 0
    interrupted: bool = False
    dropped_truncated_line: bool = False
    recorded: int = 0
    wall_time: float = 0.0
    error_ids: list[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when every trial of the sweep has a line in ``results.jsonl``."""
        return self.recorded == self.total


def _error_record(spec: TrialSpec, message: str, wall_time: float, tb: str | None = None,
                  world_text: str | None = None) -> dict[str, Any]:
    """A trial that crashed, hung or could not start: no steps were recorded (counts 0), its metrics are
    unknown (``null``), ``error`` says why and ``traceback`` where.  ``world``: the name in ``world_text`` (the
    world file's text, when known and readable), else the world's id; ``retracted`` (false) when the sweep or
    that world asks for retraction."""
    name, retract = _name_and_retract(world_text)
    rec: dict[str, Any] = {
        "world": name or spec.world_id, "seed": spec.seed, "controller": spec.controller, "planner": spec.planner,
        "success": False, "reason": "error", "goals_reached": 0, "sim_time": 0.0, "steps": 0,
        "wall_time": round(wall_time, 6), "metrics": {k: None for k in METRIC_KEYS}, "error": message,
    }
    if tb:
        rec["traceback"] = tb
    if spec.retract or retract:
        rec["retracted"] = False
    return rec


def _json_object(text: str | None) -> dict[str, Any] | None:
    """A world file's text parsed, unvalidated: the JSON object, or None (no text, not JSON: also nested too
    deeply or an integer of over 4300 digits, or JSON but not an object)."""
    try:
        data = json.loads(text.lstrip("\ufeff")) if text else None
    except (ValueError, RecursionError):
        return None
    return data if isinstance(data, dict) else None


def _name_and_retract(world_text: str | None) -> tuple[str | None, bool]:
    """The ``name`` (a string, else None) and whether ``retract`` is true in a world file's text, unvalidated."""
    data = _json_object(world_text)
    if data is None:
        return None, False
    name = data.get("name")
    return (name if isinstance(name, str) and name else None), data.get("retract") is True


def _finish_record(spec: TrialSpec, result: dict[str, Any], prov: dict[str, Any]) -> dict[str, Any]:
    """The results line: the runner's fields, the sweep's fields of ``spec``, and ``provenance`` last."""
    record: dict[str, Any] = {"trial_id": spec.trial_id}
    record.update({k: v for k, v in result.items() if k not in ("trial_id", "provenance")})
    record.update(family=spec.family, difficulty=spec.difficulty, index=spec.index, world_id=spec.world_id,
                  world_file=spec.world_file, world_seed=spec.world_seed)
    if spec.settings is not None:
        record["settings"] = spec.settings
    record["provenance"] = prov
    return record


def _validated_result(spec: TrialSpec, result: Any) -> dict[str, Any]:
    if not isinstance(result, dict) or not isinstance(result.get("success"), bool) \
            or not isinstance(result.get("reason"), str):
        raise TypeError(f"trial {spec.trial_id}: runner result lacks a bool 'success' and a str 'reason': "
                        f"{result!r:.200}")
    return result


def read_sweep_file(sweep_path: Path) -> dict[str, Any]:
    """The stored sweep description (``sweep.json``) at ``sweep_path``; :class:`SweepError` if it cannot be read
    or is not a :data:`SWEEP_FORMAT` file with a list of trials."""
    try:
        stored = json.loads(sweep_path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:
        raise SweepError(f"{sweep_path}: unreadable sweep description ({exc})") from exc
    if not isinstance(stored, dict) or stored.get("format") != SWEEP_FORMAT or not isinstance(stored.get("trials"),
                                                                                             list):
        raise SweepError(f"{sweep_path}: not a {SWEEP_FORMAT} file")
    return stored


def _prepare_dir(out_dir: Path, specs: Sequence[TrialSpec], config: dict[str, Any] | None,
                 command: str | None) -> bool:
    """Create ``out_dir`` and its ``sweep.json``, or check that the stored sweep is the same one; True if this
    call wrote ``sweep.json``."""
    if out_dir.exists() and not out_dir.is_dir():
        raise SweepError(f"--out: {out_dir} exists and is not a directory")
    out_dir.mkdir(parents=True, exist_ok=True)
    sweep_path = out_dir / SWEEP_NAME
    wanted = [s.to_dict() for s in specs]
    hashes = _world_hashes(specs)
    if sweep_path.exists():
        stored = read_sweep_file(sweep_path)
        _check_world_hashes(sweep_path, stored.get("world_files"), hashes)  # first: an edit changes the trials
        have = stored["trials"]
        if have != wanted:
            first = next((i for i, (a, b) in enumerate(zip(have, wanted, strict=False)) if a != b),
                         min(len(have), len(wanted)))
            what = (f"trial {first}: {_differences(have[first], wanted[first])}"
                    if first < min(len(have), len(wanted)) else "one list is a prefix of the other")
            raise SweepError(
                f"{out_dir} holds a different sweep ({len(have)} stored trials, {len(wanted)} requested; "
                f"first difference at {what}). Resume it with its original arguments or choose a new --out.")
        return False
    if (out_dir / RESULTS_NAME).exists():
        raise SweepError(f"{out_dir / RESULTS_NAME} exists but {sweep_path} does not: not a navstack sweep "
                         f"directory (or its sweep.json was removed); choose a new --out")
    doc = {"format": SWEEP_FORMAT, "config": config, "command": command, "n_trials": len(wanted),
           "trials": wanted, "world_files": hashes}
    _atomic_write_bytes(sweep_path, (json.dumps(doc, indent=1) + "\n").encode("utf-8"))
    return True


def _differences(stored: Any, wanted: dict[str, Any]) -> str:
    """What differs between a stored trial and a requested one, key by key (each value cut to 80 characters)."""
    if not isinstance(stored, dict):
        return f"stored {stored!r:.160} vs requested {wanted!r:.160}"
    absent = object()

    def shown(v: Any) -> str:
        return "absent" if v is absent else f"{v!r:.80}"

    keys = sorted(set(stored) | set(wanted), key=str)
    diff = [f"{k}: stored {shown(stored.get(k, absent))}, requested {shown(wanted.get(k, absent))}" for k in keys
            if stored.get(k, absent) != wanted.get(k, absent)]
    return "; ".join(diff)


def _world_hashes(specs: Sequence[TrialSpec]) -> dict[str, str | None]:
    """SHA-256 of each world file the trials read (``--worlds``; None: unreadable), by path, and of each mesh file
    such a world names (by its resolved path): a mesh changed between two runs of a sweep changes its world."""
    from navstack.world import named_mesh_files

    out: dict[str, str | None] = {}
    for spec in specs:
        if not spec.generated and spec.world_file not in out:
            text = _read_regular(Path(spec.world_file))
            out[spec.world_file] = None if text is None else hashlib.sha256(text).hexdigest()
            for mesh in named_mesh_files(text, spec.world_file):
                if str(mesh) not in out:
                    out[str(mesh)] = _sha256(mesh)
    return out


def _read_regular(path: Path) -> bytes | None:
    """The bytes of a regular file (None: not one, or unreadable: a FIFO or a device is not read, the trial refuses
    it with its own message)."""
    try:
        return path.read_bytes() if path.is_file() else None
    except OSError:
        return None


def _sha256(path: Path) -> str | None:
    """SHA-256 of a regular file, read in chunks (None as :func:`_read_regular`)."""
    try:
        if not path.is_file():
            return None
        digest = hashlib.sha256()
        with path.open("rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                digest.update(chunk)
        return digest.hexdigest()
    except OSError:
        return None


def _check_world_hashes(sweep_path: Path, stored: Any, now: dict[str, str | None]) -> None:
    """Refuse to resume a sweep whose world files changed since it began: its finished trials ran the earlier
    text, the rest would run the new one, and the results would mix them unseen.  (Sweeps written before
    the hashes were stored have none: nothing to compare.)"""
    if not isinstance(stored, dict):
        return
    changed = [f for f, h in now.items() if f in stored and stored[f] != h]
    if changed:
        more = f" (and {len(changed) - 1} more)" if len(changed) > 1 else ""
        raise SweepError(f"{changed[0]}{more} changed since the sweep in {sweep_path.parent} began: its finished "
                         f"trials ran the earlier file. Put the earlier file back to resume, or choose a new --out")


SPEC_KEYS = ("controller", "planner", "seed", "family", "difficulty", "index", "world_id", "world_file",
             "world_seed")
"""The fields of a results line that its :class:`TrialSpec` fixes: a resumed line must agree with the spec of its
``trial_id`` on each it holds (a line of another sweep configuration, e.g. another ``--seed``, has the same
``trial_id`` but other seeds and worlds)."""


def spec_mismatch(rec: dict[str, Any], spec: TrialSpec) -> str | None:
    """Why ``rec`` is not a line of ``spec``'s trial, or None."""
    want = spec.to_dict()
    for key in SPEC_KEYS:
        if key in rec and (rec[key] != want[key] or isinstance(rec[key], bool) != isinstance(want[key], bool)):
            return f"'{key}' is {rec[key]!r:.80}, but this sweep's trial {spec.trial_id!r} has {want[key]!r:.80}"
    return None


def _load_done(results: Path, ids: set[str] | dict[str, TrialSpec]) -> tuple[dict[str, dict[str, Any]], bool]:
    """Finished records by trial_id; drops (and cuts off) a truncated last line; errors on foreign ids and, when
    ``ids`` maps each id to its spec, on a line that disagrees with its spec (:data:`SPEC_KEYS`)."""
    from navstack.report import check_record

    rf = read_results(results)
    if rf.truncated_tail:
        os.truncate(results, rf.valid_bytes)
    elif rf.valid_bytes and not results.read_bytes().endswith(b"\n"):
        with open(results, "ab") as fh:  # complete last record without its newline: terminate it
            fh.write(b"\n")
            fh.flush()
            os.fsync(fh.fileno())
    done: dict[str, dict[str, Any]] = {}
    for rec, line in zip(rf.records, rf.line_numbers, strict=True):
        tid = rec.get("trial_id")
        if not isinstance(tid, str):
            raise SweepError(f"{results}, line {line}: record without a string 'trial_id'")
        if tid not in ids:
            raise SweepError(f"{results}, line {line}: trial_id {tid!r} is not part of this sweep")
        if tid in done:
            raise SweepError(f"{results}, line {line}: trial_id {tid!r} recorded twice")
        why = spec_mismatch(rec, ids[tid]) if isinstance(ids, dict) else None
        if why is not None:
            raise SweepError(f"{results}, line {line}: not a line of this sweep: {why} (a line of another sweep "
                             "configuration, or edited); remove it to run that trial again, or choose a new --out")
        why = check_record(rec)  # what report and compare would refuse is no finished trial either
        if why is not None:
            raise SweepError(f"{results}, line {line}: {why}; remove the line to run that trial again, or choose a "
                             "new --out")
        done[tid] = rec
    return done, rf.truncated_tail


def _rewrite_sorted(results: Path, specs: Sequence[TrialSpec]) -> None:
    rf = read_results(results)
    by_id = {r["trial_id"]: r for r in rf.records}
    data = b"".join(_encode(by_id[s.trial_id]) for s in specs)
    if data != results.read_bytes():
        _atomic_write_bytes(results, data)


def _check_picklable(name: str, fn: Any) -> None:
    if fn is None:
        return
    try:
        pickle.dumps(fn)
    except Exception as exc:
        raise SweepError(f"{name} must be a picklable top-level function (workers are spawned): "
                         f"{exc}") from exc


class _Interrupted(Exception):
    pass


def run_sweep(specs: Iterable[TrialSpec], out_dir: str | Path, jobs: int | None = None,
              trial_timeout: float | None = DEFAULT_TRIAL_TIMEOUT, runner: Runner | None = None,
              progress: bool = True, *, generator: Generator | None = None, keep_trajectories: bool = False,
              config: SweepConfig | dict[str, Any] | None = None, command: str | None = None,
              backend: str = "local", ray_address: str | None = None,
              animate_failures: bool = False) -> SweepSummary:
    """Run (or resume) the trials ``specs`` on ``backend``; results go to ``out_dir``.

    Parameters
    ----------
    specs: the trial list (usually :func:`build_specs`); stored in ``out_dir/sweep.json`` on the first run and
        compared on every rerun (a different list raises :class:`SweepError`).
    jobs: parallel trials (default: all usable cores; for Ray, all the cluster's CPUs).
    trial_timeout: wall-clock limit per trial in seconds (``None``: no limit), counted from the moment a
        started worker takes the trial; a trial over it is killed with its worker and recorded as
        ``reason: "error"``.
    runner: ``runner(world_path, *, controller, planner, seed, out_dir) -> dict | TrialResult`` (default
        ``navstack.trial.run_trial``); must be a picklable top-level function.
    progress: show a tqdm bar (stderr) with done/total, successes and ETA.
    generator: ``generator(family, seed=world_seed, difficulty=d) -> World | dict`` for generated worlds (default
        ``navstack.generate.generate_world``); called with ``retract=True`` as well for ``retract`` specs.
    keep_trajectories: write each trial's output files under ``out_dir/trials/<trial_id>/``.
    animate_failures: keep the output files of the trials that fail (reason other than ``reached`` and
        ``error``) and animate them there (``animation.mp4``, made by the driver).
    config, command: stored in ``sweep.json`` for the record (not compared).
    backend, ray_address: ``local`` (worker processes here) or ``ray`` (see :mod:`navstack.executors`).

    Returns a :class:`SweepSummary`; on Ctrl-C (SIGINT) or SIGTERM it stops the workers, keeps every finished
    line and returns with ``interrupted=True``.
    """
    specs = list(specs)
    _check_unique(specs)
    try:
        out = Path(out_dir).expanduser().resolve()
    except (OSError, RuntimeError) as exc:  # RuntimeError: a loop of symbolic links (Python < 3.13)
        raise SweepError(f"--out: {out_dir}: {exc}") from exc
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise SweepError(f"jobs must be an integer >= 1, got {jobs!r}")
    if trial_timeout is not None and not (isinstance(trial_timeout, int | float) and trial_timeout > 0):
        raise SweepError(f"trial_timeout must be a positive number of seconds or None, got {trial_timeout!r}")
    if backend not in BACKENDS:
        raise SweepError(f"--backend: unknown backend {backend!r}; expected one of {list(BACKENDS)}")
    _check_picklable("runner", runner)
    _check_picklable("generator", generator)
    cfg = config.to_dict() if isinstance(config, SweepConfig) else config
    if any(not s.generated and Path(s.world_file).expanduser().parent.resolve() == out for s in specs):
        raise SweepError(f"--out: {out} is the --worlds folder; the sweep's own {SWEEP_NAME} there would be read "
                         "as a world file by the next run, so the sweep could not be resumed. Choose another "
                         "--out (a subfolder of the worlds folder is fine)")
    if out.exists() and not out.is_dir():
        raise SweepError(f"--out: {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    run = _Run(out=out, jobs=jobs, trial_timeout=trial_timeout, runner=runner, generator=generator,
               keep_trajectories=keep_trajectories, backend=backend, ray_address=ray_address, progress=progress,
               animate_failures=animate_failures)
    with _exclusive_lock(out):
        created = _prepare_dir(out, specs, cfg, command)
        try:
            return run.sweep(specs)
        except SweepError:
            if created and not (out / RESULTS_NAME).exists():
                # nothing ran (the backend did not start): leave no sweep.json that a rerun with other arguments
                # would refuse as "a different sweep"
                (out / SWEEP_NAME).unlink(missing_ok=True)
            raise


@contextlib.contextmanager
def _exclusive_lock(out: Path) -> Any:
    """Hold ``out/sweep.lock`` (flock; released by the kernel even if the process is killed)."""
    import fcntl

    fd = os.open(out / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as exc:
            raise SweepError(f"{out}: another sweep is running in this directory (it holds "
                             f"{out / LOCK_NAME}); wait for it or stop it first") from exc
        yield
    finally:
        os.close(fd)


def _job(spec: TrialSpec, run: _Run) -> TrialJob | str:
    """The job of ``spec``, or why it cannot run (an unreadable or syntactically malformed world file)."""
    from navstack.executors import TrialJob

    text = None
    if not spec.generated:
        path = Path(spec.world_file)
        if path.is_symlink() and not path.exists():
            return (f"{path}: cannot read world file: a symbolic link to {os.readlink(path)}, which leads to no "
                    "file (a missing target or a loop of links)")
        try:
            text = path.read_bytes().decode("utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            return f"{path}: cannot read world file: {exc}"
        try:
            json.loads(text.lstrip("\ufeff"))
        except json.JSONDecodeError as exc:
            return f"{path}: invalid JSON: {exc.msg} (line {exc.lineno}, column {exc.colno})"
        except RecursionError:
            return f"{path}: invalid JSON: nested too deeply"
        except ValueError as exc:  # an integer of more than 4300 digits (sys.get_int_max_str_digits)
            return f"{path}: invalid JSON: {exc}"
    return TrialJob(spec=spec, world_text=text, keep_files=run.keep_trajectories or run.animate_failures,
                    runner=run.runner,
                    generator=run.generator)


def _wall_limit(job: TrialJob, trial_timeout: float | None) -> float | None:
    """The trial's wall-clock limit [s]: ``trial_timeout``, or its world file's ``time_limit`` if that is
    longer (at most :data:`navstack.world.MAX_TIME_LIMIT`), so a valid world is never cut off before its
    simulated time could pass in real time (a 3600 s world takes minutes; the default limit is 600 s)."""
    if trial_timeout is None or job.world_text is None:
        return trial_timeout
    from navstack.world import MAX_TIME_LIMIT

    try:
        limit = json.loads(job.world_text.lstrip("\ufeff")).get("time_limit")
    except (ValueError, RecursionError, AttributeError):
        return trial_timeout
    if isinstance(limit, bool) or not isinstance(limit, int | float) or not limit <= MAX_TIME_LIMIT:
        return trial_timeout
    return max(trial_timeout, float(limit))


@dataclass
class _Run:
    """One invocation of :func:`run_sweep`: its options, and the driver loop that is the only writer of ``out``."""

    out: Path
    jobs: int | None
    trial_timeout: float | None
    runner: Runner | None
    generator: Generator | None
    keep_trajectories: bool
    backend: str
    ray_address: str | None
    progress: bool
    animate_failures: bool = False
    bar: Any = None
    summary: Any = None
    successes: int = 0

    def sweep(self, specs: list[TrialSpec]) -> SweepSummary:
        results = self.out / RESULTS_NAME
        done, dropped = _load_done(results, {s.trial_id: s for s in specs})
        todo = deque(s for s in specs if s.trial_id not in done)
        self.summary = SweepSummary(out_dir=self.out, results_path=results, total=len(specs), skipped=len(done),
                                    dropped_truncated_line=dropped, recorded=len(done))
        t0 = time.monotonic()
        self.successes = sum(1 for r in done.values() if r.get("success") is True)
        if todo:
            self._run_pending(todo, {s.trial_id: i for i, s in enumerate(specs)})
        self.summary.wall_time = time.monotonic() - t0
        if self.summary.complete and not self.summary.interrupted:
            _rewrite_sorted(results, specs)
        return self.summary

    def _run_pending(self, todo: deque[TrialSpec], order: dict[str, int]) -> None:
        from navstack.executors import BackendError, make_executor

        try:
            executor = make_executor(self.backend, jobs=self.jobs, runner=self.runner,
                                     log_path=str(self.out / LOG_NAME), ray_address=self.ray_address)
        except BackendError as exc:
            raise SweepError(str(exc)) from exc
        writer = _ResultsWriter(self.summary.results_path)
        if self.progress:
            from tqdm import tqdm

            self.bar = tqdm(total=self.summary.total, initial=self.summary.recorded, unit="trial",
                            dynamic_ncols=True, desc="trials", file=sys.stderr)
            self.bar.set_postfix_str(f"ok {self.successes}/{self.summary.recorded}")
        old_term = None
        if threading.current_thread() is threading.main_thread():
            old_term = signal.signal(signal.SIGTERM, _on_sigterm)
        pending: dict[cf.Future[Any], TrialSpec] = {}
        cancel = True
        try:
            while todo or pending:
                while todo and len(pending) < executor.capacity():
                    spec = todo.popleft()
                    job = _job(spec, self)
                    if isinstance(job, str):
                        self._record(writer, spec, error_reply(job, 0.0), executor.backend)
                    else:
                        pending[executor.submit(job, _wall_limit(job, self.trial_timeout))] = spec
                if pending:
                    finished, _ = cf.wait(pending, timeout=1.0, return_when=cf.FIRST_COMPLETED)
                    executor.check()
                    for fut in sorted(finished, key=lambda f: order[pending[f].trial_id]):
                        self._record(writer, pending.pop(fut), fut.result(), executor.backend)
            cancel = False
        except (KeyboardInterrupt, _Interrupted):
            self.summary.interrupted = True
        finally:
            executor.close(cancel=cancel)
            writer.close()
            if self.bar is not None:
                self.bar.close()
            if old_term is not None:
                signal.signal(signal.SIGTERM, old_term)

    def _keep_files(self, spec: TrialSpec, files: dict[str, bytes]) -> bool:
        """Write a trial's output files into its folder; whether any were written (a file that cannot be written
        is said on stderr: it must never cost the sweep the trial's results line)."""
        try:
            for rel, data in files.items():
                path = trial_folder(self.out, spec.trial_id) / rel
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
        except OSError as exc:
            print(f"navstack trials: could not keep the files of {spec.trial_id}: {exc}", file=sys.stderr)
            return False
        return bool(files)

    def _animate(self, spec: TrialSpec) -> str | None:
        """Animate a failed trial's kept folder; the file relative to ``out`` (None if it could not be made)."""
        from navstack.animate import animate_run

        try:
            return animate_run(trial_folder(self.out, spec.trial_id)).relative_to(self.out).as_posix()
        except Exception as exc:  # noqa: BLE001 - a picture must never cost the sweep its results line
            print(f"navstack trials: could not animate {spec.trial_id}: {exc}", file=sys.stderr)
            return None

    def _world_text(self, spec: TrialSpec, reply: dict[str, Any]) -> str | None:
        """The trial's world file as text, if known: generated by the worker, or on disk (at most 64 MB)."""
        if reply.get("world_json"):
            return reply["world_json"]
        path = self.out / spec.world_file if spec.generated else Path(spec.world_file)
        try:
            if not path.is_file() or path.stat().st_size > 64 << 20:
                return None
            return path.read_bytes().decode("utf-8-sig", errors="replace")
        except OSError:
            return None

    def _record(self, writer: _ResultsWriter, spec: TrialSpec, reply: dict[str, Any], backend: str) -> None:
        """Write what a worker returned: the generated world, the trial's files, then its results line."""
        if reply.get("world_json") and spec.generated:
            _write_if_changed(self.out / spec.world_file, reply["world_json"].encode("utf-8"))
        result = reply.get("result")
        if result is None:
            rec = _error_record(spec, reply["error"], reply["wall_time"], reply.get("traceback"),
                                self._world_text(spec, reply))
        else:
            try:
                rec = _validated_result(spec, result)
            except TypeError as exc:
                rec = _error_record(spec, str(exc), reply["wall_time"], world_text=self._world_text(spec, reply))
        failed = rec.get("success") is not True and rec.get("reason") != "error"
        kept = False
        if self.keep_trajectories or (self.animate_failures and failed):
            kept = self._keep_files(spec, reply.get("files") or {})
        if self.animate_failures and failed and kept:
            rec["animation"] = self._animate(spec)
        s = self.summary
        with _signals_deferred():  # the line and its count together: an interrupt comes before or after both
            writer.append(_finish_record(spec, rec, {**reply["provenance"], "backend": backend}))
            s.recorded += 1
            s.ran += 1
            if rec.get("success") is True:
                s.succeeded += 1
                self.successes += 1
            if rec.get("reason") == "error":
                s.errors += 1
                s.error_ids.append(spec.trial_id)
        if self.bar is not None:
            self.bar.set_postfix_str(f"ok {self.successes}/{s.recorded}"
                                     + (f", errors {s.errors}" if s.errors else ""), refresh=False)
            self.bar.update(1)


FOLDER_BYTES = 200
"""The longest kept trial folder name [bytes]; a longer ``trial_id`` (a world file of a long name) is cut and
ends in 16 hex digits of its SHA-256 (file systems allow 255 bytes a name)."""


def trial_folder(out: Path, trial_id: str) -> Path:
    """The folder where a kept trial's files go: ``out/trials/<trial_id>``, its name cut as :data:`FOLDER_BYTES`
    says when the id is too long for one."""
    raw = os.fsencode(trial_id)
    if len(raw) <= FOLDER_BYTES:
        return out / "trials" / trial_id
    digest = hashlib.sha256(raw).hexdigest()[:16]
    head = raw[:FOLDER_BYTES - 18].decode("utf-8", errors="ignore")  # a character cut in two is dropped
    return out / "trials" / f"{head}__{digest}"


def _on_sigterm(signum: int, frame: Any) -> None:
    raise _Interrupted()


@contextlib.contextmanager
def _signals_deferred() -> Any:
    """Hold SIGINT and SIGTERM until the block is done, then deliver them to the handlers in place before, so
    an interrupt cannot fall between a results line and the summary's count of it.  The handlers are swapped
    (a thread's signal mask is not enough: the process's other threads would take the signal).  Only the
    main thread can do so; elsewhere nothing is held."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    signals = (signal.SIGINT, signal.SIGTERM)
    old = {sig: signal.signal(sig, lambda signum, frame: held.append(signum)) for sig in signals}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(held):
            signal.raise_signal(sig)


def _write_if_changed(path: Path, data: bytes) -> None:
    with contextlib.suppress(OSError):
        if path.read_bytes() == data:
            return
    path.parent.mkdir(parents=True, exist_ok=True)
    _atomic_write_bytes(path, data)


# --------------------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------------------


def _timeout_arg(text: str) -> float:
    """``--trial-timeout``: a finite number of seconds >= 0 (0 = no limit); anything else is bad input."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a number of seconds >= 0 (0 = no limit), got {text!r}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``navstack trials`` options to ``parser`` (see :func:`run_from_args`)."""
    from navstack.cli import nonempty_path
    from navstack.registry import CONTROLLERS, FAMILIES, PLANNERS

    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--generate", nargs="+", metavar="FAMILY",
                     help="world families to generate (listed below): " + ", ".join(FAMILIES))
    src.add_argument("--worlds", metavar="DIR", type=nonempty_path,
                     help="run every *.json world file in DIR (the suffix in any case; not in subfolders)")
    parser.add_argument("--count", type=int, default=1,
                        help="worlds per family and difficulty (--generate) "
                             "or repetitions per file (--worlds)")
    parser.add_argument("--seed", type=int, default=0, help="sweep seed; worlds and noise derive from it")
    parser.add_argument("--difficulty", type=float, nargs="+", default=None, metavar="D",
                        help="generator difficulties (default 0.5)")
    parser.add_argument("--controller", action="append", choices=tuple(CONTROLLERS), default=None,
                        help="controller to run (repeatable; default slither)")
    parser.add_argument("--planner", action="append", choices=tuple(PLANNERS), default=None,
                        help="planner to run (repeatable; default field)")
    parser.add_argument("--settings", metavar="FILE", type=nonempty_path, default=None,
                        help="a JSON file of trial settings to change (see: navstack settings); every trial uses "
                             "them, sweep.json keeps them, each results line names their SHA-256")
    parser.add_argument("--retract", action="store_true",
                        help="generate worlds the robot must back out of after the last goal (--generate only)")
    parser.add_argument("--jobs", type=int, default=None,
                        help="trials at once (default: all cores; with --backend ray, the cluster's CPUs)")
    parser.add_argument("--backend", choices=BACKENDS, default="local",
                        help="local: worker processes on this machine (default); ray: Ray tasks "
                             "(needs pip install 'navstack[ray]')")
    parser.add_argument("--ray-address", metavar="ADDR", default=None,
                        help="Ray cluster to use with --backend ray (default: $RAY_ADDRESS, else a new Ray "
                             "instance on this machine)")
    parser.add_argument("--trial-timeout", type=_timeout_arg, default=DEFAULT_TRIAL_TIMEOUT, metavar="SEC",
                        help=f"wall-clock limit per trial, s (default {DEFAULT_TRIAL_TIMEOUT:g}; 0 = none); "
                             "at least the world file's time_limit")
    parser.add_argument("--keep-trajectories", action="store_true",
                        help="write each trial's result.json and trajectory.npz under DIR/trials/")
    parser.add_argument("--animate-failures", action="store_true",
                        help="keep the failed trials' folders under DIR/trials/ with an animation.mp4 each "
                             "(the report links them)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--out", required=True, metavar="DIR", type=nonempty_path,
                        help="sweep directory (created or resumed)")


def trial_settings(path: str | None) -> Any:
    """The :class:`navstack.trial.TrialConfig` of a ``--settings`` file, ``None`` without one or when it leaves
    every setting at its default; :class:`SweepError` naming the file and the setting when it is bad."""
    if path is None:
        return None
    from navstack.settings import SettingsError, load_settings
    from navstack.trial import TrialConfig

    try:
        config = load_settings(path)
    except SettingsError as exc:
        raise SweepError(f"--settings: {exc}") from None
    return None if config == TrialConfig() else config


def config_from_args(args: argparse.Namespace, settings: Any = None) -> SweepConfig:
    """The :class:`SweepConfig` described by parsed ``navstack trials`` arguments (``settings``: the trials'
    :class:`navstack.trial.TrialConfig` when not the defaults, :func:`trial_settings`)."""
    from navstack.settings import settings_digest

    if args.worlds is not None and args.difficulty is not None:
        raise SweepError("--difficulty only applies to --generate (world files carry their own)")
    if args.worlds is not None and args.retract:
        raise SweepError("--retract only applies to --generate (a world file says \"retract\": true itself)")
    if args.ray_address is not None and args.backend != "ray":
        raise SweepError("--ray-address only applies to --backend ray")
    return SweepConfig(
        families=tuple(args.generate or ()), count=args.count, seed=args.seed,
        difficulties=tuple(args.difficulty) if args.difficulty else (0.5,), worlds_dir=args.worlds,
        controllers=tuple(args.controller or ("slither",)), planners=tuple(args.planner or ("field",)),
        retract=bool(args.retract), settings=None if settings is None else settings_digest(settings))


def run_from_args(args: argparse.Namespace, argv: Sequence[str] | None = None) -> int:
    """Run ``navstack trials``; returns the exit status (0 done, 2 bad input, 130 interrupted).

    ``argv`` (the command's arguments, default ``sys.argv[1:]``) is only used to print how to resume.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    command = shlex.join(["navstack", *argv])
    try:
        settings = trial_settings(args.settings)
        config = config_from_args(args, settings)
        specs = build_specs(config)
        record: SweepConfig | dict[str, Any] = config
        custom: dict[str, Any] = {}  # the default runner unless settings are given
        if settings is not None:  # every trial runs with them; sweep.json keeps every setting for the record
            from navstack.settings import settings_to_dict
            from navstack.trial import run_trial

            record = {**config.to_dict(), "trial_settings": settings_to_dict(settings)}
            custom["runner"] = functools.partial(run_trial, config=settings)
        summary = run_sweep(specs, args.out, jobs=args.jobs, **custom,
                            trial_timeout=args.trial_timeout if args.trial_timeout > 0 else None,
                            progress=not args.no_progress, keep_trajectories=args.keep_trajectories,
                            config=record, command=command, backend=args.backend,
                            ray_address=args.ray_address, animate_failures=args.animate_failures)
    except SweepError as exc:
        print(f"navstack trials: error: {exc}", file=sys.stderr)
        return 2
    if summary.dropped_truncated_line:
        print(f"note: dropped a truncated last line of {summary.results_path} (a write cut by a kill); "
              "that trial was run again", file=sys.stderr)
    if summary.interrupted:
        print(f"\nInterrupted: {summary.recorded} of {summary.total} trials are recorded in "
              f"{summary.results_path}.\nTo resume, run the same command again:\n  {command}",
              file=sys.stderr)
        return 130
    failed = summary.recorded - summary.skipped - summary.succeeded
    print(f"{summary.total} trials ({summary.skipped} already done, {summary.ran} run now: "
          f"{summary.succeeded} succeeded, {failed} failed, {summary.errors} of them errors) "
          f"in {summary.wall_time:.1f} s -> {summary.results_path}\n"
          f"Summarise with: navstack report {shlex.quote(str(summary.out_dir))}")
    if summary.error_ids:
        print(f"errors (see the 'error' field): {', '.join(summary.error_ids[:10])}"
              + (" ..." if len(summary.error_ids) > 10 else ""), file=sys.stderr)
    return 0


add_trials_arguments = add_arguments
"""Alias of :func:`add_arguments` (the name ``navstack.cli`` uses)."""


def main_trials(args: argparse.Namespace) -> int:
    """``navstack trials`` entry point for ``navstack.cli`` (= :func:`run_from_args` with ``sys.argv``)."""
    return run_from_args(args)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m navstack.sweep`` = ``navstack trials``."""
    parser = argparse.ArgumentParser(prog="navstack trials", description=__doc__.split("\n")[0])
    add_arguments(parser)
    argv = list(sys.argv[1:] if argv is None else argv)
    return run_from_args(parser.parse_args(argv), ["trials", *argv])


if __name__ == "__main__":
    sys.exit(main())
