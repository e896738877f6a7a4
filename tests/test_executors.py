"""Tests of navstack.executors: the Ray backend against the local one, failures on both, the worker pool's
recovery from a broken pebble pool, and provenance.

The Ray tests start a local Ray instance (``num_cpus=2``, no dashboard) through ``run_sweep`` itself, as
``navstack trials --backend ray`` does; the fake runner and generator come from ``tests/test_sweep.py``.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import subprocess
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest
import ray
from test_sweep import fake_generator, fake_runner, lines_of, write_worlds

from navstack import executors, provenance
from navstack.executors import SweepWorkerError, TrialJob, WorkerPool
from navstack.sweep import SweepConfig, build_specs, run_sweep


def comparable(records: list[dict]) -> list[dict]:
    """Lines without what may differ between backends: ``wall_time``, ``provenance.host`` and
    ``provenance.backend`` (which names the backend, so it differs by definition)."""
    out = []
    for r in records:
        r = {k: v for k, v in r.items() if k != "wall_time"}
        r["provenance"] = {k: v for k, v in r["provenance"].items() if k not in ("host", "backend")}
        out.append(r)
    return out


@pytest.mark.slow
def test_ray_sweep_gives_the_local_lines(tmp_path, monkeypatch):
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    monkeypatch.setattr("navstack.sweep._known_families", lambda: ("truss", "pipe-rack", "sphere-field"))
    specs = build_specs(SweepConfig(families=("truss", "pipe-rack", "sphere-field"), count=1, seed=5,
                                    controllers=("slither", "tip-only")))
    assert len(specs) == 6
    for backend in ("local", "ray"):
        run_sweep(specs, tmp_path / backend, jobs=2, runner=fake_runner, generator=fake_generator,
                  progress=False, backend=backend)
    local, remote = (lines_of(tmp_path / b / "results.jsonl") for b in ("local", "ray"))
    assert [r["provenance"]["backend"] for r in local] == ["local"] * 6
    assert [r["provenance"]["backend"] for r in remote] == ["ray"] * 6
    assert comparable(local) == comparable(remote)
    assert [r["trial_id"] for r in remote] == [s.trial_id for s in specs]
    for s in specs:  # the driver wrote the worlds the Ray workers generated
        assert (tmp_path / "ray" / s.world_file).read_bytes() == (tmp_path / "local" / s.world_file).read_bytes()
    assert not ray.is_initialized()  # the instance run_sweep started is shut down


@pytest.mark.slow
def test_ray_hanging_and_dying_trials_are_errors_and_sweep_completes(tmp_path, monkeypatch):
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    folder = write_worlds(tmp_path / "in", 2)
    for name, behaviour in (("x_hang", "hang"), ("x_die", "die"), ("x_kill_worker", "die_parent")):
        (folder / f"{name}.json").write_text(json.dumps({"name": name, "extra": {"behaviour": behaviour}}))
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    summary = run_sweep(specs, tmp_path / "out", jobs=2, trial_timeout=5.0, runner=fake_runner, progress=False,
                        backend="ray")
    recs = {r["world_id"]: r for r in lines_of(tmp_path / "out" / "results.jsonl")}
    assert summary.complete and summary.errors == 3 and len(recs) == 5
    assert "5 s wall-clock limit" in recs["x_hang"]["error"]
    assert "worker process died (exit code 7)" in recs["x_die"]["error"]
    # the Ray worker itself killed: Ray retries the task, then gives up; where it died is unknown
    assert recs["x_kill_worker"]["error"].startswith("Ray task failed: ")
    assert recs["x_kill_worker"]["provenance"]["host"] is None
    for name in ("x_hang", "x_die", "x_kill_worker"):
        assert (recs[name]["success"], recs[name]["reason"]) == (False, "error")
    assert recs["w00"]["reason"] in ("reached", "collision") and recs["w01"]["reason"] in ("reached", "collision")


def test_unknown_backend_is_bad_input(tmp_path):
    from navstack.sweep import SweepError

    folder = write_worlds(tmp_path / "in", 1)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    with pytest.raises(SweepError, match="unknown backend 'dask'"):
        run_sweep(specs, tmp_path / "out", runner=fake_runner, progress=False, backend="dask")


# ---------------------------------------------------------------------------------------------- pool recovery


class _Done(cf.Future):
    def __init__(self, exc: BaseException | None = None, value=None) -> None:
        super().__init__()
        if exc is not None:
            self.set_exception(exc)
        else:
            self.set_result(value)


class _Event:
    def __init__(self, flag: bool) -> None:
        self.flag = flag

    def is_set(self) -> bool:
        return self.flag


def _job(tmp_path: Path) -> TrialJob:
    folder = write_worlds(tmp_path / "in", 1)
    spec = build_specs(SweepConfig(worlds_dir=str(folder)))[0]
    return TrialJob(spec=spec, world_text=Path(spec.world_file).read_text(), runner=fake_runner)


def test_broken_lane_is_replaced_and_its_trial_run_again(tmp_path, monkeypatch):
    """pebble's race (a worker that dies at once breaks its pool) must not lose or misreport the trial."""
    from navstack.executors import _Lane, _Task

    pool = WorkerPool(1, log_path=str(tmp_path / "sweep.log"))
    job = _job(tmp_path)
    replaced = []
    monkeypatch.setattr(pool, "_replace", replaced.append)
    monkeypatch.setattr(pool, "_dispatch", lambda: None)
    lane = _Lane(pool=None, started=_Event(True), busy=True)
    task = _Task(job, 9.0, cf.Future())
    pool._settle(_Done(BrokenProcessPool("All workers expired")), lane, task, 0.0)
    assert replaced == [lane] and list(pool._queue) == [task] and task.attempt == 2 and not task.out.done()
    assert not lane.busy
    # ... at most MAX_ATTEMPTS times, then an error reply
    pool._queue.clear()
    task.attempt = executors.MAX_ATTEMPTS
    pool._settle(_Done(BrokenProcessPool("x")), lane, task, 0.0)
    assert task.out.result()["result"] is None and "broke 3 times" in task.out.result()["error"]
    # a worker that never started: the sweep stops
    task = _Task(job, 9.0, cf.Future())
    pool._settle(_Done(BrokenProcessPool("x")), _Lane(pool=None, started=_Event(False)), task, 0.0)
    with pytest.raises(SweepWorkerError, match="died while starting.*see the messages above or .*sweep.log"):
        task.out.result()
    assert not pool._queue
    pool.close(cancel=True)


