"""Equation (4) of the paper, in one place.

    thetadot_d = [J^T W J + lambda^2 W_v]^-1 J^T W (zdot_d + K e),   e = z_d - z,

with ``W``, ``W_v`` and ``K`` diagonal.  :func:`dls_rate` is that formula in numpy, nothing else (the
reference the tests hold the controller to).  :func:`solve_rows_into` is the same equation on the task
rows stacked by :class:`~navstack.control.solver.TaskSolver`, compiled: it forms the normal matrix
``J^T W J + lambda^2 W_v`` (a unit row ``e_j^T`` adds its weight to the diagonal only) and solves it by
Cholesky (symmetric positive definite whenever ``lambda^2 W_v > 0``).  :func:`step_into` then integrates
the rate into ``theta_d``: ``theta_d(t + dt) = theta_d(t) + dt * thetadot_d``, clipped into the joint limits.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from navstack.control.tasks.base import I_COL, I_K, I_W, I_Z, I_ZD, I_ZDOT


def dls_rate(
    J: NDArray[np.float64],
    w: NDArray[np.float64],
    wv: NDArray[np.float64],
    lam2: float,
    zdot_d: NDArray[np.float64],
    k: NDArray[np.float64],
    e: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Equation (4): ``[J^T W J + lam2 W_v]^-1 J^T W (zdot_d + K e)``.

    ``W = diag(w)``, ``W_v = diag(wv)`` and ``K = diag(k)`` are diagonal, given
    as vectors; ``J`` is (r, n), ``zdot_d``, ``e``, ``w``, ``k`` are (r,), ``wv``
    is (n,), ``lam2 = lambda^2``.  Units follow the rows (m, rad; 1/s for ``k``).
    """
    JtW = J.T * w
    return np.linalg.solve(JtW @ J + lam2 * np.diag(wv), JtW @ (zdot_d + k * e))


@numba.njit(cache=True)
def solve_rows_into(R, info, n_rows, wv, lam2, H, g, out):  # pragma: no cover - jitted
    """Equation (4) on stacked rows: ``out = [J^T W J + lam2 W_v]^-1 J^T W (zdot_d + K e)``.

    Row ``r`` is ``R[r]`` with ``z, z_d, zdot_d, w, k = info[I_Z..I_K, r]``; a row with
    ``info[I_COL, r] = j >= 0`` is the unit row ``e_j^T`` (``R[r]`` not read).  ``H`` (n, n) and ``g``
    (n,) are work space.  Returns False (``out`` undefined) if the matrix is not positive definite.
    """
    n = H.shape[0]
    for i in range(n):
        g[i] = 0.0
        for j in range(n):
            H[i, j] = 0.0
        H[i, i] = lam2 * wv[i]
    for r in range(n_rows):
        w = info[I_W, r]
        if w == 0.0:
            continue
        rhs = w * (info[I_ZDOT, r] + info[I_K, r] * (info[I_ZD, r] - info[I_Z, r]))
        col = int(info[I_COL, r])
        if col >= 0:
            H[col, col] += w
            g[col] += rhs
            continue
        for i in range(n):
            ri = R[r, i]
            if ri == 0.0:
                continue
            wri = w * ri
            g[i] += ri * rhs
            for j in range(i + 1):
                H[i, j] += wri * R[r, j]
    # Cholesky H = L L^T in the lower triangle, then L y = g, L^T x = y
    for j in range(n):
        s = H[j, j]
        for k in range(j):
            s -= H[j, k] * H[j, k]
        if not s > 0.0:
            return False
        ljj = math.sqrt(s)
        H[j, j] = ljj
        for i in range(j + 1, n):
            s = H[i, j]
            for k in range(j):
                s -= H[i, k] * H[j, k]
            H[i, j] = s / ljj
    for i in range(n):
        s = g[i]
        for k in range(i):
            s -= H[i, k] * out[k]
        out[i] = s / H[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= H[k, i] * out[k]
        out[i] = s / H[i, i]
    return True


STEP_OK, STEP_NOT_SPD, STEP_NONFINITE = range(3)


@numba.njit(cache=True)
def step_into(R, info, n_rows, wv, lam2, H, g, rate, q, qdot, bounds, dt):  # pragma: no cover - jitted
    """Equation (4) into ``rate`` (:func:`solve_rows_into`), then ``q += dt * rate`` clipped into ``bounds``
    (2, n: lower, upper); ``qdot`` the effective rate.  Returns ``STEP_OK``, or ``STEP_NOT_SPD`` /
    ``STEP_NONFINITE`` with ``q`` and ``qdot`` unchanged."""
    if not solve_rows_into(R, info, n_rows, wv, lam2, H, g, rate):
        return STEP_NOT_SPD
    n = q.shape[0]
    for j in range(n):
        if not math.isfinite(rate[j]):
            return STEP_NONFINITE
    for j in range(n):
        v = q[j] + dt * rate[j]
        if v < bounds[0, j]:
            v = bounds[0, j]
        elif v > bounds[1, j]:
            v = bounds[1, j]
        qdot[j] = (v - q[j]) / dt
        q[j] = v
    return STEP_OK
