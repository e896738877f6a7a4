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


def blocked_goals(world: World) -> list[BlockedGoal]:
    """Every (goal, static obstacle) pair where the goal cannot be reached without contact (module docstring),
    in goal order, then obstacle order."""
    from navstack.sim.exact_distance import signed_distance

    points = np.array([g.position for g in world.goals], dtype=np.float64).reshape(-1, 3)
    reach = np.array([g.tolerance for g in world.goals]) - world.robot.serpentine_radius
    found: list[BlockedGoal] = []
    for j, o in enumerate(world.obstacles):
        if getattr(o, "motion", None) is not None or len(points) == 0:
            continue
        d = (_mesh_signed_distance(o, points, -reach) if isinstance(o, Mesh) else signed_distance(o, points))
        found += [BlockedGoal(int(k), j, float(d[k])) for k in np.flatnonzero(d + reach <= 0.0)]
    return sorted(found, key=lambda b: (b.goal, b.obstacle))


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