def test_a_worker_that_never_starts_stops_the_sweep_after_the_startup_limit():
    from navstack.executors import _Lane

    pool = WorkerPool(1)
    pool.check(startup_timeout=0.0)  # idle lanes are never late
    pool._lanes[0] = _Lane(pool=pool._lanes[0].pool, started=_Event(False), busy=True,
                          born=time.monotonic() - 301.0)
    with pytest.raises(SweepWorkerError, match="did not start within 300 s"):
        pool.check(startup_timeout=300.0)
    pool._lanes[0].started = _Event(True)
    pool.check(startup_timeout=300.0)
    pool.close(cancel=True)


def test_pool_runs_trials_and_reports_timeouts_and_deaths(tmp_path):
    job = _job(tmp_path)
    hang = TrialJob(spec=job.spec, world_text=json.dumps({"name": "h", "extra": {"behaviour": "hang"}}),
                    runner=fake_runner)
    die = TrialJob(spec=job.spec, world_text=json.dumps({"name": "d", "extra": {"behaviour": "die"}}),
                   runner=fake_runner)
    pool = WorkerPool(2, runner=fake_runner)
    try:
        ok, hung, died = pool.submit(job, None), pool.submit(hang, 5.0), pool.submit(die, None)
        assert ok.result()["result"]["world"] == "w00" and ok.result()["error"] is None
        assert hung.result()["error"] == "trial exceeded the 5 s wall-clock limit; worker killed"
        assert died.result()["error"].startswith("worker process died (exit code 7)")
        assert died.result()["error"].endswith(", 3 times")  # run again twice: it always dies
        assert pool.submit(job, None).result()["result"] == ok.result()["result"]  # the pool goes on
    finally:
        pool.close(cancel=True)


