"""Posture task: chosen joints held near a posture.

One unit row ``e_j^T`` per joint ``j`` of ``joints`` (for the JPL robot the arm joints 2..8):
``z = theta_j``, ``z_d`` = the posture [rad], ``zdot_d = 0``, weight ``w_posture``, gain ``k_posture``
[1/s].  Together with a cheap lathe bed in ``W_v`` it makes insertion come from the lathe bed (with
``W_v`` alike for metres and radians and no posture the solver straightens the elbow instead, and the arm
ends at full stretch; see tests/test_control.py).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.control.tasks.base import I_COL, I_K, I_W, I_Z, I_ZD, I_ZDOT, Kinematics, Task


@numba.njit(cache=True)
def posture_rows_into(q, joints, target, w, k, info, r0):  # pragma: no cover - jitted
    """Unit rows from r0: joint ``joints[i]`` towards ``target[i]``."""
    for i in range(joints.shape[0]):
        r = r0 + i
        j = joints[i]
        info[I_Z, r], info[I_ZD, r], info[I_ZDOT, r] = q[j], target[i], 0.0
        info[I_W, r], info[I_K, r], info[I_COL, r] = w, k, j


class PostureTask(Task):
    """Joints ``joints`` (0-based indices) towards ``target`` [rad or m] (one unit row each)."""

    name = "posture"
    unit_rows = True

    def __init__(self, joints: ArrayLike, target: ArrayLike, weight: float = 1e-2, gain: float = 1.0) -> None:
        super().__init__(weight, gain)
        self.joints = np.array(joints, dtype=np.int64).reshape(-1)
        self.target = np.zeros(len(self.joints))
        self.set_target(target)

    @property
    def size(self) -> int:
        return len(self.joints)

    def row_names(self) -> tuple[str, ...]:
        return tuple(f"posture.q{j + 1}" for j in self.joints)

    def set_target(self, target: ArrayLike) -> None:
        """The posture [rad] (one value per joint of ``joints``)."""
        t = np.asarray(target, dtype=np.float64)
        if t.shape != self.target.shape or not np.isfinite(t).all():
            raise ValueError(f"PostureTask: target must be {len(self.joints)} finite values, got {target!r}")
        self.target[:] = t

    def fill(self, kin: Kinematics, R: NDArray[np.float64], info: NDArray[np.float64], r0: int) -> None:
        posture_rows_into(kin.q, self.joints, self.target, self.weight, self.gain, info, r0)
