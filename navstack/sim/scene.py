"""The obstacles of a :class:`~navstack.world.World` as PyBullet bodies, their motion, and clearance queries.

Obstacles are known to the simulator only: this module is the one place that turns obstacle geometry
into simulator bodies.  The planner and controller must never import it or read ``world.obstacles``.

Geometry (metres, radians):

* cylinder: ``GEOM_CYLINDER`` (flat-ended, local z axis) centred at the midpoint of ``p0``-``p1`` and
  rotated so that its z axis runs from ``p0`` to ``p1``;
* box: ``GEOM_BOX`` with the world's ``rpy`` (roll X, pitch Y, yaw Z of the world, in that order);
* sphere: ``GEOM_SPHERE``;
* mesh: loaded with trimesh, vertices multiplied by ``scale``, and given to PyBullet as vertices + indices,
  which PyBullet turns into a static concave triangle mesh (``btBvhTriangleMeshShape``).

Moving obstacles (a primitive with ``motion``, interfaces.md section 2b) get a body of their own each
(mass 0, like every obstacle: moved by the scene, never by the physics).  :meth:`Scene.update` places them
at a simulated time t: translated by ``motion.displacement(t)`` from their pose in the file, never
rotated (``resetBasePositionAndOrientation``).  The trial calls it once per control step, then
``performCollisionDetection`` so rays and clearance queries see the new positions, and
:meth:`Scene.swept_clearance` for the contacts a mover could make between two control steps.  Only the
simulator knows the motion.

Performance choice (measured on a 40-cylinder truss with a 9-capsule chain inside it, pybullet 3.2.7,
median of 9 x 50 queries): the primitives are packed into compound bodies of at most 16 children
(``createCollisionShapeArray``; PyBullet keeps at most 16, so the packing is chunked: 40 cylinders make
3 bodies).  A clearance query took 31-35 us that way against 250-490 us with one body per cylinder
(8-16x faster).  :meth:`Scene.clearance` also asks with small thresholds first (0.05, 0.15, 0.4 m, then
``max_distance``): this is exact, because the first threshold that reports any point bounds the minimum,
and 13-15x cheaper than one ``max_distance=1`` pass (about 460 us), since PyBullet returns one Python
tuple per shape pair within the threshold.  ``SceneOptions(combine_primitives=False)`` builds one body
per obstacle for comparison.

PyBullet limitations found (pybullet 3.2.7):

* a triangle mesh is a surface: a robot part entirely *inside* a closed mesh reports the (positive)
  distance to the nearest triangle, not a penetration (the start check asks :mod:`navstack.sim.mesh_inside`),
  and a part pushed into one the depth below the facets it touches, not below the surface: a mesh read within
  :data:`MARGIN` of a contact, and a closed mesh once penetrated, are measured exactly
  (:mod:`navstack.sim.mesh_depth`, in :meth:`Scene.clearance`);
* ``createCollisionShapeArray`` keeps at most 16 children and silently drops the rest, and
  ``createVisualShapeArray`` with more than 16 crashed the process, hence the chunking;
* collision shapes ask for a cylinder's ``height``, visual shapes for its ``length``;
* a triangle mesh gets a 1 mm collision margin by default, which grows its triangles outwards: every
  distance between a link's capsule and a mesh read 1.000 mm short (measured; a sphere's was exact), so mesh
  bodies get none (:data:`MESH_MARGIN`; rays and the start check are unaffected);
* boxes and cylinders get a 1 mm collision margin that rounds their corners, edges and rims, so PyBullet's
  distance there reads up to 0.73 mm more than the true one (zero margin would make rays miss boxes): every
  distance PyBullet reports within that margin of 0 (or of ``exact_below``, a trial's smallest clearance so
  far) is computed again exactly (:mod:`navstack.sim.exact_distance`), so no contact hides in the rounding
  and a trial's ``min_clearance`` is exact.  A box or cylinder thinner than that margin reads up to 1.9 mm
  *less* than the true distance (a 0.3 mm gap to a 1 mm wire read as a 0.4 mm penetration): for a robot of
  capsules the exact distances alone decide, PyBullet's only choosing when and which primitives to measure
  (:data:`THIN_SLACK`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from navstack.sim._bullet import pybullet as p
from navstack.sim.exact_distance import MARGIN, ROW, member_distances, primitive_row
from navstack.sim.mesh_depth import MeshContacts
from navstack.sim.mover_sweep import MoverSweeps
from navstack.world import Box, Cylinder, Mesh, Motion, Obstacle, Sphere, World, WorldError

Capsules = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""A robot's collision capsules ``(a, b, r)``: segments ``a[k]``-``b[k]`` (K, 3) [m] of radii ``r[k]`` (K,) [m]."""

_NONE = np.zeros(0, dtype=np.int64)

