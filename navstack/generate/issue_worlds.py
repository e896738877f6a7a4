"""Fixed worlds of the sensor-planner issue (:func:`write_issue_worlds`, files in ``worlds/``).

``truss_displaced.json`` (the paper's truss 0.046 m / 3 deg away from its drawing), ``truss_clutter.json``
(the paper's truss with an unmodelled cable and an equipment box), ``u_trap.json`` (a U of boxes straight
ahead, the goal behind it, the way round over the top) and ``pipe_rack.json`` (a generated rack).
Examples of the families whose goals do not mark the way, and of ``dead-end``
(:func:`write_family_examples`): ``slot_rack.json``, ``sparse_truss.json``, ``bend_clutter.json``,
``dead_end.json``, ``fin_bank.json``, ``rod_forest.json``, ``duct_elbow.json`` (generated worlds,
:data:`FAMILY_EXAMPLES`).
Units: metres, radians.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from navstack.generate.base import GENERATOR_VERSION, HEADING, TIP, TOLERANCE, Candidate, default_robot
from navstack.generate.build import finish, generate_world
from navstack.generate.checks import CheckConfig
from navstack.generate.geometry import box_dict, cylinder_dict, rounded
from navstack.generate.truss_families import reachable_via
from navstack.truss import incircle_offset, paper_truss_world
from navstack.world import World, save_world, world_from_dict

__all__ = [
    "FAMILY_EXAMPLES",
    "blind_pocket_world",
    "ISSUE_PIPE_RACK",
    "pipe_rack_world",
    "truss_clutter_world",
    "truss_displaced_world",
    "u_trap_world",
    "write_family_examples",
    "write_issue_worlds",
]


def _fixed(cand: Candidate, name: str, family: str | None, note: str) -> World:
    cfg = CheckConfig()
    robot = default_robot()
    world, _, why = finish(cand, name, family, cfg, robot, {"fixed": name, "version": GENERATOR_VERSION,
                                                            "note": note})
    if world is None:
        raise RuntimeError(f"fixed world {name} fails its checks: {why}")
    return world


def truss_displaced_world() -> World:
    """The paper's truss displaced 0.046 m and rotated 3 deg from its drawing; goals at drawn positions.

    Of the 26 x 13 grid directions of a 0.046 m offset and a 3 deg rotation, this one (offset along -y,
    rotation about (1, 0, -1)) brings the actual truss closest to the path through the drawn goals
    (0.029 m surface clearance of the serpentine) while a path through the actual opening stays feasible.
    """
    offset = np.array([0.0, -0.046, 0.0])
    rpy = Rotation.from_rotvec(np.radians(3.0) * np.array([1.0, 0.0, -1.0]) / np.sqrt(2.0)).as_euler("xyz")
    drawn = paper_truss_world()
    actual = paper_truss_world(truss_offset=offset, truss_rpy=rpy)
    goals = np.array([g["position"] for g in drawn["goals"]])
    # the goals carried with the actual truss: the same rigid motion about the entry opening's centre
    pivot = TIP + 0.55 * HEADING
    R = Rotation.from_euler("xyz", rpy).as_matrix()
    moved = (goals - pivot) @ R.T + pivot + offset
    via = reachable_via(goals, moved, CheckConfig().goal_reach * TOLERANCE - 1e-3)
    angle = np.degrees(Rotation.from_euler("xyz", rpy).magnitude())
    desc = (f"The paper's truss, actually displaced {np.linalg.norm(offset):.3f} m and rotated "
            f"{angle:.1f} deg from its drawing; the goals are where the drawing puts them (issue: uncertain "
            f"workspace).")
    cand = Candidate(obstacles=actual["obstacles"], goals=goals, via=via, structure=len(actual["obstacles"]),
                      params={"truss_offset": rounded(offset), "truss_rpy": rounded(rpy)}, description=desc,
                      drawn=drawn["obstacles"])
    return _fixed(cand, "truss-displaced", "truss", "paper truss displaced from its drawing")


def truss_clutter_world() -> World:
    """The paper's truss with an unmodelled cable in front of it and an equipment box inside the bay."""
    paper = paper_truss_world()
    goals = np.array([g["position"] for g in paper["goals"]])
    side, c = 0.5, incircle_offset(0.5)
    entry = TIP + 0.55 * HEADING  # centre of the entry opening
    bay0 = entry - np.array([0.0, side - c, c])  # entry bay's (0, 0, 0) corner
    cable = cylinder_dict(entry + np.array([-0.32, -0.085, -0.45]), entry + np.array([-0.22, -0.075, 0.45]), 0.008)
    box = box_dict(bay0 + np.array([0.43, side - c + 0.02, 0.26]), (0.05, 0.07, 0.06), (0.0, 0.0, 0.3))
    cand = Candidate(obstacles=paper["obstacles"] + [cable, box], goals=goals, via=goals,
                      structure=len(paper["obstacles"]), params={},
                      description=("The paper's truss with unmodelled clutter near the path: a cable hanging "
                                   "beside the approach and an equipment box on the entry bay's back face, "
                                   "beside the climb."))
    return _fixed(cand, "truss-clutter", "cluttered-truss", "paper truss + unmodelled cable and box")


