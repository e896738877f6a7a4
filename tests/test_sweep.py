"""Tests of navstack.sweep with injected fake runners (no PyBullet; spawned worker processes are real).

The fake runner and generator are top-level functions so spawned workers can unpickle them. A world file's
``extra`` steers the fake: ``behaviour`` (ok / raise / hang / die / die_parent), ``gate`` (a file the runner
waits for: the test creates it when the trial may finish), ``exec_log`` (a file the runner appends one line
to per execution, to prove which trials really ran) and ``pid_log`` (the worker's pid, appended at start).
No test here depends on how fast the machine is: trials that must still be running when the test acts wait
for a gate; a hanging trial blocks on an event that never comes.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from navstack import sweep
from navstack.cli import main
from navstack.sweep import SweepConfig, SweepError, TrialSpec, build_specs, read_results, run_sweep

TESTS_DIR = Path(__file__).resolve().parent


# ---------------------------------------------------------------------------------------------- fakes


def fake_outcome(world_name: str, controller: str, seed: int) -> dict:
    """What the fake runner returns: deterministic in its inputs, varied enough to catch mix-ups."""
    success = (seed + len(controller)) % 3 != 0
    return {
        "world": world_name, "seed": seed, "controller": controller, "planner": "field",
        "success": success, "reason": "reached" if success else "collision",
        "goals_reached": 2 if success else 1, "sim_time": 10.0 + seed % 97 / 10.0, "steps": 1000 + seed % 89,
        "wall_time": 0.05,
        "metrics": {"tip_error_max": 0.001 * (seed % 5), "slither_deviation_max": 0.002 * (seed % 7),
                    "min_clearance": 0.01 * (seed % 11) - (0.0 if success else 0.02), "contacts": 0 if success else 3},
    }


def wait_for(path: Path) -> None:
    """Block until ``path`` exists (the test creates it when it wants the waiting side to go on)."""
    while not path.exists():
        time.sleep(0.01)


def fake_runner(world, *, controller, planner, seed, out_dir=None):
    data = json.loads(Path(world).read_text())
    extra = data.get("extra", {})
    if extra.get("pid_log"):
        with open(extra["pid_log"], "a") as fh:
            fh.write(f"{os.getpid()}\n")
    if extra.get("gate"):
        wait_for(Path(extra["gate"]))
    if extra.get("exec_log"):
        with open(extra["exec_log"], "a") as fh:
            fh.write(f"{data['name']} {controller} {planner}\n")
    behaviour = extra.get("behaviour", "ok")
    if behaviour == "talk":  # what a trial's own prints do in a worker
        print(f"fake trial {data['name']} says this on stdout", flush=True)
        print(f"fake trial {data['name']} says this on stderr", file=sys.stderr, flush=True)
    if behaviour == "raise":
        raise RuntimeError(f"fake failure in {data['name']}")
    if behaviour == "hang":
        threading.Event().wait()  # nobody ever sets it: only the trial timeout ends this
    if behaviour == "die":
        os._exit(7)
    if behaviour == "die_once":  # killed once (the OOM killer, a user's kill), fine when run again
        marker = Path(extra["marker"])
        if not marker.exists():
            marker.write_text("died once")
            os._exit(9)
    if behaviour == "die_parent":  # kill the process that started this worker (a Ray worker; never local)
        os.kill(os.getppid(), signal.SIGKILL)
        threading.Event().wait()
    out = fake_outcome(data["name"], controller, seed)
    out["planner"] = planner
    if out_dir is not None:  # what run_trial writes there
        Path(out_dir).mkdir(parents=True)
        (Path(out_dir) / "result.json").write_text(json.dumps(out))
        (Path(out_dir) / "sub").mkdir()
        (Path(out_dir) / "sub" / "trajectory.npz").write_bytes(bytes(range(256)))
    return out


def fake_generator(family: str, seed: int, difficulty: float) -> dict:
    return {"format": "navstack-world/1", "name": f"{family}-{seed}-{difficulty!r}", "family": family,
            "robot": {}, "obstacles": [], "goals": [{"position": [1, 0, 1]}],
            "extra": {"difficulty": difficulty, "world_seed": seed}}


def write_worlds(folder: Path, n: int, **extra) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        doc = {"format": "navstack-world/1", "name": f"w{i:02d}", "family": "truss" if i % 2 else "pipe-rack",
               "extra": {"difficulty": 0.25 * (i % 3), **extra}}
        (folder / f"w{i:02d}.json").write_text(json.dumps(doc))
    return folder


def lines_of(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def without_wall_time(records: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "wall_time"} for r in records]


@pytest.fixture()
def families(monkeypatch):
    """Families known to build_specs, independent of navstack.generate's progress."""
    monkeypatch.setattr(sweep, "_known_families", lambda: ("truss", "pipe-rack", "sphere-field"))


# ---------------------------------------------------------------------------------------------- spec lists


def test_generated_specs_are_deterministic_and_paired(families):
    cfg = SweepConfig(families=("truss", "pipe-rack"), count=3, seed=7, difficulties=(0.2, 0.8),
                      controllers=("slither", "tip-only"))
    a, b = build_specs(cfg), build_specs(cfg)
    assert a == b
    assert len(a) == 2 * 3 * 2 * 2
    assert len({s.trial_id for s in a}) == len(a)
    by_world: dict[tuple, set] = {}
    for s in a:
        assert s.generated and s.world_file == f"worlds/{s.world_id}.json"
        by_world.setdefault((s.family, s.index), set()).add((s.world_seed, s.seed))
    # world and noise seeds depend on (seed, family, index) only: shared by difficulties and controllers
    assert all(len(v) == 1 for v in by_world.values())
    assert len({next(iter(v)) for v in by_world.values()}) == len(by_world)
    # index-major order: a longer sweep starts with the shorter one
    assert build_specs(dataclass_replace(cfg, count=4))[: len(a)] == a
    # another sweep seed gives other worlds
    other = build_specs(dataclass_replace(cfg, seed=8))
    assert {s.world_seed for s in other}.isdisjoint({s.world_seed for s in a})
    # specs survive a JSON round trip (they are stored in sweep.json)
    assert [TrialSpec.from_dict(json.loads(json.dumps(s.to_dict()))) for s in a] == a


def dataclass_replace(cfg: SweepConfig, **kw) -> SweepConfig:
    import dataclasses

    return dataclasses.replace(cfg, **kw)


def test_worlds_dir_specs_read_family_and_difficulty(tmp_path):
    folder = write_worlds(tmp_path / "in", 3)
    specs = build_specs(SweepConfig(worlds_dir=str(folder), count=2, controllers=("slither", "tip-only")))
    assert len(specs) == 3 * 2 * 2
    s0 = [s for s in specs if s.world_id == "w01"]
    assert {s.family for s in s0} == {"truss"} and {s.difficulty for s in s0} == {0.25}
    assert all(Path(s.world_file).is_absolute() and not s.generated for s in specs)
    assert len({s.seed for s in specs if s.world_id == "w00"}) == 2  # repetitions get different noise seeds


def test_worlds_dir_takes_the_json_suffix_in_any_case_and_no_subfolders(tmp_path):
    """``B.JSON`` (a Windows export) was left out without a word (a review's case); a subfolder's files, other
    suffixes and folders named like a world file are not worlds."""
    folder = write_worlds(tmp_path / "in", 3)
    (folder / "w01.json").rename(folder / "W01.JSON")
    (folder / "w02.json").rename(folder / "w02.Json")
    (folder / "sub").mkdir()
    (folder / "sub" / "w03.json").write_text((folder / "w00.json").read_text())
    (folder / "dir.json").mkdir()
    (folder / "notes.json.txt").write_text("not a world")
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    assert [s.world_id for s in specs] == ["W01", "w00", "w02"]  # sorted by name, as before
    assert {Path(s.world_file).name for s in specs} == {"W01.JSON", "w00.json", "w02.Json"}
    (folder / "w00.JSON").write_text((folder / "w00.json").read_text())
    with pytest.raises(SweepError, match=r"w00\.(JSON|json) and w00\.(JSON|json) would both be world 'w00'"):
        build_specs(SweepConfig(worlds_dir=str(folder)))