MAX_COMPOUND_CHILDREN = 16
"""PyBullet keeps at most this many shapes in one ``createCollisionShapeArray`` / visual array."""

CLEARANCE_STAGES = (0.05, 0.15, 0.4)
"""Thresholds (m) tried before ``max_distance`` in :meth:`Scene.clearance` (an exact speed-up)."""

BOX_SLACK = 1e-3
"""Subtracted (m) from the box lower bounds of :meth:`Scene.clearance`, so that rounding in PyBullet's
distances or in the caller's link boxes can never make a skipped body or stage matter."""

MESH_MARGIN = 0.0
"""PyBullet's collision margin (m) for mesh bodies: none (the default 1 mm made distances to meshes read 1 mm
short; module doc)."""

THIN_SLACK = 3e-3
"""How much lower than the true distance (m), beyond :data:`MARGIN`, PyBullet may read a box or cylinder thinner than
its 1 mm margin: measured up to 1.74 mm for a 0.1 mm wire and a sphere, 1.9 mm in a review's probes (0 from a
thickness of 1 mm on).  The exact check of such a scene looks this much farther, so the nearest primitive is
always among those it measures."""

LARGE_EXTENT = 10.0
"""Metres: a primitive longer or wider than this is measured exactly at every :meth:`Scene.clearance` query, not
only when PyBullet reads it near.  PyBullet's distance to a cylinder 1-3 km long and 1-2 cm thick read 1.4-14 mm
high in 1-3 % of placements beside it (an audit, session 29; none seen up to 1 km, nor for boxes), which hid a
5 um contact: a wrong success.  Every shape of the families and the demo is far below this size."""


@dataclass(frozen=True)
class SceneOptions:
    """How obstacles become bodies.

    Attributes:
        combine_primitives: pack cylinders/boxes/spheres into compound bodies (faster queries); False
            makes one body per obstacle (for comparison and debugging).
        primitive_rgba: colour of cylinders, boxes and spheres (grey-blue) in rendered pictures.
        mesh_rgba: colour of meshes.
        visuals: give the bodies visual shapes, which only pictures use (without them a scene is built in
            about 60 % of the time; rays, contacts and distances use the collision shapes either way).
    """

    combine_primitives: bool = True
    primitive_rgba: tuple[float, float, float, float] = (0.55, 0.62, 0.75, 1.0)
    mesh_rgba: tuple[float, float, float, float] = (0.45, 0.5, 0.6, 1.0)
    visuals: bool = True


def _quat_xyzw_from_rpy(rpy: np.ndarray) -> list[float]:
    """PyBullet quaternion (x, y, z, w) of roll X, pitch Y, yaw Z about the world axes, in that order."""
    return Rotation.from_euler("xyz", rpy).as_quat().tolist()


def _quat_z_to(direction: np.ndarray) -> list[float]:
    """Quaternion (x, y, z, w) of the shortest rotation taking +z onto ``direction`` (any length > 0)."""
    d = direction / np.linalg.norm(direction)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, d)
    s = float(np.linalg.norm(axis))
    c = float(d[2])
    if s < 1e-12:
        return [0.0, 0.0, 0.0, 1.0] if c > 0 else [1.0, 0.0, 0.0, 0.0]
    return Rotation.from_rotvec(axis / s * math.atan2(s, c)).as_quat().tolist()


@dataclass
class _Primitive:
    """One primitive in the form both PyBullet shape calls want (frame pose in the world)."""

    shape: int
    radius: float
    half_extents: list[float]
    length: float
    position: list[float]
    orientation: list[float]


def _primitive(o: Obstacle) -> _Primitive:
    if isinstance(o, Cylinder):
        return _Primitive(p.GEOM_CYLINDER, o.radius, [0.0, 0.0, 0.0], o.length,
                          ((o.p0 + o.p1) / 2.0).tolist(), _quat_z_to(o.p1 - o.p0))
    if isinstance(o, Box):
        return _Primitive(p.GEOM_BOX, 0.0, o.half_extents.tolist(), 0.0, o.center.tolist(),
                          _quat_xyzw_from_rpy(o.rpy))
    if isinstance(o, Sphere):
        return _Primitive(p.GEOM_SPHERE, o.radius, [0.0, 0.0, 0.0], 0.0, o.center.tolist(), [0.0, 0.0, 0.0, 1.0])
    raise TypeError(f"not a primitive obstacle: {type(o).__name__}")


def _check_id(value: int, what: str) -> int:
    if value < 0:
        raise RuntimeError(f"PyBullet failed to create {what} (returned {value})")
    return value


@dataclass(frozen=True)
class _Mover:
    """A moving obstacle's body and its pose at zero displacement (the pose the world file gives)."""

    index: int
    body: int
    position: np.ndarray
    orientation: list[float]
    motion: Motion


