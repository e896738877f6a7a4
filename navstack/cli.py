"""The ``navstack`` command line.

Exit status (interfaces.md section 3): 0 when the command ran to an outcome (a trial that failed is still
an outcome), 2 for bad input (the message says what and where), 1 for an internal error.  For ``run`` and
``demo`` that means: a world file that is invalid, too large, not a regular file, has a mesh outside its
folder, a goal out of reach or a robot starting in contact with an obstacle, or an ``--out`` that cannot
be written, all exit 2 before anything is simulated; an exception inside the simulation is recorded in
``result.json`` as reason ``error`` (interfaces.md) and exits 1, as does any other exception.  Output into
a pipe whose reader has gone (``navstack run ... | head -1``) ends the command quietly with 141, as a Unix
tool killed by SIGPIPE (what it wrote to files before that is complete).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path
from typing import Any

from navstack import __version__

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT = 0, 1, 2
EXIT_BROKEN_PIPE = 141
"""128 + SIGPIPE: what a shell reports for a Unix tool whose reader closed the pipe (``yes | head -1``)."""

DESCRIPTION = "navstack: sensor-based slithering control of the JPL serpentine robot, simulated in PyBullet."
EPILOG = """exit status: 0 the command ran to an outcome (a failed trial is an outcome), 2 bad input (the
message names the file, the JSON path and what was expected), 1 internal error, 141 the reader of the
output closed the pipe.

Start with 'navstack demo'; 'navstack COMMAND --help' describes a command."""
BYTES_PER_MB = 1024 * 1024


class BadInput(Exception):
    """A user error that the CLI reports in one line with exit status 2."""


def _shown(text: str) -> str:
    """``text`` from a world file as it may reach a terminal: control characters (an escape sequence could
    rewrite the screen) written as Python escapes (``\\x1b``), everything else as it is."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def _mm(value: float | None) -> str:
    """A length [m] in millimetres; None (no obstacle in the world): ``none``."""
    return "none" if value is None else f"{value * 1e3:.1f} mm"


def _summary(result) -> str:
    m = result.metrics
    return (
        f"{_shown(result.world)}: {'SUCCESS' if result.success else 'FAILURE'} ({result.reason}), "
        f"goals {result.goals_reached}, sim {result.sim_time:.2f} s in {result.steps} steps, "
        f"wall {result.wall_time:.1f} s\n"
        f"  tip_error_max {m['tip_error_max'] * 1e3:.2f} mm, slither_deviation_max "
        f"{m['slither_deviation_max'] * 1e3:.3f} mm, min_clearance {_mm(m['min_clearance'])}, "
        f"contacts {m['contacts']}"
        + (f"\n  the robot touched itself in {result.self_contacts} control steps (least distance "
           f"{result.self_clearance})" if result.self_contacts else "")
    )


def _load(args: argparse.Namespace, path: str):
    """The world file at ``path`` with the ``--allow-mesh-outside`` / ``--max-world-mb`` options."""
    from navstack.world import load_world

    return load_world(path, allow_mesh_outside=args.allow_mesh_outside,
                      max_bytes=int(args.max_world_mb * BYTES_PER_MB))


def _animation_config(args: argparse.Namespace):
    """An :class:`~navstack.animate.AnimationConfig` from the ``animate`` options (defaults elsewhere)."""
    from navstack.animate import AnimationConfig

    kw = {}
    for key in ("fps", "speed", "view"):
        if getattr(args, key, None) is not None:
            kw[key] = getattr(args, key)
    if getattr(args, "size", None):
        w, sep, h = args.size.lower().partition("x")
        if not (sep and w.isdigit() and h.isdigit()):
            raise BadInput(f"--size must be WIDTHxHEIGHT in pixels (e.g. 768x432), got {args.size!r}")
        kw["width"], kw["height"] = int(w), int(h)
    if getattr(args, "eye", None) is not None or getattr(args, "target", None) is not None:
        kw["eye"] = tuple(args.eye) if args.eye is not None else None
        kw["target"] = tuple(args.target) if args.target is not None else None
    return AnimationConfig(**kw)


