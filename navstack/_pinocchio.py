"""The same modified-DH chain built in Pinocchio: a reference for tests and benchmarks.

Optional dependency (``pip install pin``); nothing in the control loop uses it.
:func:`build_pinocchio` adds the chain joint by joint with ``Model.addJoint``:
``JointModelPZ`` for a prismatic joint (the lathe bed), ``JointModelRZ`` for a
revolute one, each placed in its parent joint's frame by
``Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)`` (the table row, joint value
zero).  The joint variable then acts about / along the new frame's z axis; since
``Rz(q)`` and ``Tz(d)`` commute with ``Rz(theta) Tz(d)``, Pinocchio's joint frame
``i`` is exactly DH frame ``i``.  Fixed rows past the last joint (the tool frame)
become an operational frame on the last joint.  One operational frame
``"dh<k>"`` is added for every DH frame ``k`` (0..21 for the JPL robot), so the
frames ``"dh21"`` (tip) and ``"dh19"`` .. ``"dh9"`` (J1..J6) are the backbone.
Units: metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.kinematics import Chain


def _row_placement(alpha: float, a: float, d: float, theta: float) -> NDArray[np.float64]:
    """Homogeneous ``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` (4x4)."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array(
        [
            [ct, -st, 0.0, a],
            [st * ca, ct * ca, -sa, -sa * d],
            [st * sa, ct * sa, ca, ca * d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


@dataclass
class PinocchioChain:
    """A Pinocchio model/data pair equivalent to a :class:`~navstack.kinematics.Chain`.

    ``dh_frame_ids[k]`` is the Pinocchio frame id of DH frame ``k``;
    ``point_frame_ids`` those of ``chain.point_frames`` (tip, J1..J6).
    """

    model: Any
    data: Any
    dh_frame_ids: NDArray[np.int64]
    point_frame_ids: NDArray[np.int64]

    def frames(self, q: ArrayLike) -> NDArray[np.float64]:
        """All DH frames in the base frame, (n_frames, 4, 4), like ``Chain.frames``."""
        import pinocchio as pin

        qv = np.asarray(q, dtype=np.float64)
        pin.forwardKinematics(self.model, self.data, qv)
        pin.updateFramePlacements(self.model, self.data)
        return np.stack([self.data.oMf[int(f)].homogeneous for f in self.dh_frame_ids])

    def points_and_jacobians(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points (k, 3) [m] and LOCAL_WORLD_ALIGNED linear Jacobians (k, 3, n) of the point frames."""
        import pinocchio as pin

        qv = np.asarray(q, dtype=np.float64)
        pin.computeJointJacobians(self.model, self.data, qv)  # also runs forward kinematics
        pin.updateFramePlacements(self.model, self.data)
        pts = np.stack([self.data.oMf[int(f)].translation for f in self.point_frame_ids])
        jac = np.stack(
            [
                pin.getFrameJacobian(self.model, self.data, int(f), pin.LOCAL_WORLD_ALIGNED)[:3]
                for f in self.point_frame_ids
            ]
        )
        return pts, jac


def build_pinocchio(chain: Chain) -> PinocchioChain:
    """Build ``chain`` in Pinocchio (see the module docstring); ``ImportError`` without ``pin``."""
    try:
        import pinocchio as pin
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("navstack._pinocchio needs Pinocchio: pip install pin") from exc

    model = pin.Model()
    model.name = chain.name
    n = chain.n
    parent = 0
    for i in range(n):
        placement = pin.SE3(_row_placement(chain.alpha[i], chain.a[i], chain.d[i], chain.theta[i]))
        joint_model = pin.JointModelPZ() if chain.prismatic[i] else pin.JointModelRZ()
        parent = model.addJoint(parent, joint_model, placement, f"joint{i + 1}")
    if parent != n:  # joint ids are 1..n, joint k carrying DH frame k
        raise RuntimeError(f"unexpected Pinocchio joint numbering: last joint id {parent}, expected {n}")

    dh_ids = []
    tool = np.eye(4)
    for k in range(chain.n_frames):
        if k <= n:
            joint, place = k, np.eye(4)
        else:  # fixed tool rows, attached to the last joint
            tool = tool @ _row_placement(chain.alpha[k - 1], chain.a[k - 1], chain.d[k - 1], chain.theta[k - 1])
            joint, place = n, tool.copy()
        frame = pin.Frame(f"dh{k}", joint, pin.SE3(place), pin.FrameType.OP_FRAME)
        dh_ids.append(model.addFrame(frame))
    dh = np.asarray(dh_ids, dtype=np.int64)
    return PinocchioChain(
        model=model,
        data=model.createData(),
        dh_frame_ids=dh,
        point_frame_ids=dh[np.asarray(chain.point_frames)],
    )