@pytest.mark.parametrize(("kwargs", "needle"), [
    ({"families": ("truss",), "count": 0}, "count"),
    ({"families": ("truss",), "difficulties": (float("nan"),)}, "difficulty"),
    ({"families": ("truss",), "controllers": ("snake",)}, "controller 'snake'"),
    ({"families": ("truss",), "planners": ()}, "planners"),
    ({"families": ("truss", "truss")}, "duplicates"),
    ({"families": ("truss",), "difficulties": (1.5,)}, "difficulty must be in"),
    ({}, "exactly one"),
    ({"families": ("truss",), "worlds_dir": "x"}, "exactly one"),
])
def test_bad_config_is_refused(kwargs, needle):
    with pytest.raises(SweepError, match=needle):
        SweepConfig(**kwargs)


def test_bad_inputs_name_what_and_where(tmp_path, families):
    with pytest.raises(SweepError, match="unknown world family 'moon'"):
        build_specs(SweepConfig(families=("moon",)))
    with pytest.raises(SweepError, match="no \\*.json"):
        build_specs(SweepConfig(worlds_dir=str(tmp_path)))
    with pytest.raises(SweepError, match="picklable"):
        run_sweep([], tmp_path / "o", runner=lambda w, **k: {})


# ---------------------------------------------------------------------------------------------- results file


def test_read_results_truncated_tail_and_malformed_line(tmp_path):
    p = tmp_path / "results.jsonl"
    good = '{"trial_id": "a", "success": true}\n{"trial_id": "b", "success": false}\n'
    p.write_text(good + '{"trial_id": "c", "succ')
    rf = read_results(p)
    assert [r["trial_id"] for r in rf.records] == ["a", "b"]
    assert rf.truncated_tail and rf.valid_bytes == len(good.encode())
    p.write_text('{"trial_id": "a"}\n{"trial_id": \n{"trial_id": "b"}\n')
    with pytest.raises(SweepError, match=r"results\.jsonl, line 2: malformed"):
        read_results(p)
    p.write_text('{"trial_id": "a"}\n[1, 2]\n')
    with pytest.raises(SweepError, match="line 2"):
        read_results(p)


# ---------------------------------------------------------------------------------------------- sweeps


def test_parallel_sweep_then_partial_resume_with_truncated_line(tmp_path):
    log = tmp_path / "exec.log"
    folder = write_worlds(tmp_path / "in", 5, exec_log=str(log))
    specs = build_specs(SweepConfig(worlds_dir=str(folder), controllers=("slither", "tip-only")))
    full = tmp_path / "full"
    summary = run_sweep(specs, full, jobs=2, runner=fake_runner, progress=False)
    assert summary.complete and summary.ran == 10 and summary.errors == 0
    recs = lines_of(full / "results.jsonl")
    # N unique lines, in trial-list order once complete, each the runner's answer plus the sweep fields
    assert [r["trial_id"] for r in recs] == [s.trial_id for s in specs]
    for r, s in zip(recs, specs, strict=True):
        expect = fake_outcome(s.world_id, s.controller, s.seed)
        assert {k: r[k] for k in expect} == expect
        assert (r["family"], r["difficulty"], r["index"]) == (s.family, s.difficulty, s.index)
    assert summary.succeeded == sum(r["success"] for r in recs)
    assert len(log.read_text().splitlines()) == 10
    assert json.loads((full / "sweep.json").read_text())["trials"] == [s.to_dict() for s in specs]

    # A partial copy: 4 finished lines, then half of a 5th line (a write cut by a kill).
    part = tmp_path / "part"
    part.mkdir()
    shutil.copy(full / "sweep.json", part / "sweep.json")
    raw = (full / "results.jsonl").read_text().splitlines(keepends=True)
    (part / "results.jsonl").write_text("".join(raw[:4]) + raw[4][: len(raw[4]) // 2])
    log.write_text("")
    summary = run_sweep(specs, part, jobs=2, runner=fake_runner, progress=False)
    assert summary.dropped_truncated_line and summary.skipped == 4 and summary.ran == 6
    ran = sorted(log.read_text().splitlines())
    assert ran == sorted(f"{s.world_id} {s.controller} {s.planner}" for s in specs[4:])
    assert without_wall_time(lines_of(part / "results.jsonl")) == without_wall_time(recs)

    # Rerun of a finished sweep runs nothing; another spec list in the same directory is refused.
    log.write_text("")
    summary = run_sweep(specs, part, jobs=2, runner=fake_runner, progress=False)
    assert summary.ran == 0 and summary.skipped == 10 and log.read_text() == ""
    with pytest.raises(SweepError, match="holds a different sweep"):
        run_sweep(specs[:-1], part, jobs=1, runner=fake_runner, progress=False)
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "results.jsonl").write_text("")
    with pytest.raises(SweepError, match="sweep.json does not"):
        run_sweep(specs, tmp_path / "foreign", runner=fake_runner, progress=False)


def test_raising_hanging_and_dying_trials_are_errors_and_sweep_completes(tmp_path):
    folder = tmp_path / "in"
    write_worlds(folder, 3)
    for name, behaviour in (("x_raise", "raise"), ("x_hang", "hang"), ("x_die", "die")):
        (folder / f"{name}.json").write_text(json.dumps({"name": name, "extra": {"behaviour": behaviour}}))
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    summary = run_sweep(specs, tmp_path / "out", jobs=2, trial_timeout=5.0, runner=fake_runner,
                        progress=False)
    recs = {r["trial_id"]: r for r in lines_of(tmp_path / "out" / "results.jsonl")}
    assert summary.complete and len(recs) == 6 and summary.errors == 3
    for tid, needle in (("x_raise", "RuntimeError: fake failure in x_raise"), ("x_hang", "5 s wall-clock"),
                        ("x_die", "exit code 7")):
        r = recs[f"{tid}__000__slither__field"]
        assert (r["success"], r["reason"]) == (False, "error")
        assert needle in r["error"]
        assert r["metrics"]["min_clearance"] is None
    assert "fake_runner" in recs["x_raise__000__slither__field"]["traceback"]
    assert all(recs[f"w{i:02d}__000__slither__field"]["reason"] in ("reached", "collision") for i in range(3))


def test_a_backend_that_does_not_start_leaves_no_sweep_behind(tmp_path, monkeypatch):
    """A Ray address that answers nothing left a ``sweep.json`` with no trial run: the same command with other
    arguments was then refused as "a different sweep". Now only a sweep stored before the failure is kept."""
    import navstack.executors as executors

    def no_backend(backend, **kw):
        raise executors.BackendError("ray: at 127.0.0.1:9: nothing accepts connections")

    folder = write_worlds(tmp_path / "in", 2)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    out = tmp_path / "out"
    monkeypatch.setattr(executors, "make_executor", no_backend)
    with pytest.raises(SweepError, match="nothing accepts connections"):
        run_sweep(specs, out, runner=fake_runner, progress=False, backend="ray")
    assert not (out / "sweep.json").exists() and not (out / "results.jsonl").exists()
    with pytest.raises(SweepError, match="nothing accepts connections"):  # other arguments: not "a different sweep"
        run_sweep(specs[:1], out, runner=fake_runner, progress=False, backend="ray")
    monkeypatch.undo()
    run_sweep(specs, out, jobs=1, runner=fake_runner, progress=False)
    stored = (out / "sweep.json").read_bytes()
    first = (out / "results.jsonl").read_text().splitlines(keepends=True)[0]
    (out / "results.jsonl").write_text(first)  # one trial left to run
    monkeypatch.setattr(executors, "make_executor", no_backend)
    with pytest.raises(SweepError, match="nothing accepts connections"):  # a sweep stored before: kept
        run_sweep(specs, out, runner=fake_runner, progress=False, backend="ray")
    assert (out / "sweep.json").read_bytes() == stored and (out / "results.jsonl").read_text() == first


def _retracting_and_raising(family: str, seed: int, difficulty: float) -> dict:
    world = fake_generator(family, seed, difficulty)
    world["retract"] = True  # a family whose worlds ask for retraction themselves (dead-end), no --retract
    world["extra"]["behaviour"] = "raise"
    return world


def test_an_error_line_names_its_world_and_holds_retracted_when_the_world_asks_for_it(tmp_path, families):
    """An audit's error line of a generated dead-end world: ``world`` was the id, not the world's name, and
    ``retracted`` was missing though the world asks for retraction (spec 2a)."""
    specs = build_specs(SweepConfig(families=("truss",), count=1))
    run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, generator=_retracting_and_raising,
              progress=False)
    (rec,) = lines_of(tmp_path / "out" / "results.jsonl")
    world = json.loads((tmp_path / "out" / specs[0].world_file).read_text())
    assert rec["reason"] == "error" and "fake failure" in rec["error"]
    assert rec["world"] == world["name"] != specs[0].world_id
    assert rec["retracted"] is False


