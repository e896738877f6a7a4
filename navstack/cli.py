"""The ``navstack`` command line.

Exit status (interfaces.md section 3): 0 when the command ran to an outcome
(a trial that failed is still an outcome), 2 for bad input (the message says
what and where), 1 for an internal error.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT = 0, 1, 2


class BadInput(Exception):
    """A user error that the CLI reports in one line with exit status 2."""


def _summary(result) -> str:
    m = result.metrics
    return (
        f"{result.world}: {'SUCCESS' if result.success else 'FAILURE'} ({result.reason}), "
        f"goals {result.goals_reached}, sim {result.sim_time:.2f} s in {result.steps} steps, "
        f"wall {result.wall_time:.1f} s\n"
        f"  tip_error_max {m['tip_error_max'] * 1e3:.2f} mm, slither_deviation_max "
        f"{m['slither_deviation_max'] * 1e3:.3f} mm, min_clearance {m['min_clearance'] * 1e3:.1f} mm, "
        f"contacts {m['contacts']}"
    )


def _run(args: argparse.Namespace) -> int:
    from navstack.trial import run_trial

    result = run_trial(
        args.world,
        controller=args.controller,
        planner=args.planner,
        seed=args.seed,
        out_dir=args.out,
        render=args.render,
    )
    print(_summary(result))
    if result.error:
        print(f"  error: {result.error}", file=sys.stderr)
    print(f"wrote {Path(args.out) / 'result.json'} and trajectory.npz")
    return EXIT_OK


def _demo(args: argparse.Namespace) -> int:
    from navstack.trial import run_trial
    from navstack.truss import paper_truss_world
    from navstack.world import world_from_dict

    world = world_from_dict(paper_truss_world())
    print(f"navstack demo: {world.description}")
    results = []
    for controller in args.controller or ["slither", "tip-only"]:
        out = Path(args.out) / controller
        result = run_trial(world, controller=controller, planner=args.planner, seed=args.seed, out_dir=out, render=True)
        print(f"[{controller}] " + _summary(result))
        print(f"  wrote {out}/result.json, trajectory.npz, scene.png")
        results.append(result)
    return EXIT_OK


def _check_world(args: argparse.Namespace) -> int:
    from navstack.trial import check_reach
    from navstack.world import WorldError, load_world

    status = EXIT_OK
    for path in args.files:
        try:
            w = load_world(path)
            check_reach(w)
        except (WorldError, ValueError, OSError) as exc:
            print(f"navstack check-world: error: {exc}", file=sys.stderr)
            status = EXIT_BAD_INPUT
            continue
        print(f"{path}: ok ({w.name}: {len(w.obstacles)} obstacles, {len(w.goals)} goals, time limit {w.time_limit} s)")
    return status


def _generate(args: argparse.Namespace) -> int:
    from navstack.generate import generate_world
    from navstack.world import save_world

    world = generate_world(args.family, seed=args.seed, difficulty=args.difficulty)
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


def build_parser() -> argparse.ArgumentParser:
    from navstack.registry import controller_names, planner_names

    CONTROLLERS, PLANNERS = controller_names(), planner_names()

    p = argparse.ArgumentParser(prog="navstack", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)

    d = sub.add_parser("demo", help="the paper's truss demo, headless (writes result.json, trajectory.npz, scene.png)")
    d.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    d.add_argument("--planner", choices=PLANNERS, default="field")
    d.add_argument(
        "--controller",
        action="append",
        choices=CONTROLLERS,
        help="repeatable (default: slither, then the tip-only baseline)",
    )
    d.add_argument("--seed", type=int, default=0)
    d.set_defaults(func=_demo)

    r = sub.add_parser("run", help="run one closed-loop trial headless")
    r.add_argument("world", help="a navstack-world/1 JSON file")
    r.add_argument("--out", required=True, help="output folder for result.json and trajectory.npz")
    r.add_argument("--controller", choices=CONTROLLERS, default="slither")
    r.add_argument("--planner", choices=PLANNERS, default="field")
    r.add_argument("--seed", type=int, default=0, help="seed of the sensor noise (default 0)")
    r.add_argument("--render", action="store_true", help="also write scene.png (TinyRenderer)")
    r.set_defaults(func=_run)

    c = sub.add_parser("check-world", help="validate world files without running them")
    c.add_argument("files", nargs="+")
    c.set_defaults(func=_check_world)

    g = sub.add_parser("generate", help="write a randomized world of a family")
    g.add_argument("family")
    g.add_argument("--seed", type=int, required=True)
    g.add_argument("--difficulty", type=float, default=0.5, help="0 (easy) .. 1 (hard), default 0.5")
    g.add_argument("--out", required=True, help="world file to write")
    g.set_defaults(func=_generate)

    t = sub.add_parser("trials", help="run many trials in parallel into DIR/results.jsonl (resumable)")
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

    m = sub.add_parser("model", help="print the robot model (Figure 2 in metres) and the default posture")
    m.set_defaults(func=_model)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from navstack.world import WorldError

    try:
        return args.func(args)
    except (WorldError, BadInput, ValueError, OSError) as exc:  # OSError: an unusable --out or input path
        print(f"navstack {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"navstack {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - internal error: exit 1 with a one-line message
        print(f"navstack {args.command}: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        if "--debug" in (argv or sys.argv):
            raise
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