@dataclass
class Scene(MoverSweeps):
    """The obstacle bodies of one world in one PyBullet client.

    Attributes:
        client: the ``pybullet_utils.bullet_client.BulletClient`` the bodies live in.
        world: the world they were built from.
        body_ids: ids of all obstacle bodies (compound bodies hold several primitives).
        obstacle_body: for each ``world.obstacles[i]``, the id of the body that holds it.
        time: the simulated time (s) the moving obstacles were last placed at (:meth:`update`).
    """

    client: Any
    world: World
    body_ids: tuple[int, ...]
    obstacle_body: tuple[int, ...]
    options: SceneOptions = field(default_factory=SceneOptions)
    movers: tuple[_Mover, ...] = ()
    time: float = 0.0
    boxes: tuple[NDArray[np.float64], NDArray[np.float64]] | None = field(default=None, compare=False, repr=False)
    """``(lo, hi)``, each (len(world.obstacles), 3) [m]: a world box holding each obstacle where it is now
    (moving ones follow :meth:`update`); for :meth:`clearance`'s ``robot_boxes``."""
    _file_boxes: tuple[NDArray[np.float64], NDArray[np.float64]] | None = field(default=None, init=False,
                                                                               compare=False, repr=False)
    _body_rank: NDArray[np.int64] | None = field(default=None, init=False, compare=False, repr=False)
    """For each obstacle, the position of its body in :attr:`body_ids`."""
    _capsules: dict[int, list[tuple[int, np.ndarray, np.ndarray, float]]] = field(
        default_factory=dict, init=False, compare=False, repr=False)
    """robot body -> its links' collision capsules in their own frames (:func:`_link_capsules`' cache)."""
    _rows: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, ROW)), init=False, compare=False,
                                       repr=False)
    """(len(world.obstacles), ROW): each primitive for :func:`member_distances` (NaN rows: meshes)."""
    _shifts: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)), init=False, compare=False,
                                         repr=False)
    """(len(world.obstacles), 3) [m]: each obstacle's translation from its file pose now (movers')."""
    _primitives: dict[int, NDArray[np.int64]] = field(default_factory=dict, init=False, compare=False, repr=False)
    """body -> the indices in ``world.obstacles`` of the primitives it holds."""
    _thin_slack: float = field(default=0.0, init=False, compare=False, repr=False)
    """m: how much more than :data:`MARGIN` PyBullet's distance may read below the true one (:data:`THIN_SLACK`
    with a box or cylinder thinner than its margin, else 0)."""
    _capsule_robots: dict[int, bool] = field(default_factory=dict, init=False, compare=False, repr=False)
    """robot body -> whether every collision shape it has is a capsule or a sphere (:meth:`_all_capsules`)."""
    _large: frozenset[int] = field(default=frozenset(), init=False, compare=False, repr=False)
    """The bodies holding a primitive larger than :data:`LARGE_EXTENT`, which :meth:`clearance` always measures
    exactly."""
    _meshes: MeshContacts = field(default_factory=lambda: MeshContacts({}, MARGIN), init=False, compare=False,
                                  repr=False)
    """The mesh bodies, measured exactly near a contact and once entered (:mod:`navstack.sim.mesh_depth`)."""

    @classmethod
    def build(cls, client: Any, world: World, options: SceneOptions | None = None) -> Scene:
        """Create every obstacle of ``world`` as a mass-0 body in ``client``, moving ones at t = 0.

        Raises:
            WorldError: a mesh file cannot be read (it was readable when the world was loaded).
            RuntimeError: PyBullet refused to create a shape or body.
        """
        opts = options or SceneOptions()
        body_of: list[int] = [-1] * len(world.obstacles)
        bodies: list[int] = []
        prims = [(i, o) for i, o in enumerate(world.obstacles) if not isinstance(o, Mesh) and o.motion is None]
        if opts.combine_primitives:
            for s in range(0, len(prims), MAX_COMPOUND_CHILDREN):
                chunk = prims[s:s + MAX_COMPOUND_CHILDREN]
                b = _compound_body(client, [_primitive(o) for _, o in chunk], opts.primitive_rgba, opts.visuals)
                bodies.append(b)
                for i, _ in chunk:
                    body_of[i] = b
        else:
            for i, o in prims:
                b = _single_body(client, _primitive(o), opts.primitive_rgba, opts.visuals)
                bodies.append(b)
                body_of[i] = b
        movers = []
        for i, o in enumerate(world.obstacles):
            if isinstance(o, Mesh):
                b = _mesh_body(client, o, i, opts.mesh_rgba, opts.visuals)
            elif o.motion is not None:
                q = _primitive(o)
                b = _single_body(client, q, opts.primitive_rgba, opts.visuals)
                movers.append(_Mover(i, b, np.array(q.position), q.orientation, o.motion))
            else:
                continue
            bodies.append(b)
            body_of[i] = b
        scene = cls(client=client, world=world, body_ids=tuple(bodies), obstacle_body=tuple(body_of),
                    options=opts, movers=tuple(movers), boxes=_obstacle_boxes(client, world, body_of))
        scene._file_boxes = (scene.boxes[0].copy(), scene.boxes[1].copy())
        rank = {b: k for k, b in enumerate(bodies)}
        scene._body_rank = np.array([rank[b] for b in body_of], dtype=np.int64)
        scene._rows = np.array([np.full(ROW, np.nan) if isinstance(o, Mesh) else primitive_row(o)
                                for o in world.obstacles]).reshape(-1, ROW)
        scene._shifts = np.zeros((len(world.obstacles), 3))
        members: dict[int, list[int]] = {b: [] for b in bodies}
        for i, o in enumerate(world.obstacles):
            if not isinstance(o, Mesh):
                members[body_of[i]].append(i)
        scene._primitives = {b: np.array(m, dtype=np.int64) for b, m in members.items()}
        scene._thin_slack = THIN_SLACK if any(_thinner_than_margin(o) for o in world.obstacles) else 0.0
        scene._large = frozenset(body_of[i] for i, o in enumerate(world.obstacles) if _larger_than(o, LARGE_EXTENT))
        scene._meshes = MeshContacts({body_of[i]: o for i, o in enumerate(world.obstacles) if isinstance(o, Mesh)},
                                     MARGIN)
        scene.update(0.0)
        return scene

    def update(self, t: float) -> bool:
        """Place the moving obstacles at simulated time ``t`` (s): each translated by its
        ``motion.displacement(t)`` (m) from its pose in the world file.  Returns whether the scene has
        moving obstacles (then call ``performCollisionDetection`` before querying distances or rays)."""
        self.time = float(t)
        for m in self.movers:
            shift = m.motion.displacement(self.time)
            position = m.position + shift
            self.client.resetBasePositionAndOrientation(m.body, position.tolist(), m.orientation)
            self._place_exact(m.index, shift)
        return bool(self.movers)

    def _place_exact(self, index: int, shift: NDArray[np.float64]) -> None:
        """Where the exact distances and :attr:`boxes` see obstacle ``index``: translated by ``shift`` (m) from
        its file pose."""
        self._shifts[index] = shift
        if self.boxes is not None and self._file_boxes is not None:
            self.boxes[0][index] = self._file_boxes[0][index] + shift
            self.boxes[1][index] = self._file_boxes[1][index] + shift

    def touching(self, robot_id: int) -> list[tuple[int, float]]:
        """The obstacles that ``robot_id`` touches or penetrates now (signed distance <= 0), as
        ``(index in world.obstacles, signed distance in m)`` sorted by index.

        A compound body that touches is resolved child by child with temporary bodies, so each obstacle
        is named on its own; every primitive within :data:`MARGIN` of a link is measured exactly too, so a
        contact PyBullet's rounded corners hide is named, and a primitive's depth is the exact one (as in
        :meth:`clearance`; a mesh's is PyBullet's here).  Here a robot part inside a closed mesh is not seen (module
        doc; :mod:`navstack.sim.mesh_inside` tells the start check, which is what calls this).
        """
        cl = self.client
        out: dict[int, float] = {}
        for b in self.body_ids:
            d = _min_distance(cl, robot_id, b) if self._pybullet_judges(robot_id, b) else math.inf
            if d > 0.0:
                continue
            members = [i for i, body in enumerate(self.obstacle_body) if body == b]
            if len(members) == 1:
                out[members[0]] = d
                continue
            for i in members:  # a compound body: which of its primitives?
                tmp = _single_body(cl, _primitive(self.world.obstacles[i]), self.options.primitive_rgba)
                try:
                    di = _min_distance(cl, robot_id, tmp)
                finally:
                    cl.removeBody(tmp)
                if di <= 0.0:
                    out[i] = di
        for i, d in self._exact_distances(_link_capsules(cl, robot_id, self._capsules), self.body_ids, MARGIN):
            if d <= 0.0:  # the exact depth (as in clearance), and what PyBullet's rounding hides
                out[i] = d
        return sorted(out.items())

    def clearance(self, robot_id: int, max_distance: float = 1.0,
                  robot_boxes: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
                  exact_below: float = 0.0, robot_capsules: Capsules | None = None) -> float:
        """Minimum signed distance (m) between any link of ``robot_id`` and any obstacle.

        Negative means penetration.  Returns ``max_distance`` when nothing is closer than that.  Uses
        ``getClosestPoints``; the caller has already called ``stepSimulation`` or
        ``performCollisionDetection`` (or reset the robot's state) so link poses are current.

        ``robot_boxes``: ``(lo, hi)``, each (L, 3) [m], world boxes that together hold every collision
        shape of ``robot_id`` now (:meth:`navstack.sim.body.RobotBody.link_boxes`).  With them, the
        distance between those boxes and each obstacle's box (:attr:`boxes`), less :data:`BOX_SLACK`, bounds
        each body's distance from below: a threshold below every bound is not tried, and a body whose bound
        is not below the threshold is not asked (it cannot report a closer point).  The result is the
        same number; obstacles far from the robot then cost one box test each.

        PyBullet's rounded box corners, edges and cylinder rims read up to 0.73 mm high, which could hide a
        contact.  So when PyBullet's smallest distance is below ``max(exact_below, 0)`` + :data:`MARGIN`, every
        primitive near the robot is measured again exactly (:meth:`_sharpen`): the result is exact whenever the
        true clearance is below ``exact_below`` (m) or 0 (a contact is never hidden), and otherwise not below
        ``exact_below``.  A mesh is measured exactly likewise where PyBullet reads it within :data:`MARGIN` of a
        contact, and at every query once the robot has been inside it (:class:`~navstack.sim.mesh_depth.
        MeshContacts`).  A trial passes its smallest clearance so far, which makes its ``min_clearance``
        exact.  ``robot_capsules``: ``(a, b, r)``, the robot's collision capsules now (segments ``a``-``b``,
        each (K, 3) [m], radii (K,) [m]); without them they are read from PyBullet.
        """
        try:
            dmax = float(max_distance)
        except (TypeError, ValueError):
            dmax = math.nan
        if isinstance(max_distance, bool) or not (math.isfinite(dmax) and dmax > 0.0):
            raise ValueError(f"Scene.clearance: max_distance must be a positive finite number of metres, "
                             f"got {max_distance!r}")
        cl = self.client
        thresholds = [t for t in CLEARANCE_STAGES if t < dmax] + [dmax]
        bodies = self.body_ids
        if robot_boxes is not None and self.boxes is not None and self._body_rank is not None and bodies:
            lo, hi = (np.ascontiguousarray(a, dtype=np.float64) for a in robot_boxes)
            if lo.ndim != 2 or lo.shape[1:] != (3,) or hi.shape != lo.shape or not len(lo):
                raise ValueError(f"Scene.clearance: robot_boxes must be two (L, 3) arrays, got shapes "
                                 f"{lo.shape} and {hi.shape}")
            gaps = np.empty(len(bodies))
            _body_gaps(lo, hi, self.boxes[0], self.boxes[1], self._body_rank, dmax + BOX_SLACK, BOX_SLACK, gaps)
            bound = gaps.tolist()
        else:
            bound = [-math.inf] * len(bodies)  # no boxes: every body may be near
        prims = self._primitives
        out, reached, meshes = dmax, dmax, {}
        for d in thresholds:
            best, meshes = d, {}  # PyBullet's smallest distance to the primitives; to each mesh closer than d
            for b, g in zip(bodies, bound, strict=True):
                if g < d:
                    near = min((pt[8] for pt in cl.getClosestPoints(robot_id, b, d)), default=d)
                    if len(prims[b]):
                        best = min(best, near)
                    elif near < d:
                        meshes[b] = float(near)
            if best < d or meshes:
                out = self._sharpen(robot_id, float(best), float(exact_below), robot_capsules, bodies, bound)
                reached = d
                break
        if meshes or self._meshes.entered:  # exact near a contact, and inside a mesh entered (mesh_depth)
            if robot_capsules is None and self._meshes.needs_capsules(meshes):
                robot_capsules = _link_capsules(cl, robot_id, self._capsules)
            out = min(out, self._meshes.clearance(meshes, reached, float(exact_below), robot_capsules,
                                                  self._all_capsules(robot_id)))
        if self._large:
            out = min(out, _large_exact(self, robot_id, dmax, robot_capsules, bodies, bound))
        return out

    def _sharpen(self, robot_id: int, best: float, exact_below: float, capsules: Capsules | None,
                 bodies: Sequence[int], bound: Sequence[float] | None = None) -> float:
        """``best``, PyBullet's smallest distance (m) to the primitives of ``bodies``, made exact when the true one
        could be below ``exact_below`` or 0 (``best`` below their larger + :data:`MARGIN`): the primitives of
        ``bodies`` (those whose lower ``bound`` (m) on their distance, if given, is below ``best`` +
        :data:`MARGIN`) are measured again against the robot's ``capsules`` (read from PyBullet if None) wherever
        they may be within ``max(best, 0)`` + :data:`MARGIN` (:mod:`navstack.sim.exact_distance`).  A penetration
        (``best`` <= 0) is measured the same way, as the depth of the capsule's deepest ball below the
        primitive's surface.  For a robot made of capsules and spheres alone (:meth:`_all_capsules`: the
        exact test then covers every pair PyBullet measured, and the nearest primitive is within ``best`` +
        :data:`MARGIN` + the thin shapes' slack) the exact minimum is the answer: a box or cylinder thinner than
        PyBullet's 1 mm margin reads up to 1.9 mm *low* (measured: a 1 mm wire 0.3 mm from a link read
        -0.4 mm, a contact that never happened; :data:`THIN_SLACK`).  For other robots PyBullet's distance is
        kept where it is lower (its shapes the exact test does not know), unless the exact test finds a
        penetration: then its depth (PyBullet's estimate, the shift that would separate the two, was up to 8
        mm deeper in a measured case)."""
        if not best < max(exact_below, 0.0) + MARGIN:
            return best
        within = max(best, 0.0) + MARGIN + self._thin_slack
        near = bodies if bound is None else [b for b, g in zip(bodies, bound, strict=True) if g < within]
        caps = capsules if capsules is not None else _link_capsules(self.client, robot_id, self._capsules)
        exact = [d for _, d in self._exact_distances(caps, near, within)]
        if exact and self._all_capsules(robot_id):
            return min(exact)  # every pair that could be nearest, measured exactly: PyBullet's number only chose
        if best <= 0.0 and exact and min(exact) <= 0.0:
            return min(exact)  # a penetration's depth: the deepest ball of a capsule, not PyBullet's estimate
        return min([best] + exact)

    def _all_capsules(self, robot_id: int) -> bool:
        """Whether every link of ``robot_id`` (and its base) has no collision shape or one capsule or sphere, the
        shapes :func:`_link_capsules` reads and the exact distances measure (cached per robot)."""
        known = self._capsule_robots.get(robot_id)
        if known is None:
            cl = self.client
            shapes = (cl.getCollisionShapeData(robot_id, link) for link in range(-1, cl.getNumJoints(robot_id)))
            known = all(len(s) == 0 or (len(s) == 1 and s[0][2] in (p.GEOM_CAPSULE, p.GEOM_SPHERE)) for s in shapes)
            self._capsule_robots[robot_id] = known
        return known

    def _pybullet_judges(self, robot_id: int, body: int) -> bool:
        """Whether PyBullet's own distances between ``robot_id`` and ``body`` decide a contact: not for a body of
        primitives against a robot of capsules (:meth:`_all_capsules`), which the exact distances measure."""
        return not (len(self._primitives.get(body, _NONE)) and self._all_capsules(robot_id))

    def _exact_distances(self, capsules: Capsules, bodies: Sequence[int], within: float) -> list[tuple[int, float]]:
        """``(obstacle index, exact signed distance in m)`` of each primitive of ``bodies`` within ``within`` (m)
        of a capsule's box (the others are farther than ``within``)."""
        members = [self._primitives.get(b, _NONE) for b in bodies]
        idx = np.concatenate(members) if members else _NONE
        if not len(idx) or self.boxes is None or not len(capsules[2]):
            return []
        out = np.empty(len(idx))
        member_distances(self._rows, idx, self._shifts, self.boxes[0], self.boxes[1], *capsules, within, out)
        return [(int(i), float(d)) for i, d in zip(idx, out, strict=True) if d < math.inf]

    def contact_links(self, robot_id: int) -> frozenset[int]:
        """The links of ``robot_id`` (PyBullet link indices, -1 the base) that touch or penetrate an obstacle now
        (signed distance <= 0): PyBullet's closest points at distance 0, and each capsule or sphere link
        measured exactly as in :meth:`touching`, so the pictures' red links agree with the ``contacts`` metric."""
        cl = self.client
        links = {int(pt[3]) for b in self.body_ids if self._pybullet_judges(robot_id, b)
                 for pt in cl.getClosestPoints(robot_id, b, 0.0) if pt[8] <= 0.0}
        a, b, r = _link_capsules(cl, robot_id, self._capsules)
        for k, (link, *_) in enumerate(self._capsules[robot_id]):
            one = a[k:k + 1], b[k:k + 1], r[k:k + 1]
            if link not in links and any(d <= 0.0 for _, d in self._exact_distances(one, self.body_ids, MARGIN)):
                links.add(link)
        return frozenset(links)

    def in_contact(self, robot_id: int) -> bool:
        """True if any link of ``robot_id`` touches or penetrates an obstacle (distance <= 0 m), judged
        from the last step's contact points and from :meth:`touching`."""
        cl = self.client
        for b in self.body_ids:
            if self._pybullet_judges(robot_id, b) and any(pt[8] <= 0.0 for pt in cl.getContactPoints(robot_id, b)):
                return True
        return bool(self.touching(robot_id))

    def remove(self) -> None:
        """Remove the obstacle bodies from the client (the scene is unusable afterwards)."""
        for b in self.body_ids:
            self.client.removeBody(b)
        self.body_ids = ()
        self.obstacle_body = ()
        self.movers = ()


