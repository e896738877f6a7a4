"""The ``local`` backend: trials in worker processes on this machine (see :mod:`navstack.executors`)."""

from __future__ import annotations

import concurrent.futures as cf

from navstack.executors import Reply, Runner, TrialJob, WorkerPool


class LocalExecutor:
    """``jobs`` worker processes (a :class:`~navstack.executors.WorkerPool`); their output goes to ``log_path``."""

    backend = "local"

    def __init__(self, jobs: int, *, runner: Runner | None = None, log_path: str | None = None) -> None:
        self.jobs = jobs
        self._pool = WorkerPool(jobs, runner=runner, log_path=log_path)

    def capacity(self) -> int:
        """Two trials per worker: one running, one waiting, so no worker idles between trials."""
        return 2 * self.jobs

    def submit(self, job: TrialJob, timeout: float | None) -> cf.Future[Reply]:
        """See :class:`navstack.executors.Executor`."""
        return self._pool.submit(job, timeout)

    def check(self) -> None:
        """See :class:`navstack.executors.Executor`."""
        self._pool.check()

    def close(self, *, cancel: bool) -> None:
        """See :class:`navstack.executors.Executor`."""
        self._pool.close(cancel=cancel)
