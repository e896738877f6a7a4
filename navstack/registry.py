"""The registry: every planner, controller and world family, named once.

The trial, the sweep, the report and the command line read names, one-line summaries and factories
from here, so a new planner, controller or family is one new module plus one ``register_*`` call (below,
or from user code before a sweep starts).  Factories are given as ``"module:attribute"`` strings and
imported only when used, so importing the registry loads neither PyBullet nor the planners.

Factory signatures:

* planner: ``factory(context: navstack.registry.PlannerContext) -> TipPlanner`` (see
  :mod:`navstack.planner` for the interface); ``senses`` says whether the trial must cast the tip rays
  and pass filtered readings each step;
* controller: ``factory(chain, q0, dt, trial_config) -> controller`` with ``step(x_d, xdot_d)``;
* family: ``factory(rng, difficulty, cfg, robot) -> candidate`` (see :mod:`navstack.generate`);
  ``seed_id`` enters the family's sub-seeds, so a family's worlds never depend on which other families
  exist or in which order they are listed.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CONTROLLERS",
    "FAMILIES",
    "PLANNERS",
    "ControllerEntry",
    "FamilyEntry",
    "PlannerContext",
    "PlannerEntry",
    "controller_names",
    "family_names",
    "load",
    "planner_names",
    "register_controller",
    "register_family",
    "register_planner",
]


@dataclass(frozen=True)
class PlannerEntry:
    """A tip planner: ``factory(PlannerContext) -> TipPlanner``; ``senses``: needs tip sensor readings."""

    name: str
    summary: str
    factory: str
    senses: bool


@dataclass(frozen=True)
class ControllerEntry:
    """A controller: ``factory(chain, q0, dt, trial_config)``."""

    name: str
    summary: str
    factory: str


@dataclass(frozen=True)
class FamilyEntry:
    """A world family of :mod:`navstack.generate`; ``difficulty`` says what the 0..1 knob changes."""

    name: str
    summary: str
    factory: str
    seed_id: int
    difficulty: str


@dataclass(frozen=True)
class PlannerContext:
    """What a planner is built from: the robot's start and the goals, never obstacle geometry.

    Positions are in the world frame [m]; ``heading`` is the unit tip direction at t = 0; ``dt`` the
    control period [s]; ``config`` the trial's :class:`navstack.trial.TrialConfig` (planner parameters).
    The robot's own shape at t = 0: ``arm`` (k, 3) points along the axes of the arm's capsules (frames
    1..9), ``arm_radius`` [m] their radius, ``flange`` (3,) the flange J6 (frame 9), where the serpentine
    begins; ``lathe_axis`` (3,) the lathe bed's unit axis and ``lathe_travel`` (lo, hi) how far it may still
    move along it from the start [m].  Nothing says whether obstacles move: a planner senses that (spec 2b).
    """

    start: NDArray[np.float64]
    heading: NDArray[np.float64]
    goals: NDArray[np.float64]
    tolerances: NDArray[np.float64]
    dt: float
    config: Any = None
    arm: NDArray[np.float64] | None = None
    arm_radius: float = 0.06
    flange: NDArray[np.float64] | None = None
    lathe_axis: NDArray[np.float64] | None = None
    lathe_travel: tuple[float, float] = (-np.inf, np.inf)


PLANNERS: dict[str, PlannerEntry] = {}
CONTROLLERS: dict[str, ControllerEntry] = {}
FAMILIES: dict[str, FamilyEntry] = {}


def _check_name(kind: str, name: str, table: dict[str, Any]) -> None:
    if not isinstance(name, str) or not name or name != name.strip() or "/" in name or "__" in name:
        raise ValueError(f"{kind} name must be a non-empty string without '/', '__' or spaces; got {name!r}")
    if name in table:
        raise ValueError(f"{kind} {name!r} is already registered")


def register_planner(name: str, summary: str, factory: str, *, senses: bool) -> PlannerEntry:
    """Register a planner under ``name`` (``ValueError`` if taken)."""
    _check_name("planner", name, PLANNERS)
    entry = PlannerEntry(name, summary, factory, bool(senses))
    PLANNERS[name] = entry
    return entry


def register_controller(name: str, summary: str, factory: str) -> ControllerEntry:
    """Register a controller under ``name`` (``ValueError`` if taken)."""
    _check_name("controller", name, CONTROLLERS)
    entry = ControllerEntry(name, summary, factory)
    CONTROLLERS[name] = entry
    return entry


def register_family(name: str, summary: str, factory: str, *, seed_id: int, difficulty: str) -> FamilyEntry:
    """Register a world family under ``name`` with a ``seed_id`` no other family uses."""
    _check_name("family", name, FAMILIES)
    if any(e.seed_id == seed_id for e in FAMILIES.values()):
        raise ValueError(f"family seed_id {seed_id} is already used")
    entry = FamilyEntry(name, summary, factory, int(seed_id), difficulty)
    FAMILIES[name] = entry
    return entry


def planner_names() -> tuple[str, ...]:
    return tuple(PLANNERS)


def controller_names() -> tuple[str, ...]:
    return tuple(CONTROLLERS)


def family_names() -> tuple[str, ...]:
    return tuple(FAMILIES)


def load(target: str) -> Any:
    """Import ``"module:attribute"``."""
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def describe(table: dict[str, Any]) -> str:
    """One line per entry, ``name: summary`` (for ``--help`` texts)."""
    return "; ".join(f"{e.name}: {e.summary}" for e in table.values())


# ------------------------------------------------------------------------------------------ built-ins
register_controller(
    "slither", "equation (4) with every serpentine joint on the tip's recorded path (the paper's)",
    "navstack.trial:make_slither_controller")
register_controller(
    "tip-only", "baseline: equation (4) with the tip task only, the body free",
    "navstack.trial:make_tip_only_controller")

register_planner(
    "field", "sensing planner: sensed map, potential, hybrid A* over arcs the tip can follow, backing out",
    "navstack.trial:make_field_planner", senses=True)
register_planner(
    "reactive", "baseline: the earlier reactive potential field (pursues the goal spline, gap centring)",
    "navstack.trial:make_reactive_planner", senses=True)
register_planner(
    "scripted", "baseline: a smooth spline through the goals, no sensing",
    "navstack.trial:make_scripted_planner", senses=False)

register_family("truss", "the paper's box-bay truss, displaced from its drawing; goals at every opening",
                "navstack.generate.truss_families:family_truss", seed_id=0,
                difficulty="displacement up to 6 cm / 3 deg, bay 0.5 -> 0.42 m, members 2 -> 2.5 cm")
register_family("cluttered-truss", "truss plus unmodelled cables and equipment boxes near the path",
                "navstack.generate.truss_families:family_cluttered_truss", seed_id=1,
                difficulty="as truss, plus more and closer clutter")
register_family("pipe-rack", "2-3 layers of horizontal pipes, a goal at each crossing",
                "navstack.generate.pipe_rack:family_pipe_rack", seed_id=2,
                difficulty="gap 0.25 -> 0.13 m")
register_family("sphere-field", "spheres beside a bumped path, via goals on the bump",
                "navstack.generate.sphere_field:family_sphere_field", seed_id=3,
                difficulty="more spheres, closer to the path")
register_family("slot-rack", "2-3 rows of pipes or slotted plates, any roll; slots alternate off the line; "
                "goals: entry and destination only",
                "navstack.generate.slot_rack:family_slot_rack", seed_id=4,
                difficulty="3rd row 0.15 -> 0.75 likely, rows 0.5-0.65 -> 0.33-0.45 m apart, slot 0.15 -> 0.12 m, "
                           "2nd sphere 0.2 -> 0.8 likely, spheres closer")
register_family("sparse-truss", "the box-bay truss, displaced, with clutter 1.7-5 cm from the way; goals: an "
                "inspection point inside and the exit only",
                "navstack.generate.sparse_truss:family_sparse_truss", seed_id=5,
                difficulty="as truss (bay 0.5 -> 0.42 m, members 2 -> 2.5 cm, displacement up to 6 cm / 3 deg), "
                           "3 -> 6 clutter items, 1.7-5.2 -> 1.7-3.2 cm from the tip's path")
register_family("bend-clutter", "a 60-110 deg bend round a column, clutter on its inside and outside; goals: "
                "the start of the bend region and the destination only",
                "navstack.generate.bend_clutter:family_bend_clutter", seed_id=6,
                difficulty="radius 0.36-0.45 -> 0.3-0.36 m, bend 60-85 -> 80-110 deg, column/plate 7 -> 5.5 cm "
                           "from the path, 2 -> 5 clutter items 1.7-5.7 -> 1.7-2.7 cm from the tip's path")
register_family("dead-end", "a box tube or cage open towards the robot, the goal at its back; retract: true "
                "(back out along the path)",
                "navstack.generate.dead_end:family_dead_end", seed_id=7,
                difficulty="half width 0.11 -> 0.08 m, depth 0.3 -> 0.5 m, axis tilt (and so mouth offset) up to "
                           "10 -> 30 deg, 0 -> 2 clutter items beside the approach")
register_family("sliding-door", "a wall with a window, shut by a door behind it that slides away later (a moving "
                "obstacle); goal: the destination only",
                "navstack.generate.sliding_door:family_sliding_door", seed_id=8,
                difficulty="window 0.2 -> 0.15 m, turn onto its axis up to 10 -> 25 deg, the door opens at 2-6 -> "
                           "8-12 s")
register_family("fin-bank", "two banks of thin fins (1.5-8 mm plates) edge-on to the approach, any roll; the channel "
                "near the line alternates off it; goals: entry and destination only",
                "navstack.generate.fin_bank:family_fin_bank", seed_id=9,
                difficulty="fins 3-8 -> 1.5-4 mm thick, an S-curve 0.36-0.45 -> 0.26-0.35 m long between the banks, "
                           "channel 0.15 -> 0.12 m, 0-1 -> 2-3 cables, closer to the way")
register_family("rod-forest", "thin parallel rods across the approach, any roll, filling all but a winding way "
                "through; goals: entry and destination only",
                "navstack.generate.rod_forest:family_rod_forest", seed_id=10,
                difficulty="rod radius 6-12 -> 4-8 mm, 20 -> 60 rods drawn, the way winds 0.08-0.1 -> 0.08-0.11 m "
                           "aside")
register_family("duct-elbow", "inside a square duct, round an elbow; goal: the destination only (inside, near the "
                "duct's far end)",
                "navstack.generate.duct_elbow:family_duct_elbow", seed_id=11,
                difficulty="half width 0.1 -> 0.075 m, elbow 45-70 -> 75-100 deg of radius 0.42-0.5 -> 0.3-0.38 m, "
                           "mouth off the heading up to 10 -> 25 deg")
register_family("sized-slot-rack", "the slot rack for a serpentine of radius 12-45 mm drawn per world (the default is "
                "25 mm), its slots sized to the body; goals: entry and destination only",
                "navstack.generate.sized:family_sized_slot_rack", seed_id=12,
                difficulty="as slot-rack (slots 2 (r - 0.025) m wider: the same room each side of the body)")