def _animate_and_report(run_dir, out=None, config=None, world=None, indent: str = "") -> None:
    from navstack.animate import animate_stats

    s = animate_stats(run_dir, out, config, world)
    c = s.config
    print(f"{indent}wrote {s.path}: {s.frames} frames {c.width}x{c.height} at {c.fps:g} fps "
          f"(x{c.speed:g} real time), animated in {s.seconds:.1f} s")


def _given_world(args: argparse.Namespace, prefix: str):
    """``--world`` of animate / view loaded with the world options (None without it), with a warning on
    stderr where the run folder says its trial ran another world (:func:`navstack.rundir.other_world`)."""
    from navstack.rundir import other_world

    if args.world is None:
        return None
    world = _load(args, args.world)
    why = other_world(args.run_dir, world)
    if why:
        print(f"{prefix}: warning: {why}", file=sys.stderr)
    return world


def _animate(args: argparse.Namespace) -> int:
    _animate_and_report(args.run_dir, args.out, _animation_config(args), _given_world(args, "navstack animate"))
    return EXIT_OK


def _view(args: argparse.Namespace) -> int:
    from navstack.viewer import serve

    try:
        return serve(args.run_dir, host=args.host, port=args.port, world=_given_world(args, "navstack view"))
    except ImportError as exc:  # the optional extra is missing: say how to get it
        print(f"navstack view: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


class _PlannerNotes(logging.Handler):
    """The planners' INFO lines, indented, on whatever standard output is when each comes."""

    def emit(self, record: logging.LogRecord) -> None:
        print(f"  planner: {record.getMessage()}", file=sys.stdout)


def _show_planner_notes() -> None:
    """Print the planners' INFO lines (why a planner gave up) to standard output, once per process; library
    use and sweep workers keep logging's defaults (not shown)."""
    log = logging.getLogger("navstack.planner")
    if not any(isinstance(h, _PlannerNotes) for h in log.handlers):
        log.addHandler(_PlannerNotes())
        log.setLevel(logging.INFO)


def _run(args: argparse.Namespace) -> int:
    from navstack.trial import run_trial

    _show_planner_notes()
    # bad input raises before anything is simulated: WorldError, TrialInputError (an unwritable --out)
    config = _settings(args.settings)
    world = _load(args, args.world)
    _warn_blocked_goals("navstack run", world, field=args.planner == "field")
    result = run_trial(world, controller=args.controller, planner=args.planner, seed=args.seed,
                       out_dir=args.out, render=args.render, config=config)
    out = Path(args.out)
    print(_summary(result))
    print(f"wrote {out / 'result.json'}, trajectory.npz, world.json"
          + (", scene.png" if args.render and result.reason != "error" else ""))
    if result.reason == "error":
        print(f"navstack run: internal error during the simulation (recorded in result.json as reason "
              f"\"error\"): {result.error}", file=sys.stderr)
        return EXIT_INTERNAL
    if args.animate:
        _animate_and_report(args.out)
    return EXIT_OK


def _settings(path: str | None):
    """The :class:`~navstack.trial.TrialConfig` of a ``--settings`` file (``None`` without one); bad input ->
    :class:`BadInput`."""
    if path is None:
        return None
    from navstack.settings import SettingsError, load_settings

    try:
        return load_settings(path)
    except SettingsError as exc:
        raise BadInput(str(exc)) from None


def _show_settings(args: argparse.Namespace) -> int:
    """``navstack settings [FILE]``: every setting (the defaults, or what FILE makes of them) as JSON."""
    import json

    from navstack.settings import settings_to_dict
    from navstack.trial import TrialConfig

    config = _settings(args.file) or TrialConfig()
    print(json.dumps(settings_to_dict(config), indent=2))
    return EXIT_OK


def _demo(args: argparse.Namespace) -> int:
    from navstack.trial import check_out_dir, run_trial
    from navstack.truss import paper_truss_world
    from navstack.world import world_from_dict

    world = world_from_dict(paper_truss_world())
    _show_planner_notes()
    controllers = list(dict.fromkeys(args.controller or ["slither", "tip-only"]))  # each once
    for controller in controllers:  # every output folder checked before anything is simulated
        check_out_dir(Path(args.out) / controller)
    print(f"navstack demo: {world.description}")
    status = EXIT_OK
    for controller in controllers:
        out = Path(args.out) / controller
        result = run_trial(world, controller=controller, planner=args.planner, seed=args.seed, out_dir=out, render=True)
        print(f"[{controller}] " + _summary(result))
        print(f"  wrote {out}/result.json, trajectory.npz, world.json, scene.png")
        if result.reason == "error":
            print(f"navstack demo: internal error during the simulation: {result.error}", file=sys.stderr)
            status = EXIT_INTERNAL
        elif not args.no_animate:
            _animate_and_report(out, indent="  ")
    return status


def _warn_blocked_goals(prefix: str, world, field: bool = True) -> None:
    """A warning on stderr for each goal that cannot be reached without contact, and (``field``: for the field
    planner) for each that leaves the tip less room than the planner's least margin (:mod:`navstack.goal_check`)."""
    from navstack.goal_check import blocked_goals, tight_goals
    from navstack.planner.field import FieldPlannerConfig

    for blocked in blocked_goals(world):
        print(f"{prefix}: warning: {blocked.message(world)}", file=sys.stderr)
    if field:
        for tight in tight_goals(world, FieldPlannerConfig().least_margin):
            print(f"{prefix}: warning: {tight.message(world)}", file=sys.stderr)


def _check_world(args: argparse.Namespace) -> int:
    from navstack.trial import check_reach, check_start
    from navstack.world import WorldError

    status = EXIT_OK
    for path in args.files:
        try:
            w = _load(args, path)
            check_reach(w)
            check_start(w)
        except WorldError as exc:
            print(f"navstack check-world: error: {_shown(str(exc))}", file=sys.stderr)
            status = EXIT_BAD_INPUT
            continue
        moving = sum(getattr(o, "motion", None) is not None for o in w.obstacles)
        _warn_blocked_goals(f"navstack check-world: {_shown(path)}", w)
        movers = f" ({moving} moving)" if moving else ""
        print(f"{_shown(path)}: ok ({_shown(w.name)}: {len(w.obstacles)} obstacles{movers}, "
              f"{len(w.goals)} goals, time limit {w.time_limit:g} s, robot clear of every obstacle at t = 0)")
    return status


def _generate(args: argparse.Namespace) -> int:
    from navstack.generate import generate_world
    from navstack.world import save_world

    world = generate_world(args.family, seed=args.seed, difficulty=args.difficulty, retract=args.retract)
    save_world(world, args.out)
    print(f"wrote {args.out} ({world.name}: {len(world.obstacles)} obstacles, {len(world.goals)} goals)")
    return EXIT_OK


def _trials(args: argparse.Namespace) -> int:
    from navstack.sweep import main_trials

    return main_trials(args)


def _report(args: argparse.Namespace) -> int:
    from navstack.report import run_from_args

    return run_from_args(args)


def _compare(args: argparse.Namespace) -> int:
    from navstack.compare import run_from_args

    return run_from_args(args)


def _model(args: argparse.Namespace) -> int:
    import numpy as np

    from navstack import jpl

    robot = jpl.jpl_serpentine()
    print("JPL serpentine robot (Figure 2, metres/radians): i, alpha_{i-1}, a_{i-1}, d_i, theta_i, joint, limits")
    for i in range(len(robot.alpha)):
        kind = "fixed" if i >= robot.n else ("prismatic" if robot.prismatic[i] else "revolute")
        lim = "" if i >= robot.n else f"[{robot.lower[i]:+.3f}, {robot.upper[i]:+.3f}]"
        print(
            f"{i + 1:3d} {robot.alpha[i]:+.4f} {robot.a[i]:.4f} {robot.d[i]:.4f} {robot.theta[i]:+.4f} {kind:9s} {lim}"
        )
    F = robot.frames(robot.q_default)
    print("default posture q0 =", np.round(robot.q_default, 4).tolist())
    print("tip at q0 (base frame):", np.round(F[21, :3, 3], 4).tolist())
    return EXIT_OK


def _seed(text: str) -> int:
    from navstack.validate import is_seed

    try:
        value = int(text)
    except ValueError:
        value = -1
    if not is_seed(value):
        raise argparse.ArgumentTypeError(f"expected an integer from 0 to 2**63 - 1, got {text!r}")
    return value


def _port(text: str) -> int:
    """``view --port``: 0 (any free port) .. 65535 (a port outside made the server thread fail and the
    command hang)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"expected a port number from 0 (any free one) to 65535, got {text!r}")
    return value


def _host(text: str) -> str:
    """``view --host``: an address this machine has (an empty one listened on every interface while the
    command printed 127.0.0.1; one it cannot bind made the command hang)."""
    import socket

    if not text.strip():
        raise argparse.ArgumentTypeError("expected an address to listen on (0.0.0.0 for every interface), got ''")
    try:
        for family, kind, proto, _, address in socket.getaddrinfo(text, 0, type=socket.SOCK_STREAM):
            with socket.socket(family, kind, proto) as probe:
                probe.bind(address)
                return text
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"cannot listen on {text!r} ({exc})") from None
    raise argparse.ArgumentTypeError(f"cannot listen on {text!r} (no address)")


def nonempty_path(text: str) -> str:
    """An ``--out`` / ``--worlds`` path: an empty one would silently mean the current folder."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a path, got {text!r} (for the current folder, write '.')")
    return text