def test_a_trial_whose_worker_is_killed_once_is_run_again(tmp_path):
    """A worker killed under its trial (an audit killed one with SIGKILL): the trial used to be an ``error``
    line for good, which no resume ever replaced; now it is run again, as the Ray backend does."""
    job = _job(tmp_path)
    once = TrialJob(spec=job.spec, runner=fake_runner, world_text=json.dumps(
        {"name": "w00", "extra": {"behaviour": "die_once", "marker": str(tmp_path / "died")}}))
    pool = WorkerPool(1, runner=fake_runner)
    try:
        reply = pool.submit(once, None).result()
        assert (tmp_path / "died").exists()  # it did die once
        assert reply["error"] is None and reply["result"] == pool.submit(job, None).result()["result"]
    finally:
        pool.close(cancel=True)


# ---------------------------------------------------------------------------------------------- provenance


def _git(cwd: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(cwd), *args], check=True, capture_output=True, text=True).stdout


def test_source_commit_only_for_a_tracked_navstack(tmp_path):
    assert provenance.source_commit(tmp_path) is None  # not a git checkout
    repo = tmp_path / "repo"
    pkg = repo / "navstack"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    _git(repo, "init", "-q")
    (repo / "other.txt").write_text("x")
    _git(repo, "add", "other.txt")
    _git(repo, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "other")
    assert provenance.source_commit(pkg) is None  # someone else's repository: navstack is not tracked there
    _git(repo, "add", "navstack/__init__.py")
    _git(repo, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "navstack")
    assert provenance.source_commit(pkg) == _git(repo, "rev-parse", "HEAD").strip()
    (repo / "other.txt").write_text("y")  # an edit outside the package: still that commit
    assert provenance.source_commit(pkg) == _git(repo, "rev-parse", "HEAD").strip()
    head = _git(repo, "rev-parse", "HEAD").strip()
    for edit, expected in ((lambda: (pkg / "__init__.py").write_text("x = 1\n"), None),  # edited
                           (lambda: _git(repo, "add", "navstack/__init__.py"), None),  # staged
                           (lambda: _git(repo, "reset", "-q", "--hard"), head),  # as committed again
                           (lambda: (pkg / "new.py").write_text(""), None),  # a new file
                           (lambda: (pkg / "new.py").unlink(), head)):
        edit()
        assert provenance.source_commit(pkg) == expected


def test_provenance_keys_and_version_key():
    p = provenance.provenance("ray")
    assert tuple(p) == provenance.PROVENANCE_KEYS and p["backend"] == "ray"
    assert provenance.version_key(p) == tuple(p[k] for k in provenance.VERSION_KEYS)
    assert provenance.version_key(None) is None


HEX40 = "0123456789abcdef" * 2 + "01234567"


def _fake_git(tmp_path: Path, monkeypatch, **answers: tuple[str, int | str]) -> Path:
    """Put first on PATH a ``git`` that answers ``git -C DIR SUBCOMMAND ...`` with ``answers[SUBCOMMAND]``
    (``rev_parse`` for ``rev-parse``): ``(stdout, exit code)``, or ``(stdout, "kill")`` to die by SIGKILL after
    writing it, or ``(seconds, "sleep")`` to hang; any other subcommand fails. Returns a folder to ask about."""
    lines = ["#!/bin/sh", 'case "$3" in']
    for sub, (out, end) in answers.items():
        if end == "sleep":
            act = f"exec sleep {out}"
        else:
            act = f"printf '%s\\n' '{out}'; " + ("kill -9 $$" if end == "kill" else f"exit {end}")
        lines.append(f"  {sub.replace('_', '-')}) {act};;")
    lines += ["esac", "exit 1", ""]
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "git").write_text("\n".join(lines))
    (bin_dir / "git").chmod(0o755)
    monkeypatch.setenv("PATH", str(bin_dir), prepend=os.pathsep)
    return tmp_path


CLEAN = {"ls_files": ("__init__.py", 0), "status": ("", 0)}


def test_source_commit_from_a_fake_git_that_answers(tmp_path, monkeypatch):
    """The fake ``git`` itself: tracked, clean, HEAD 40 lower-case hex digits - that commit."""
    assert provenance.source_commit(_fake_git(tmp_path, monkeypatch, **CLEAN, rev_parse=(HEX40, 0))) == HEX40


@pytest.mark.parametrize("head", [HEX40[:-1], HEX40 + "0", HEX40 + HEX40[:24], HEX40.upper(), HEX40[:-1] + "g"],
                         ids=["39", "41", "64-sha256", "upper", "not-hex"])
