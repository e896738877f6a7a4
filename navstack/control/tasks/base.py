"""What every task of equation (4) shares: the row layout, the kinematics it reads, the Task interface.

A task is a block of rows of equation (4): for each row ``r`` a Jacobian row ``J[r]`` (1 x n), the
task coordinate ``z`` at the current configuration, its desired value ``z_d`` and rate ``zdot_d``, a
weight ``w`` (the diagonal of ``W``) and a gain ``k`` (the diagonal of ``K``, 1/s); the error is
``e = z_d - z``.  :class:`~navstack.control.solver.TaskSolver` gives each task its slice of the stacked
buffers ``R`` (rows x n: the Jacobian rows) and ``info`` (6 x rows: ``z, z_d, zdot_d, w, k, col`` at the
indices :data:`I_Z` ... :data:`I_COL`) and calls :meth:`Task.fill` once per step.

A *unit-row* task (``unit_rows = True``: posture, joint limits) has rows ``e_j^T``: it sets
``info[I_COL, r] = j`` and leaves ``R`` alone; equation (4) then adds its weight to the diagonal only.
Every other row has ``info[I_COL, r] = -1``.

The kinematics (:class:`Kinematics`) are evaluated once per step at the configuration the rows are
built at (``theta_d``: the kinematic loop) and shared by the tasks.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.kinematics import Chain, frames_into, point_jacobians_into

I_Z, I_ZD, I_ZDOT, I_W, I_K, I_COL = range(6)
"""Rows of the ``info`` buffer: task coordinate, desired value, desired rate, weight, gain, unit column."""
N_INFO = 6


@numba.njit(cache=True)
def kinematics_into(dh, prismatic, point_frames, q, F, P, Jp):  # pragma: no cover - jitted
    """Frames ``F``, points ``P`` (origins of ``point_frames``) and their Jacobians ``Jp`` at ``q``."""
    frames_into(dh[0], dh[1], dh[2], dh[3], prismatic, q, F)
    point_jacobians_into(F, prismatic, point_frames, Jp)
    for i in range(point_frames.shape[0]):
        f = point_frames[i]
        P[i, 0], P[i, 1], P[i, 2] = F[f, 0, 3], F[f, 1, 3], F[f, 2, 3]


class Kinematics:
    """The robot at one configuration, as the tasks read it.

    Attributes (overwritten by :meth:`update`): ``q`` (n,) the configuration [m, rad]; ``F`` the
    frames (n_frames, 4, 4); ``P`` (k, 3) the origins of ``chain.point_frames`` [m] (for the JPL robot:
    tip, J1..J6); ``Jp`` (k, 3, n) their position Jacobians [m/m, m/rad].
    """

    def __init__(self, chain: Chain) -> None:
        self.chain = chain
        self._dh = np.ascontiguousarray(np.stack([chain.alpha, chain.a, chain.d, chain.theta]))
        k = len(chain.point_frames)
        self.q = np.zeros(chain.n)
        self.F = np.empty((chain.n_frames, 4, 4))
        self.P = np.empty((k, 3))
        self.Jp = np.empty((k, 3, chain.n))

    def update(self, q: NDArray[np.float64]) -> None:
        """Evaluate at ``q`` (kept by reference: the caller must not change it before the rows are built)."""
        self.q = q
        kinematics_into(self._dh, self.chain.prismatic, self.chain.point_frames, q, self.F, self.P, self.Jp)


@dataclass(frozen=True)
class TaskRows:
    """Rows of equation (4), for inspection and tests.

    ``J`` (r, n); ``z``, ``z_d``, ``zdot_d``, ``w``, ``k`` (r,); ``names`` (r,)
    like ``"tip.x"``, ``"slither.J3.n1"``, ``"posture.q5"``, ``"limit.q12"``.
    """

    J: NDArray[np.float64]
    z: NDArray[np.float64]
    z_d: NDArray[np.float64]
    zdot_d: NDArray[np.float64]
    w: NDArray[np.float64]
    k: NDArray[np.float64]
    names: tuple[str, ...]

    @property
    def e(self) -> NDArray[np.float64]:
        """Task error ``z_d - z``."""
        return self.z_d - self.z


def check_weight_gain(owner: str, weight: float, gain: float) -> tuple[float, float]:
    """Validate a task's weight (>= 0) and gain [1/s] (>= 0); ``ValueError`` naming ``owner``."""
    for name, v in (("weight", weight), ("gain", gain)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating)) or not math.isfinite(v) or v < 0:
            raise ValueError(f"{owner}: {name} must be a finite number >= 0, got {v!r}")
    return float(weight), float(gain)


class Task(ABC):
    """One block of rows of equation (4) (see the module docstring).

    Subclasses set ``name`` and ``unit_rows``, and implement :attr:`size`, :meth:`row_names` and
    :meth:`fill`; a task that takes part in the adaptive damping's singular value also implements
    :meth:`conditioning` and :attr:`conditioning_size`.
    """

    name: str = "task"
    unit_rows: bool = False

    def __init__(self, weight: float, gain: float) -> None:
        self.weight, self.gain = check_weight_gain(type(self).__name__, weight, gain)

    @property
    @abstractmethod
    def size(self) -> int:
        """Number of rows."""

    @abstractmethod
    def row_names(self) -> tuple[str, ...]:
        """One name per row, ``"<task>.<coordinate>"``."""

    @abstractmethod
    def fill(self, kin: Kinematics, R: NDArray[np.float64], info: NDArray[np.float64], r0: int) -> None:
        """Write rows ``r0 .. r0 + size - 1`` of ``R`` (dense tasks) and ``info`` at ``kin``."""

    @property
    def conditioning_size(self) -> int:
        """Rows this task adds to the damping's conditioning matrix (0: none)."""
        return 0

    def conditioning(self, kin: Kinematics, C: NDArray[np.float64], r0: int) -> None:
        """Write ``sqrt(w) J`` rows of the damping's conditioning matrix into ``C[r0:]`` (default: none)."""
        return None

    def rows(self, kin: Kinematics) -> TaskRows:
        """This task's rows at ``kin`` as a :class:`TaskRows` (fresh arrays; unit rows expanded)."""
        n = kin.chain.n
        R = np.zeros((self.size, n))
        info = np.zeros((N_INFO, self.size))
        info[I_COL] = -1.0
        self.fill(kin, R, info, 0)
        for r in np.flatnonzero(info[I_COL] >= 0):
            R[r] = 0.0
            R[r, int(info[I_COL, r])] = 1.0
        return TaskRows(J=R, z=info[I_Z].copy(), z_d=info[I_ZD].copy(), zdot_d=info[I_ZDOT].copy(),
                        w=info[I_W].copy(), k=info[I_K].copy(), names=self.row_names())

    def __repr__(self) -> str:
        return f"{type(self).__name__}(size={self.size}, weight={self.weight}, gain={self.gain})"