@numba.njit(cache=True)
def _body_gaps(link_lo, link_hi, lo, hi, rank, cutoff, slack, out):  # pragma: no cover - jitted
    """``out[b]``: a lower bound [m] of the distance between the robot's link boxes (``link_lo``, ``link_hi``,
    (L, 3)) and the obstacles of body ``b`` (rows ``m`` of ``lo``, ``hi`` with ``rank[m] == b``): the
    smallest box-to-box distance less ``slack``; ``inf`` when no box of the body is within ``cutoff`` of the
    box around all links (one test for a far obstacle)."""
    n_links = link_lo.shape[0]
    rlo = np.empty(3)
    rhi = np.empty(3)
    for c in range(3):
        rlo[c] = link_lo[0, c]
        rhi[c] = link_hi[0, c]
        for k in range(1, n_links):
            rlo[c] = min(rlo[c], link_lo[k, c])
            rhi[c] = max(rhi[c], link_hi[k, c])
    out[:] = np.inf
    c2 = cutoff * cutoff
    for m in range(lo.shape[0]):
        g2 = 0.0
        for c in range(3):
            e = max(lo[m, c] - rhi[c], rlo[c] - hi[m, c], 0.0)
            g2 += e * e
        if g2 >= c2:
            continue
        best = np.inf
        for k in range(n_links):
            g2 = 0.0
            for c in range(3):
                e = max(lo[m, c] - link_hi[k, c], link_lo[k, c] - hi[m, c], 0.0)
                g2 += e * e
            best = min(best, g2)
        g = np.sqrt(best) - slack
        if g < out[rank[m]]:
            out[rank[m]] = g