def test_source_commit_none_unless_head_is_40_hex_digits(tmp_path, monkeypatch, head):
    """A HEAD that is not 40 lower-case hex digits (too short, too long, a SHA-256 repository's 64, upper
    case, a non-hex digit) names no commit."""
    assert provenance.source_commit(_fake_git(tmp_path, monkeypatch, **CLEAN, rev_parse=(head, 0))) is None


@pytest.mark.parametrize("end", [1, 128, "kill"])
def test_source_commit_none_when_git_fails_or_dies_despite_its_output(tmp_path, monkeypatch, end):
    """``git rev-parse`` writing a well-formed commit but exiting non-zero, or killed by a signal (a negative
    return code): its output is no answer."""
    assert provenance.source_commit(_fake_git(tmp_path, monkeypatch, **CLEAN, rev_parse=(HEX40, end))) is None


@pytest.mark.parametrize("failing", ["status", "rev_parse"])
def test_source_commit_none_when_a_later_git_call_fails(tmp_path, monkeypatch, failing):
    """``ls-files`` succeeds but ``status`` or ``rev-parse`` then fails (no output, exit 128): None, no error."""
    answers = {**CLEAN, "rev_parse": (HEX40, 0), failing: ("", 128)}
    assert provenance.source_commit(_fake_git(tmp_path, monkeypatch, **answers)) is None


def test_source_commit_none_when_git_hangs_or_is_missing(tmp_path, monkeypatch):
    """A ``git`` that outlasts ``GIT_TIMEOUT``, or no ``git`` on PATH (an OSError): None, no error."""
    monkeypatch.setattr(provenance, "GIT_TIMEOUT", 0.3)
    hung = _fake_git(tmp_path, monkeypatch, ls_files=(60, "sleep"), status=("", 0), rev_parse=(HEX40, 0))
    t0 = time.monotonic()
    assert provenance.source_commit(hung) is None
    assert 0.3 <= time.monotonic() - t0 < 30.0  # it did hang, and was cut off (long before its 60 s sleep)
    empty = tmp_path / "empty"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    assert provenance.source_commit(tmp_path) is None


def test_provenance_versions_of_distributions():
    """An installed distribution's version from its metadata; a distribution not installed: None."""
    import numpy

    assert provenance._dist_version("numpy") == numpy.__version__
    assert provenance._dist_version("navstack-no-such-distribution-xyz") is None


def test_provenance_computed_once_per_process(monkeypatch):
    """The commit (a git call) is looked up once per process, however many lines ask; each call still gives
    a new dict."""
    calls = []
    monkeypatch.setattr(provenance, "source_commit", lambda: calls.append(1) or HEX40)
    provenance._this_process.cache_clear()
    try:
        a, b = provenance.provenance("local"), provenance.provenance("ray")
        assert len(calls) == 1
        assert a["commit"] == b["commit"] == HEX40 and (a["backend"], b["backend"]) == ("local", "ray")
        a["host"] = "changed"
        assert provenance.provenance("ray") == b
    finally:
        provenance._this_process.cache_clear()


# ---------------------------------------------------------------------------- generated worlds kept by a worker
def _text_runner(world, *, controller, planner, seed, out_dir=None):
    """A runner that reports the world text it was given (in-process tests only)."""
    return {"world": Path(world).read_text(), "seed": seed, "controller": controller, "planner": planner,
            "success": True, "reason": "reached", "goals_reached": 1, "sim_time": 0.0, "steps": 0,
            "wall_time": 0.0, "metrics": {}}


