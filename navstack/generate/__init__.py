"""Randomized world generators (families) built around a feasible reference path, and their checks.

``generate_world(family, seed, difficulty)`` returns a :class:`~navstack.world.World` of one of
:data:`FAMILIES`, deterministic in its arguments.  Every world is built around a *reference tip path*:
the cubic spline that :class:`navstack.scripted.ScriptedPlanner` would follow through the reference
via points (start tip, leaving along the tip's heading, then the via points, chord-length
parameterised; :func:`reference_path`).  For worlds whose obstacles match the goals the via points are
the goals; for a truss displaced from its drawing they are the goals moved towards the *actual*
truss by at most 90 % of their tolerance (the path a robot that senses the truss can take).  The via
points and the number of leading "structure" obstacles are stored in
``extra.generator.reference_via`` / ``structure_obstacles``, so :func:`check_world` can re-check a
saved world.

The package, one concept per module:

* :mod:`~navstack.generate.geometry`: exact point-to-obstacle distances, obstacle dicts;
* :mod:`~navstack.generate.checks`: :class:`CheckConfig`, :func:`check_world` and the reference path;
* :mod:`~navstack.generate.base`: the robot placement, candidates, clutter placement;
* :mod:`~navstack.generate.build`: :func:`generate_world` (sub-seeds, retries);
* one module per family, registered in :mod:`navstack.registry` (name, factory, fixed ``seed_id``,
  what difficulty changes), each documenting its layout and its difficulty knob:

  - goals at every crossing: :mod:`~navstack.generate.truss_families` (``truss``, ``cluttered-truss``),
    :mod:`~navstack.generate.pipe_rack`, :mod:`~navstack.generate.sphere_field`;
  - goals that do not mark the way (:mod:`~navstack.generate.sparse`: 12 mm for every link, the spline
    through the goals alone must cut into an obstacle): :mod:`~navstack.generate.slot_rack`
    (``slot-rack``), :mod:`~navstack.generate.sparse_truss` (``sparse-truss``),
    :mod:`~navstack.generate.bend_clutter` (``bend-clutter``), and :mod:`~navstack.generate.sized`
    (``sized-slot-rack``: the slot rack for a serpentine radius of 12-45 mm drawn per world);
  - :mod:`~navstack.generate.dead_end` (``dead-end``): the goal at the back of a pocket, ``retract``;
  - :mod:`~navstack.generate.sliding_door` (``sliding-door``): a window shut by a door that slides away later
    (a moving obstacle; the checks take obstacles where their motions end, :func:`~navstack.generate.checks.
    settled`, and the time limit adds the time the last one stops);
* :mod:`~navstack.generate.issue_worlds`: the fixed worlds in ``worlds/``.

``generate_world(..., retract=True)`` writes ``"retract": true`` into any family's world (the robot must
back out to its start after the last goal, interfaces.md section 2a); the way back is the same path
reversed, so the checks cover it and only the time limit grows (:func:`~navstack.generate.build.
time_limit_for`: three times the path at 0.06 m/s, counted twice for a retract world, at least 60 s).
A family's stricter thresholds are stored in ``extra.generator.check_config`` and re-applied by
:func:`check_world`; for the sparse-goal families ``extra.generator.goal_path_clearance`` is the surface
clearance of the body slithering along the spline through the goals alone (negative: the scripted
planner collides).

Robot of every family: the paper's demo placement, base (0, 0, 0.3) m, rpy (0, -pi/2, pi), tip at
(1.8085, 0.1079, 1.1668) m heading +x, lathe bed along +x; radii 0.025 m (serpentine) and 0.06 m (arm), but
for a family whose candidate sets its own ``serpentine_radius`` (the checks then use that radius).

Checks (:func:`check_world`; a candidate that fails any of them is discarded and the next sub-seed
``attempt`` is drawn, up to :data:`MAX_ATTEMPTS`), thresholds in :class:`CheckConfig`:

1. goals: every goal is at least ``goal_clearance`` (0.06 m) from every obstacle surface;
2. reference path: every point of the reference tip path (sampled every 2 mm) is at least
   ``serpentine_radius + path_margin`` (0.04 m) from every obstacle surface, its smallest radius of
   curvature is at least ``min_turn_radius`` (0.25 m), and it passes within 90 % of each goal's
   tolerance, in order;
3. slithering body: the chord chain (tip, J1..J6, one link apart along the recorded path, as
   :class:`navstack.path.PathMemory` computes it, starting from the initial backbone) is evaluated
   every 1 cm of tip travel; every link capsule keeps a surface clearance of at least ``body_margin``
   (0.01 m);
4. length rule: the part of the reference path from where it first enters the structure's bounding
   box (grown by 0.05 m) to the last goal is at most ``max_inside_length`` (1.1 m), and the flange's
   (J6) travel along the lathe axis fits the lathe's remaining travel;
5. arm: the arm's capsules (frames 1..9 at ``q0``, radius ``arm_radius``) translated by every
   displacement of J6 along the slither keep a surface clearance of at least ``arm_margin`` (0.03 m)
   (a cheap stand-in for the lathe bed carrying the arm forward);
6. start: the robot at ``q0``, built in PyBullet (:class:`navstack.sim.body.RobotBody`,
   :class:`navstack.sim.scene.Scene`), has ``scene.clearance >= start_clearance`` (0.05 m).

For the truss families the path through the goals is also checked (1-3) against the truss as
*drawn*, so the drawn goals make sense; the surface clearance of the body slithering along it, against
the actual obstacles, is recorded in ``extra.generator.drawn_path_clearance`` (negative: a planner that
trusts the drawing hits the truss; the scripted planner's ``min_clearance`` is close to it).
Distances are exact point-to-primitive distances (flat-ended cylinders, boxes, spheres), sampled
along curves every 2 mm (tip path), 1 cm (capsule axes) and 2 cm (arm); mesh obstacles are not
supported by the checks.

Sub-seeds: attempt ``k`` of ``(family, seed)`` draws from ``numpy.random.default_rng([1, seed_id, seed,
k])`` with the family's fixed ``seed_id`` (:mod:`navstack.registry`); difficulty does not enter the
seed, so one seed at several difficulties gives related layouts.  Units: metres, radians, seconds.
"""

