"""The robot as a PyBullet multibody, built from the same DH table as the kinematics.

PyBullet link ``k - 1`` carries DH frame ``k`` (k = 1..21; link 20 is the tip,
a fixed joint), so ``getLinkState(body, k - 1)[4]`` is the origin of frame
``k`` in the world.  The base of the multibody is DH frame 0, placed by the
world's ``robot.base``.

Joint ``k``'s origin in frame ``k - 1`` is ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``
of the table at q = 0; the joint moves along (prismatic) or about (revolute)
its local z axis, which reproduces ``Rz(theta + q) Tz(d)`` and
``Rz(theta) Tz(d + q)`` exactly.

Collision geometry (interfaces.md section 1): a capsule on DH frame ``k``
from its origin to the origin of frame ``k + 1`` whenever the two differ:
radius ``arm_radius`` for frames 1..8, ``serpentine_radius`` for 9..20.
Inertias are lumped at each link frame; the body has no self-collision.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from operator import itemgetter
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from navstack.kinematics import Chain
from navstack.sim._bullet import pybullet

_POSITION, _VELOCITY = itemgetter(0), itemgetter(1)
"""A joint's position and velocity in a ``getJointStates`` entry."""

ARM_COLOUR = (0.85, 0.55, 0.15, 1.0)
SERPENTINE_COLOUR = (0.2, 0.6, 0.25, 1.0)
ARM_LINK_MASS = 4.0
"""kg per arm link (lumped at the link frame)."""
SERPENTINE_LINK_MASS = 0.3
"""kg per serpentine link."""
ARM_LINK_INERTIA = 0.05
"""kg m^2, each principal moment of an arm link."""
SERPENTINE_LINK_INERTIA = 0.002
"""kg m^2, each principal moment of a serpentine link."""


def _quat_z_to(v: NDArray[np.float64]) -> list[float]:
    """Quaternion (x, y, z, w) rotating the z axis onto the unit vector ``v``."""
    rot, _ = Rotation.align_vectors([v], [[0.0, 0.0, 1.0]])
    return list(rot.as_quat())


def _row_transform(chain: Chain, row: int) -> NDArray[np.float64]:
    """T_{row, row+1} of the table at q = 0 (0-based table row)."""
    out = np.empty((2, 4, 4))
    from navstack.kinematics import frames_into

    frames_into(
        chain.alpha[row : row + 1],
        chain.a[row : row + 1],
        chain.d[row : row + 1],
        chain.theta[row : row + 1],
        np.zeros(1, dtype=np.bool_),
        np.zeros(0),
        out,
    )
    return out[1]


