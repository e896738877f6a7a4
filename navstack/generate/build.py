"""``generate_world``: draw a family's candidate from a fixed sub-seed, check it, retry, return the world.

Sub-seeds: attempt ``k`` of ``(family, seed)`` draws from ``numpy.random.default_rng([GENERATOR_VERSION,
seed_id, seed, k])`` with the family's fixed ``seed_id`` from :mod:`navstack.registry`; difficulty does
not enter the seed, so one seed at several difficulties gives related layouts, and a family's worlds
never depend on which other families exist.  Units: metres, seconds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navstack.generate.base import GENERATOR_VERSION, Candidate, build_world, default_robot
from navstack.generate.checks import CheckConfig, CheckReport, RobotStart, path_samples, run_checks
from navstack.generate.geometry import obstacle_distance, rounded
from navstack.registry import FAMILIES as REGISTERED
from navstack.registry import load
from navstack.world import World

__all__ = ["MAX_ATTEMPTS", "finish", "generate_world", "world_name"]

MAX_ATTEMPTS = 60
"""Sub-seeds tried before :func:`generate_world` gives up (RuntimeError)."""


def check_args(family: Any, seed: Any, difficulty: Any) -> tuple[str, int, float]:
    """Validated ``(family, seed, difficulty)``; ValueError naming the bad argument."""
    if not isinstance(family, str) or family not in REGISTERED:
        raise ValueError(f"family must be one of {', '.join(REGISTERED)}; got {family!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    real = (int, float, np.integer, np.floating)
    number = isinstance(difficulty, real) and not isinstance(difficulty, bool)
    if not (number and math.isfinite(float(difficulty)) and 0.0 <= float(difficulty) <= 1.0):
        raise ValueError(f"difficulty must be a number in [0, 1], got {difficulty!r}")
    return family, int(seed), float(difficulty)


def world_name(family: str, seed: int, difficulty: float) -> str:
    """``family-sNNNN-dD.DD`` (more digits when the difficulty needs them)."""
    d = f"{difficulty:.2f}"
    if abs(float(d) - difficulty) > 1e-12:
        d = f"{difficulty:.6f}".rstrip("0")
    return f"{family}-s{seed:04d}-d{d}"


def finish(cand: Candidate, name: str, family: str | None, cfg: CheckConfig, robot: RobotStart,
           generator: dict[str, Any]) -> tuple[World | None, CheckReport | None, str]:
    """Check a candidate; the world (or None), its report and why it failed."""
    extra = {"generator": {**generator, **cand.params, "reference_via": [rounded(v) for v in cand.via],
                           "structure_obstacles": cand.structure}}
    world = build_world(name, family, cand, extra)
    via = np.array(extra["generator"]["reference_via"])
    drawn_clearance = None
    if cand.drawn is not None:
        as_drawn = Candidate(cand.drawn, cand.goals, cand.goals, len(cand.drawn), {}, "")
        drawn = build_world(name, family, as_drawn, {})
        drawn_samples = path_samples(robot, cand.goals, cfg)
        rep = run_checks(drawn, cand.goals, len(cand.drawn), cfg, robot, drawn_samples, pybullet_start=False)
        if not rep.ok:
            return None, rep, "drawing: " + "; ".join(rep.problems)
        # the slithering body along the path through the drawn goals, against the actual obstacles
        drawn_clearance = float(obstacle_distance(world.obstacles, drawn_samples.body, cfg.horizon).min()
                                - robot.serpentine_radius)
    rep = run_checks(world, via, cand.structure, cfg, robot)
    if not rep.ok:
        return None, rep, "; ".join(rep.problems)
    extra["generator"]["checks"] = rep.to_dict()
    if drawn_clearance is not None:
        extra["generator"]["drawn_path_clearance"] = round(drawn_clearance, 4)
    time_limit = float(max(60.0, math.ceil(3.0 * rep.path_length / 0.06)))
    return build_world(name, family, cand, extra, time_limit), rep, ""


def _candidate(family: str, rng: np.random.Generator, difficulty: float, cfg: CheckConfig,
               robot: RobotStart) -> Candidate:
    return load(REGISTERED[family].factory)(rng, difficulty, cfg, robot)


def generate_world(family: str, seed: int, difficulty: float = 0.5) -> World:
    """A random world of ``family`` (one of :data:`navstack.generate.FAMILIES`), deterministic in its arguments.

    Args:
        family: a registered family (:mod:`navstack.registry`).
        seed: non-negative integer.
        difficulty: 0 (easy) .. 1 (hard): what it changes is each family's registry ``difficulty`` text.

    The world's ``name`` is ``family-sNNNN-dD.DD``, ``family`` is set, and ``extra.generator`` holds
    the arguments, ``version``, the sub-seed ``attempt`` that passed, the drawn parameters, the
    reference via points, the structure's obstacle count and the measured check values.

    Raises:
        ValueError: unknown family, negative or non-integer seed, difficulty outside [0, 1].
        RuntimeError: no sub-seed passed the checks within :data:`MAX_ATTEMPTS` (a generator bug).
    """
    family, seed, difficulty = check_args(family, seed, difficulty)
    cfg = CheckConfig()
    robot = default_robot()
    name = world_name(family, seed, difficulty)
    last = ""
    for attempt in range(MAX_ATTEMPTS):
        rng = np.random.default_rng([GENERATOR_VERSION, REGISTERED[family].seed_id, seed, attempt])
        cand = _candidate(family, rng, difficulty, cfg, robot)
        generator = {"family": family, "seed": seed, "difficulty": difficulty, "version": GENERATOR_VERSION,
                     "attempt": attempt}
        world, _, why = finish(cand, name, family, cfg, robot, generator)
        if world is not None:
            return world
        last = why
    raise RuntimeError(f"generate_world({family!r}, {seed}, {difficulty}): no candidate passed the checks in "
                       f"{MAX_ATTEMPTS} attempts; last failure: {last}")