from __future__ import annotations

from navstack.generate.base import BASE_POSITION, GENERATOR_VERSION, TOLERANCE, with_reference_goals
from navstack.generate.bend_clutter import family_bend_clutter
from navstack.generate.build import MAX_ATTEMPTS, generate_world, time_limit_for, world_name
from navstack.generate.checks import (
    CheckConfig,
    CheckReport,
    ReferencePath,
    check_world,
    reference_path,
    start_clearance,
)
from navstack.generate.dead_end import family_dead_end
from navstack.generate.geometry import obstacle_distance
from navstack.generate.issue_worlds import (
    FAMILY_EXAMPLES,
    ISSUE_PIPE_RACK,
    pipe_rack_world,
    truss_clutter_world,
    truss_displaced_world,
    u_trap_world,
    write_family_examples,
    write_issue_worlds,
)
from navstack.generate.pipe_rack import family_pipe_rack
from navstack.generate.slot_rack import family_slot_rack
from navstack.generate.sparse_truss import family_sparse_truss
from navstack.generate.sphere_field import family_sphere_field
from navstack.generate.truss_families import TrussLayout, family_cluttered_truss, family_truss
from navstack.registry import FAMILIES as _REGISTERED

FAMILIES = tuple(_REGISTERED)
"""World families :func:`generate_world` knows (read from :mod:`navstack.registry`)."""

__all__ = [
    "BASE_POSITION",
    "FAMILIES",
    "FAMILY_EXAMPLES",
    "GENERATOR_VERSION",
    "ISSUE_PIPE_RACK",
    "MAX_ATTEMPTS",
    "TOLERANCE",
    "CheckConfig",
    "CheckReport",
    "ReferencePath",
    "TrussLayout",
    "check_world",
    "family_bend_clutter",
    "family_cluttered_truss",
    "family_dead_end",
    "family_pipe_rack",
    "family_slot_rack",
    "family_sparse_truss",
    "family_sphere_field",
    "family_truss",
    "generate_world",
    "obstacle_distance",
    "pipe_rack_world",
    "reference_path",
    "start_clearance",
    "time_limit_for",
    "truss_clutter_world",
    "truss_displaced_world",
    "u_trap_world",
    "with_reference_goals",
    "world_name",
    "write_family_examples",
    "write_issue_worlds",
]
