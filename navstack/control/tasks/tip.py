"""Tip task: the tip position follows the desired tip x_d(t).

Three rows: ``z = x`` (the tip, origin of ``chain.point_frames[0]`` [m]), ``J`` its position Jacobian,
``z_d = x_d``, ``zdot_d = xdot_d`` [m/s], weight ``w_tip``, gain ``k_tip`` [1/s].  The tip rows also enter
the adaptive damping's conditioning matrix.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.control.tasks.base import I_COL, I_K, I_W, I_Z, I_ZD, I_ZDOT, Kinematics, Task


@numba.njit(cache=True)
def tip_rows_into(P, Jp, x_d, xdot_d, w, k, R, info, r0):  # pragma: no cover - jitted
    """Rows r0..r0+2: the tip (point 0) position task."""
    n = Jp.shape[2]
    for c in range(3):
        r = r0 + c
        for j in range(n):
            R[r, j] = Jp[0, c, j]
        info[I_Z, r] = P[0, c]
        info[I_ZD, r] = x_d[c]
        info[I_ZDOT, r] = xdot_d[c]
        info[I_W, r] = w
        info[I_K, r] = k
        info[I_COL, r] = -1.0


@numba.njit(cache=True)
def scaled_rows_into(J, sw, C, r0):  # pragma: no cover - jitted
    """``C[r0 : r0 + len(J)] = sw * J``."""
    for r in range(J.shape[0]):
        for j in range(J.shape[1]):
            C[r0 + r, j] = sw * J[r, j]


class TipTask(Task):
    """The tip follows ``x_d`` [m] with feed-forward ``xdot_d`` [m/s] (3 rows)."""

    name = "tip"

    def __init__(self, weight: float = 1.0, gain: float = 20.0) -> None:
        super().__init__(weight, gain)
        if self.weight <= 0:
            raise ValueError(f"TipTask: weight must be > 0, got {weight!r}")
        self.x_d = np.zeros(3)
        self.xdot_d = np.zeros(3)

    @property
    def size(self) -> int:
        return 3

    def row_names(self) -> tuple[str, ...]:
        return ("tip.x", "tip.y", "tip.z")

    def set_target(self, x_d: NDArray[np.float64], xdot_d: NDArray[np.float64]) -> None:
        """Desired tip ``x_d`` [m] and velocity ``xdot_d`` [m/s] (float64 3-vectors, kept by reference)."""
        self.x_d = x_d
        self.xdot_d = xdot_d

    def fill(self, kin: Kinematics, R: NDArray[np.float64], info: NDArray[np.float64], r0: int) -> None:
        tip_rows_into(kin.P, kin.Jp, self.x_d, self.xdot_d, self.weight, self.gain, R, info, r0)

    @property
    def conditioning_size(self) -> int:
        return 3

    def conditioning(self, kin: Kinematics, C: NDArray[np.float64], r0: int) -> None:
        scaled_rows_into(kin.Jp[0], math.sqrt(self.weight), C, r0)
