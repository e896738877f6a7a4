"""Box-bay trusses of cylindrical members, and the paper's demo world.

A truss is a grid of cubic bays (``side`` [m]); every bay edge is a member,
and every square face (outer and inner) carries one diagonal, so each face is
two right-isoceles triangular openings with legs ``side``.  Vertical faces
take the diagonal from their (low, low) to their (high, high) corner,
horizontal faces the other diagonal: a straight climb through the centre of a
bottom triangle of a front face then meets the centre of a top triangle.

The incircle of an opening has radius ``side * (2 - sqrt 2) / 2`` (0.146 m
for 0.5 m bays); minus the member radius and the serpentine radius this is
the room the serpentine has while passing.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from navstack.jpl import Q_DEFAULT, jpl_serpentine

PAPER_BASE_RPY = (0.0, -np.pi / 2, np.pi)
"""Robot base orientation of the demo: lathe axis z0 along world +x, the arm's
x0 up (world +z)."""


def incircle_offset(side: float) -> float:
    """Distance [m] of an opening's incentre from its two legs."""
    return side * (2.0 - np.sqrt(2.0)) / 2.0


def truss_members(bays: tuple[int, int, int], side: float) -> list[tuple[NDArray, NDArray]]:
    """Members (p0, p1) of a truss of ``bays`` = (nx, ny, nz) cubic bays, in the truss frame.

    The truss occupies [0, nx side] x [0, ny side] x [0, nz side].
    """
    nx, ny, nz = bays
    if min(bays) < 1 or side <= 0:
        raise ValueError(f"truss needs >= 1 bay per axis and a positive side, got {bays}, {side}")
    members: set[tuple[tuple[int, int, int], tuple[int, int, int]]] = set()

    def add(a: tuple[int, int, int], b: tuple[int, int, int]) -> None:
        members.add((a, b) if a <= b else (b, a))

    nodes = list(itertools.product(range(nx + 1), range(ny + 1), range(nz + 1)))
    for i, j, k in nodes:  # edges
        if i < nx:
            add((i, j, k), (i + 1, j, k))
        if j < ny:
            add((i, j, k), (i, j + 1, k))
        if k < nz:
            add((i, j, k), (i, j, k + 1))
    for i, j, k in nodes:  # face diagonals
        if j < ny and k < nz:  # face x = const, in (y, z): vertical, low-low to high-high
            add((i, j, k), (i, j + 1, k + 1))
        if i < nx and k < nz:  # face y = const, in (x, z): vertical
            add((i, j, k), (i + 1, j, k + 1))
        if i < nx and j < ny:  # face z = const, in (x, y): horizontal, the other diagonal
            add((i, j + 1, k), (i + 1, j, k))
    return [(np.array(a, float) * side, np.array(b, float) * side) for a, b in sorted(members)]


def robot_tip_start(base_position: ArrayLike, base_rpy: ArrayLike, q0: ArrayLike = Q_DEFAULT):
    """World position and heading of the tip for a robot base and posture."""
    R = Rotation.from_euler("xyz", base_rpy).as_matrix()
    F = jpl_serpentine().frames(q0)
    return R @ F[21, :3, 3] + np.asarray(base_position, float), R @ F[20, :3, 0]


def entry_climb_goals(side: float, approach: float = 0.15, exit_height: float = 0.2) -> NDArray:
    """Goals of the paper's manoeuvre in the frame of the entry bay (front face x = 0).

    In front of the bottom-right opening of the front face, inside it, climbing
    on a quarter circle of radius ``side - incircle`` (0.354 m for 0.5 m bays),
    and out through the top opening above.
    """
    c = incircle_offset(side)
    r = side - c
    y = side - c
    arc = [(r * np.sin(a), side - r * np.cos(a)) for a in np.radians([20.0, 70.0])]
    return np.array(
        [
            [-approach, y, c],
            [arc[0][0], y, arc[0][1]],
            [arc[1][0], y, arc[1][1]],
            [r, y, side + exit_height],
        ]
    )


def paper_truss_world(
    *,
    side: float = 0.5,
    member_radius: float = 0.02,
    bays: tuple[int, int, int] = (1, 3, 2),
    standoff: float = 0.55,
    base_position: ArrayLike = (0.0, 0.0, 0.3),
    truss_offset: ArrayLike = (0.0, 0.0, 0.0),
    truss_rpy: ArrayLike = (0.0, 0.0, 0.0),
    name: str = "paper-truss",
    retract: bool = False,
    time_limit: float = 60.0,
) -> dict[str, Any]:
    """The paper's demo as a ``navstack-world/1`` dict.

    The robot stands with its lathe bed along world +x; the tip starts
    ``standoff`` [m] in front of the bottom-right opening of the front face of
    the truss's middle upper bay.  Goals: in front of the opening, inside it,
    climbing inside the bay, out through the top.  ``truss_offset`` [m] and
    ``truss_rpy`` [rad] move the *actual* truss away from its drawing (about
    the entry opening's centre) while the goals stay where the drawing puts
    them: the uncertain workspace of issue 4.  ``retract=True`` adds ``"retract": true`` (after the last
    goal the robot backs out along its path to its start; interfaces.md section 2a); ``time_limit`` [s].
    """
    tip, heading = robot_tip_start(base_position, PAPER_BASE_RPY)
    c = incircle_offset(side)
    entry_bay = np.array([0, bays[1] // 2, bays[2] - 1], dtype=float) * side
    # truss frame origin such that the entry opening's centre is `standoff` ahead of the tip
    entry_local = entry_bay + np.array([0.0, side - c, c])
    origin = tip + standoff * heading - entry_local
    goals = entry_climb_goals(side) + entry_bay + origin
    R = Rotation.from_euler("xyz", truss_rpy).as_matrix()
    pivot = origin + entry_local
    shift = np.asarray(truss_offset, dtype=float)
    obstacles = []
    for p0, p1 in truss_members(bays, side):
        a = R @ (origin + p0 - pivot) + pivot + shift
        b = R @ (origin + p1 - pivot) + pivot + shift
        obstacles.append({"type": "cylinder", "p0": _r(a), "p1": _r(b), "radius": member_radius})
    world = {
        "format": "navstack-world/1",
        "name": name,
        "description": (
            "The paper's demo: the serpentine reaches into a triangular opening of a box-bay truss "
            f"({bays[0]}x{bays[1]}x{bays[2]} bays of {side} m, members of radius {member_radius} m), "
            "climbs inside it and leaves through the top; the lathe bed does the insertion."
        ),
        "family": "truss",
        "robot": {
            "base": {"position": _r(base_position), "rpy": _r(PAPER_BASE_RPY)},
            "q0": _r(Q_DEFAULT),
            "serpentine_radius": 0.025,
            "arm_radius": 0.06,
        },
        "obstacles": obstacles,
        "goals": [{"position": _r(g), "tolerance": 0.02} for g in goals],
        "time_limit": float(time_limit),
    }
    if retract:
        world["retract"] = True
        world["description"] += " Then it retracts along its own path, all the way back out of the entry opening."
    return world


def _r(v: ArrayLike) -> list[float]:
    """Round to 0.1 micrometre for a readable file (well below any tolerance)."""
    return [round(float(x), 7) for x in np.asarray(v, dtype=float)]
