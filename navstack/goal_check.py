"""Goals that no tip can reach without touching an obstacle (a warning for ``check-world`` and ``run``).

A goal counts as reached when the tip point passes within the goal's ``tolerance``; the tip is the end of
the last serpentine capsule, a ball of ``serpentine_radius`` around it is robot surface.  A signed distance
``sdf`` (metres, negative inside) changes by at most the distance moved, so every point within ``tolerance``
of a goal at signed distance ``d`` from an obstacle has ``sdf <= d + tolerance``; the tip there is clear of
the obstacle only if ``sdf > serpentine_radius``.  So when ``d + tolerance <= serpentine_radius`` the goal
cannot be reached without contact (the bound is attained: the tolerance ball's point straight away from the
obstacle's nearest surface point, for a convex obstacle), and the trial can only end in ``collision`` or
``timeout``.  Such a world is a mistake its author wants to hear of, but it is not refused: it fails
honestly.  Only one obstacle at a time is considered (a goal shut in by several obstacles together is not
detected), and moving obstacles are skipped: they may move off the goal.

The same bound gives a softer warning (:func:`tight_goals`): a goal whose tolerance ball offers the tip less than
a margin of clearance from an obstacle (``0 < d + tolerance - serpentine_radius < margin``) can be reached without
contact, but the field planner, which keeps its ``tight_margin`` (5 mm) from every surface it senses, is not
expected to reach it (``worlds/hard11/near_wall_goal.json``: a goal 2 mm in front of a wall with a 27 mm
tolerance, 4 mm of room: 0 of 7 trials).

Exact for boxes, cylinders and spheres (:func:`navstack.sim.exact_distance.signed_distance`).  A mesh is a
surface to PyBullet: the distance to its nearest triangle, negative inside a closed mesh (the winding-number
test of :mod:`navstack.sim.mesh_inside`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from navstack.world import Mesh, World


@dataclass(frozen=True)
class BlockedGoal:
    """Goal ``goal`` (index into ``world.goals``) at signed distance ``distance`` (m, negative inside) from
    obstacle ``obstacle``: too close to be reached without contact."""

    goal: int
    obstacle: int
    distance: float

    def message(self, world: World) -> str:
        """One line naming both by their JSON paths, for a warning."""
        g = world.goals[self.goal]
        where = (f"{-self.distance:.3f} m inside" if self.distance < 0 else f"{self.distance:.3f} m from")
        return (f"goals[{self.goal}] at {np.round(g.position, 3).tolist()} lies {where} "
                f"obstacles[{self.obstacle}] (a {world.obstacles[self.obstacle].type}): with a tolerance of "
                f"{g.tolerance:g} m and a serpentine radius of {world.robot.serpentine_radius:g} m the tip "
                f"cannot reach it without contact, so no trial of this world can succeed")


@dataclass(frozen=True)
class TightGoal:
    """Goal ``goal`` that the tip can reach without contact, but only within ``room`` (m, > 0) of obstacle
    ``obstacle``, less than ``margin`` (m): the most clearance from it anywhere within the goal's tolerance."""

    goal: int
    obstacle: int
    room: float
    margin: float

    def message(self, world: World) -> str:
        """One line naming both by their JSON paths, for a warning."""
        g = world.goals[self.goal]
        return (f"goals[{self.goal}] at {np.round(g.position, 3).tolist()}: anywhere within its tolerance the "
                f"tip keeps at most {self.room * 1e3:.4f} mm from obstacles[{self.obstacle}] (a "
                f"{world.obstacles[self.obstacle].type}), less than the {self.margin * 1e3:g} mm the field "
                f"planner keeps from what it senses, so the field planner is not expected to reach it")


def blocked_goals(world: World) -> list[BlockedGoal]:
    """Every (goal, static obstacle) pair where the goal cannot be reached without contact (module docstring),
    in goal order, then obstacle order."""
    return [BlockedGoal(k, j, d) for k, j, d in _near_pairs(world, 0.0)]


def tight_goals(world: World, margin: float) -> list[TightGoal]:
    """Every (goal, static obstacle) pair where the tip can reach the goal without contact but cannot keep
    ``margin`` (m) from the obstacle anywhere within its tolerance: ``0 < d + tolerance - serpentine_radius <
    margin`` (module docstring: the most clearance from one obstacle the goal's tolerance ball offers), in goal
    order, then obstacle order."""
    r = world.robot.serpentine_radius
    rooms = [(k, j, d + world.goals[k].tolerance - r) for k, j, d in _near_pairs(world, margin)]
    return [TightGoal(k, j, room, margin) for k, j, room in rooms if 0.0 < room < margin]


def _near_pairs(world: World, slack: float) -> list[tuple[int, int, float]]:
    """``(goal, obstacle, signed distance in m)`` of every goal and static obstacle where the tip, anywhere
    within the goal's tolerance, keeps at most ``slack`` (m) from the obstacle: ``d + tolerance -
    serpentine_radius <= slack``; in goal order, then obstacle order."""
    from navstack.sim.exact_distance import signed_distance

    points = np.array([g.position for g in world.goals], dtype=np.float64).reshape(-1, 3)
    reach = np.array([g.tolerance for g in world.goals]) - world.robot.serpentine_radius - slack
    found: list[tuple[int, int, float]] = []
    for j, o in enumerate(world.obstacles):
        if getattr(o, "motion", None) is not None or len(points) == 0:
            continue
        d = (_mesh_signed_distance(o, points, -reach) if isinstance(o, Mesh) else signed_distance(o, points))
        found += [(int(k), j, float(d[k])) for k in np.flatnonzero(d + reach <= 0.0)]
    return sorted(found)


def _mesh_signed_distance(mesh: Mesh, points: NDArray[np.float64], within: NDArray[np.float64],
                          ) -> NDArray[np.float64]:
    """Signed distance (m, negative inside a closed mesh) from ``points`` (P, 3) [m, world] to the mesh
    obstacle's triangles; points farther than ``within`` (P,) [m] from the mesh's box get +inf, unmeasured."""
    import trimesh  # slow to import: only mesh worlds need it

    from navstack.sim.mesh_inside import points_inside

    vertices, faces = mesh.triangles()
    R = Rotation.from_euler("xyz", mesh.rpy).as_matrix()  # as mesh_inside places it
    local = (points - mesh.position) @ R  # R.T @ (p - position), row by row
    gap = np.linalg.norm(np.maximum(vertices.min(axis=0) - local, 0.0)
                         + np.maximum(local - vertices.max(axis=0), 0.0), axis=1)  # to the mesh's box
    out = np.full(len(points), np.inf)
    near = np.flatnonzero(gap <= np.maximum(within, 0.0))  # a point inside has gap 0
    if len(near) == 0:
        return out
    triangles = vertices[faces]
    for k in near:
        nearest = trimesh.triangles.closest_point(triangles, np.repeat(local[k][None], len(triangles), axis=0))
        out[k] = float(np.linalg.norm(nearest - local[k], axis=1).min())
    inside = points_inside(mesh, points[near])
    out[near[inside]] *= -1.0
    return out