def u_trap_world() -> World:
    """A U of boxes opening towards the robot, the goal behind it; the way round is over the top."""
    x0, y0, z0 = TIP
    mouth, depth, half_w, wall = x0 + 0.5, 0.3, 0.16, 0.04
    z_lo, z_hi = z0 - 0.22, z0 + 0.12
    zc, hz = (z_lo + z_hi) / 2, (z_hi - z_lo) / 2
    back = box_dict((mouth + depth + wall / 2, y0, zc), (wall / 2, half_w + wall, hz))
    left = box_dict((mouth + depth / 2, y0 - half_w - wall / 2, zc), (depth / 2, wall / 2, hz))
    right = box_dict((mouth + depth / 2, y0 + half_w + wall / 2, zc), (depth / 2, wall / 2, hz))
    goal = np.array([mouth + depth + wall + 0.22, y0, z0 + 0.08])
    via = np.array([[mouth - 0.02, y0, z0 + 0.2], [mouth + depth + wall / 2, y0, z0 + 0.2], goal])
    desc = ("A U-shaped trap of three boxes (back wall and two side walls, open upwards, downwards and "
            "towards the robot) straight ahead of the tip; the goal is behind the back wall.  Heading "
            "straight for the goal leads into the U; the way round is over the top (reference via points in "
            "extra.generator.reference_via).")
    cand = Candidate(obstacles=[back, left, right], goals=goal[None], via=via, structure=3, params={},
                      description=desc)
    return _fixed(cand, "u-trap", "u-trap", "local-minimum trap for a potential-field planner")


def blind_pocket_world() -> World:
    """A box tube open towards the robot, straight on the way to the goal and deeper than the sensors see.

    From outside the tube's back wall is beyond the rays' 0.4 m, so the straight way through the opening
    looks open: a planner that takes it must find the back wall from inside, where the tube (0.2 m wide,
    less than a turn) leaves no room to turn, and back out to go over the top.
    """
    x0, y0, z0 = TIP
    mouth, depth, half, wall = x0 + 0.45, 0.5, 0.1, 0.02
    xc = mouth + depth / 2
    boxes = [
        box_dict((mouth + depth + wall / 2, y0, z0), (wall / 2, half + wall, half + wall)),  # back
        box_dict((xc, y0, z0 + half + wall / 2), (depth / 2, half + wall, wall / 2)),  # top
        box_dict((xc, y0, z0 - half - wall / 2), (depth / 2, half + wall, wall / 2)),  # bottom
        box_dict((xc, y0 + half + wall / 2, z0), (depth / 2, wall / 2, half)),  # sides
        box_dict((xc, y0 - half - wall / 2, z0), (depth / 2, wall / 2, half)),
    ]
    goal = np.array([mouth + depth + wall + 0.35, y0, z0 + 0.12])
    via = np.array([[mouth + 0.05, y0, z0 + 0.22], [mouth + depth, y0, z0 + 0.22], goal])
    desc = ("A box tube (0.2 m square inside, 0.5 m deep) open towards the robot, on the straight way to the "
            "goal behind it; from outside its back wall is beyond the sensors' range.  The way round is over "
            "the top; a planner that enters the tube must back out.")
    cand = Candidate(obstacles=boxes, goals=goal[None], via=via, structure=len(boxes), params={},
                     description=desc)
    return _fixed(cand, "blind-pocket", "blind-pocket", "pocket deeper than the sensor range on the way")


ISSUE_PIPE_RACK = ("pipe-rack", 7, 0.6)
"""(family, seed, difficulty) of ``worlds/pipe_rack.json``."""


def pipe_rack_world() -> World:
    """The generated pipe rack of :data:`ISSUE_PIPE_RACK`, renamed ``pipe-rack``."""
    w = generate_world(*ISSUE_PIPE_RACK)
    d = w.to_dict()
    d["name"] = "pipe-rack"
    d["extra"]["generator"]["fixed"] = "pipe-rack"
    return world_from_dict(d)


def write_issue_worlds(folder: str | Path) -> list[Path]:
    """Write the fixed worlds of the sensor-planner issue into ``folder`` (created if missing).

    ``truss_displaced.json``, ``truss_clutter.json``, ``u_trap.json``, ``pipe_rack.json`` and
    ``blind_pocket.json``; each passes
    :func:`check_world`.  Returns the written paths.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for fname, make in (("truss_displaced.json", truss_displaced_world),
                        ("truss_clutter.json", truss_clutter_world),
                        ("u_trap.json", u_trap_world), ("pipe_rack.json", pipe_rack_world),
                        ("blind_pocket.json", blind_pocket_world)):
        path = out / fname
        save_world(make(), path)
        written.append(path)
    return written


FAMILY_EXAMPLES = (
    ("slot_rack.json", "slot-rack", 0, 0.5),
    ("sparse_truss.json", "sparse-truss", 1, 1.0),
    ("bend_clutter.json", "bend-clutter", 0, 1.0),
    ("dead_end.json", "dead-end", 1, 1.0),
    ("fin_bank.json", "fin-bank", 0, 1.0),
    ("rod_forest.json", "rod-forest", 0, 1.0),
    ("duct_elbow.json", "duct-elbow", 0, 0.5),
    ("sized_slot_rack.json", "sized-slot-rack", 6, 1.0),
)
"""(file, family, seed, difficulty) of the example worlds of the newer families in ``worlds/``."""


def write_family_examples(folder: str | Path) -> list[Path]:
    """Write the worlds of :data:`FAMILY_EXAMPLES` into ``folder`` (created if missing); the written paths."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for fname, family, seed, difficulty in FAMILY_EXAMPLES:
        path = out / fname
        save_world(generate_world(family, seed, difficulty), path)
        written.append(path)
    return written