def test_a_worker_generates_a_world_once_for_all_its_trials(monkeypatch):
    """navstack's own generator: a world's second trial (another controller) gets the kept text, not a new
    generation; another world is generated; after WORLDS_KEPT other worlds the first is generated again; a
    user's generator is called for every trial (its worlds are not assumed reproducible)."""
    calls = []

    def counting(family, seed, difficulty, **kwargs):
        calls.append((family, seed, difficulty))
        return fake_generator(family, seed, difficulty)

    monkeypatch.setattr("navstack.generate.generate_world", counting)
    monkeypatch.setattr(executors, "_GENERATED", executors.OrderedDict())
    specs = build_specs(SweepConfig(families=("truss",), count=executors.WORLDS_KEPT + 2, seed=4,
                                    controllers=("slither", "tip-only")))
    replies = [executors.run_job(TrialJob(spec=s, runner=_text_runner)) for s in specs[:4]]
    assert all(r["error"] is None for r in replies), replies
    assert len(calls) == 2  # two worlds, two trials each
    for a, b in (replies[0:2], replies[2:4]):
        assert a["world_json"] == b["world_json"] == a["result"]["world"] == b["result"]["world"]
        assert json.loads(a["world_json"])["extra"]["world_seed"] == specs[replies.index(a)].world_seed
    assert replies[0]["world_json"] != replies[2]["world_json"]
    for s in specs[4::2]:  # the first trial of each of the other worlds: the first two worlds drop out
        executors.run_job(TrialJob(spec=s, runner=_text_runner))
    assert len(calls) == executors.WORLDS_KEPT + 2
    again = executors.run_job(TrialJob(spec=specs[1], runner=_text_runner))
    assert len(calls) == executors.WORLDS_KEPT + 3 and again["world_json"] == replies[1]["world_json"]
    for _ in range(2):
        executors.run_job(TrialJob(spec=specs[0], runner=_text_runner, generator=fake_generator))
    assert len(calls) == executors.WORLDS_KEPT + 3  # the user's generator was called instead, twice


def test_an_idle_worker_takes_its_own_worlds_trial_then_one_nobody_is_generating():
    pick = executors.pick_for_worker
    a, b, c = ("truss", 1, 0.5, False), ("truss", 2, 0.5, False), ("pipe-rack", 3, 0.5, False)
    kept = executors.deque([c], maxlen=executors.WORLDS_KEPT)
    assert pick([a, b, None], executors.deque(), set()) == 0  # nothing kept, nothing busy: in order
    assert pick([a, b, c], kept, {a}) == 2  # the world it keeps, first
    assert pick([a, a, b], executors.deque(), {a}) == 2  # a is being generated elsewhere: b
    assert pick([a, None, b], executors.deque(), {a}) == 1  # a world from a file needs no generating
    assert pick([a, a], executors.deque(), {a}) == 0  # nothing else to do: generate it too, rather than idle
    assert pick([None], kept, {c}) == 0


@pytest.mark.slow
def test_a_sweep_of_two_controllers_on_two_workers_gives_the_one_worker_lines(tmp_path, monkeypatch):
    """The real generator and runner's results do not depend on which worker runs which trial or on the
    kept worlds: a sweep on two workers gives the lines of a sweep on one, and the same world files."""
    monkeypatch.setattr("navstack.sweep._known_families", lambda: ("truss", "pipe-rack", "sphere-field"))
    cfg = SweepConfig(families=("pipe-rack", "sphere-field"), count=2, seed=12,
                      controllers=("slither", "tip-only"))
    specs = build_specs(cfg)
    outs = {}
    for jobs in (1, 2):
        run_sweep(specs, tmp_path / str(jobs), jobs=jobs, runner=fake_runner, progress=False)
        outs[jobs] = lines_of(tmp_path / str(jobs) / "results.jsonl")
    assert comparable(outs[1]) == comparable(outs[2])
    for s in specs:
        assert (tmp_path / "1" / s.world_file).read_bytes() == (tmp_path / "2" / s.world_file).read_bytes()


def test_a_worker_exits_when_the_process_that_started_it_is_gone():
    """The watchdog every local worker runs: it exits (status 3) within a second once its parent is no longer
    the process that started it (the driver was killed), and keeps running while it is."""
    import os
    import sys

    code = "import sys; from navstack.executors import _parent_watchdog; _parent_watchdog(int(sys.argv[1]))"
    orphan = subprocess.Popen([sys.executable, "-c", code, str(2**22 + 7)])  # above any pid: as if orphaned
    assert orphan.wait(timeout=30) == 3
    child = subprocess.Popen([sys.executable, "-c", code, str(os.getpid())])  # its real parent: keeps watching
    try:
        time.sleep(3.0)
        assert child.poll() is None
    finally:
        child.kill()
        child.wait()