def test_generated_sweep_is_reproducible_and_writes_worlds(tmp_path, families):
    cfg = SweepConfig(families=("truss", "sphere-field"), count=2, seed=3, difficulties=(0.3, 0.9))
    specs = build_specs(cfg)
    outs = []
    for name in ("a", "b"):
        run_sweep(specs, tmp_path / name, jobs=2, runner=fake_runner, generator=fake_generator,
                  progress=False, config=cfg)
        outs.append(lines_of(tmp_path / name / "results.jsonl"))
    assert without_wall_time(outs[0]) == without_wall_time(outs[1])
    for r, s in zip(outs[0], specs, strict=True):
        world = json.loads((tmp_path / "a" / s.world_file).read_text())
        # the runner was given the written world file: its name carries the generator's inputs
        assert r["world"] == world["name"] == f"{s.family}-{s.world_seed}-{s.difficulty!r}"
    assert len(list((tmp_path / "a" / "worlds").glob("*.json"))) == 2 * 2 * 2
    assert json.loads((tmp_path / "a" / "sweep.json").read_text())["config"]["seed"] == 3


def _partial_copy(full: Path, part: Path, lines: list[str]) -> Path:
    """A sweep folder holding ``full``'s sweep.json and the given results text lines."""
    part.mkdir()
    shutil.copy(full / "sweep.json", part / "sweep.json")
    (part / "results.jsonl").write_text("".join(lines))
    return part


def test_error_lines_count_as_finished_on_resume(tmp_path):
    log = tmp_path / "exec.log"
    folder = write_worlds(tmp_path / "in", 2, exec_log=str(log))
    (folder / "x_raise.json").write_text(json.dumps({"name": "x_raise",
                                                     "extra": {"behaviour": "raise", "exec_log": str(log)}}))
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    out = tmp_path / "out"
    assert run_sweep(specs, out, jobs=2, runner=fake_runner, progress=False).errors == 1
    before = (out / "results.jsonl").read_bytes()
    log.write_text("")
    summary = run_sweep(specs, out, jobs=2, runner=fake_runner, progress=False)
    assert (summary.ran, summary.skipped, summary.errors) == (0, 3, 0)
    assert log.read_text() == ""  # the failed trial was not run again
    assert (out / "results.jsonl").read_bytes() == before


def test_complete_last_line_without_newline_is_terminated_before_appending(tmp_path):
    folder = write_worlds(tmp_path / "in", 3)
    specs = build_specs(SweepConfig(worlds_dir=str(folder), controllers=("slither", "tip-only")))
    full = tmp_path / "full"
    run_sweep(specs, full, jobs=2, runner=fake_runner, progress=False)
    raw = (full / "results.jsonl").read_text().splitlines(keepends=True)
    part = _partial_copy(full, tmp_path / "part", [*raw[:2], raw[2].rstrip("\n")])
    summary = run_sweep(specs, part, jobs=2, runner=fake_runner, progress=False)
    assert not summary.dropped_truncated_line and summary.skipped == 3 and summary.ran == 3
    text = (part / "results.jsonl").read_text()
    assert text.endswith("\n") and text.count("\n") == 6
    assert without_wall_time(lines_of(part / "results.jsonl")) == without_wall_time(lines_of(full / "results.jsonl"))


def test_resumed_sweep_is_rewritten_in_trial_order(tmp_path):
    """The finished half is stored in reverse order, so the order of the result can only come from the
    rewrite, whatever order the other half completes in."""
    folder = write_worlds(tmp_path / "in", 4)
    specs = build_specs(SweepConfig(worlds_dir=str(folder), controllers=("slither", "tip-only")))
    full = tmp_path / "full"
    run_sweep(specs, full, jobs=2, runner=fake_runner, progress=False)
    raw = (full / "results.jsonl").read_text().splitlines(keepends=True)
    part = _partial_copy(full, tmp_path / "part", raw[:4][::-1])
    assert run_sweep(specs, part, jobs=2, runner=fake_runner, progress=False).ran == 4
    assert [r["trial_id"] for r in lines_of(part / "results.jsonl")] == [s.trial_id for s in specs]
    whole = _partial_copy(full, tmp_path / "whole", raw[::-1])  # complete but out of order: rewritten too
    assert run_sweep(specs, whole, jobs=1, runner=fake_runner, progress=False).ran == 0
    assert (whole / "results.jsonl").read_text() == "".join(raw)


def test_malformed_world_file_is_an_error_line_and_the_sweep_goes_on(tmp_path, capsys):
    """Issue 8 item 3: a syntax error is recorded like a schema error, naming the file, line and column."""
    folder = write_worlds(tmp_path / "in", 2)
    bad = folder / "bad.json"
    bad.write_text('{"name": "x",\n "family": }')
    (folder / "list.json").write_text("[1, 2]")
    args = _parse(["--worlds", str(folder), "--out", str(tmp_path / "out"), "--jobs", "2", "--no-progress"])
    import functools

    real = sweep.run_sweep
    sweep_with_fake = functools.partial(real, runner=fake_runner)
    try:
        sweep.run_sweep = sweep_with_fake
        assert sweep.run_from_args(args, []) == 0
    finally:
        sweep.run_sweep = real
    recs = {r["world_id"]: r for r in lines_of(tmp_path / "out" / "results.jsonl")}
    assert set(recs) == {"bad", "list", "w00", "w01"}
    assert (recs["bad"]["reason"], recs["bad"]["success"]) == ("error", False)
    assert recs["bad"]["error"] == f"{bad}: invalid JSON: Expecting value (line 2, column 12)"
    assert recs["list"]["reason"] == "error"  # not a world object: the runner's error, like any schema error
    assert recs["w00"]["reason"] in ("reached", "collision") and recs["w01"]["reason"] in ("reached", "collision")
    assert "2 of them errors" in capsys.readouterr().out


def test_every_line_carries_provenance(tmp_path):
    import platform
    import socket

    import navstack
    from navstack.provenance import source_commit

    folder = write_worlds(tmp_path / "in", 2)
    (folder / "x_raise.json").write_text(json.dumps({"name": "x_raise", "extra": {"behaviour": "raise"}}))
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    run_sweep(specs, tmp_path / "out", jobs=2, runner=fake_runner, progress=False)
    recs = lines_of(tmp_path / "out" / "results.jsonl")
    assert len(recs) == 3
    for r in recs:
        assert list(r)[-1] == "provenance"
        assert r["provenance"] == {"navstack": navstack.__version__, "commit": source_commit(),
                                   "python": platform.python_version(), "pybullet": _version("pybullet"),
                                   "numpy": _version("numpy"), "host": socket.gethostname(), "backend": "local"}
        assert "retracted" not in r  # no retraction world here


def _version(dist: str) -> str:
    from importlib.metadata import version

    return version(dist)


