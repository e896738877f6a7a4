"""The ``ray`` backend: one Ray task per trial (``navstack trials --backend ray``; needs ``navstack[ray]``).

Where: ``--ray-address``, else the ``RAY_ADDRESS`` environment variable, else a new Ray instance on this
machine with ``--jobs`` CPUs (default: all cores) whose workers get the driver's ``sys.path`` (so they import
the same navstack). A driver that already called ``ray.init`` (a script, a test) is used as it is.

Each task runs its trial in a one-process :class:`~navstack.executors.WorkerPool` inside the Ray worker, so
the trial's wall-clock limit counts from the moment the trial starts (not while the task waits for a CPU) and
a hang or a crash is an ``error`` reply exactly as with the local backend. A Ray worker or a whole node lost
mid-trial is Ray's to handle: the task is retried (``MAX_RETRIES`` times) and, if it still fails, recorded as
an ``error`` line naming the Ray exception, with ``provenance.host`` null (where it died is unknown).
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import os
import socket
import sys
import threading
import time
from typing import Any

from navstack.executors import (
    BackendError,
    Reply,
    Runner,
    SweepWorkerError,
    TrialJob,
    WorkerPool,
    available_cores,
    error_reply,
)

MAX_RETRIES = 3
"""Ray retries of a task whose worker process or node died (Ray's ``max_retries``)."""
CAPACITY_REFRESH = 5.0
"""Seconds between two looks at the cluster's CPU count (nodes may join or leave)."""

_POOL: WorkerPool | None = None  # per Ray worker process


def _ray_trial(job: TrialJob, timeout: float | None) -> Reply:
    """The Ray task: run ``job`` in this worker's pool (created on first use) and return its reply."""
    global _POOL
    if _POOL is None:
        _POOL = WorkerPool(1, runner=job.runner)
    try:
        fut = _POOL.submit(job, timeout)
        while True:
            try:
                return fut.result(timeout=1.0)
            except cf.TimeoutError:
                _POOL.check()
    except SweepWorkerError as exc:
        _POOL.close(cancel=True)
        _POOL = None
        return {"fatal": f"on {socket.gethostname()}: {exc}"}


def _worker_pythonpath() -> str:
    parts = [os.path.abspath(p or os.curdir) for p in sys.path]
    return os.pathsep.join(dict.fromkeys(parts))


CONNECT_TIMEOUT = 10.0
"""Seconds to wait for a TCP connection to ``--ray-address`` before calling it unreachable."""


def _check_reachable(address: str, timeout: float = CONNECT_TIMEOUT) -> None:
    """Raise :class:`ConnectionError` when nothing accepts a TCP connection at ``address`` (``HOST:PORT``, also
    after ``ray://``): ``ray.init`` retries such an address without end when it is this machine's (a review:
    ``--ray-address 127.0.0.1:6379`` with no Ray running printed Ray's retries for more than 6 minutes). Other
    forms (``auto``, a malformed address) are left to Ray, which answers them at once."""
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit():
        return
    host = host.strip("[]")  # an IPv6 literal
    try:
        socket.create_connection((host, int(port)), timeout=timeout).close()
    except (OSError, ValueError, OverflowError) as exc:
        raise ConnectionError(f"nothing accepts connections at {address} ({exc}); is a Ray cluster running "
                              "there (ray start --head)?") from exc


class RayExecutor:
    """Trials as Ray tasks; ``jobs`` caps the trials running at once (default: the cluster's CPUs)."""

    backend = "ray"

    def __init__(self, jobs: int | None, *, runner: Runner | None = None, address: str | None = None) -> None:
        try:
            import ray
        except ImportError as exc:
            raise BackendError("--backend ray needs Ray: pip install 'navstack[ray]'") from exc
        self._ray = ray
        self.jobs = jobs
        self._owns = False
        if not ray.is_initialized():
            self._connect(address or os.environ.get("RAY_ADDRESS") or None, jobs)
        self._remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(_ray_trial)
        self._refs: dict[cf.Future[Reply], Any] = {}
        self._lock = threading.Lock()
        self._cpus, self._cpus_at = 1, -float("inf")

    def _connect(self, address: str | None, jobs: int | None) -> None:
        ray = self._ray
        quiet = {"log_to_driver": False, "logging_level": logging.WARNING}
        try:
            if address is None:
                ray.init(address="local", num_cpus=jobs or available_cores(), include_dashboard=False,
                         runtime_env={"env_vars": {"PYTHONPATH": _worker_pythonpath()}}, **quiet)
            else:
                _check_reachable(address)
                ray.init(address=address, **quiet)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            where = f"at {address}" if address else "on this machine"
            raise BackendError(f"--backend ray: cannot start or reach a Ray cluster {where}: {exc}") from exc
        self._owns = True

    def capacity(self) -> int:
        """``jobs``, else the cluster's CPUs (looked up every ``CAPACITY_REFRESH`` s)."""
        if self.jobs:
            return self.jobs
        now = time.monotonic()
        if now - self._cpus_at > CAPACITY_REFRESH:
            self._cpus = max(1, int(self._ray.cluster_resources().get("CPU", 1)))
            self._cpus_at = now
        return self._cpus

    def submit(self, job: TrialJob, timeout: float | None) -> cf.Future[Reply]:
        """See :class:`navstack.executors.Executor`."""
        out: cf.Future[Reply] = cf.Future()
        t0 = time.monotonic()
        ref = self._remote.remote(job, timeout)
        with self._lock:
            self._refs[out] = ref

        def settle(f: cf.Future[Any]) -> None:
            with self._lock:
                self._refs.pop(out, None)
            if out.done():
                return
            try:
                reply = f.result()
            except Exception as exc:  # noqa: BLE001 - Ray's failure of this task is data about the trial
                text = str(exc).strip().splitlines()
                out.set_result(error_reply(f"Ray task failed: {type(exc).__name__}: {text[0] if text else ''}",
                                           time.monotonic() - t0, host_known=False))
                return
            if "fatal" in reply:
                out.set_exception(SweepWorkerError(f"a Ray worker could not start the trial runner {reply['fatal']}"))
            else:
                out.set_result(reply)

        ref.future().add_done_callback(settle)
        return out

    def check(self) -> None:
        """Nothing to check: a Ray worker that cannot start its trial process answers with ``fatal``."""

    def close(self, *, cancel: bool) -> None:
        """See :class:`navstack.executors.Executor`; shuts down the Ray instance if this executor started it."""
        if cancel:
            with self._lock:
                refs = list(self._refs.values())
            for ref in refs:
                try:
                    self._ray.cancel(ref, force=True)
                except Exception:  # noqa: BLE001, S110 - already finished or its node is gone
                    pass
        if self._owns:
            self._ray.shutdown()
            self._owns = False