@dataclass
class RobotBody:
    """Handle of the robot in one PyBullet client.

    ``joint_indices`` are the PyBullet joint indices of q[0..19] (0..19);
    ``tip_link`` is the PyBullet link of DH frame 21.
    """

    client: object
    body_id: int
    chain: Chain
    base_transform: NDArray[np.float64]
    link_radii: NDArray[np.float64] | None = None
    """(21,) [m]: the radius of the capsule on DH frame k (index k - 1), from its origin to frame k + 1's
    (0 where the two coincide and the link has no shape); set by :meth:`build`."""

    @classmethod
    def build(
        cls,
        client,
        chain: Chain,
        base_transform: ArrayLike | None = None,
        *,
        serpentine_radius: float = 0.025,
        arm_radius: float = 0.06,
        first_serpentine_frame: int = 9,
        visuals: bool = True,
    ) -> RobotBody:
        """Create the multibody in ``client`` (a ``BulletClient``).

        ``base_transform`` (4x4) places DH frame 0 in the world [m].  ``visuals``: give the links (and the
        lathe bed's rail) visual shapes, which only pictures use; the collision shapes are the same either way.
        """
        T0 = np.eye(4) if base_transform is None else np.asarray(base_transform, dtype=np.float64)
        rows = len(chain.alpha)
        masses, col_ids, vis_ids, positions, orientations, radii = [], [], [], [], [], []
        parents, types, axes = [], [], []
        for row in range(rows):  # link `row` carries DH frame row + 1
            T = _row_transform(chain, row)
            positions.append(list(T[:3, 3]))
            orientations.append(list(Rotation.from_matrix(T[:3, :3]).as_quat()))
            parents.append(row)  # link row's parent is link row-1, i.e. index row (0 = base)
            if row < chain.n:
                types.append(pybullet.JOINT_PRISMATIC if chain.prismatic[row] else pybullet.JOINT_REVOLUTE)
            else:
                types.append(pybullet.JOINT_FIXED)
            axes.append([0.0, 0.0, 1.0])
            frame = row + 1
            # segment from the origin of frame `frame` to that of frame + 1, in frame `frame`
            if frame < rows:
                seg = _row_transform(chain, frame)[:3, 3]
            else:
                seg = np.zeros(3)
            length = float(np.linalg.norm(seg))
            serp = frame >= first_serpentine_frame
            radius = serpentine_radius if serp else arm_radius
            masses.append(SERPENTINE_LINK_MASS if serp else ARM_LINK_MASS)
            radii.append(radius if length > 1e-9 else 0.0)
            col, vis = _link_shapes(client, seg, length, radius, SERPENTINE_COLOUR if serp else ARM_COLOUR, visuals)
            col_ids.append(col)
            vis_ids.append(vis)
        base_vis = _lathe_bed_visual(client, chain) if visuals else -1
        body = client.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            baseVisualShapeIndex=base_vis,
            basePosition=list(T0[:3, 3]),
            baseOrientation=list(Rotation.from_matrix(T0[:3, :3]).as_quat()),
            linkMasses=masses,
            linkCollisionShapeIndices=col_ids,
            linkVisualShapeIndices=vis_ids,
            linkPositions=positions,
            linkOrientations=orientations,
            linkInertialFramePositions=[[0.0, 0.0, 0.0]] * rows,
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * rows,
            linkParentIndices=parents,
            linkJointTypes=types,
            linkJointAxis=axes,
        )
        _lumped_inertia(client, body, rows, first_serpentine_frame)
        for j in range(chain.n):  # PyBullet's default velocity motors would fight the servo
            client.setJointMotorControl2(body, j, pybullet.VELOCITY_CONTROL, force=0.0)
        return cls(client=client, body_id=body, chain=chain, base_transform=T0, link_radii=np.array(radii))

    @property
    def joint_indices(self) -> list[int]:
        return list(range(self.chain.n))

    @property
    def tip_link(self) -> int:
        return len(self.chain.alpha) - 1

    def link_boxes(self, origins: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World boxes ``(lo, hi)``, each (20, 3) [m], that hold the robot's collision capsules (box k - 1: the
        capsule of DH frame k, from its origin to frame k + 1's), from the world positions ``origins``
        (21, 3) [m] of the origins of DH frames 1..21.

        For :meth:`navstack.sim.scene.Scene.clearance`'s ``robot_boxes``; needs :attr:`link_radii`.
        """
        if self.link_radii is None:
            raise ValueError("RobotBody.link_boxes needs link_radii (a body made by RobotBody.build)")
        r = self.link_radii[:len(origins) - 1, None]
        a, b = origins[:-1], origins[1:]
        return np.minimum(a, b) - r, np.maximum(a, b) + r

    def capsules(self, origins: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                             NDArray[np.float64]]:
        """The robot's collision capsules ``(a, b, r)`` from the world positions ``origins`` (21, 3) [m] of the
        origins of DH frames 1..21: segments ``a[k]``-``b[k]`` (K, 3) [m], radii ``r[k]`` (K,) [m], one per link
        that has a shape (interfaces.md section 1).  For :meth:`navstack.sim.scene.Scene.clearance`."""
        if self.link_radii is None:
            raise ValueError("RobotBody.capsules needs link_radii (a body made by RobotBody.build)")
        r = self.link_radii[:len(origins) - 1]
        shaped = r > 0.0
        return origins[:-1][shaped], origins[1:][shaped], r[shaped]

    def reset(self, q: ArrayLike, qd: ArrayLike | None = None) -> None:
        """Teleport the joints to ``q`` (velocities ``qd``, default 0)."""
        q = self.chain.check(q)
        qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=np.float64)
        for j in range(self.chain.n):
            self.client.resetJointState(self.body_id, j, float(q[j]), float(qd[j]))

    def joint_state(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Measured joint positions and velocities (20,) from the simulator."""
        states = self.client.getJointStates(self.body_id, self.joint_indices)
        q = np.fromiter(map(_POSITION, states), dtype=np.float64, count=self.chain.n)
        qd = np.fromiter(map(_VELOCITY, states), dtype=np.float64, count=self.chain.n)
        return q, qd

    def link_frames_world(self) -> NDArray[np.float64]:
        """World transforms of DH frames 1..21 as PyBullet reports them, shape (21, 4, 4)."""
        states = self.client.getLinkStates(
            self.body_id, list(range(len(self.chain.alpha))), computeForwardKinematics=True
        )
        out = np.zeros((len(states), 4, 4))
        for k, s in enumerate(states):
            out[k, :3, :3] = np.reshape(self.client.getMatrixFromQuaternion(s[5]), (3, 3))
            out[k, :3, 3] = s[4]
            out[k, 3, 3] = 1.0
        return out


def _link_shapes(client: Any, seg: NDArray[np.float64], length: float, radius: float, rgba: Sequence[float],
                 visuals: bool) -> tuple[int, int]:
    """The collision and visual capsule (ids; -1 for none) of a link whose segment ``seg`` (3,) [m], ``length``
    [m] long, runs from its frame's origin to the next frame's; none for a zero-length (DH) link."""
    if length <= 1e-9:
        return -1, -1
    quat = _quat_z_to(seg / length)
    mid = list(seg / 2.0)
    col = client.createCollisionShape(pybullet.GEOM_CAPSULE, radius=radius, height=length,
                                      collisionFramePosition=mid, collisionFrameOrientation=quat)
    vis = -1 if not visuals else client.createVisualShape(pybullet.GEOM_CAPSULE, radius=radius, length=length,
                                                          visualFramePosition=mid, visualFrameOrientation=quat,
                                                          rgbaColor=rgba)
    return col, vis


def _lathe_bed_visual(client: Any, chain: Chain) -> int:
    """The lathe bed: a rail along z0 over the prismatic joint's travel (a visual shape only)."""
    travel = (float(chain.lower[0]), float(chain.upper[0])) if chain.prismatic[0] else (-0.1, 0.1)
    return client.createVisualShape(
        pybullet.GEOM_BOX,
        halfExtents=[0.05, 0.12, 0.5 * (travel[1] - travel[0]) + 0.1],
        visualFramePosition=[-0.1, 0.0, 0.5 * (travel[0] + travel[1])],
        rgbaColor=(0.3, 0.3, 0.35, 1.0),
    )


def _lumped_inertia(client: Any, body: int, rows: int, first_serpentine_frame: int) -> None:
    """Every link the inertia of a lumped body, no damping.  Links without a shape (zero-length DH rows) would
    get zero inertia, which stalls the constraint solver."""
    for link in range(rows):
        serp = link + 1 >= first_serpentine_frame
        inertia = SERPENTINE_LINK_INERTIA if serp else ARM_LINK_INERTIA
        client.changeDynamics(body, link, localInertiaDiagonal=[inertia] * 3, linearDamping=0.0,
                              angularDamping=0.0, jointDamping=0.0)