def _obstacle_boxes(client: Any, world: World, body_of: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """World boxes (lo, hi) [m] holding each obstacle at its pose in the file: from the geometry for
    primitives, PyBullet's ``getAABB`` of its body for a mesh."""
    n = len(world.obstacles)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    for i, o in enumerate(world.obstacles):
        if isinstance(o, Cylinder):
            lo[i] = np.minimum(o.p0, o.p1) - o.radius
            hi[i] = np.maximum(o.p0, o.p1) + o.radius
        elif isinstance(o, Box):
            half = np.abs(Rotation.from_euler("xyz", o.rpy).as_matrix()) @ o.half_extents
            lo[i], hi[i] = o.center - half, o.center + half
        elif isinstance(o, Sphere):
            lo[i], hi[i] = o.center - o.radius, o.center + o.radius
        else:
            a, b = client.getAABB(body_of[i])
            lo[i], hi[i] = a, b
    return lo, hi


def _link_capsules(client: Any, body: int, cache: dict[int, list[tuple[int, np.ndarray, np.ndarray, float]]],
                   ) -> Capsules:
    """The world segments ``(a, b)`` ((K, 3) [m]) and radii ((K,) [m]) of the collision capsules of ``body``'s
    links and base (a sphere is one of length 0; links of other shapes are left out), from PyBullet's shape
    data (read once into ``cache``) and its link states now."""
    if body not in cache:
        cache[body] = []
        for link in range(-1, client.getNumJoints(body)):
            shapes = client.getCollisionShapeData(body, link)
            if len(shapes) != 1 or shapes[0][2] not in (p.GEOM_CAPSULE, p.GEOM_SPHERE):
                continue
            geom = shapes[0]
            capsule = geom[2] == p.GEOM_CAPSULE
            half = Rotation.from_quat(geom[6]).apply([0.0, 0.0, geom[3][0] / 2.0 if capsule else 0.0])
            centre = np.asarray(geom[5], dtype=np.float64)
            cache[body].append((link, centre - half, centre + half, float(geom[3][1] if capsule else geom[3][0])))
    a, b, r = [], [], []
    links = [link for link, *_ in cache[body] if link >= 0]
    states = {} if not links else dict(zip(links, client.getLinkStates(body, links, computeForwardKinematics=1),
                                           strict=True))
    for link, la, lb, radius in cache[body]:
        pos, orn = client.getBasePositionAndOrientation(body) if link < 0 else states[link][:2]
        rot = Rotation.from_quat(orn)
        a.append(rot.apply(la) + pos)
        b.append(rot.apply(lb) + pos)
        r.append(radius)
    return np.array(a).reshape(-1, 3), np.array(b).reshape(-1, 3), np.array(r, dtype=np.float64)


def _large_exact(scene: Scene, robot_id: int, dmax: float, capsules: Capsules | None, bodies: Sequence[int],
                 bound: Sequence[float]) -> float:
    """The exact distance (m) from the robot's capsules to the primitives of ``scene``'s bodies larger than
    :data:`LARGE_EXTENT` (whose lower ``bound`` is below ``dmax``), or ``dmax`` (also for a robot not made of
    capsules, whose other shapes only PyBullet measures)."""
    large = [b for b, g in zip(bodies, bound, strict=True) if b in scene._large and g < dmax]
    if not large or not scene._all_capsules(robot_id):
        return dmax
    caps = capsules if capsules is not None else _link_capsules(scene.client, robot_id, scene._capsules)
    return min((d for _, d in scene._exact_distances(caps, large, dmax)), default=dmax)


def _larger_than(o: Any, size: float) -> bool:
    """Whether primitive ``o`` (not a mesh) is longer or wider than ``size`` [m]."""
    if isinstance(o, Cylinder):
        return max(o.length, 2.0 * o.radius) > size
    if isinstance(o, Box):
        return 2.0 * float(np.max(o.half_extents)) > size
    if isinstance(o, Sphere):
        return 2.0 * o.radius > size
    return False


def _thinner_than_margin(o: Any) -> bool:
    """Whether ``o`` is a box or cylinder with a half extent, radius or half length below :data:`MARGIN`, which
    PyBullet's distances read too low (a sphere's margin is its radius: exact; a mesh has none)."""
    if isinstance(o, Box):
        return float(np.min(o.half_extents)) < MARGIN
    if isinstance(o, Cylinder):
        return min(o.radius, 0.5 * o.length) < MARGIN
    return False


def _min_distance(client: Any, robot_id: int, body: int) -> float:
    """Smallest signed distance (m) between ``robot_id`` and ``body`` if <= 0, else ``inf``."""
    return min((pt[8] for pt in client.getClosestPoints(robot_id, body, 0.0)), default=math.inf)


def _compound_body(client: Any, prims: Sequence[_Primitive], rgba: Sequence[float], visuals: bool = True) -> int:
    n = len(prims)
    shapes = [q.shape for q in prims]
    radii = [q.radius for q in prims]
    half = [q.half_extents for q in prims]
    lengths = [q.length for q in prims]
    pos = [q.position for q in prims]
    orn = [q.orientation for q in prims]
    cs = _check_id(client.createCollisionShapeArray(
        shapeTypes=shapes, radii=radii, halfExtents=half, lengths=lengths,
        collisionFramePositions=pos, collisionFrameOrientations=orn), "a compound collision shape")
    vs = -1 if not visuals else _check_id(client.createVisualShapeArray(
        shapeTypes=shapes, radii=radii, halfExtents=half, lengths=lengths,
        visualFramePositions=pos, visualFrameOrientations=orn, rgbaColors=[list(rgba)] * n),
        "a compound visual shape")
    return _check_id(client.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=cs, baseVisualShapeIndex=vs,
                                            basePosition=[0.0, 0.0, 0.0]), "an obstacle body")


