"""Randomized trial sweeps: many closed-loop trials in parallel worker processes, with resume.

``navstack trials`` (interfaces.md section 4) runs every combination of world x controller x planner
(x repetition) and appends one JSON line per finished trial to ``DIR/results.jsonl``.

Trial list
    :func:`build_specs` turns a :class:`SweepConfig` into a deterministic list of :class:`TrialSpec`, each
    with a stable ``trial_id``. Generated worlds come from ``navstack.generate.generate_world(family,
    world_seed, difficulty)`` where ``world_seed`` is derived (SHA-256, not Python's salted ``hash``) from
    ``(seed, family, index)`` only, so the same index gives the same layout at every difficulty and the same
    seed always gives the same worlds. The trial's noise seed is derived the same way and is shared by all
    controllers and planners on one world (paired comparison). The list is ordered by index first, so an
    interrupted sweep has covered every family / difficulty / controller about equally.

Outputs in ``DIR``
    * ``sweep.json``: the trial list (and the config / command that made it). A rerun whose trial list differs
      is refused with :class:`SweepError`; use a new ``--out`` directory instead.
    * ``results.jsonl``: one line per finished trial: the ``result.json`` fields of interfaces.md section 3
      plus ``trial_id``, ``family``, ``difficulty``, ``index``, ``world_id``, ``world_file`` and
      ``world_seed``. Only the parent process writes it, one ``os.write`` of a whole line followed by
      ``fsync``. Lines appear in completion order while the sweep runs; when every trial is done the file is
      rewritten (atomically, via ``os.replace``) in trial-list order, so a completed sweep's file is identical
      for identical inputs except for ``wall_time``. Non-finite floats are written as ``null`` (strict JSON).
    * ``worlds/<world_id>.json``: each generated world, as the trial loaded it; rerun one by hand with
      ``navstack run DIR/worlds/<world_id>.json --controller C --planner P --seed S`` (values from its line).
    * ``workers.log``: the worker processes' stdout/stderr (PyBullet banners, prints), kept off the terminal.
    * ``sweep.lock``: held (``flock``) while a sweep runs, so a second sweep on the same ``DIR`` is refused.
    * ``trials/<trial_id>/`` (only with ``keep_trajectories``): each trial's ``result.json`` and trajectory.

Resume and crash safety
    A rerun on the same ``DIR`` skips every ``trial_id`` already in ``results.jsonl``. A line is only written
    once a trial has finished, so a Ctrl-C, ``kill`` or power loss never records a trial twice, and a
    recorded trial is never lost. If the parent was killed in the middle of writing a line, the file ends
    with an unterminated line: on resume (and in :func:`read_results`) a last line that lacks its final
    newline and is not valid JSON is recognised as such a truncated write and dropped (the file is truncated
    back to the last complete line, and that trial runs again). Any other malformed line is an error naming
    the file and line: it is never silently discarded.

Failures
    A trial whose runner raises, whose worker process dies, or which exceeds ``trial_timeout`` seconds of wall
    clock (the worker is killed and a fresh one started) is recorded with ``success: false``,
    ``reason: "error"`` and an ``error`` message; the sweep goes on. Such lines count as finished: a resume
    does not retry them (start a new ``DIR`` to retry). Unknown metrics of error lines are ``null``.
    The wall-clock limit starts when a worker that has finished starting up (imports done) receives the
    trial, so a slow worker start is never charged to a trial. A worker that cannot start at all (its runner
    does not import) stops the sweep with :class:`SweepWorkerError` instead of being restarted forever.

Processes
    Workers are started with the ``spawn`` method: PyBullet is only ever created inside workers, never in the
    parent. Workers ignore SIGINT (the parent handles Ctrl-C, stops them and keeps what finished) and exit
    by themselves if the parent disappears (``SIGKILL`` of the parent).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import hashlib
import json
import math
import multiprocessing as mp
import os
import pickle
import shlex
import signal
import sys
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import wait as mp_wait
from pathlib import Path
from typing import Any

SWEEP_FORMAT = "navstack-sweep/1"
DEFAULT_TRIAL_TIMEOUT = 600.0
"""Default per-trial wall-clock limit (s), counted from the moment a worker receives the trial."""

RESULTS_NAME = "results.jsonl"
SWEEP_NAME = "sweep.json"
WORLDS_DIR = "worlds"
LOG_NAME = "workers.log"
LOCK_NAME = "sweep.lock"
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
    written by the worker) and an absolute path for ``--worlds`` files. ``world_seed`` is ``None`` for a
    world read from a file. ``difficulty`` is dimensionless (the generator's scale), ``None`` if unknown.
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

    @property
    def generated(self) -> bool:
        """True when the world is generated by the worker (not read from a user's file)."""
        return self.world_seed is not None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (inverse of :meth:`from_dict`)."""
        return dataclasses.asdict(self)

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
    ``seed``) or ``worlds_dir`` (every ``*.json`` directly in that folder, sorted by name, each run ``count``
    times with different noise seeds). ``difficulties`` are passed to the generator (ignored for
    ``worlds_dir``; there the difficulty is read from the world's ``extra.difficulty`` when present).
    """

    families: tuple[str, ...] = ()
    count: int = 1
    seed: int = 0
    difficulties: tuple[float, ...] = (0.5,)
    worlds_dir: str | None = None
    controllers: tuple[str, ...] = ("slither",)
    planners: tuple[str, ...] = ("field",)

    def __post_init__(self) -> None:
        object.__setattr__(self, "families", tuple(self.families))
        object.__setattr__(self, "difficulties", tuple(float(d) for d in self.difficulties))
        object.__setattr__(self, "controllers", tuple(self.controllers))
        object.__setattr__(self, "planners", tuple(self.planners))
        if bool(self.families) == (self.worlds_dir is not None):
            raise SweepError("sweep config: give exactly one of families (--generate) "
                             "or worlds_dir (--worlds)")
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise SweepError(f"sweep config: count must be an integer >= 1, got {self.count!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise SweepError(f"sweep config: seed must be an integer >= 0, got {self.seed!r}")
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


def _world_file_info(path: Path) -> tuple[str | None, float | None]:
    """(family, difficulty) of a world file, read without full validation (the trial validates)."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise SweepError(f"{path}: cannot read world file: {exc}") from exc
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SweepError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from exc
    if not isinstance(data, dict):
        raise SweepError(f"{path}: expected a JSON object (a navstack-world/1 file)")
    family = data.get("family")
    if family is not None and not isinstance(family, str):
        raise SweepError(f"{path}: 'family' must be a string, got {family!r}")
    extra = data.get("extra")
    difficulty = extra.get("difficulty") if isinstance(extra, dict) else None
    if difficulty is None and isinstance(extra, dict) and isinstance(extra.get("generator"), dict):
        difficulty = extra["generator"].get("difficulty")  # a world written by navstack generate
    if isinstance(difficulty, bool) or not isinstance(difficulty, int | float):
        difficulty = None
    return family, (float(difficulty) if difficulty is not None else None)


def build_specs(config: SweepConfig) -> list[TrialSpec]:
    """The deterministic trial list of ``config`` (same config, same list, same ``trial_id`` values).

    Generated: ``trial_id = "<family>__d<difficulty>__<index:04d>__<controller>__<planner>"``.
    Files: ``trial_id = "<file stem>__<repetition:03d>__<controller>__<planner>"``.
    Raises :class:`SweepError` for unknown families, an empty / unreadable worlds folder, or colliding ids.
    """
    specs: list[TrialSpec] = []
    if config.families:
        known = _known_families()
        for fam in config.families:
            if fam not in known:
                raise SweepError(f"--generate: unknown world family {fam!r}; expected one of {list(known)}")
        for index in range(config.count):
            for fam in config.families:
                world_seed = derive_seed("world", config.seed, fam, index)
                trial_seed = derive_seed("trial", config.seed, fam, index)
                for diff in config.difficulties:
                    world_id = f"{fam}__d{diff!r}__{index:04d}"
                    for planner in config.planners:
                        for controller in config.controllers:
                            specs.append(TrialSpec(
                                trial_id=f"{world_id}__{controller}__{planner}", world_id=world_id,
                                world_file=f"{WORLDS_DIR}/{world_id}.json", controller=controller,
                                planner=planner, seed=trial_seed, index=index, family=fam,
                                difficulty=diff, world_seed=world_seed))
    else:
        folder = Path(config.worlds_dir).expanduser().resolve()  # type: ignore[arg-type]
        if not folder.is_dir():
            raise SweepError(f"--worlds: {folder} is not a directory")
        files = sorted(p for p in folder.glob("*.json") if p.is_file())
        if not files:
            raise SweepError(f"--worlds: no *.json world files in {folder}")
        infos = [(p, *_world_file_info(p)) for p in files]
        for rep in range(config.count):
            for path, fam, diff in infos:
                trial_seed = derive_seed("trial", config.seed, path.stem, rep)
                world_id = path.stem
                for planner in config.planners:
                    for controller in config.controllers:
                        specs.append(TrialSpec(
                            trial_id=f"{world_id}__{rep:03d}__{controller}__{planner}", world_id=world_id,
                            world_file=str(path), controller=controller, planner=planner, seed=trial_seed,
                            index=rep, family=fam, difficulty=diff, world_seed=None))
    _check_unique(specs)
    return specs


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
                obj = json.loads(raw.decode("utf-8"))
                if not isinstance(obj, dict):
                    raise ValueError(f"expected a JSON object, got {type(obj).__name__}")
            except (ValueError, UnicodeDecodeError) as exc:
                if not terminated:
                    return ResultsFile(path, records, numbers, pos, True)
                raise SweepError(f"{path}, line {lineno}: malformed result line ({exc})") from exc
            if not terminated:  # complete JSON but missing newline: keep it, the writer will fix the ending
                records.append(obj)
                numbers.append(lineno)
                return ResultsFile(path, records, numbers, len(data), False)
            records.append(obj)
            numbers.append(lineno)
        pos = end
    return ResultsFile(path, records, numbers, len(data), False)


def _json_ready(obj: Any) -> Any:
    """Plain JSON data: numpy scalars/arrays to Python, Paths to str, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_ready(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist"):  # numpy scalar / array
        return _json_ready(obj.tolist())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return _json_ready(dataclasses.asdict(obj))
    return str(obj)


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
# Worker process
# --------------------------------------------------------------------------------------------------------


def _save_world(world: Any, path: Path) -> None:
    """Write a generated world atomically (``dict`` as JSON, else ``navstack.world.save_world``)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.json")
    if isinstance(world, dict):
        tmp.write_text(json.dumps(world, indent=2) + "\n", encoding="utf-8")
    else:
        from navstack.world import save_world

        save_world(world, tmp)
    os.replace(tmp, path)


def _result_to_dict(result: Any) -> dict[str, Any]:
    if isinstance(result, dict):
        return dict(result)
    if hasattr(result, "to_dict"):
        return dict(result.to_dict())
    if dataclasses.is_dataclass(result) and not isinstance(result, type):
        return dataclasses.asdict(result)
    raise TypeError(f"the trial runner returned {type(result).__name__}, expected a dict or a TrialResult")


def _run_one(spec: TrialSpec, out_dir: Path, runner: Runner | None, generator: Generator | None,
             keep_trajectories: bool) -> dict[str, Any]:
    if runner is None:
        from navstack.trial import run_trial as runner
    world_path = out_dir / spec.world_file if spec.generated else Path(spec.world_file)
    if spec.generated:
        if generator is None:
            from navstack.generate import generate_world as generator
        world = generator(spec.family, seed=spec.world_seed, difficulty=spec.difficulty)
        _save_world(world, world_path)
    trial_out = out_dir / "trials" / spec.trial_id if keep_trajectories else None
    result = runner(str(world_path), controller=spec.controller, planner=spec.planner, seed=spec.seed,
                    out_dir=trial_out)
    return _json_ready(_result_to_dict(result))


def _parent_watchdog(parent_pid: int) -> None:
    while True:
        time.sleep(0.5)
        if os.getppid() != parent_pid:
            os._exit(3)


def _worker_main(conn: Any, parent_pid: int, out_dir: str, runner: Runner | None,
                 generator: Generator | None, keep_trajectories: bool, log_path: str | None) -> None:
    """Worker loop.

    Sends ``("ready",)`` once set up (runner imported), or ``("fatal", msg, tb)`` if it cannot start; then for
    each received spec dict ``("ok", trial_id, record)`` or ``("fail", trial_id, msg, tb)``.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_parent_watchdog, args=(parent_pid,), daemon=True).start()
    if log_path is not None:
        fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)
    try:
        if runner is None:
            from navstack.trial import run_trial as runner
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which stops the sweep
        with contextlib.suppress(BrokenPipeError, EOFError, OSError):
            conn.send(("fatal", f"{type(exc).__name__}: {exc}", traceback.format_exc()))
        return
    try:
        conn.send(("ready",))
    except (BrokenPipeError, EOFError, OSError):
        return
    out = Path(out_dir)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        spec = TrialSpec.from_dict(msg)
        try:
            record = _run_one(spec, out, runner, generator, keep_trajectories)
            reply: tuple[Any, ...] = ("ok", spec.trial_id, record)
        except BaseException as exc:  # noqa: BLE001 - every failure of a trial is data, not a crash
            reply = ("fail", spec.trial_id, f"{type(exc).__name__}: {exc}", traceback.format_exc())
        try:
            conn.send(reply)
        except (BrokenPipeError, EOFError, OSError):
            return


@dataclass
class _Worker:
    proc: Any
    conn: Any
    born: float
    ready: bool = False
    spec: TrialSpec | None = None
    started: float = 0.0


class SweepWorkerError(RuntimeError):
    """A worker process could not start (e.g. the runner cannot be imported); the sweep stops."""


STARTUP_TIMEOUT = 300.0
"""Seconds a new worker may take to import its runner before the sweep gives up (s)."""


# --------------------------------------------------------------------------------------------------------
# Parent
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


def _error_record(spec: TrialSpec, message: str, wall_time: float, tb: str | None = None) -> dict[str, Any]:
    """A trial that crashed, hung or could not start: no steps were recorded (counts 0), its metrics are
    unknown (``null``), ``error`` says why and ``traceback`` where."""
    rec: dict[str, Any] = {
        "world": spec.world_id, "seed": spec.seed, "controller": spec.controller, "planner": spec.planner,
        "success": False, "reason": "error", "goals_reached": 0, "sim_time": 0.0, "steps": 0,
        "wall_time": round(wall_time, 6), "metrics": {k: None for k in METRIC_KEYS}, "error": message,
    }
    if tb:
        rec["traceback"] = tb
    return rec


def _finish_record(spec: TrialSpec, result: dict[str, Any]) -> dict[str, Any]:
    record: dict[str, Any] = {"trial_id": spec.trial_id}
    record.update({k: v for k, v in result.items() if k != "trial_id"})
    record.update(family=spec.family, difficulty=spec.difficulty, index=spec.index, world_id=spec.world_id,
                  world_file=spec.world_file, world_seed=spec.world_seed)
    return record


def _validated_result(spec: TrialSpec, result: Any) -> dict[str, Any]:
    if not isinstance(result, dict) or not isinstance(result.get("success"), bool) \
            or not isinstance(result.get("reason"), str):
        raise TypeError(f"trial {spec.trial_id}: runner result lacks a bool 'success' and a str 'reason': "
                        f"{result!r:.200}")
    return result


def _prepare_dir(out_dir: Path, specs: Sequence[TrialSpec], config: dict[str, Any] | None,
                 command: str | None) -> None:
    """Create ``out_dir`` and its ``sweep.json``, or check that the stored sweep is the same one."""
    if out_dir.exists() and not out_dir.is_dir():
        raise SweepError(f"--out: {out_dir} exists and is not a directory")
    out_dir.mkdir(parents=True, exist_ok=True)
    sweep_path = out_dir / SWEEP_NAME
    wanted = [s.to_dict() for s in specs]
    if sweep_path.exists():
        try:
            stored = json.loads(sweep_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise SweepError(f"{sweep_path}: unreadable sweep description ({exc})") from exc
        if not isinstance(stored, dict) or stored.get("format") != SWEEP_FORMAT \
                or not isinstance(stored.get("trials"), list):
            raise SweepError(f"{sweep_path}: not a {SWEEP_FORMAT} file")
        have = stored["trials"]
        if have != wanted:
            first = next((i for i, (a, b) in enumerate(zip(have, wanted, strict=False)) if a != b),
                         min(len(have), len(wanted)))
            what = (f"trial {first}: stored {have[first]!r:.160} vs requested {wanted[first]!r:.160}"
                    if first < min(len(have), len(wanted)) else "one list is a prefix of the other")
            raise SweepError(
                f"{out_dir} holds a different sweep ({len(have)} stored trials, {len(wanted)} requested; "
                f"first difference at {what}). Resume it with its original arguments or choose a new --out.")
        return
    if (out_dir / RESULTS_NAME).exists():
        raise SweepError(f"{out_dir / RESULTS_NAME} exists but {sweep_path} does not: not a navstack sweep "
                         f"directory (or its sweep.json was removed); choose a new --out")
    doc = {"format": SWEEP_FORMAT, "config": config, "command": command, "n_trials": len(wanted),
           "trials": wanted}
    _atomic_write_bytes(sweep_path, (json.dumps(doc, indent=1) + "\n").encode("utf-8"))


def _load_done(results: Path, ids: set[str]) -> tuple[dict[str, dict[str, Any]], bool]:
    """Finished records by trial_id; drops (and cuts off) a truncated last line; errors on foreign ids."""
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
        done[tid] = rec
    return done, rf.truncated_tail


def _rewrite_sorted(results: Path, specs: Sequence[TrialSpec]) -> None:
    rf = read_results(results)
    by_id = {r["trial_id"]: r for r in rf.records}
    data = b"".join(_encode(by_id[s.trial_id]) for s in specs)
    if data != results.read_bytes():
        _atomic_write_bytes(results, data)


def _resolve_jobs(jobs: int | None) -> int:
    if jobs is None:
        try:
            return max(1, len(os.sched_getaffinity(0)))
        except AttributeError:  # pragma: no cover - not Linux
            return max(1, os.cpu_count() or 1)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise SweepError(f"jobs must be an integer >= 1, got {jobs!r}")
    return jobs


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
              config: SweepConfig | dict[str, Any] | None = None, command: str | None = None) -> SweepSummary:
    """Run (or resume) the trials ``specs`` in ``jobs`` worker processes; results go to ``out_dir``.

    Parameters
    ----------
    specs: the trial list (usually :func:`build_specs`); stored in ``out_dir/sweep.json`` on the first run and
        compared on every rerun (a different list raises :class:`SweepError`).
    jobs: worker processes (default: all usable cores); never more than the trials left.
    trial_timeout: wall-clock limit per trial in seconds (``None``: no limit); a trial over it is killed with
        its worker and recorded as ``reason: "error"``.
    runner: ``runner(world_path, *, controller, planner, seed, out_dir) -> dict | TrialResult`` (default
        ``navstack.trial.run_trial``); must be a picklable top-level function.
    progress: show a tqdm bar (stderr) with done/total, successes and ETA.
    generator: ``generator(family, seed=world_seed, difficulty=d) -> World | dict`` for generated worlds (default
        ``navstack.generate.generate_world``).
    keep_trajectories: give each trial ``out_dir/trials/<trial_id>/`` as its output folder.
    config, command: stored in ``sweep.json`` for the record (not compared).

    Returns a :class:`SweepSummary`; on Ctrl-C (SIGINT) or SIGTERM it stops the workers, keeps every finished
    line and returns with ``interrupted=True``.
    """
    specs = list(specs)
    _check_unique(specs)
    out = Path(out_dir).expanduser().resolve()
    n_jobs = _resolve_jobs(jobs)
    if trial_timeout is not None and not (isinstance(trial_timeout, int | float) and trial_timeout > 0):
        raise SweepError(f"trial_timeout must be a positive number of seconds or None, got {trial_timeout!r}")
    _check_picklable("runner", runner)
    _check_picklable("generator", generator)
    cfg = config.to_dict() if isinstance(config, SweepConfig) else config
    if out.exists() and not out.is_dir():
        raise SweepError(f"--out: {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    with _exclusive_lock(out):
        return _sweep_locked(specs, out, n_jobs, trial_timeout, runner, progress, generator,
                             keep_trajectories, cfg, command)


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


def _sweep_locked(specs: list[TrialSpec], out: Path, n_jobs: int, trial_timeout: float | None,
                  runner: Runner | None, progress: bool, generator: Generator | None, keep_trajectories: bool,
                  cfg: dict[str, Any] | None, command: str | None) -> SweepSummary:
    _prepare_dir(out, specs, cfg, command)
    results = out / RESULTS_NAME
    done, dropped = _load_done(results, {s.trial_id for s in specs})
    todo = deque(s for s in specs if s.trial_id not in done)
    summary = SweepSummary(out_dir=out, results_path=results, total=len(specs), skipped=len(done),
                           dropped_truncated_line=dropped, recorded=len(done))
    t0 = time.monotonic()
    successes = sum(1 for r in done.values() if r.get("success") is True)
    if todo:
        _run_pending(todo, out, n_jobs, trial_timeout, runner, generator, keep_trajectories, progress,
                     summary, successes)
    summary.wall_time = time.monotonic() - t0
    if summary.complete and not summary.interrupted:
        _rewrite_sorted(results, specs)
    return summary


def _run_pending(todo: deque[TrialSpec], out: Path, n_jobs: int, trial_timeout: float | None,
                 runner: Runner | None, generator: Generator | None, keep_trajectories: bool,
                 progress: bool, summary: SweepSummary, successes: int) -> None:
    ctx = mp.get_context("spawn")
    log_path = str(out / LOG_NAME)
    writer = _ResultsWriter(summary.results_path)
    workers: list[_Worker] = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=summary.total, initial=summary.recorded, unit="trial", dynamic_ncols=True,
                   desc="trials", file=sys.stderr)
        bar.set_postfix_str(f"ok {successes}/{summary.recorded}")

    def start_worker() -> _Worker:
        parent_conn, child_conn = ctx.Pipe(duplex=True)
        proc = ctx.Process(target=_worker_main, name="navstack-trial-worker", daemon=True,
                           args=(child_conn, os.getpid(), str(out), runner, generator, keep_trajectories,
                                 log_path))
        proc.start()
        child_conn.close()
        return _Worker(proc=proc, conn=parent_conn, born=time.monotonic())

    def stop_worker(w: _Worker, hard: bool) -> None:
        if hard and w.proc.is_alive():
            w.proc.kill()
        w.proc.join(timeout=5.0)
        if w.proc.is_alive():  # pragma: no cover - ignoring SIGKILL is impossible; belt and braces
            w.proc.kill()
            w.proc.join(timeout=5.0)
        w.conn.close()

    def record(spec: TrialSpec, rec: dict[str, Any]) -> None:
        nonlocal successes
        writer.append(_finish_record(spec, rec))
        summary.recorded += 1
        summary.ran += 1
        if rec.get("success") is True:
            summary.succeeded += 1
            successes += 1
        if rec.get("reason") == "error":
            summary.errors += 1
            summary.error_ids.append(spec.trial_id)
        if bar is not None:
            bar.set_postfix_str(f"ok {successes}/{summary.recorded}" + (
                f", errors {summary.errors}" if summary.errors else ""), refresh=False)
            bar.update(1)

    def on_sigterm(signum: int, frame: Any) -> None:
        raise _Interrupted()

    old_term = None
    if threading.current_thread() is threading.main_thread():
        old_term = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        workers = [start_worker() for _ in range(min(n_jobs, len(todo)))]
        while todo or any(w.spec is not None for w in workers):
            for w in list(workers):
                if w.ready and w.spec is None and todo:
                    spec = todo.popleft()
                    try:
                        w.conn.send(spec.to_dict())
                    except (BrokenPipeError, EOFError, OSError):  # idle worker died: replace it
                        todo.appendleft(spec)
                        stop_worker(w, hard=True)
                        workers.remove(w)
                        workers.append(start_worker())
                        continue
                    w.spec, w.started = spec, time.monotonic()
            now = time.monotonic()
            watched = [w for w in workers if w.spec is not None or not w.ready]
            deadlines = [w.started + trial_timeout for w in watched if w.spec is not None
                         and trial_timeout is not None] + [w.born + STARTUP_TIMEOUT for w in watched
                                                          if not w.ready]
            wait_for = min([1.0] + [max(0.0, t - now) for t in deadlines])
            mp_wait([w.conn for w in watched] + [w.proc.sentinel for w in watched], timeout=wait_for)
            for w in list(workers):
                if w.spec is None and w.ready:
                    continue
                msg = None
                try:
                    if w.conn.poll():
                        msg = w.conn.recv()
                except (EOFError, OSError):
                    msg = None
                now = time.monotonic()
                if not w.ready:
                    if msg is not None and msg[0] == "ready":
                        w.ready = True
                        continue
                    if msg is not None and msg[0] == "fatal":
                        raise SweepWorkerError(f"a worker process could not start: {msg[1]}\n{msg[2]}")
                    if not w.proc.is_alive():
                        raise SweepWorkerError(f"a worker process died while starting (exit code "
                                               f"{w.proc.exitcode}); see the messages above or {log_path}")
                    if now - w.born > STARTUP_TIMEOUT:
                        raise SweepWorkerError(f"a worker process did not start within {STARTUP_TIMEOUT:g} s; "
                                               f"see {log_path}")
                    continue
                spec = w.spec
                assert spec is not None
                elapsed = now - w.started
                if msg is not None:
                    w.spec = None
                    if msg[0] == "ok":
                        try:
                            rec = _validated_result(spec, msg[2])
                        except TypeError as exc:
                            rec = _error_record(spec, str(exc), elapsed)
                    else:
                        rec = _error_record(spec, msg[2], elapsed, msg[3])
                    record(spec, rec)
                    continue
                if w.proc.is_alive():
                    if trial_timeout is None or elapsed <= trial_timeout:
                        continue
                    why = f"trial exceeded the {trial_timeout:g} s wall-clock limit; worker killed"
                else:
                    why = f"worker process died (exit code {w.proc.exitcode}) while running the trial"
                stop_worker(w, hard=True)
                workers.remove(w)
                if todo:
                    workers.append(start_worker())
                record(spec, _error_record(spec, why, elapsed))
        for w in workers:
            with contextlib.suppress(BrokenPipeError, EOFError, OSError):
                w.conn.send(None)
        for w in workers:
            stop_worker(w, hard=False)
        workers = []
    except (KeyboardInterrupt, _Interrupted):
        summary.interrupted = True
    finally:
        for w in workers:
            with contextlib.suppress(Exception):
                stop_worker(w, hard=True)
        writer.close()
        if bar is not None:
            bar.close()
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)


