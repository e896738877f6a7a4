"""Executors: where a sweep's trials run (``navstack trials --backend local|ray``, interfaces.md section 4).

One small interface, :class:`Executor`: ``submit(job, timeout)`` returns a :class:`concurrent.futures.Future`
that resolves to the trial's *reply* (never raises for a failed trial), ``capacity()`` says how many trials
to keep in flight, ``close(cancel=...)`` ends it. Two implementations:

* :class:`navstack.executors.local.LocalExecutor` (``local``, the default): worker processes on this machine,
  a :class:`WorkerPool` (pebble's ``ProcessPool``);
* :class:`navstack.executors.ray_backend.RayExecutor` (``ray``): one Ray task per trial; inside each Ray
  worker the trial runs in a one-process :class:`WorkerPool`, so a trial's timeout and crash handling are
  exactly the local backend's.

Workers need no shared file system: a :class:`TrialJob` carries the world file's text (or the generator's
inputs), and the reply carries the generated world's JSON and, if asked, the trial's output files. Only the
sweep driver writes the sweep folder.

A reply is a dict: ``result`` (the runner's ``result.json`` dict, or ``None``), ``error`` / ``traceback``
(why there is no result), ``world_json`` (a generated world, or ``None``), ``files`` (relative path ->
bytes), ``wall_time`` (s) and ``provenance`` (:func:`navstack.provenance.provenance` of the process that ran
the trial; ``host`` is ``None`` when it is unknown, e.g. a Ray worker that died).

Why pebble (``python tools/bench_executors.py``): its pool kills and replaces the worker of a task that
exceeds its timeout (counted from the moment a worker takes the task) and reports a worker that dies as
``ProcessExpired`` on that task alone; ``concurrent.futures`` and loky have no per-task timeout and fail every
task in flight when one worker dies. pebble's shared pool has a race (a worker that dies at once can break the
whole pool, or be charged to the trial it ran before); :class:`WorkerPool` therefore gives each worker its
own one-process pool and one trial at a time, and reruns a trial whose pool pebble declares broken.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import hashlib
import json
import math
import multiprocessing as mp
import os
import sys
import tempfile
import threading
import time
import traceback
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from navstack.provenance import provenance

if TYPE_CHECKING:
    from navstack.sweep import TrialSpec

Runner = Callable[..., Any]
Generator = Callable[..., Any]
Reply = dict[str, Any]

BACKENDS = ("local", "ray")
MAX_ATTEMPTS = 3
"""How often a trial is submitted again after its worker pool broke under it (not after its own crash)."""
STARTUP_TIMEOUT = 300.0
"""Seconds a new worker may take to start (import the runner) while a trial waits for it (s)."""
WORLDS_KEPT = 8
"""Generated worlds a worker keeps (their text), for the other trials of the same world (controllers, planners)."""


class SweepWorkerError(RuntimeError):
    """Workers cannot start (e.g. the runner cannot be imported there); the sweep stops."""


class BackendError(ValueError):
    """A backend that cannot be used (Ray missing, no cluster at the address); the message says why."""


@dataclass(frozen=True)
class TrialJob:
    """Everything a worker needs to run one trial, without access to the sweep folder.

    ``world_text`` is the world file's content for a spec read from a file (``None`` for a generated world);
    ``keep_files`` asks for the trial's output files (``result.json``, ``trajectory.npz``) in the reply.
    ``runner`` / ``generator`` ``None`` mean :func:`navstack.trial.run_trial` /
    :func:`navstack.generate.generate_world`.
    """

    spec: TrialSpec
    world_text: str | None = None
    keep_files: bool = False
    runner: Runner | None = None
    generator: Generator | None = None


class Executor(Protocol):
    """Runs trials; see the module docstring."""

    backend: str

    def capacity(self) -> int:
        """How many trials the driver should keep submitted at once."""

    def submit(self, job: TrialJob, timeout: float | None) -> cf.Future[Reply]:
        """Start ``job`` with a wall-clock limit of ``timeout`` s (``None``: none); the future gives its reply.

        The future raises only :class:`SweepWorkerError` (workers cannot start)."""

    def close(self, *, cancel: bool) -> None:
        """Stop: ``cancel`` kills running trials (Ctrl-C), else waits for them."""

    def check(self) -> None:
        """Raise :class:`SweepWorkerError` if workers do not start (called by the driver while it waits)."""


def make_executor(backend: str, *, jobs: int | None, runner: Runner | None = None, log_path: str | None = None,
                  ray_address: str | None = None) -> Executor:
    """The executor named ``backend`` (``local`` or ``ray``); ``jobs`` = parallel trials (``None``: all cores,
    or for Ray all the cluster's CPUs). Raises :class:`BackendError` for an unusable backend."""
    if backend == "local":
        from navstack.executors.local import LocalExecutor

        return LocalExecutor(jobs or available_cores(), runner=runner, log_path=log_path)
    if backend == "ray":
        from navstack.executors.ray_backend import RayExecutor

        return RayExecutor(jobs, runner=runner, address=ray_address)
    raise BackendError(f"--backend: unknown backend {backend!r}; expected one of {list(BACKENDS)}")


def available_cores() -> int:
    """CPU cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


# --------------------------------------------------------------------------------------------------------
# Worker side
# --------------------------------------------------------------------------------------------------------


def error_reply(message: str, wall_time: float, tb: str | None = None, *, host_known: bool = True) -> Reply:
    """A reply without result: the trial crashed, hung, or could not be run; ``message`` says why."""
    prov = provenance()
    if not host_known:
        prov["host"] = None
    return {"result": None, "error": message, "traceback": tb, "world_json": None, "files": {},
            "wall_time": wall_time, "provenance": prov}


def json_ready(obj: Any) -> Any:
    """Plain JSON data: numpy scalars/arrays to Python, Paths to str, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_ready(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist"):  # numpy scalar / array
        return json_ready(obj.tolist())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return json_ready(dataclasses.asdict(obj))
    return str(obj)


def _result_to_dict(result: Any) -> dict[str, Any]:
    if isinstance(result, dict):
        return dict(result)
    if hasattr(result, "to_dict"):
        return dict(result.to_dict())
    if dataclasses.is_dataclass(result) and not isinstance(result, type):
        return dataclasses.asdict(result)
    raise TypeError(f"the trial runner returned {type(result).__name__}, expected a dict or a TrialResult")


def world_key(job: TrialJob) -> tuple | None:
    """What identifies the world of ``job`` when navstack's own generator makes it (``None`` otherwise)."""
    spec = job.spec
    if not spec.generated or job.generator is not None:
        return None
    return (spec.family, spec.world_seed, spec.difficulty, spec.retract)


_GENERATED: OrderedDict[tuple, str] = OrderedDict()
"""The last :data:`WORLDS_KEPT` worlds this worker generated, by :func:`world_key`: navstack's generator gives
the same text for the same key (tests/test_generate_stable.py), so another trial of the world (another
controller or planner) reads the text instead of generating it again."""


def _world_path(job: TrialJob, tmp: Path, reply: Reply) -> Path:
    """The world file the runner is given: the generated world (made here, or the text this worker kept from
    another trial of the world, :data:`_GENERATED`), the user's own file when this process sees it unchanged (so
    relative mesh paths work), else a copy of the shipped text in ``tmp``."""
    spec = job.spec
    name = Path(spec.world_file).name
    if spec.generated:
        path = tmp / name
        key = world_key(job)
        text = _GENERATED.get(key) if key is not None else None
        if text is not None:
            _GENERATED.move_to_end(key)
            path.write_text(text, encoding="utf-8")
        else:
            generator = job.generator
            if generator is None:
                from navstack.generate import generate_world as generator
            kwargs = {"retract": True} if spec.retract else {}
            world = generator(spec.family, seed=spec.world_seed, difficulty=spec.difficulty, **kwargs)
            if isinstance(world, dict):
                path.write_text(json.dumps(world, indent=2) + "\n", encoding="utf-8")
            else:
                from navstack.world import save_world

                save_world(world, path)
            text = path.read_text(encoding="utf-8")
            if key is not None:
                _GENERATED[key] = text
                while len(_GENERATED) > WORLDS_KEPT:
                    _GENERATED.popitem(last=False)
        reply["world_json"] = text
        return path
    original = Path(spec.world_file)
    text = job.world_text if job.world_text is not None else ""
    with contextlib.suppress(OSError):
        if hashlib.sha256(original.read_bytes()).digest() == hashlib.sha256(text.encode("utf-8")).digest():
            return original
    (tmp / name).write_text(text, encoding="utf-8")
    return tmp / name


def run_job(job: TrialJob) -> Reply:
    """Run one trial in this process (the worker side of every executor); never raises for a failed trial."""
    t0 = time.monotonic()
    reply: Reply = {"result": None, "error": None, "traceback": None, "world_json": None, "files": {},
                    "wall_time": 0.0, "provenance": provenance()}
    spec = job.spec
    runner = job.runner
    with tempfile.TemporaryDirectory(prefix="navstack-trial-") as tmp_name:
        tmp = Path(tmp_name)
        try:
            if runner is None:
                from navstack.trial import run_trial as runner
            world = _world_path(job, tmp, reply)
            out = tmp / "out" if job.keep_files else None
            result = runner(str(world), controller=spec.controller, planner=spec.planner, seed=spec.seed,
                            out_dir=out)
            reply["result"] = json_ready(_result_to_dict(result))
            if out is not None and out.is_dir():
                reply["files"] = {p.relative_to(out).as_posix(): p.read_bytes()
                                  for p in sorted(out.rglob("*")) if p.is_file()}
        except BaseException as exc:  # noqa: BLE001 - every failure of a trial is data, not a crash
            reply["error"] = f"{type(exc).__name__}: {exc}"
            reply["traceback"] = traceback.format_exc()
    reply["wall_time"] = time.monotonic() - t0
    return reply


def _parent_watchdog(parent_pid: int) -> None:
    """Exit when the process that started this worker is gone (its driver was killed)."""
    while True:
        time.sleep(0.5)
        if os.getppid() != parent_pid:
            os._exit(3)


THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Set to 1 in local workers (unless already set), as Ray does for a 1-CPU task: one trial per core, and a
multithreaded BLAS in every worker only fights the others for the cores."""


def _init_worker(log_path: str | None, parent_pid: int, runner: Runner | None, started: Any) -> None:
    """pebble initializer: one BLAS thread, output to ``log_path``, exit with the parent, import the runner,
    then say so."""
    for var in THREAD_VARIABLES:  # before numpy is imported in this process (the default runner's imports)
        os.environ.setdefault(var, "1")
    if log_path is not None:
        fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)
    threading.Thread(target=_parent_watchdog, args=(parent_pid,), daemon=True).start()
    if runner is None:
        import navstack.trial  # noqa: F401 - import now, so the first trial's time limit excludes imports
    started.set()


# --------------------------------------------------------------------------------------------------------
# A crash-tolerant process pool
# --------------------------------------------------------------------------------------------------------


@dataclass
class _Lane:
    """One worker process: a one-process pebble pool that is given one trial at a time."""

    pool: Any
    started: Any
    busy: bool = False
    born: float | None = None
    """When its worker was asked to start (its first trial; pebble starts the process then)."""
    worlds: deque = field(default_factory=lambda: deque(maxlen=WORLDS_KEPT))
    """The generated worlds (:func:`world_key`) its worker last ran: it keeps their text."""
    running: tuple | None = None
    """The generated world of the trial it runs now."""


@dataclass
class _Task:
    job: TrialJob
    timeout: float | None
    out: cf.Future[Reply]
    attempt: int = 1


class WorkerPool:
    """``workers`` spawned processes running :func:`run_job` with per-trial timeouts (pebble underneath).

    Each worker is its own one-process pebble ``ProcessPool`` (a *lane*) and holds at most one trial, so
    pebble can never blame one trial for another's crash (in a shared pool an instantly dying worker can be
    charged with the trial it finished just before, measured by ``tools/bench_executors.py``). A trial over its
    limit has its worker killed and replaced (error reply); a trial whose worker dies under it (killed from
    outside, or crashed) is run again, and a lane that pebble declares broken is replaced and its trial run
    again, each at most :data:`MAX_ATTEMPTS` times in all (then an error reply); a lane whose worker never
    finished starting raises :class:`SweepWorkerError`.
    """

    def __init__(self, workers: int, *, runner: Runner | None = None, log_path: str | None = None) -> None:
        self.runner, self.log_path = runner, log_path
        self._lock = threading.Lock()
        self._closed = False
        self._queue: deque[_Task] = deque()
        self._lanes = [self._new_lane() for _ in range(workers)]
        self._stoppers: list[threading.Thread] = []

    def _new_lane(self) -> _Lane:
        import pebble

        ctx = mp.get_context("spawn")  # PyBullet only ever inside fresh worker processes
        started = ctx.Event()
        pool = pebble.ProcessPool(max_workers=1, initializer=_init_worker,
                                  initargs=(self.log_path, os.getpid(), self.runner, started), context=ctx)
        return _Lane(pool=pool, started=started)

    def check(self, startup_timeout: float = STARTUP_TIMEOUT) -> None:
        """Raise :class:`SweepWorkerError` when a worker has been given a trial but has not finished starting
        ``startup_timeout`` s after it was created (a hung import would otherwise hang the sweep)."""
        now = time.monotonic()
        with self._lock:
            late = [lane for lane in self._lanes if lane.busy and not lane.started.is_set()
                    and lane.born is not None and now - lane.born > startup_timeout]
        if late:
            raise SweepWorkerError(f"a worker process did not start within {startup_timeout:g} s"
                                   + (f"; see {self.log_path}" if self.log_path else ""))

    def submit(self, job: TrialJob, timeout: float | None) -> cf.Future[Reply]:
        """Run ``job`` with a limit of ``timeout`` s; the future gives its reply."""
        task = _Task(job, timeout, cf.Future())
        with self._lock:
            if self._closed:
                task.out.cancel()
                return task.out
            self._queue.append(task)
        self._dispatch()
        return task.out

    def _dispatch(self) -> None:
        """Give queued trials to idle lanes."""
        started: list[tuple[_Lane, _Task, Any]] = []
        with self._lock:
            for lane in self._lanes:
                if self._closed or not self._queue:
                    break
                if not lane.busy:
                    task = self._take_for(lane)
                    lane.busy = True
                    if lane.born is None:
                        lane.born = time.monotonic()
                    started.append((lane, task, lane.pool.schedule(run_job, (task.job,), timeout=task.timeout)))
        for lane, task, pf in started:
            t0 = time.monotonic()
            pf.add_done_callback(lambda f, lane=lane, task=task, t0=t0: self._settle(f, lane, task, t0))

    def _take_for(self, lane: _Lane) -> _Task:
        """Take from the queue the trial for idle ``lane`` (the lock held): see :func:`pick_for_worker`."""
        busy = {other.running for other in self._lanes if other.busy and other.running is not None}
        i = pick_for_worker([world_key(t.job) for t in self._queue], lane.worlds, busy)
        task = self._queue[i]
        del self._queue[i]
        key = lane.running = world_key(task.job)
        if key is not None:
            if key in lane.worlds:
                lane.worlds.remove(key)
            lane.worlds.append(key)
        return task

    def _settle(self, f: cf.Future[Reply], lane: _Lane, task: _Task, t0: float) -> None:
        """A lane's trial ended: resolve its future (or requeue it), free or replace the lane, dispatch."""
        from concurrent.futures.process import BrokenProcessPool

        from pebble import ProcessExpired

        elapsed = time.monotonic() - t0
        reply: Reply | None = None
        try:
            reply = f.result()
        except TimeoutError:
            reply = error_reply(f"trial exceeded the {task.timeout:g} s wall-clock limit; worker killed",
                                float(task.timeout or elapsed))
        except ProcessExpired as exc:  # killed from outside (the OOM killer, a user) or crashed (a segfault)
            if task.attempt >= MAX_ATTEMPTS:
                reply = error_reply(f"worker process died (exit code {exc.exitcode}) while running the trial, "
                                    f"{task.attempt} times", elapsed)
            else:  # run it again, as the Ray backend does: a sweep loses no trial to a worker killed once
                task.attempt += 1
                with self._lock:
                    self._queue.appendleft(task)
        except BrokenProcessPool as exc:
            was_started = lane.started.is_set()
            self._replace(lane)
            if not was_started:
                _resolve(task.out, exc=SweepWorkerError(
                    f"worker processes died while starting ({exc}); see the messages above"
                    + (f" or {self.log_path}" if self.log_path else "")))
            elif task.attempt >= MAX_ATTEMPTS:
                reply = error_reply(f"the worker pool broke {task.attempt} times under this trial ({exc})", elapsed)
            else:
                task.attempt += 1
                with self._lock:
                    self._queue.appendleft(task)
        except cf.CancelledError:
            task.out.cancel()
        except Exception as exc:  # noqa: BLE001 - e.g. an unpicklable result: data about this trial
            reply = error_reply(f"{type(exc).__name__}: {exc}", elapsed, traceback.format_exc())
        if reply is not None:
            _resolve(task.out, reply)
        with self._lock:
            lane.busy = False
        self._dispatch()

    def _replace(self, lane: _Lane) -> None:
        """Give ``lane`` a new pool; the broken one is stopped in the background (we are on its thread)."""
        with self._lock:
            if self._closed:
                return
            old = lane.pool
            fresh = self._new_lane()
            lane.pool, lane.started, lane.born = fresh.pool, fresh.started, None
            lane.worlds.clear()  # a new worker keeps nothing
            stopper = threading.Thread(target=_stop_pool, args=(old,), daemon=True)
            self._stoppers.append(stopper)
        stopper.start()

    def close(self, *, cancel: bool) -> None:
        """Stop accepting trials; ``cancel``: kill the running ones, else let them finish first."""
        with self._lock:
            self._closed = True
            pools = [lane.pool for lane in self._lanes]
            for task in self._queue:
                task.out.cancel()
            self._queue.clear()
        for pool in pools:
            if cancel:
                _stop_pool(pool)
            else:
                pool.close()
                pool.join()
        for t in self._stoppers:
            t.join()


def pick_for_worker(queued: list[tuple | None], kept: deque, busy: set[tuple]) -> int:
    """Which queued trial (index into ``queued``, their worlds' :func:`world_key`) an idle worker takes.

    The first whose world the worker keeps (``kept``); else the first whose world no other worker is
    generating now (``busy``), so two workers do not make the same world at once; else the first.  The queue
    holds at most a trial per worker (``LocalExecutor.capacity``), so trials start at most that many places
    out of their order; results never depend on which worker runs a trial.
    """
    for i, key in enumerate(queued):
        if key is not None and key in kept:
            return i
    return next((i for i, key in enumerate(queued) if key is None or key not in busy), 0)


def _resolve(out: cf.Future[Reply], reply: Reply | None = None, exc: BaseException | None = None) -> None:
    """Set ``out`` unless it was cancelled meanwhile (``close``)."""
    with contextlib.suppress(cf.InvalidStateError):
        if exc is not None:
            out.set_exception(exc)
        else:
            out.set_result(reply)


def _stop_pool(pool: Any) -> None:
    pool.stop()
    pool.join()