def retract_generator(family: str, seed: int, difficulty: float, *, retract: bool = False) -> dict:
    world = fake_generator(family, seed, difficulty)
    world["extra"].update(retract_arg=retract, behaviour="raise" if retract else "ok")
    return world


def test_retract_flag_changes_only_retract_sweeps(tmp_path, families, monkeypatch):
    plain = build_specs(SweepConfig(families=("truss",), count=1))
    assert [s.trial_id for s in plain] == ["truss__d0.5__0000__slither__field"]  # ids of today
    assert "retract" not in plain[0].to_dict()
    assert not sweep._generator_supports_retract(fake_generator)
    assert sweep._generator_supports_retract(retract_generator)
    monkeypatch.setattr(sweep, "_generator_supports_retract", lambda generator=None: False)
    with pytest.raises(SweepError, match="--retract: this navstack's world generator cannot"):
        build_specs(SweepConfig(families=("truss",), retract=True))
    monkeypatch.setattr(sweep, "_generator_supports_retract", lambda generator=None: True)
    specs = build_specs(SweepConfig(families=("truss",), count=2, retract=True))
    assert [s.trial_id for s in specs] == ["truss__d0.5__0000__retract__slither__field",
                                           "truss__d0.5__0001__retract__slither__field"]
    assert [(s.world_seed, s.seed) for s in specs] == [(p.world_seed, p.seed) for p in
                                                       build_specs(SweepConfig(families=("truss",), count=2))]
    assert specs[0].to_dict()["retract"] is True and TrialSpec.from_dict(specs[0].to_dict()) == specs[0]
    run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, generator=retract_generator, progress=False)
    for r, s in zip(lines_of(tmp_path / "out" / "results.jsonl"), specs, strict=True):
        assert json.loads((tmp_path / "out" / s.world_file).read_text())["extra"]["retract_arg"] is True
        assert (r["reason"], r["retracted"]) == ("error", False)
    with pytest.raises(SweepError, match="retract applies to generated worlds"):
        SweepConfig(worlds_dir=str(tmp_path), retract=True)


def test_keep_trajectories_files_come_back_to_the_driver(tmp_path):
    folder = write_worlds(tmp_path / "in", 2)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    run_sweep(specs, tmp_path / "out", jobs=2, runner=fake_runner, progress=False, keep_trajectories=True)
    for r in lines_of(tmp_path / "out" / "results.jsonl"):
        trial = tmp_path / "out" / "trials" / r["trial_id"]
        assert json.loads((trial / "result.json").read_text())["world"] == r["world"]
        assert (trial / "sub" / "trajectory.npz").read_bytes() == bytes(range(256))
    run_sweep(specs, tmp_path / "plain", jobs=1, runner=fake_runner, progress=False)
    assert not (tmp_path / "plain" / "trials").exists()


def test_a_world_file_of_a_long_name_keeps_its_files_in_a_shortened_folder(tmp_path, monkeypatch):
    """An audit (session 33): a 250-byte world file name made 'trials/<trial_id>' too long a name; the trial ran,
    then the driver stopped with 'File name too long' before its line, and every rerun did the same, so the sweep
    could never finish.  The folder's name is cut (ending in a hash of the id), and a file that cannot be kept
    is said on stderr and costs no results line."""
    folder = write_worlds(tmp_path / "in", 2)
    long = folder / ("L" * 245 + ".json")
    (folder / "w00.json").rename(long)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, progress=False, keep_trajectories=True)
    lines = lines_of(tmp_path / "out" / "results.jsonl")
    assert len(lines) == 2 and {r["trial_id"] for r in lines} == {s.trial_id for s in specs}
    for r in lines:
        trial = sweep.trial_folder(tmp_path / "out", r["trial_id"])
        assert json.loads((trial / "result.json").read_text())["world"] == r["world"]
        assert len(os.fsencode(trial.name)) <= sweep.FOLDER_BYTES
    long_id = next(s.trial_id for s in specs if s.trial_id.startswith("LLL"))
    assert sweep.trial_folder(tmp_path, long_id).name.startswith("L" * 150)
    assert sweep.trial_folder(tmp_path, long_id) != sweep.trial_folder(tmp_path, long_id.replace("L", "M", 1))

    def unwritable(self, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Path, "write_bytes", unwritable)
    run_sweep(specs, tmp_path / "full", jobs=1, runner=fake_runner, progress=False, keep_trajectories=True)
    assert len(lines_of(tmp_path / "full" / "results.jsonl")) == 2


def test_animate_failures_keeps_and_animates_only_the_failed_trials(tmp_path, monkeypatch):
    """The driver keeps the folders of failed trials, animates them there and names the file in the line;
    successful trials leave nothing behind; the report links the animations."""
    import navstack.animate
    from navstack.report import write_report

    animated = []

    def fake_animate(run_dir):
        animated.append(Path(run_dir))
        assert (Path(run_dir) / "result.json").is_file()  # the trial's files are there before it is animated
        out = Path(run_dir) / "animation.mp4"
        out.write_bytes(b"mp4")
        return out

    monkeypatch.setattr(navstack.animate, "animate_run", fake_animate)
    folder = write_worlds(tmp_path / "in", 4)
    specs = build_specs(SweepConfig(worlds_dir=str(folder), controllers=("slither", "tip-only")))
    run_sweep(specs, tmp_path / "out", jobs=2, runner=fake_runner, progress=False, animate_failures=True)
    lines = lines_of(tmp_path / "out" / "results.jsonl")
    failed = [r for r in lines if not r["success"]]
    assert failed and len(failed) < len(lines)  # both kinds present
    for r in lines:
        trial = tmp_path / "out" / "trials" / r["trial_id"]
        if r["success"]:
            assert not trial.exists() and "animation" not in r
        else:
            assert r["animation"] == f"trials/{r['trial_id']}/animation.mp4"
            assert (tmp_path / "out" / r["animation"]).read_bytes() == b"mp4"
    assert sorted(p.name for p in animated) == sorted(r["trial_id"] for r in failed)
    report = write_report(tmp_path / "out", plots=False).read_text()
    for r in failed:
        assert f"[{r['trial_id']}]({r['animation']})" in report


# ---------------------------------------------------------------------------------------------- real kills

KILL_SCRIPT = """
import signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal, even if the test runner ignores it
sys.path.insert(0, {tests!r})
from test_sweep import fake_runner
from navstack.sweep import SweepConfig, build_specs, run_sweep
specs = build_specs(SweepConfig(worlds_dir={worlds!r}, controllers=("slither", "tip-only")))
s = run_sweep(specs, {out!r}, jobs=2, runner=fake_runner, progress=False)
print("INTERRUPTED" if s.interrupted else "DONE", s.recorded, flush=True)
sys.exit(130 if s.interrupted else 0)
"""


HANG_GUARD = 600.0
"""Seconds after which a waiting test gives up instead of hanging CI (never reached on a working sweep)."""


def _wait_until(what: str, condition) -> None:
    """Wait for ``condition()``: an event the test controls, not a measure of speed."""
    deadline = time.monotonic() + HANG_GUARD
    while not condition():
        assert time.monotonic() < deadline, f"gave up waiting for {what}"
        time.sleep(0.02)


def _n_lines(path: Path) -> int:
    return len(path.read_text().splitlines()) if path.exists() else 0


def _start_and_signal(script: str, results: Path, lines: int, sig: int) -> tuple[int, str]:
    """Run ``script`` until ``results`` has ``lines`` lines (the rest of its trials wait for a gate), then
    send ``sig``."""
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    _wait_until(f"{lines} lines in {results}", lambda: _n_lines(results) >= lines or proc.poll() is not None)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=HANG_GUARD)
    return proc.returncode, out + err


def _gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] == "Z"  # a zombie has exited
    except FileNotFoundError:
        return True