def test_a_replys_wall_time_is_the_trials_own_and_results_become_dicts(tmp_path):
    """``run_job`` times the trial itself (seconds, from its start: not a clock reading), and turns a runner's
    dataclass result into a dict (a dataclass *class* is no result)."""
    import dataclasses

    t0 = time.monotonic()
    reply = executors.run_job(_job(tmp_path))
    assert reply["error"] is None and 0.0 <= reply["wall_time"] <= time.monotonic() - t0

    @dataclasses.dataclass
    class Result:
        success: bool = True

    assert executors._result_to_dict(Result()) == {"success": True}
    with pytest.raises(TypeError, match="the trial runner returned"):
        executors._result_to_dict(Result)


def test_a_closed_pool_takes_no_more_trials(tmp_path):
    pool = WorkerPool(1, runner=fake_runner)
    pool.close(cancel=True)
    late = pool.submit(_job(tmp_path), None)
    assert late.cancelled()  # refused at once, never queued for a worker that is gone


def test_a_workers_output_goes_to_the_sweeps_log_and_not_to_the_terminal(tmp_path, capfd):
    log = tmp_path / "sweep.log"
    job = _job(tmp_path)
    talk = TrialJob(spec=job.spec, world_text=json.dumps({"name": "t", "extra": {"behaviour": "talk"}}),
                    runner=fake_runner)
    pool = WorkerPool(1, runner=fake_runner, log_path=str(log))
    try:
        assert pool.submit(talk, None).result()["error"] is None
    finally:
        pool.close(cancel=False)
    text = log.read_text()
    assert "fake trial t says this on stdout" in text and "fake trial t says this on stderr" in text
    out, err = capfd.readouterr()
    assert "fake trial t says" not in out + err


def test_a_lane_running_a_trial_is_busy_and_a_late_start_names_the_log(tmp_path):
    """Submitted, a lane is busy before its worker has started (spawning a Python takes far over 10 ms), so a
    startup limit of 0 s is already exceeded; the error points at the sweep's log."""
    log = tmp_path / "sweep.log"
    pool = WorkerPool(1, runner=fake_runner, log_path=str(log))
    try:
        reply = pool.submit(_job(tmp_path), None)
        assert pool._lanes[0].busy
        time.sleep(0.01)
        with pytest.raises(SweepWorkerError, match=f"did not start within 0 s; see {log}"):
            pool.check(startup_timeout=0.0)
        assert reply.result()["error"] is None
        assert not pool._lanes[0].busy  # free again once its trial is done
        pool.check(startup_timeout=0.0)
    finally:
        pool.close(cancel=True)


def test_closing_the_pool_waits_for_the_broken_workers_to_be_stopped(monkeypatch):
    """A replaced lane's old pool is stopped on a thread of its own; close() returns only after those end
    (else a sweep could exit with a worker process still alive)."""
    stopped, stop = [], executors._stop_pool

    def slow_stop(old):
        time.sleep(0.5)
        stop(old)
        stopped.append(old)

    monkeypatch.setattr(executors, "_stop_pool", slow_stop)
    pool = WorkerPool(1, runner=fake_runner)
    old = pool._lanes[0].pool
    pool._replace(pool._lanes[0])
    assert pool._lanes[0].pool is not old and len(pool._stoppers) == 1
    pool.close(cancel=False)
    assert stopped[:1] == [old] and not any(t.is_alive() for t in pool._stoppers)


def test_an_address_where_no_ray_listens_is_bad_input_at_once(tmp_path):
    """``ray.init`` retried ``--ray-address 127.0.0.1:6379`` without end when no Ray ran there (a review: Ray's
    retry messages for more than 6 minutes, no error); now refused within seconds, as bad input naming it."""
    import socket

    from navstack.executors import BackendError
    from navstack.executors.ray_backend import RayExecutor, _check_reachable

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    with pytest.raises(BackendError, match=rf"at 127\.0\.0\.1:{port}: nothing accepts connections"):
        RayExecutor(1, address=f"127.0.0.1:{port}")
    assert time.monotonic() - t0 < 30 and not ray.is_initialized()
    with socket.socket() as s:  # a listening port passes the check (Ray itself then talks to it)
        s.bind(("127.0.0.1", 0))
        s.listen()
        _check_reachable(f"127.0.0.1:{s.getsockname()[1]}")
        _check_reachable(f"ray://127.0.0.1:{s.getsockname()[1]}")
    for other in ("auto", "nonsense", "host:port"):  # left to Ray, which answers these at once
        _check_reachable(other)
