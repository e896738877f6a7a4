"""Joint-limit avoidance: a joint that enters a margin near its limit is pushed back.

One unit row per joint ``j``: ``z = theta_j``.  Inside the margin ``m_j`` of a limit the target ``z_d``
is the margin's edge (``e`` pushes back) and the weight ramps smoothly as
``w_limit * smoothstep(depth / m_j)`` (``smoothstep(x) = 3x^2 - 2x^3``, capped at 1), zero outside the
margin, so the task is continuous in ``theta``.  Gain ``k_limit`` [1/s].  The controller also clips
``theta_d`` into the limits; this task keeps it from getting there.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.control.tasks.base import I_COL, I_K, I_W, I_Z, I_ZD, I_ZDOT, Kinematics, Task


@numba.njit(cache=True)
def limit_rows_into(q, bounds, w_max, k, info, r0):  # pragma: no cover - jitted
    """Unit rows from r0, one per joint; ``bounds`` (3, n) = lower, upper, margin."""
    for j in range(q.shape[0]):
        r = r0 + j
        m = bounds[2, j]
        lo = bounds[0, j] + m
        hi = bounds[1, j] - m
        target = q[j]
        depth = 0.0
        if q[j] < lo:
            target = lo
            depth = lo - q[j]
        elif q[j] > hi:
            target = hi
            depth = q[j] - hi
        wgt = 0.0
        if depth > 0.0 and m > 0.0:
            x = min(depth / m, 1.0)
            wgt = w_max * x * x * (3.0 - 2.0 * x)
        info[I_Z, r], info[I_ZD, r], info[I_ZDOT, r] = q[j], target, 0.0
        info[I_W, r], info[I_K, r], info[I_COL, r] = wgt, k, j


class JointLimitTask(Task):
    """Keep every joint out of a ``margin`` [rad or m, per joint] inside ``lower`` .. ``upper``."""

    name = "limit"
    unit_rows = True

    def __init__(self, lower: ArrayLike, upper: ArrayLike, margin: ArrayLike, weight: float = 1.0,
                 gain: float = 5.0) -> None:
        super().__init__(weight, gain)
        lo = np.asarray(lower, dtype=np.float64).reshape(-1)
        hi = np.asarray(upper, dtype=np.float64).reshape(-1)
        m = np.broadcast_to(np.asarray(margin, dtype=np.float64), lo.shape)
        if hi.shape != lo.shape or not (np.isfinite(lo).all() and np.isfinite(hi).all() and np.isfinite(m).all()):
            raise ValueError("JointLimitTask: lower, upper and margin must be finite, one value per joint")
        if (m < 0).any() or (2.0 * m >= hi - lo).any():
            j = int(np.flatnonzero((m < 0) | (2.0 * m >= hi - lo))[0])
            raise ValueError(f"JointLimitTask: margin {m[j]} leaves no free range for joint {j + 1} "
                             f"(range {hi[j] - lo[j]})")
        self.bounds = np.ascontiguousarray(np.stack([lo, hi, m]))

    @property
    def size(self) -> int:
        return self.bounds.shape[1]

    def row_names(self) -> tuple[str, ...]:
        return tuple(f"limit.q{j + 1}" for j in range(self.size))

    def fill(self, kin: Kinematics, R: NDArray[np.float64], info: NDArray[np.float64], r0: int) -> None:
        limit_rows_into(kin.q, self.bounds, self.weight, self.gain, info, r0)