@pytest.mark.slow
def test_sigint_and_sigkill_then_resume_lose_and_duplicate_nothing(tmp_path):
    """w00-w01 finish at once, w02-w03 wait for gate_a, w04-w11 for gate_b: each stop is at a known point."""
    log, pids = tmp_path / "exec.log", tmp_path / "pids.log"
    gate_a, gate_b = tmp_path / "gate_a", tmp_path / "gate_b"
    folder = tmp_path / "in"
    folder.mkdir()
    for i in range(12):
        extra = {"exec_log": str(log), "pid_log": str(pids)}
        if i >= 2:
            extra["gate"] = str(gate_a if i < 4 else gate_b)
        (folder / f"w{i:02d}.json").write_text(json.dumps({"name": f"w{i:02d}", "extra": extra}))
    out = tmp_path / "out"
    results = out / "results.jsonl"
    script = KILL_SCRIPT.format(tests=str(TESTS_DIR), worlds=str(folder), out=str(out))
    specs = build_specs(SweepConfig(worlds_dir=str(folder), controllers=("slither", "tip-only")))
    total = len(specs)

    rc, text = _start_and_signal(script, results, 4, signal.SIGINT)
    assert rc == 130 and "INTERRUPTED 4" in text, text
    after_int = results.read_bytes()
    assert {r["trial_id"] for r in lines_of(results)} == {s.trial_id for s in specs[:4]}

    gate_a.touch()
    rc, _ = _start_and_signal(script, results, 8, signal.SIGKILL)
    assert rc == -signal.SIGKILL
    workers = [int(p) for p in pids.read_text().split()]
    _wait_until("the killed sweep's workers to exit", lambda: all(_gone(p) for p in workers))
    after_kill = results.read_bytes()
    assert after_kill.startswith(after_int)  # nothing recorded was lost or rewritten
    recorded_before_resume = {r["trial_id"] for r in read_results(results).records}
    assert recorded_before_resume == {s.trial_id for s in specs[:8]}
    executed_before = len(log.read_text().splitlines())

    gate_b.touch()
    summary = run_sweep(specs, out, jobs=2, runner=fake_runner, progress=False)
    assert summary.complete and summary.skipped == 8 and summary.ran == total - 8
    recs = lines_of(results)
    assert [r["trial_id"] for r in recs] == [s.trial_id for s in specs]  # each exactly once, in order
    # the resume executed only trials that had no line yet
    resumed = log.read_text().splitlines()[executed_before:]
    assert sorted(resumed) == sorted(f"{s.world_id} {s.controller} {s.planner}" for s in specs[8:])
    for r, s in zip(recs, specs, strict=True):
        assert r["success"] == fake_outcome(s.world_id, s.controller, s.seed)["success"]


# ---------------------------------------------------------------------------------------------- command line


def _parse(argv: list[str]):
    import argparse

    parser = argparse.ArgumentParser()
    sweep.add_trials_arguments(parser)
    return parser.parse_args(argv)


def test_cli_arguments_build_the_config(families):
    args = _parse(["--generate", "truss", "pipe-rack", "--count", "2", "--seed", "4", "--difficulty", "0.2", "0.8",
                   "--controller", "slither", "--controller", "tip-only", "--out", "x"])
    cfg = sweep.config_from_args(args)
    assert cfg == SweepConfig(families=("truss", "pipe-rack"), count=2, seed=4, difficulties=(0.2, 0.8),
                              controllers=("slither", "tip-only"), planners=("field",))
    assert len(build_specs(cfg)) == 2 * 2 * 2 * 2


def test_cli_bad_input_and_interrupt_messages(tmp_path, capsys, monkeypatch):
    assert sweep.run_from_args(_parse(["--worlds", str(tmp_path), "--out", str(tmp_path / "o")]), []) == 2
    assert "no *.json world files" in capsys.readouterr().err
    write_worlds(tmp_path / "in", 2)

    def interrupted(specs, out_dir, **kw):
        return sweep.SweepSummary(out_dir=Path(out_dir), results_path=Path(out_dir) / "results.jsonl",
                                  total=len(specs), skipped=0, recorded=1, interrupted=True)

    monkeypatch.setattr(sweep, "run_sweep", interrupted)
    argv = ["trials", "--worlds", str(tmp_path / "in"), "--out", str(tmp_path / "o")]
    assert sweep.run_from_args(_parse(argv[1:]), argv) == 130
    err = capsys.readouterr().err
    assert "1 of 2 trials are recorded" in err and f"navstack trials --worlds {tmp_path / 'in'}" in err


def test_cli_backend_and_retract_options(tmp_path, capsys, monkeypatch, families):
    seen = {}

    def fake_sweep(specs, out_dir, **kw):
        seen.update(kw, ids=[s.trial_id for s in specs])
        return sweep.SweepSummary(out_dir=Path(out_dir), results_path=Path(out_dir) / "results.jsonl",
                                  total=len(specs), skipped=0, recorded=len(specs))

    monkeypatch.setattr(sweep, "run_sweep", fake_sweep)
    monkeypatch.setattr(sweep, "_generator_supports_retract", lambda generator=None: True)
    argv = ["--generate", "truss", "--backend", "ray", "--ray-address", "10.0.0.1:6379", "--retract",
            "--out", str(tmp_path / "o")]
    assert sweep.run_from_args(_parse(argv), argv) == 0
    assert (seen["backend"], seen["ray_address"]) == ("ray", "10.0.0.1:6379")
    assert seen["ids"] == ["truss__d0.5__0000__retract__slither__field"] and seen["config"].retract
    assert sweep.run_from_args(_parse(["--generate", "truss", "--out", "o"]), []) == 0
    assert (seen["backend"], seen["ray_address"], seen["ids"]) == ("local", None, ["truss__d0.5__0000__slither__field"])
    for bad, needle in ((["--generate", "truss", "--ray-address", "x:1"], "--ray-address only applies"),
                        (["--worlds", str(tmp_path), "--retract"], "--retract only applies")):
        capsys.readouterr()
        assert sweep.run_from_args(_parse([*bad, "--out", "o"]), []) == 2
        assert needle in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _parse(["--generate", "truss", "--backend", "dask", "--out", "o"])


def test_sweep_accepts_exactly_the_registered_names():
    """Trial, sweep and CLI read one registry: every registered name is accepted, anything else refused."""
    from navstack.registry import controller_names, planner_names

    for c in controller_names():
        for p in planner_names():
            assert SweepConfig(families=("truss",), controllers=(c,), planners=(p,)).planners == (p,)
    with pytest.raises(SweepError, match="unknown planner"):
        SweepConfig(families=("truss",), planners=("no-such-planner",))
    with pytest.raises(SweepError, match="unknown controller"):
        SweepConfig(families=("truss",), controllers=("no-such-controller",))


def test_worker_that_cannot_start_stops_the_sweep(tmp_path, monkeypatch):
    """A runner the spawned worker cannot import is a sweep error, not an endless respawn loop."""
    import types

    mod = types.ModuleType("navstack_test_not_importable")

    def runner(world, **kw):  # pragma: no cover - never runs
        return {}

    runner.__module__ = mod.__name__
    runner.__qualname__ = "runner"
    mod.runner = runner
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    folder = write_worlds(tmp_path / "in", 2)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    with pytest.raises(sweep.SweepWorkerError, match="died while starting"):
        run_sweep(specs, tmp_path / "out", jobs=1, runner=mod.runner, progress=False)
    assert (tmp_path / "out" / "results.jsonl").read_text() == ""


