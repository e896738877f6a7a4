"""``generate_world``: draw a family's candidate from a fixed sub-seed, check it, retry, return the world.

Sub-seeds: attempt ``k`` of ``(family, seed)`` draws from ``numpy.random.default_rng([GENERATOR_VERSION,
seed_id, seed, k])`` with the family's fixed ``seed_id`` from :mod:`navstack.registry`; difficulty does
not enter the seed, so one seed at several difficulties gives related layouts, and a family's worlds
never depend on which other families exist.  Units: metres, seconds.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from navstack.generate.base import GENERATOR_VERSION, Candidate, build_world, default_robot
from navstack.generate.checks import CheckConfig, CheckReport, RobotStart, path_samples, run_checks
from navstack.generate.geometry import obstacle_distance, rounded
from navstack.registry import FAMILIES as REGISTERED
from navstack.registry import load
from navstack.validate import is_seed
from navstack.world import World

__all__ = ["MAX_ATTEMPTS", "finish", "generate_world", "goal_path_clearance", "time_limit_for", "world_name"]

MAX_ATTEMPTS = 60
"""Sub-seeds tried before :func:`generate_world` gives up (RuntimeError)."""


def check_args(family: Any, seed: Any, difficulty: Any) -> tuple[str, int, float]:
    """Validated ``(family, seed, difficulty)``; ValueError naming the bad argument."""
    if not isinstance(family, str) or family not in REGISTERED:
        raise ValueError(f"family must be one of {', '.join(REGISTERED)}; got {family!r}")
    if not is_seed(seed):
        raise ValueError(f"seed must be an integer from 0 to 2**63 - 1, got {seed!r}")
    real = (int, float, np.integer, np.floating)
    number = isinstance(difficulty, real) and not isinstance(difficulty, bool)
    if not (number and math.isfinite(float(difficulty)) and 0.0 <= float(difficulty) <= 1.0):
        raise ValueError(f"difficulty must be a number in [0, 1], got {difficulty!r}")
    return family, int(seed), float(difficulty) + 0.0  # -0.0 is 0.0 (it named worlds "d-0.00")


def world_name(family: str, seed: int, difficulty: float) -> str:
    """``family-sNNNN-dD.DD`` (more digits when the difficulty needs them)."""
    d = f"{difficulty:.2f}"
    if abs(float(d) - difficulty) > 1e-12:
        d = f"{difficulty:.6f}".rstrip("0")
    return f"{family}-s{seed:04d}-d{d}"


def time_limit_for(path_length: float, retract: bool) -> float:
    """``time_limit`` [s] of a generated world whose reference path is ``path_length`` [m] long.

    Three times what the reference path takes at the planners' cruise speed of 0.06 m/s, at least 60 s.
    A ``retract`` world's way back retraces the same path (interfaces.md section 2a), so it counts twice.
    """
    travel = 2.0 * path_length if retract else path_length
    return float(max(60.0, math.ceil(3.0 * travel / 0.06)))


def goal_path_clearance(cand: Candidate, cfg: CheckConfig, robot: RobotStart) -> float:
    """Surface clearance [m] of the body slithering along the spline through the goals alone (the
    scripted planner's path), against the candidate's obstacles; negative: it cuts into one."""
    obstacles = build_world("probe", None, cand, {}).obstacles
    body = path_samples(robot, cand.goals, cfg).body
    return float(obstacle_distance(obstacles, body, cfg.horizon).min() - robot.serpentine_radius)


def _drawn_clearance(cand: Candidate, world: World, name: str, family: str | None, cfg: CheckConfig,
                     robot: RobotStart) -> tuple[float | None, str]:
    """Checks 1-3 of the path through the goals against the truss as drawn; the body's clearance along
    it against the actual obstacles (None, why) when the drawing fails."""
    as_drawn = Candidate(cand.drawn, cand.goals, cand.goals, len(cand.drawn), {}, "")
    drawn = build_world(name, family, as_drawn, {})
    drawn_samples = path_samples(robot, cand.goals, cfg)
    rep = run_checks(drawn, cand.goals, len(cand.drawn), cfg, robot, drawn_samples, pybullet_start=False)
    if not rep.ok:
        return None, "drawing: " + "; ".join(rep.problems)
    return float(obstacle_distance(world.obstacles, drawn_samples.body, cfg.horizon).min()
                 - robot.serpentine_radius), ""


def finish(cand: Candidate, name: str, family: str | None, cfg: CheckConfig, robot: RobotStart,
           generator: dict[str, Any], retract: bool = False) -> tuple[World | None, CheckReport | None, str]:
    """Check a candidate; the world (or None), its report and why it failed.

    The family's stricter thresholds (``cand.checks``) replace those of ``cfg``; a candidate whose goals
    must not mark the way (``cand.blocked_depth``) is discarded, before the slower checks, when the
    path through its goals alone is clear.
    """
    if cand.checks:
        cfg = replace(cfg, **cand.checks)
    gen = {**generator, **cand.params, "reference_via": [rounded(v) for v in cand.via],
           "structure_obstacles": cand.structure}
    if cand.checks:
        gen["check_config"] = dict(cand.checks)
    if cand.blocked_depth is not None:
        gen["goal_path_clearance"] = round(goal_path_clearance(cand, cfg, robot), 4)
        if gen["goal_path_clearance"] > -cand.blocked_depth:
            return None, None, (f"the goals mark the way: the path through them clears every obstacle by "
                                f"{gen['goal_path_clearance']:.4f} m (> -{cand.blocked_depth} m)")
    extra = {"generator": gen}
    world = build_world(name, family, cand, extra)
    via = np.array(gen["reference_via"])
    drawn_clearance = None
    if cand.drawn is not None:
        drawn_clearance, why = _drawn_clearance(cand, world, name, family, cfg, robot)
        if drawn_clearance is None:
            return None, None, why
    rep = run_checks(world, via, cand.structure, cfg, robot)
    if not rep.ok:
        return None, rep, "; ".join(rep.problems)
    gen["checks"] = rep.to_dict()
    if drawn_clearance is not None:
        gen["drawn_path_clearance"] = round(drawn_clearance, 4)
    if retract:
        # the way back: the tip retraces the same path and every joint point stays on it, so the body
        # and the arm pass through the same configurations in reverse order (checks 2-5 cover both ways)
        gen["retract"] = True
        gen["return_length"] = round(rep.path_length, 4)
    settle = max((o.motion.stop for o in world.obstacles if getattr(o, "motion", None) is not None), default=0.0)
    limit = time_limit_for(rep.path_length, retract) + math.ceil(settle)  # run_checks refused a motion without end
    return build_world(name, family, cand, extra, limit, retract), rep, ""


def _candidate(family: str, rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
               robot: RobotStart) -> Candidate:
    return load(REGISTERED[family].factory)(rng, difficulty, cfg, robot)


def generate_world(family: str, seed: int, difficulty: float = 0.5, *, retract: bool | None = None) -> World:
    """A random world of ``family`` (one of :data:`navstack.generate.FAMILIES`), deterministic in its arguments.

    Args:
        family: a registered family (:mod:`navstack.registry`).
        seed: non-negative integer.
        difficulty: 0 (easy) .. 1 (hard): what it changes is each family's registry ``difficulty`` text.
        retract: write ``"retract": true`` (the robot must back out to its start after the last goal,
            interfaces.md section 2a); ``None``: the family's default (true for ``dead-end`` only).
            It does not enter the seed: the same arguments give the same obstacles and goals either way.

    The world's ``name`` is ``family-sNNNN-dD.DD`` (plus ``-retract`` or ``-noretract`` when ``retract``
    differs from the family's default), ``family`` is set, and ``extra.generator`` holds the arguments,
    ``version``, the sub-seed ``attempt`` that passed, the drawn parameters, the reference via points,
    the structure's obstacle count and the measured check values.  ``time_limit``: :func:`time_limit_for`.

    Raises:
        ValueError: unknown family, negative or non-integer seed, difficulty outside [0, 1], a
            non-boolean ``retract``.
        RuntimeError: no sub-seed passed the checks within :data:`MAX_ATTEMPTS` (a generator bug).
    """
    family, seed, difficulty = check_args(family, seed, difficulty)
    if retract is not None and not isinstance(retract, (bool, np.bool_)):
        raise ValueError(f"retract must be true, false or None, got {retract!r}")
    cfg = CheckConfig()
    robot = default_robot()
    last = ""
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng([GENERATOR_VERSION, REGISTERED[family].seed_id, seed, attempt])
        cand = _candidate(family, rng, difficulty, cfg, robot)
        own = cand.serpentine_radius
        drawn_for = robot if own is None else replace(robot, serpentine_radius=own)  # the checks use its radius
        back = cand.retract if retract is None else bool(retract)
        name = world_name(family, seed, difficulty)
        if back != cand.retract:
            name += "-retract" if back else "-noretract"
        generator = {"family": family, "seed": seed, "difficulty": difficulty, "version": GENERATOR_VERSION,
                     "attempt": attempt}
        world, _, why = finish(cand, name, family, cfg, drawn_for, generator, back)
        if world is not None:
            return world
        last = why
    raise RuntimeError(f"generate_world({family!r}, {seed}, {difficulty}): no candidate passed the checks in "
                       f"{MAX_ATTEMPTS} attempts; last failure: {last}")
