"""Adaptive damping of equation (4): lambda from the smallest singular value of the weighted tasks.

``sigma`` is the smallest singular value of the weighted, velocity-scaled task Jacobian
``W^1/2 J W_v^-1/2`` over the *conditioning* rows (the tip rows and the projected slither rows: the
tasks that report them, see :meth:`navstack.control.tasks.Task.conditioning`), i.e. the scale at which
the damping term competes in (4).  Then::

    lambda^2 = lambda0^2 + lambda_max^2 (1 - (sigma/eps)^2)   if sigma < eps,   else lambda0^2.

``sigma`` (an eigen-decomposition of the conditioning rows' Gram matrix) is refreshed every ``every``
steps, the first step included, and held in between.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray


@numba.njit(cache=True)
def damping_lambda2(sigma: float, lambda0: float, lambda_max: float, eps: float) -> float:  # pragma: no cover
    """The damping rule: lambda^2 for a smallest singular value ``sigma`` (see the module docstring)."""
    lam2 = lambda0 * lambda0
    if sigma < eps:
        r = sigma / eps
        lam2 += lambda_max * lambda_max * (1.0 - r * r)
    return lam2


@numba.njit(cache=True)
def sigma_min(C, r, inv_sqrt_wv, G):  # pragma: no cover - jitted
    """Smallest singular value of ``C[:r] diag(inv_sqrt_wv)`` (``G`` (>= r, >= r) is work space)."""
    n = C.shape[1]
    for i in range(r):
        for k in range(i + 1):
            s = 0.0
            for j in range(n):
                s += C[i, j] * C[k, j] * inv_sqrt_wv[j] * inv_sqrt_wv[j]
            G[i, k] = s
            G[k, i] = s
    ev = np.linalg.eigvalsh(G[:r, :r])
    lo = ev[0]
    return math.sqrt(lo) if lo > 0.0 else 0.0


class AdaptiveDamping:
    """lambda^2 of equation (4), refreshed every ``every`` steps (see the module docstring).

    ``lambda0`` > 0 and ``lambda_max`` >= 0 are dimensionless like ``W_v``; ``eps`` > 0 is the singular
    value below which the damping grows; ``wv`` the diagonal of ``W_v``; ``rows`` the number of
    conditioning rows.
    """

    def __init__(self, lambda0: float, lambda_max: float, eps: float, every: int, wv: NDArray[np.float64],
                 rows: int) -> None:
        self.lambda0, self.lambda_max, self.eps, self.every = float(lambda0), float(lambda_max), float(eps), every
        self._inv_sqrt_wv = 1.0 / np.sqrt(np.asarray(wv, dtype=np.float64))
        self.C = np.zeros((rows, len(self._inv_sqrt_wv)))
        self._G = np.zeros((rows, rows))
        self.state = np.array([0.0, self.lambda0**2])
        """[sigma, lambda^2] of the last refresh (an array, so compiled callers update it in place)."""

    @property
    def sigma(self) -> float:
        """Smallest singular value of the last refresh."""
        return float(self.state[0])

    @property
    def lam2(self) -> float:
        """lambda^2 in force."""
        return float(self.state[1])

    def due(self, step: int) -> bool:
        """Whether step ``step`` (0-based) refreshes sigma."""
        return step % self.every == 0

    def refresh(self) -> None:
        """Recompute sigma and lambda^2 from the conditioning rows in :attr:`C` (filled by the tasks)."""
        sigma = sigma_min(self.C, self.C.shape[0], self._inv_sqrt_wv, self._G)
        self.state[0] = sigma
        self.state[1] = damping_lambda2(sigma, self.lambda0, self.lambda_max, self.eps)