def test_second_sweep_on_a_busy_directory_is_refused(tmp_path):
    import fcntl

    folder = write_worlds(tmp_path / "in", 1)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    out = tmp_path / "out"
    out.mkdir()
    fd = os.open(out / "sweep.lock", os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # another process's open file description holding the lock
        with pytest.raises(SweepError, match="another sweep is running"):
            run_sweep(specs, out, runner=fake_runner, progress=False)
    finally:
        os.close(fd)
    assert not (out / "results.jsonl").exists()


def test_closing_the_results_writer_twice_is_harmless(tmp_path):
    writer = sweep._ResultsWriter(tmp_path / "results.jsonl")
    writer.append({"trial_id": "a"})
    writer.close()
    writer.close()  # an interrupted sweep closes in a finally block after a normal close
    assert writer.fd == -1
    assert lines_of(tmp_path / "results.jsonl") == [{"trial_id": "a"}]


def test_a_world_file_gone_before_its_trial_is_an_error_line(tmp_path):
    folder = write_worlds(tmp_path / "in", 2)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    gone = folder / "w01.json"
    gone.unlink()  # removed by someone else after the sweep listed it
    summary = run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, progress=False)
    recs = {r["world_id"]: r for r in lines_of(tmp_path / "out" / "results.jsonl")}
    assert summary.errors == 1 and recs["w01"]["reason"] == "error"
    assert recs["w01"]["error"].startswith(f"{gone}: cannot read world file:")
    assert recs["w00"]["reason"] in ("reached", "collision")


def test_the_progress_bar_shows_errors_without_failing(tmp_path, capsys):
    folder = write_worlds(tmp_path / "in", 1)
    (folder / "x_raise.json").write_text(json.dumps({"name": "x_raise", "extra": {"behaviour": "raise"}}))
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    summary = run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, progress=True)
    assert (summary.ran, summary.errors) == (2, 1)
    assert "errors 1" in capsys.readouterr().err


@pytest.mark.parametrize(("option", "expected"), [("0", None), ("7.5", 7.5)])
def test_trial_timeout_zero_means_none_on_the_command_line(tmp_path, option, expected):
    import functools

    folder = write_worlds(tmp_path / "in", 1)
    args = _parse(["--worlds", str(folder), "--out", str(tmp_path / "out"), "--jobs", "1", "--no-progress",
                   "--trial-timeout", option])
    seen = []
    real = sweep.run_sweep

    def spy(*a, **k):
        seen.append(k["trial_timeout"])
        return functools.partial(real, runner=fake_runner)(*a, **k)

    try:
        sweep.run_sweep = spy
        assert sweep.run_from_args(args, []) == 0
    finally:
        sweep.run_sweep = real
    assert seen == [expected]


def test_an_interrupt_while_a_line_is_recorded_comes_after_its_count():
    """The driver writes a results line and counts it with SIGINT held: a Ctrl-C that arrives in between is
    delivered once both are done (the summary once said 3 recorded with 4 lines in the file).  Another thread
    is alive meanwhile, as the driver's are: the process may hand the signal to it."""
    from navstack.sweep import _signals_deferred

    stop = threading.Event()
    other = threading.Thread(target=stop.wait, daemon=True)
    other.start()
    done = []
    old = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal, even if the runner ignores it
    try:
        with pytest.raises(KeyboardInterrupt):
            with _signals_deferred():
                os.kill(os.getpid(), signal.SIGINT)
                done.append("line")
                time.sleep(0.05)
                done.append("count")
    finally:
        stop.set()
        signal.signal(signal.SIGINT, old)
    assert done == ["line", "count"]


def test_a_sweep_interrupted_as_it_records_a_line_counts_every_line_it_wrote(tmp_path, monkeypatch):
    """The driver's own recording holds the interrupt (not just the context manager on its own): a Ctrl-C
    arriving just after a results line is written is delivered after that line is counted, so the summary's
    count is the file's."""
    folder = write_worlds(tmp_path / "in", 3)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    real = sweep._ResultsWriter.append

    def append_then_interrupt(self, record):
        real(self, record)
        os.kill(os.getpid(), signal.SIGINT)  # between the line and its count

    monkeypatch.setattr(sweep._ResultsWriter, "append", append_then_interrupt)
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        summary = run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, progress=False)
    finally:
        signal.signal(signal.SIGINT, old)
    assert summary.interrupted
    assert summary.recorded == len(lines_of(tmp_path / "out" / "results.jsonl")) == 1


# ---------------------------------------------------------------------------------------------- hardening


def _strict_json(path: Path):
    def refuse(name):
        raise AssertionError(f"{path} holds {name}")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_world_files_with_unusable_fields_neither_stop_nor_break_the_sweep(tmp_path):
    """A non-finite or float-overflowing ``extra.difficulty`` once stopped a sweep for good ('Out of range float
    values are not JSON compliant', or 'internal error: OverflowError'); it reads as absent (the world check of
    the real runner names the field), and files the parser cannot take become error lines."""
    folder = write_worlds(tmp_path / "in", 1)
    texts = {
        "nan": '{"name": "nan", "family": "truss", "extra": {"difficulty": NaN}}',
        "inf": '{"name": "inf", "extra": {"difficulty": 1e400}}',
        "long": '{"name": "long", "extra": {"difficulty": 1' + "0" * 400 + "}}",
        "family": '{"name": "family", "family": [1], "retract": "yes", "extra": {"difficulty": 0.5}}',
        "digits": '{"name": "digits", "extra": {"difficulty": 1' + "0" * 5000 + "}}",
        "deep": "[" * 100000,
        "far": '{"name": "far", "extra": {"difficulty": 2e9}}',  # finite, but beyond what the report reads
    }
    for name, text in texts.items():
        (folder / f"{name}.json").write_text(text)
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    by_world = {s.world_id: s for s in specs}
    assert {w: (s.family, s.difficulty, s.retract) for w, s in by_world.items()} == {
        "w00": ("pipe-rack", 0.0, False), "nan": ("truss", None, False), "inf": (None, None, False),
        "long": (None, None, False), "family": (None, 0.5, False), "digits": (None, None, False),
        "deep": (None, None, False), "far": (None, None, False)}
    from navstack.report import MAX_VALUE

    assert sweep.MAX_DIFFICULTY == MAX_VALUE
    out = tmp_path / "out"
    summary = run_sweep(specs, out, jobs=2, runner=fake_runner, progress=False)
    assert summary.complete and summary.errors == 2
    recs = {r["world_id"]: r for r in lines_of(out / "results.jsonl")}
    assert recs["deep"]["error"] == f"{folder / 'deep.json'}: invalid JSON: nested too deeply"
    assert recs["digits"]["error"].startswith(f"{folder / 'digits.json'}: invalid JSON: Exceeds the limit")
    assert recs["nan"]["difficulty"] is None and recs["nan"]["reason"] in ("reached", "collision")
    assert [t["difficulty"] for t in _strict_json(out / "sweep.json")["trials"]] == [s.difficulty for s in specs]
    assert run_sweep(build_specs(SweepConfig(worlds_dir=str(folder))), out, jobs=1, runner=fake_runner,
                     progress=False).ran == 0  # and it resumes


def test_a_world_file_from_the_real_runner_names_its_non_finite_difficulty(tmp_path):
    """With the real runner the world check turns the bad difficulty into an error line naming the field."""
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "nan.json").write_text('{"format": "navstack-world/1", "name": "nan", "robot": {}, "obstacles": [], '
                                     '"goals": [{"position": [1, 0, 1]}], "extra": {"difficulty": NaN}}')
    summary = run_sweep(build_specs(SweepConfig(worlds_dir=str(folder))), tmp_path / "out", jobs=1,
                        progress=False)
    (rec,) = lines_of(tmp_path / "out" / "results.jsonl")
    assert summary.errors == 1 and rec["difficulty"] is None
    assert "extra.difficulty: expected a finite number, got NaN" in rec["error"]


def test_read_results_deeply_nested_and_non_finite_lines(tmp_path):
    p = tmp_path / "results.jsonl"
    good = '{"trial_id": "a", "success": true}\n'
    p.write_text(good + "[" * 100000 + "\n" + good)
    with pytest.raises(SweepError, match=r"results\.jsonl, line 2: malformed result line \(nested too deeply\)"):
        read_results(p)
    p.write_text(good + "[" * 100000)  # unterminated last line: a truncated write, like any other
    rf = read_results(p)
    assert rf.truncated_tail and rf.valid_bytes == len(good) and len(rf.records) == 1
    p.write_text(good + '{"trial_id": "b", "sim_time": NaN}')  # the writer never writes NaN: not a cut write
    with pytest.raises(SweepError, match=r"line 2: malformed result line \(NaN is not valid JSON\)"):
        read_results(p)