def _positive_mb(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value * BYTES_PER_MB >= 1 and value * BYTES_PER_MB < 2**62):  # at least a byte (1e-9 was 0 bytes)
        raise argparse.ArgumentTypeError(f"expected a number of megabytes from {1 / BYTES_PER_MB:.3g} (one byte) "
                                         f"to {2**62 / BYTES_PER_MB:.3g}, got {text!r}")
    return value


def _families_help() -> str:
    """The world families with their one-line summaries and difficulty knobs (from the registry)."""
    from navstack.registry import FAMILIES

    lines = ["families, and what --difficulty (0 easy .. 1 hard) changes in each:"]
    for e in FAMILIES.values():
        lines += [f"  {e.name:16s}{e.summary}", f"  {'':16s}difficulty: {e.difficulty}"]
    return "\n".join(lines)


def _add_world_options(parser: argparse.ArgumentParser) -> None:
    from navstack.world import MAX_WORLD_BYTES

    parser.add_argument("--allow-mesh-outside", action="store_true",
                        help="accept mesh paths that are absolute or lead outside the world file's folder "
                             "(refused by default)")
    parser.add_argument("--max-world-mb", type=_positive_mb, default=MAX_WORLD_BYTES / BYTES_PER_MB,
                        metavar="MB", help=f"refuse world files larger than this (default "
                                           f"{MAX_WORLD_BYTES / BYTES_PER_MB:g} MB)")


