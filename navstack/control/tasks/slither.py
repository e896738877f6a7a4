"""Slither task: every serpentine joint point stays on the tip's recorded path, one link apart.

The task owns the :class:`~navstack.path.PathMemory`.  :meth:`SlitherTask.set_target` gives it the
desired tip ``x_d`` and velocity ``xdot_d`` each step: the path records ``x_d`` (or, for a reverse
command, is cut back to it) and places the desired joint points ``y_d,i`` (J1..J6) and their velocities
by the chord rule.  Rows per joint point ``y_i`` (origin of ``chain.point_frames[i]``, i = 1..6):

* ``"projected"`` (the paper's two coordinates per joint): with ``u_i = unit(y_d,i-1 - y_d,i)``
  (``y_d,0 = x_d``) the desired link direction and ``N_i`` (3x2) an orthonormal basis of the plane
  perpendicular to ``u_i`` (recomputed each step, so the frame turns with the path): rows
  ``N_i^T J_i``, ``z = N_i^T y_i``, ``z_d = N_i^T y_d,i``, ``zdot_d = N_i^T ydot_d,i`` (the frame's own
  rotation times the error is neglected: second order).  With equal weight and gain on both rows the
  result does not depend on the choice of basis in that plane (only on ``I - u u^T``).
* ``"full"``: the three coordinates of each joint point (18 rows).

Weight ``w_slither``, gain ``k_slither`` [1/s].  The projected rows (also in ``"full"`` mode, whose
along-link rows are dependent on the others through the rigid links) enter the adaptive damping's
conditioning matrix.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.control.tasks.base import I_COL, I_K, I_W, I_Z, I_ZD, I_ZDOT, Kinematics, Task
from navstack.path import PathMemory

FORMS = {"projected": 1, "full": 2}


@numba.njit(cache=True, inline="always")
def perp_basis(ux, uy, uz):  # pragma: no cover - jitted
    """Orthonormal n1, n2 perpendicular to unit u (Duff et al. 2017, branch-free)."""
    sign = 1.0 if uz >= 0.0 else -1.0
    a = -1.0 / (sign + uz)
    b = ux * uy * a
    return (1.0 + sign * ux * ux * a, sign * b, -sign * ux), (b, sign + uy * uy * a, -uy)


@numba.njit(cache=True)
def slither_rows_into(P, Jp, x_d, yd, ydot, form, w, k, R, info, r0):  # pragma: no cover - jitted
    """Rows from r0: joint points 1..m (``P[i]``, ``Jp[i]``) on the desired points ``yd``, ``ydot``."""
    n = Jp.shape[2]
    r = r0
    px, py, pz = x_d[0], x_d[1], x_d[2]
    for i in range(yd.shape[0]):
        qx, qy, qz = yd[i, 0], yd[i, 1], yd[i, 2]
        if form == 1:
            ux, uy, uz = px - qx, py - qy, pz - qz
            un = math.sqrt(ux * ux + uy * uy + uz * uz)
            n1, n2 = perp_basis(ux / un, uy / un, uz / un)
            for b in range(2):
                nb = n1 if b == 0 else n2
                z = 0.0
                zd = 0.0
                zdot = 0.0
                for c in range(3):
                    z += nb[c] * P[i + 1, c]
                    zd += nb[c] * yd[i, c]
                    zdot += nb[c] * ydot[i, c]
                for j in range(n):
                    R[r, j] = nb[0] * Jp[i + 1, 0, j] + nb[1] * Jp[i + 1, 1, j] + nb[2] * Jp[i + 1, 2, j]
                info[I_Z, r], info[I_ZD, r], info[I_ZDOT, r] = z, zd, zdot
                info[I_W, r], info[I_K, r], info[I_COL, r] = w, k, -1.0
                r += 1
        else:
            for c in range(3):
                for j in range(n):
                    R[r, j] = Jp[i + 1, c, j]
                info[I_Z, r], info[I_ZD, r], info[I_ZDOT, r] = P[i + 1, c], yd[i, c], ydot[i, c]
                info[I_W, r], info[I_K, r], info[I_COL, r] = w, k, -1.0
                r += 1
        px, py, pz = qx, qy, qz


@numba.njit(cache=True)
def projected_rows_into(Jp, x_d, yd, sw, C, r0):  # pragma: no cover - jitted
    """``sw N_i^T J_i`` for joint points 1..m into ``C[r0:]`` (the conditioning rows)."""
    n = Jp.shape[2]
    r = r0
    px, py, pz = x_d[0], x_d[1], x_d[2]
    for i in range(yd.shape[0]):
        ux, uy, uz = px - yd[i, 0], py - yd[i, 1], pz - yd[i, 2]
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        n1, n2 = perp_basis(ux / un, uy / un, uz / un)
        for b in range(2):
            nb = n1 if b == 0 else n2
            for j in range(n):
                C[r, j] = sw * (nb[0] * Jp[i + 1, 0, j] + nb[1] * Jp[i + 1, 1, j] + nb[2] * Jp[i + 1, 2, j])
            r += 1
        px, py, pz = yd[i, 0], yd[i, 1], yd[i, 2]


class SlitherTask(Task):
    """Joint points J1..J6 on the recorded tip path (see the module docstring); owns ``path``.

    ``form`` is ``"projected"`` (2 rows per joint point) or ``"full"`` (3); ``reverse_tolerance`` [m]
    is how far a reverse tip command may lie from the recorded path.
    """

    name = "slither"

    def __init__(self, path: PathMemory, form: str = "projected", weight: float = 1.0, gain: float = 20.0,
                 reverse_tolerance: float = 1e-3) -> None:
        super().__init__(weight, gain)
        if not isinstance(path, PathMemory):
            raise TypeError(f"SlitherTask: path must be a PathMemory, got {type(path).__name__}")
        if form not in FORMS:
            raise ValueError(f"SlitherTask: form must be one of {sorted(FORMS)}, got {form!r}")
        if not (math.isfinite(reverse_tolerance) and reverse_tolerance > 0):
            raise ValueError(f"SlitherTask: reverse_tolerance must be > 0 [m], got {reverse_tolerance!r}")
        self.path = path
        self.form = form
        self.reverse_tolerance = float(reverse_tolerance)
        self._form = FORMS[form]
        self._m = path.n_joints
        self.x_d = path.head

    @property
    def size(self) -> int:
        return (2 if self.form == "projected" else 3) * self._m

    def row_names(self) -> tuple[str, ...]:
        coords = ("n1", "n2") if self.form == "projected" else ("x", "y", "z")
        return tuple(f"slither.J{i}.{c}" for i in range(1, self._m + 1) for c in coords)

    def set_target(self, x_d: NDArray[np.float64], xdot_d: NDArray[np.float64], reverse: bool = False) -> None:
        """Advance the path memory with the desired tip (float64 3-vectors; ``x_d`` kept by reference).

        ``reverse``: ``x_d`` retraces the recorded path (it is cut back to ``x_d``, not recorded).
        ``ValueError`` (nothing changes) for non-finite input or a reverse command off the path.
        """
        self.path.advance(x_d, xdot_d, reverse, self.reverse_tolerance)
        self.x_d = x_d

    def fill(self, kin: Kinematics, R: NDArray[np.float64], info: NDArray[np.float64], r0: int) -> None:
        path = self.path
        slither_rows_into(kin.P, kin.Jp, self.x_d, path.pts, path.vel, self._form, self.weight, self.gain,
                          R, info, r0)

    @property
    def conditioning_size(self) -> int:
        return 2 * self._m

    def conditioning(self, kin: Kinematics, C: NDArray[np.float64], r0: int) -> None:
        projected_rows_into(kin.Jp, self.x_d, self.path.pts, math.sqrt(self.weight), C, r0)