def _single_body(client: Any, q: _Primitive, rgba: Sequence[float], visuals: bool = True) -> int:
    if q.shape == p.GEOM_CYLINDER:  # PyBullet names a cylinder's length "height" for collision, "length" for visual
        col, vis = {"radius": q.radius, "height": q.length}, {"radius": q.radius, "length": q.length}
    elif q.shape == p.GEOM_BOX:
        col = vis = {"halfExtents": q.half_extents}
    else:
        col = vis = {"radius": q.radius}
    cs = _check_id(client.createCollisionShape(q.shape, **col), "a collision shape")
    vs = -1 if not visuals else _check_id(client.createVisualShape(q.shape, rgbaColor=list(rgba), **vis),
                                          "a visual shape")
    return _check_id(client.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=cs, baseVisualShapeIndex=vs,
                                            basePosition=q.position, baseOrientation=q.orientation),
                     "an obstacle body")


def _mesh_body(client: Any, m: Mesh, index: int, rgba: Sequence[float], visuals: bool = True) -> int:
    try:
        vertices, faces = m.triangles()
    except WorldError as e:
        raise WorldError(e.detail, file=e.file, json_path=f"obstacles[{index}].path") from e
    v = vertices.tolist()
    idx = faces.ravel().tolist()
    # vertices + indices => a static concave btBvhTriangleMeshShape (GEOM_FORCE_CONCAVE_TRIMESH is
    # what a fileName-based shape would need; PyBullet accepts it here too)
    cs = _check_id(client.createCollisionShape(p.GEOM_MESH, vertices=v, indices=idx,
                                               flags=p.GEOM_FORCE_CONCAVE_TRIMESH), f"mesh shape of {m.path}")
    vs = -1 if not visuals else _check_id(
        client.createVisualShape(p.GEOM_MESH, vertices=v, indices=idx, rgbaColor=list(rgba)),
        f"mesh visual of {m.path}")
    body = _check_id(client.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=cs, baseVisualShapeIndex=vs,
                                            basePosition=m.position.tolist(),
                                            baseOrientation=_quat_xyzw_from_rpy(m.rpy)),
                     f"mesh body of {m.path}")
    # a triangle has no inside to hold PyBullet's default 1 mm collision margin: it grows outwards, and every
    # capsule-mesh distance read 1 mm short (a 0.5 mm pass was a collision); rays ignore the margin
    client.changeDynamics(body, -1, collisionMargin=MESH_MARGIN)
    return body
