"""What a newcomer sees of the command line: help texts, --version, what `run --render` wrote."""

from __future__ import annotations

import json

import pytest

import navstack
from navstack.cli import main
from navstack.registry import FAMILIES
from navstack.truss import paper_truss_world


def help_text(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as ei:
        main([*argv, "--help"])
    assert ei.value.code == 0
    return capsys.readouterr().out


def test_top_level_help_is_plain_text(capsys):
    out = help_text(capsys)
    assert "``" not in out and ":func:" not in out
    assert out.count("navstack: sensor-based slithering control") == 1
    assert "exit status: 0" in out and "2 bad input" in out and "1 internal error" in out
    for command in ("demo", "run", "check-world", "generate", "trials", "report", "model"):
        assert f"\n    {command}" in out


def test_version(capsys):
    with pytest.raises(SystemExit) as ei:
        main(["--version"])
    assert ei.value.code == 0
    assert capsys.readouterr().out.strip() == f"navstack {navstack.__version__}"


@pytest.mark.parametrize("command", ["generate", "trials"])
def test_help_lists_the_families_with_their_difficulty(capsys, command):
    out = " ".join(help_text(capsys, command).split())  # argparse may wrap lines
    for entry in FAMILIES.values():
        assert f"{entry.name} {entry.summary}" in out
        assert f"difficulty: {entry.difficulty}" in out


def test_generate_refuses_an_unknown_family(capsys, tmp_path):
    assert main(["generate", "trusss", "--seed", "1", "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err
    assert "trusss" in err and "truss" in err


@pytest.mark.parametrize("seed", ["-1", str(2**63), "99999999999999999999999", "1.5"])
def test_a_seed_outside_0_to_int64_is_bad_input(capsys, tmp_path, seed):
    """Seeds are written to result.json, results.jsonl and world files, read as int64 (or doubles) elsewhere: a
    77-bit seed was taken and written (a review's case, session 40)."""
    with pytest.raises(SystemExit) as ei:
        main(["run", "w.json", "--out", "o", "--seed", seed])
    assert ei.value.code == 2
    assert f"expected an integer from 0 to 2**63 - 1, got '{seed}'" in capsys.readouterr().err
    if seed != "1.5":
        assert main(["generate", "truss", "--seed", seed, "--out", str(tmp_path / "x.json")]) == 2
        assert "seed must be an integer from 0 to 2**63 - 1" in capsys.readouterr().err
        assert not (tmp_path / "x.json").exists()
        assert main(["trials", "--generate", "truss", "--seed", seed, "--out", str(tmp_path / "s")]) == 2
        assert "seed must be an integer from 0 to 2**63 - 1" in capsys.readouterr().err


def test_the_largest_seed_is_taken_and_one_more_is_not():
    from navstack.generate import generate_world
    from navstack.trial import TrialInputError, run_trial

    assert generate_world("truss", 2**63 - 1).extra["generator"]["seed"] == 2**63 - 1
    with pytest.raises(TrialInputError, match="seed must be an integer from 0 to 2"):
        run_trial("w.json", seed=2**63)


def test_run_render_says_it_wrote_scene_png(tmp_path, capsys):
    world = tmp_path / "w.json"
    world.write_text(json.dumps({**paper_truss_world(), "time_limit": 0.2}))
    out = tmp_path / "out"
    assert main(["run", str(world), "--out", str(out), "--planner", "scripted", "--render"]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out / 'result.json'}, trajectory.npz, world.json, scene.png" in printed
    assert (out / "scene.png").stat().st_size > 0


def test_a_reader_that_closes_the_pipe_ends_the_command_quietly(tmp_path):
    """Output into a pipe nobody reads: no 'internal error' and no traceback, exit 141 (128 + SIGPIPE)."""
    import pathlib
    import subprocess
    import sys

    script = ("import sys\nfrom navstack.cli import main\nimport time\ntime.sleep(0.5)\n"
              "sys.exit(main(['check-world'] + sys.argv[1:]))\n")
    worlds = sorted(str(p) for p in (pathlib.Path(__file__).parent.parent / "worlds").glob("*.json"))[:3]
    proc = subprocess.Popen([sys.executable, "-c", script, *worlds], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # before the command writes its first line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert "error" not in err and "Traceback" not in err


@pytest.mark.parametrize("argv", [["run", "worlds/paper_truss.json", "--out", ""], ["demo", "--out", " "],
                                  ["trials", "--generate", "truss", "--out", ""],
                                  ["trials", "--worlds", "", "--out", "x"], ["generate", "truss", "--out", ""],
                                  ["urdf", "--out", ""], ["animate", "x", "--out", ""]])
def test_an_empty_output_or_worlds_path_is_an_argument_error(argv, capsys):
    """An empty --out wrote the run's files into the current folder without a word."""
    with pytest.raises(SystemExit) as ei:
        main(argv)
    assert ei.value.code == 2
    assert "expected a path, got" in capsys.readouterr().err


def test_a_broken_pipe_that_is_not_standard_output_is_an_internal_error(monkeypatch, capsys):
    import navstack.cli as cli

    def broken(args):
        raise BrokenPipeError(32, "Broken pipe")  # e.g. a worker's pipe, while stdout is fine

    monkeypatch.setattr(cli, "_check_world", broken)
    assert main(["check-world", "worlds/paper_truss.json"]) == 1
    assert "internal error: BrokenPipeError" in capsys.readouterr().err


def test_control_characters_in_a_world_name_do_not_reach_the_terminal(tmp_path, capsys):
    """A name with an escape sequence (it could clear or rewrite the screen) is shown escaped."""
    from _worlds import world_data

    data = world_data(time_limit=0.1)
    data["name"] = "w\x1b[2J\x07x"
    path = tmp_path / "w.json"
    path.write_text(json.dumps(data))
    assert main(["check-world", str(path)]) == 0
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--planner", "scripted"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out
    assert out.count("w\\x1b[2J\\x07x") == 2


@pytest.mark.parametrize("argv, words", [
    (["view", "x", "--port", "70000"], "expected a port number from 0 (any free one) to 65535"),
    (["view", "x", "--port", "-1"], "expected a port number from 0 (any free one) to 65535"),
    (["view", "x", "--host", ""], "expected an address to listen on"),
    (["view", "x", "--host", "999.1.1.1"], "cannot listen on '999.1.1.1'"),
])
def test_view_refuses_a_port_or_host_it_cannot_serve_on(argv, words, capsys):
    """Each of these hung (the server thread failed, the command slept on), or, for '', listened on every
    interface while printing 127.0.0.1."""
    with pytest.raises(SystemExit) as ei:
        main(argv)
    assert ei.value.code == 2 and words in capsys.readouterr().err


def test_demo_checks_every_output_folder_before_simulating(tmp_path, capsys, monkeypatch):
    import navstack.trial

    monkeypatch.setattr(navstack.trial, "_Simulation", lambda *a, **k: (_ for _ in ()).throw(AssertionError("ran")))
    (tmp_path / "tip-only").write_text("a file where the second controller's folder goes")
    assert main(["demo", "--out", str(tmp_path), "--no-animate"]) == 2
    assert "tip-only" in capsys.readouterr().err and not (tmp_path / "slither" / "result.json").exists()


def test_run_and_demo_print_why_a_planner_gave_up(capsys):
    """The field planner logs why it stalls (its stall_reason); ``navstack run`` and ``demo`` print that as it
    happens (above the trial's summary), once however often they are set up."""
    import logging

    from navstack import cli

    log = logging.getLogger("navstack.planner")
    before = list(log.handlers), log.level
    try:
        cli._show_planner_notes()
        cli._show_planner_notes()
        logging.getLogger("navstack.planner.field").info("stalled at %s", "goals[0] (of 1): boxed in")
        assert capsys.readouterr().out == "  planner: stalled at goals[0] (of 1): boxed in\n"
    finally:
        log.handlers[:] = before[0]
        log.setLevel(before[1])


def test_ctrl_c_before_the_command_begins_is_interrupted_not_a_traceback(capsys, monkeypatch):
    """Ctrl-C while the parser or the simulator's modules load printed a traceback and exited -2 (an audit,
    session 29); it is 'interrupted' and 130, as during a command."""
    import navstack.cli as cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert main(["model"]) == 130
    assert capsys.readouterr().err == "navstack: interrupted\n"


def test_urdf_to_an_unwritable_path_is_bad_input_naming_it(capsys, tmp_path):
    """A write error named neither the option nor the file (an audit: '[Errno 28] No space left on device')."""
    assert main(["urdf", "--out", str(tmp_path)]) == 2  # a directory
    err = capsys.readouterr().err
    assert err.startswith(f"navstack urdf: error: --out: cannot write {tmp_path}: ")


def test_check_world_shows_a_file_name_with_control_characters_escaped(capsys, tmp_path):
    """A file name holding a terminal escape sequence was echoed raw (an audit); it is shown escaped."""
    from pathlib import Path

    folder = tmp_path / "odd\x1b[31m"
    folder.mkdir()
    world = folder / "w.json"
    world.write_text((Path(navstack.__file__).parents[1] / "worlds" / "u_trap.json").read_text())
    assert main(["check-world", str(world)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "odd\\x1b[31m" in out and ": ok (u-trap:" in out
    assert main(["check-world", str(folder / "missing.json")]) == 2  # the error line too (a review)
    err = capsys.readouterr().err
    assert "\x1b" not in err and "odd\\x1b[31m" in err