def _urdf(args: argparse.Namespace) -> int:
    from navstack import jpl
    from navstack.urdf import UrdfOptions

    opts = UrdfOptions(serpentine_radius=args.serpentine_radius, arm_radius=args.arm_radius)
    text = jpl.jpl_serpentine().to_urdf(opts)
    if args.out is None:
        sys.stdout.write(text)
        return EXIT_OK
    try:
        Path(args.out).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise BadInput(f"--out: cannot write {args.out}: {exc.strerror or exc}") from exc
    print(f"wrote {args.out} (20 joints, links dh0..dh21; PyBullet: loadURDF(..., useFixedBase=True, "
          "flags=URDF_USE_INERTIA_FROM_FILE | URDF_USE_IMPLICIT_CYLINDER))")
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="navstack", description=DESCRIPTION, epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"navstack {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_trial_commands(sub)
    _add_picture_commands(sub)
    _add_world_commands(sub)
    _add_sweep_commands(sub)
    _add_robot_commands(sub)
    return p


def _add_trial_commands(sub: Any) -> None:
    """``demo`` and ``run``."""
    from navstack.registry import controller_names, planner_names

    CONTROLLERS, PLANNERS = controller_names(), planner_names()
    d = sub.add_parser("demo", help="the paper's truss demo, headless (writes result.json, trajectory.npz, scene.png)")
    d.add_argument("--out", default="out/demo", type=nonempty_path, help="output folder (default: out/demo)")
    d.add_argument("--planner", choices=PLANNERS, default="field")
    d.add_argument(
        "--controller",
        action="append",
        choices=CONTROLLERS,
        help="repeatable (default: slither, then the tip-only baseline)",
    )
    d.add_argument("--seed", type=_seed, default=0)
    d.add_argument("--no-animate", action="store_true", help="skip the animation of each trial (animation.mp4)")
    d.set_defaults(func=_demo)

    st = sub.add_parser("settings", help="print every trial setting with its default, or what a --settings file "
                                         "makes of them, as JSON")
    st.add_argument("file", nargs="?", type=nonempty_path,
                    help="a settings file to check and apply (a JSON object naming only the settings to change)")
    st.set_defaults(func=_show_settings)

    r = sub.add_parser("run", help="run one closed-loop trial headless")
    r.add_argument("world", help="a navstack-world/1 JSON file")
    r.add_argument("--out", required=True, type=nonempty_path,
                   help="output folder for result.json and trajectory.npz")
    r.add_argument("--controller", choices=CONTROLLERS, default="slither")
    r.add_argument("--planner", choices=PLANNERS, default="field")
    r.add_argument("--seed", type=_seed, default=0, help="seed of the sensor noise (default 0)")
    r.add_argument("--render", action="store_true", help="also write scene.png (TinyRenderer)")
    r.add_argument("--settings", metavar="FILE", type=nonempty_path,
                   help="a JSON file of settings to change (see: navstack settings); the run writes settings.json")
    _add_world_options(r)
    r.add_argument("--animate", action="store_true", help="also write animation.mp4 (see: navstack animate)")
    r.set_defaults(func=_run)