def test_resume_refuses_a_deeply_nested_line(tmp_path, capsys):
    folder = write_worlds(tmp_path / "in", 2)
    out = tmp_path / "out"
    argv = ["--worlds", str(folder), "--out", str(out), "--jobs", "1", "--no-progress"]
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    run_sweep(specs, out, jobs=1, runner=fake_runner, progress=False, config=sweep.config_from_args(_parse(argv)))
    first = (out / "results.jsonl").read_text().splitlines(keepends=True)[0]
    (out / "results.jsonl").write_text(first + "[" * 100000 + "\n")
    assert sweep.run_from_args(_parse(argv), []) == 2
    assert f"{out / 'results.jsonl'}, line 2: malformed result line (nested too deeply)" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["nan", "-5", "inf", "-inf", "1e400", "soon"])
def test_trial_timeout_must_be_finite_and_not_negative(value, capsys):
    with pytest.raises(SystemExit) as info:
        _parse(["--worlds", "x", "--out", "y", f"--trial-timeout={value}"])
    assert info.value.code == 2
    assert (f"argument --trial-timeout: expected a number of seconds >= 0 (0 = no limit), got '{value}'"
            in capsys.readouterr().err)


def test_out_in_the_worlds_folder_is_refused_and_a_subfolder_is_fine(tmp_path, capsys):
    """--out equal to --worlds once wrote sweep.json among the worlds: the rerun listed it as a world and
    refused to resume ('holds a different sweep')."""
    folder = write_worlds(tmp_path / "in", 2)
    argv = ["--worlds", str(folder), "--out", str(folder) + "/", "--no-progress"]
    assert sweep.run_from_args(_parse(argv), []) == 2
    assert f"--out: {folder} is the --worlds folder" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == ["w00.json", "w01.json"]
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    for _ in range(2):  # a subfolder is not listed: the sweep resumes
        run_sweep(specs, folder / "out", jobs=1, runner=fake_runner, progress=False)
    assert len(lines_of(folder / "out" / "results.jsonl")) == 2


def test_a_dangling_symlink_is_an_error_line(tmp_path):
    folder = write_worlds(tmp_path / "in", 2)
    (folder / "gone.json").symlink_to(tmp_path / "nowhere.json")
    (folder / "loop.json").symlink_to("loop.json")
    (folder / "dir.json").mkdir()  # a folder is not a world file: not listed
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    assert sorted(s.world_id for s in specs) == ["gone", "loop", "w00", "w01"]
    summary = run_sweep(specs, tmp_path / "out", jobs=1, runner=fake_runner, progress=False)
    recs = {r["world_id"]: r for r in lines_of(tmp_path / "out" / "results.jsonl")}
    assert summary.errors == 2
    assert recs["gone"]["error"] == (f"{folder / 'gone.json'}: cannot read world file: a symbolic link to "
                                     f"{tmp_path / 'nowhere.json'}, which leads to no file (a missing target or "
                                     "a loop of links)")
    assert recs["loop"]["reason"] == "error" and "loop.json" in recs["loop"]["error"]


def test_a_trial_is_given_at_least_its_worlds_own_time_limit_of_wall_clock(tmp_path):
    """The default limit is 600 s of wall clock, but a valid world may simulate 3600 s (minutes of wall clock):
    it would have been recorded as an error.  Its limit is now the longer of the two."""
    from navstack.executors import TrialJob
    from navstack.sweep import _wall_limit

    spec = build_specs(SweepConfig(worlds_dir=str(write_worlds(tmp_path / "in", 1))))[0]

    def job(time_limit) -> TrialJob:
        return TrialJob(spec=spec, world_text=json.dumps({"name": "w", "time_limit": time_limit}), runner=fake_runner)

    assert _wall_limit(job(3600.0), 600.0) == 3600.0
    assert _wall_limit(job(30), 600.0) == 600.0
    assert _wall_limit(job(3600.0), None) is None  # no limit stays no limit
    for bad in ("x", True, 1e300, None):  # the trial's own check refuses these; the sweep's limit stays
        assert _wall_limit(job(bad), 600.0) == 600.0
    assert _wall_limit(TrialJob(spec=spec, world_text=None, runner=fake_runner), 600.0) == 600.0  # generated
    assert _wall_limit(TrialJob(spec=spec, world_text="[1, 2]", runner=fake_runner), 600.0) == 600.0


def test_a_sweep_whose_world_file_changed_is_not_resumed(tmp_path):
    """Trials of the earlier file are finished; resuming would run the rest on the new text and mix the two in
    one results.jsonl unseen.  The stored SHA-256 catches it, naming the file; put back, it resumes."""
    folder = write_worlds(tmp_path / "in", 2)
    specs = build_specs(SweepConfig(worlds_dir=str(folder), count=2))
    out = tmp_path / "out"
    run_sweep(specs[:2], out, jobs=1, runner=fake_runner, progress=False)  # a first part, as if interrupted
    stored = json.loads((out / "sweep.json").read_text())["world_files"]
    assert sorted(stored) == sorted({s.world_file for s in specs[:2]}) and all(len(h) == 64 for h in stored.values())
    edited = Path(specs[0].world_file)
    original = edited.read_text()
    edited.write_text(original.replace('"w00"', '"w00-edited"'))
    with pytest.raises(SweepError, match=rf"{edited}.* changed since the sweep in .* began"):
        run_sweep(specs[:2], out, jobs=1, runner=fake_runner, progress=False)
    edited.write_text(original)
    assert run_sweep(specs[:2], out, jobs=1, runner=fake_runner, progress=False).skipped == 2


def test_a_world_file_edited_so_its_trials_change_is_named_as_changed(tmp_path):
    """An audit (session 32): a world file edited to invalid JSON, or to another family, changes its trials' specs
    when the rerun builds them again, and the refusal spoke of a 'family' difference at a trial number.  The edit
    is the reason, so the file is named as changed (the specs are compared after the files' hashes)."""
    folder = write_worlds(tmp_path / "in", 2)
    config = SweepConfig(worlds_dir=str(folder), count=1)
    out = tmp_path / "out"
    run_sweep(build_specs(config), out, jobs=1, runner=fake_runner, progress=False)
    edited = folder / "w01.json"
    original = edited.read_text()
    for text in ('{"broken": ', json.dumps({**json.loads(original), "family": "another"})):
        edited.write_text(text)
        with pytest.raises(SweepError, match=rf"{edited} changed since the sweep in .* began") as caught:
            run_sweep(build_specs(config), out, jobs=1, runner=fake_runner, progress=False)
        assert "family" not in str(caught.value)
    edited.write_text(original)
    (folder / "w02.json").write_text(original)  # a file added: a different trial list, said as before
    with pytest.raises(SweepError, match=r"holds a different sweep \(2 stored trials, 3 requested"):
        run_sweep(build_specs(config), out, jobs=1, runner=fake_runner, progress=False)