# --------------------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``navstack trials`` options to ``parser`` (see :func:`run_from_args`)."""
    from navstack.registry import CONTROLLERS, FAMILIES, PLANNERS

    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--generate", nargs="+", metavar="FAMILY",
                     help="world families to generate (listed below): " + ", ".join(FAMILIES))
    src.add_argument("--worlds", metavar="DIR", help="run every *.json world file in DIR")
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
    parser.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--trial-timeout", type=float, default=DEFAULT_TRIAL_TIMEOUT, metavar="SEC",
                        help=f"wall-clock limit per trial, s (default {DEFAULT_TRIAL_TIMEOUT:g}; 0 = none)")
    parser.add_argument("--keep-trajectories", action="store_true",
                        help="write each trial's result.json and trajectory.npz under DIR/trials/")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--out", required=True, metavar="DIR", help="sweep directory (created or resumed)")


def config_from_args(args: argparse.Namespace) -> SweepConfig:
    """The :class:`SweepConfig` described by parsed ``navstack trials`` arguments."""
    if args.worlds is not None and args.difficulty is not None:
        raise SweepError("--difficulty only applies to --generate (world files carry their own)")
    return SweepConfig(
        families=tuple(args.generate or ()), count=args.count, seed=args.seed,
        difficulties=tuple(args.difficulty) if args.difficulty else (0.5,), worlds_dir=args.worlds,
        controllers=tuple(args.controller or ("slither",)), planners=tuple(args.planner or ("field",)))


def run_from_args(args: argparse.Namespace, argv: Sequence[str] | None = None) -> int:
    """Run ``navstack trials``; returns the exit status (0 done, 2 bad input, 130 interrupted).

    ``argv`` (the command's arguments, default ``sys.argv[1:]``) is only used to print how to resume.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    command = shlex.join(["navstack", *argv])
    try:
        config = config_from_args(args)
        specs = build_specs(config)
        summary = run_sweep(specs, args.out, jobs=args.jobs,
                            trial_timeout=args.trial_timeout if args.trial_timeout > 0 else None,
                            progress=not args.no_progress, keep_trajectories=args.keep_trajectories,
                            config=config, command=command)
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