def _add_picture_commands(sub: Any) -> None:
    """``animate`` and ``view``."""
    a = sub.add_parser("animate", help="animate a run folder (trajectory.npz + world.json) to MP4 or GIF")
    a.add_argument("run_dir", help="a folder written by navstack run --out (or demo, or a sweep's kept trial)")
    a.add_argument("--out", type=nonempty_path, help="file to write, .mp4 or .gif (default: RUN_DIR/animation.mp4)")
    a.add_argument("--fps", type=float, help="frames per second (default 15)")
    a.add_argument("--speed", type=float, help="simulated seconds per second of video (default 1: real time)")
    a.add_argument("--size", help="WIDTHxHEIGHT in pixels, multiples of 16 (default 768x432)")
    a.add_argument("--view", choices=("auto", "front", "side", "top"),
                   help="camera direction (default auto: chosen from the trajectory)")
    a.add_argument("--eye", type=float, nargs=3, metavar=("X", "Y", "Z"), help="camera position (world, m)")
    a.add_argument("--target", type=float, nargs=3, metavar=("X", "Y", "Z"), help="point looked at (world, m)")
    a.add_argument("--world", help="the world file, for run folders without world.json")
    _add_world_options(a)
    a.set_defaults(func=_animate)

    v = sub.add_parser("view", help="3D viewer of a run folder in the browser (needs: pip install 'navstack[viewer]')")
    v.add_argument("run_dir", help="a folder written by navstack run --out")
    v.add_argument("--port", type=_port, default=8080, help="local port (default 8080; the next free one if taken)")
    v.add_argument("--host", type=_host, default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only)")
    v.add_argument("--world", help="the world file, for run folders without world.json")
    _add_world_options(v)
    v.set_defaults(func=_view)