def test_a_sweep_whose_mesh_file_changed_is_not_resumed(tmp_path):
    """A mesh is part of its world: an audit (session 29) shrank and moved a world's STL between two runs of a
    sweep, and the rerun went on: one world name, a collision and a success from two different meshes.  The
    mesh's SHA-256 is stored beside its world's (by its resolved path) and checked the same way."""
    folder = write_worlds(tmp_path / "in", 1)
    (folder / "parts").mkdir()
    mesh = folder / "parts" / "box.stl"
    mesh.write_bytes(b"solid a\nendsolid a\n")
    doc = json.loads((folder / "w00.json").read_text())
    doc["obstacles"] = [{"type": "mesh", "path": "parts/box.stl", "position": [0, 0, 0]},
                        {"type": "mesh", "path": "parts/missing.stl", "position": [0, 0, 0]}]
    (folder / "w00.json").write_text(json.dumps(doc))
    specs = build_specs(SweepConfig(worlds_dir=str(folder), count=2))
    out = tmp_path / "out"
    run_sweep(specs[:1], out, jobs=1, runner=fake_runner, progress=False)  # a first part, as if interrupted
    stored = json.loads((out / "sweep.json").read_text())["world_files"]
    assert stored[str(mesh.resolve())] == sweep.hashlib.sha256(mesh.read_bytes()).hexdigest()
    assert stored[str((folder / "parts" / "missing.stl").resolve())] is None
    original = mesh.read_bytes()
    mesh.write_bytes(b"solid b\nendsolid b\n")
    with pytest.raises(SweepError, match=r"box\.stl changed since the sweep in .* began"):
        run_sweep(specs[:1], out, jobs=1, runner=fake_runner, progress=False)
    mesh.write_bytes(original)
    assert run_sweep(specs[:1], out, jobs=1, runner=fake_runner, progress=False).skipped == 1


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_mesh_path_that_is_a_fifo_is_not_read_when_hashing(tmp_path):
    """Hashing read every mesh path a world names: a FIFO blocked the sweep before any check (a review)."""
    folder = write_worlds(tmp_path / "in", 1)
    os.mkfifo(folder / "pipe.stl")
    doc = json.loads((folder / "w00.json").read_text())
    doc["obstacles"] = [{"type": "mesh", "path": "pipe.stl"}]
    (folder / "w00.json").write_text(json.dumps(doc))
    specs = build_specs(SweepConfig(worlds_dir=str(folder)))
    found: dict = {}
    worker = threading.Thread(target=lambda: found.update(sweep._world_hashes(specs)), daemon=True)
    worker.start()
    worker.join(10.0)
    assert not worker.is_alive(), "hashing blocked on the FIFO"
    assert found[str((folder / "pipe.stl").resolve())] is None and len(found[str(folder / "w00.json")]) == 64


def test_a_field_absent_from_one_trial_is_named_as_absent():
    """A key missing on one side and None on the other compared equal, leaving the refusal naming nothing."""
    assert sweep._differences({"a": 1, "world_seed": None}, {"a": 1}) == "world_seed: stored None, requested absent"


def test_a_different_sweep_is_refused_naming_what_differs(tmp_path):
    """The refusal names the fields of the first trial that differ (it once cut both trials to 160 characters,
    which hid the seed a user had changed)."""
    folder = write_worlds(tmp_path / "in", 2)
    out = tmp_path / "out"
    run_sweep(build_specs(SweepConfig(worlds_dir=str(folder), seed=0)), out, jobs=1, runner=fake_runner,
              progress=False)
    with pytest.raises(SweepError, match=r"first difference at trial 0: seed: stored \d+, requested \d+\)"):
        run_sweep(build_specs(SweepConfig(worlds_dir=str(folder), seed=1)), out, jobs=1, runner=fake_runner,
                  progress=False)


def test_a_sweep_of_more_than_a_million_trials_is_refused_before_it_is_listed(tmp_path, capsys):
    """--count 100000000 ran out of memory before the first trial; 1,000,000 is the bound."""
    from navstack.sweep import MAX_TRIALS

    with pytest.raises(SweepError, match="gives 2,000,000 trials, more than the 1,000,000"):
        build_specs(SweepConfig(families=("truss",), count=MAX_TRIALS, controllers=("slither", "tip-only")))
    assert len(build_specs(SweepConfig(worlds_dir=str(write_worlds(tmp_path / "in", 2)), count=3))) == 6
    folder = write_worlds(tmp_path / "in2", 2)
    with pytest.raises(SweepError, match="more than the 1,000,000"):
        build_specs(SweepConfig(worlds_dir=str(folder), count=MAX_TRIALS // 2 + 1))
    assert main(["trials", "--generate", "truss", "--count", "100000000", "--out", str(tmp_path / "o")]) == 2
    assert "more than the 1,000,000 one sweep may hold" in capsys.readouterr().err


def test_resume_refuses_a_line_of_another_sweep_configuration(tmp_path):
    """A line whose trial_id is in the sweep but whose seed, world or method is another's (a line of the same
    worlds run with another --seed, or an edited line) is not counted as that trial: it would be reported as a
    result of this sweep, and its own trial never run (a review: a --seed 1 line in a --seed 0 sweep, and a
    slither line edited to say tip-only, were both taken as finished and reported)."""
    folder = write_worlds(tmp_path / "in", 2)
    specs0 = build_specs(SweepConfig(worlds_dir=str(folder), seed=0))
    specs1 = build_specs(SweepConfig(worlds_dir=str(folder), seed=1))
    assert [s.trial_id for s in specs0] == [s.trial_id for s in specs1]
    run_sweep(specs0, tmp_path / "s0", jobs=1, runner=fake_runner, progress=False)
    run_sweep(specs1, tmp_path / "s1", jobs=1, runner=fake_runner, progress=False)
    lines0 = (tmp_path / "s0" / "results.jsonl").read_text().splitlines(keepends=True)
    lines1 = (tmp_path / "s1" / "results.jsonl").read_text().splitlines(keepends=True)
    mixed = _partial_copy(tmp_path / "s0", tmp_path / "mixed", [lines0[0], lines1[1]])
    with pytest.raises(SweepError, match=r"results\.jsonl, line 2: not a line of this sweep: 'seed' is"):
        run_sweep(specs0, mixed, jobs=1, runner=fake_runner, progress=False)
    edited = _partial_copy(tmp_path / "s0", tmp_path / "edited",
                           [lines0[0].replace('"controller": "slither"', '"controller": "tip-only"')])
    with pytest.raises(SweepError, match=r"line 1: not a line of this sweep: 'controller' is 'tip-only'"):
        run_sweep(specs0, edited, jobs=1, runner=fake_runner, progress=False)
    # a line report would refuse (a mistyped field) is no finished trial either (a review: resume took it, then
    # report refused the folder)
    typed = _partial_copy(tmp_path / "s0", tmp_path / "typed",
                          [re.sub(r'"steps": (\d+)', r'"steps": "\1"', lines0[0])])
    with pytest.raises(SweepError, match=r"line 1: field 'steps' must be an integer >= 0 or null, got '\d+'; remove"):
        run_sweep(specs0, typed, jobs=1, runner=fake_runner, progress=False)
    # a finished trial recorded twice is refused, not silently deduplicated (which line is the trial's?)
    twice = _partial_copy(tmp_path / "s0", tmp_path / "twice", [lines0[0], lines0[0]])
    with pytest.raises(SweepError, match=r"results\.jsonl, line 2: trial_id '[^']+' recorded twice"):
        run_sweep(specs0, twice, jobs=1, runner=fake_runner, progress=False)
    # the sweep's own lines still resume
    own = _partial_copy(tmp_path / "s0", tmp_path / "own", lines0[:1])
    summary = run_sweep(specs0, own, jobs=1, runner=fake_runner, progress=False)
    assert summary.skipped == 1 and summary.complete
    assert without_wall_time(lines_of(own / "results.jsonl")) == \
        without_wall_time(lines_of(tmp_path / "s0" / "results.jsonl"))


def test_a_world_file_name_that_is_not_utf8_is_refused_naming_it(tmp_path):
    """An audit (session 33): a file named b'w\\xff\\xfe.json' gave lines whose trial_id held lone surrogates
    (jq showed U+FFFD; strict JSON readers refuse them)."""
    folder = write_worlds(tmp_path / "in", 1)
    try:
        (folder / os.fsdecode(b"w\xff\xfe.json")).write_text((folder / "w00.json").read_text())
    except (OSError, UnicodeError):
        pytest.skip("this file system refuses names that are not UTF-8")
    with pytest.raises(SweepError, match=r"b'.*w\\xff\\xfe\.json': the path is not valid UTF-8"):
        build_specs(SweepConfig(worlds_dir=str(folder)))