def _add_world_commands(sub: Any) -> None:
    """``check-world`` and ``generate``."""
    c = sub.add_parser("check-world", help="validate world files without running them (also: goals in reach, "
                                           "robot clear of every obstacle at the start)")
    c.add_argument("files", nargs="+")
    _add_world_options(c)
    c.set_defaults(func=_check_world)

    g = sub.add_parser("generate", help="write a randomized world of a family", epilog=_families_help(),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    g.add_argument("family", metavar="FAMILY", help="one of the families listed below")
    g.add_argument("--seed", type=int, required=True, help="the world's seed (same seed, same world)")
    g.add_argument("--difficulty", type=float, default=0.5, help="0 (easy) .. 1 (hard), default 0.5")
    g.add_argument("--retract", action=argparse.BooleanOptionalAction, default=None,
                   help='write "retract": true (back out to the start after the last goal); default: the '
                        "family's (true for dead-end only)")
    g.add_argument("--out", required=True, type=nonempty_path, help="world file to write")
    g.set_defaults(func=_generate)


def _add_sweep_commands(sub: Any) -> None:
    """``trials``, ``report`` and ``compare``."""
    t = sub.add_parser("trials", help="run many trials in parallel into DIR/results.jsonl (resumable)",
                       epilog=_families_help(), formatter_class=argparse.RawDescriptionHelpFormatter)
    from navstack.sweep import add_trials_arguments

    add_trials_arguments(t)
    t.set_defaults(func=_trials)

    rp = sub.add_parser("report", help="summarise DIR/results.jsonl into DIR/report.md and PNG plots")
    from navstack.report import add_arguments as add_report_arguments

    add_report_arguments(rp)
    rp.set_defaults(func=_report)

    cp = sub.add_parser("compare", help="compare the success rates of two sweeps (Markdown, paired where possible)")
    from navstack.compare import add_arguments as add_compare_arguments

    add_compare_arguments(cp)
    cp.set_defaults(func=_compare)


def _add_robot_commands(sub: Any) -> None:
    """``model`` and ``urdf``."""
    m = sub.add_parser("model", help="print the robot model (Figure 2 in metres) and the default posture")
    m.set_defaults(func=_model)

    u = sub.add_parser("urdf", help="write the robot as URDF (joint limits, capsule collision geometry, masses)")
    u.add_argument("--out", type=nonempty_path, help="URDF file to write (default: standard output)")
    u.add_argument("--serpentine-radius", type=float, default=0.025, help="serpentine capsule radius [m]")
    u.add_argument("--arm-radius", type=float, default=0.06, help="arm capsule radius [m]")
    u.set_defaults(func=_urdf)


def main(argv: list[str] | None = None) -> int:
    """The ``navstack`` command; returns its exit status (module docstring)."""
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before a command began: while the parser or the simulator's modules load
        print("navstack: interrupted", file=sys.stderr)
        return 130


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from navstack.trial import TrialInputError
    from navstack.world import WorldError

    name = f"navstack {args.command}"
    # for these commands every input is checked up front, so any other exception is internal
    checked = args.command in ("run", "demo", "check-world")
    try:
        return args.func(args)
    except (WorldError, BadInput, TrialInputError) as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError as exc:
        if _stdout_reader_gone():  # the reader of our output went away (`navstack run ... | head -1`)
            _silence_stdout()
            return EXIT_BROKEN_PIPE
        return _internal(name, exc, argv)  # some other pipe: an internal error
    except (ValueError, OSError) as exc:  # other commands: an unusable path or value given by the user
        if checked:
            return _internal(name, exc, argv)
        print(f"{name}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{name}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - internal error: exit 1 with a one-line message
        return _internal(name, exc, argv)


def _stdout_reader_gone() -> bool:
    """Whether standard output is a pipe whose reading end is closed (``poll`` reports an error on it)."""
    import select
    import stat

    try:
        fd = sys.stdout.fileno()
        if not stat.S_ISFIFO(os.fstat(fd).st_mode):
            return False
        poller = select.poll()
        poller.register(fd, select.POLLOUT)
        return any(events & (select.POLLERR | select.POLLHUP) for _, events in poller.poll(0))
    except (OSError, ValueError, AttributeError):  # no file descriptor (captured output), no poll
        return False


def _silence_stdout() -> None:
    """Point standard output at the null device, so the interpreter's last flush cannot fail again
    (the Python documentation's recipe for SIGPIPE)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def _internal(name: str, exc: BaseException, argv: list[str] | None) -> int:
    print(f"{name}: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
    if "--debug" in (argv or sys.argv):
        raise exc
    return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
