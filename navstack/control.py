"""Configuration control of the paper's equation (4): slithering of the JPL serpentine robot.

Equation (4) of the paper (damped least squares / configuration control)::

    thetadot_d = [J^T W J + lambda^2 W_v]^-1 J^T W (zdot_d + K e),   e = z_d - z,

integrated to the desired joint trajectory ``theta_d``.  :func:`dls_rate` is that
formula and nothing else.  :class:`SlitherController` stacks the task rows, solves
(4) in a compiled kernel and integrates; it reads only the desired tip motion and
its own state (never obstacle geometry).

Tasks (row blocks of J, z_d, zdot_d, e, weight W, gain K; in this order)
    * ``tip`` (3 rows): tip position x [m], J = tip Jacobian, weight ``w_tip``.
    * ``slither`` joints J1..J6, desired points ``y_d,i`` and velocities from the
      :class:`~navstack.path.PathMemory` chord rule:

      - ``"projected"`` (default, the paper's two coordinates per joint): with
        ``u_i = unit(y_d,i-1 - y_d,i)`` (``y_d,0 = x_d``) the desired link
        direction and ``N_i`` (3x2) an orthonormal basis of the plane
        perpendicular to ``u_i`` (recomputed each step, so the frame turns with
        the path): rows ``N_i^T J_i``, ``z = N_i^T y_i``, ``zdot_d = N_i^T ydot_d,i``
        (the frame's own rotation times the error is neglected: second order).
        With equal weight and gain on both rows the result does not depend on
        the choice of basis in that plane (only on ``I - u u^T``).
      - ``"full"``: the three coordinates of each joint point (18 rows).
      - ``"none"``: no slithering rows: the ``tip-only`` baseline with the same
        damping, posture and limit tasks.

      Weight ``w_slither``, gain ``k_slither``.
    * ``posture`` (one unit row ``e_j^T`` per arm joint 2..8, weight ``w_posture``,
      gain ``k_posture``): ``z = theta_j``, ``z_d`` = posture, ``zdot_d = 0``.
      Together with a cheap lathe bed in ``W_v`` it makes insertion come from
      the lathe bed (with ``W_v`` alike for metres and radians and no posture
      the solver straightens the elbow instead, and the arm ends at full
      stretch; see tests/test_control.py).
    * ``limits`` (one unit row per joint, 20): ``z = theta_j``; inside a margin
      ``m_j`` of a limit the target is the margin's edge (``e`` pushes back) and
      the weight ramps smoothly as ``w_limit * smoothstep(depth / m_j)``
      (``smoothstep(x) = 3x^2 - 2x^3``), zero outside the margin.

    Unit rows contribute only to the diagonal of ``J^T W J``; the kernel adds
    them as such (the same equation (4), fewer flops).

Adaptive damping
    ``sigma`` is the smallest singular value of the weighted, velocity-scaled
    task Jacobian ``W^1/2 J W_v^-1/2`` of the tip rows and the *projected*
    slither rows (also in ``"full"`` mode, whose along-link rows are dependent on
    the others through the rigid links; tip rows only in ``"none"`` mode), i.e.
    the scale at which the damping term competes in (4).  Then
    ``lambda^2 = lambda0^2 + lambda_max^2 (1 - (sigma/eps)^2)`` if ``sigma < eps``,
    else ``lambda0^2``.  ``sigma`` (an eigen-decomposition) is refreshed every
    ``sigma_every`` steps (the first step included) and held in between.

Integration and safety
    ``theta_d(t + dt) = theta_d(t) + dt * thetadot_d`` (explicit Euler, the rate
    evaluated at ``theta_d(t)`` and ``x_d(t)``), then clipped into the joint
    limits.  The normal matrix is symmetric positive definite
    (``lambda0 > 0``, ``W_v > 0``), so with finite inputs (checked: ``ValueError``)
    the rate is finite; if a non-finite rate ever appears the step raises
    :class:`ControlError` and ``theta_d`` keeps its previous value (the path
    memory has recorded ``x_d``), so a non-finite ``theta_d`` is never returned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Literal

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from navstack.jpl import ARM_JOINTS, LINK_LENGTH, N_JOINTS
from navstack.kinematics import Chain, frames_into, point_jacobians_into
from navstack.path import PathMemory

SlitherMode = Literal["projected", "full", "none"]
MODES: dict[str, int] = {"none": 0, "projected": 1, "full": 2}

DEG = math.pi / 180.0


class ControlError(RuntimeError):
    """The controller could not produce a finite joint rate (state left unchanged)."""


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


# --------------------------------------------------------------------------- configuration
@dataclass(frozen=True)
class ControlConfig:
    """Configuration of :class:`SlitherController` (units in brackets).

    Weights are the diagonal of ``W`` per task block, gains the diagonal of
    ``K`` [1/s]; ``wv`` is the diagonal of ``W_v`` (20 values, per joint; the
    lathe bed is cheap so insertion comes from it).  ``posture`` is the arm
    posture (7 values [rad] for joints 2..8; ``None``: the arm joints of the
    controller's ``q0``).  ``limit_margin`` [rad] applies to revolute joints,
    ``limit_margin_prismatic`` [m] to the lathe bed.
    """

    dt: float = 1.0 / 240.0
    """Control period [s]."""
    slither: SlitherMode = "projected"
    w_tip: float = 1.0
    k_tip: float = 20.0
    w_slither: float = 1.0
    k_slither: float = 20.0
    w_posture: float = 1e-2
    k_posture: float = 1.0
    posture: tuple[float, ...] | None = None
    w_limit: float = 1.0
    k_limit: float = 5.0
    limit_margin: float = 10.0 * DEG
    limit_margin_prismatic: float = 0.1
    lambda0: float = 0.01
    lambda_max: float = 0.1
    sigma_eps: float = 0.05
    sigma_every: int = 5
    wv: tuple[float, ...] = (0.01,) + (1.0,) * 7 + (0.1,) * 12
    path_spacing: float = 1e-3
    """Minimum spacing of recorded path vertices [m]."""

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("slither", "posture", "wv", "sigma_every"):
                continue
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"ControlConfig.{f.name} must be a finite number, got {v!r}")
        positive = ("dt", "w_tip", "lambda0", "sigma_eps", "path_spacing")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"ControlConfig.{name} must be > 0, got {getattr(self, name)!r}")
        nonneg = ("k_tip", "w_slither", "k_slither", "w_posture", "k_posture", "w_limit", "k_limit",
                  "limit_margin", "limit_margin_prismatic", "lambda_max")
        for name in nonneg:
            if getattr(self, name) < 0:
                raise ValueError(f"ControlConfig.{name} must be >= 0, got {getattr(self, name)!r}")
        for name in ("k_tip", "k_slither", "k_posture", "k_limit"):
            if getattr(self, name) * self.dt > 1.0:
                raise ValueError(
                    f"ControlConfig.{name}={getattr(self, name)} 1/s is too large for dt={self.dt} s "
                    f"(need gain*dt <= 1 for a stable discrete loop)"
                )
        if self.slither not in MODES:
            raise ValueError(f"ControlConfig.slither must be one of {sorted(MODES)}, got {self.slither!r}")
        if isinstance(self.sigma_every, bool) or not isinstance(self.sigma_every, int) or self.sigma_every < 1:
            raise ValueError(f"ControlConfig.sigma_every must be an integer >= 1, got {self.sigma_every!r}")
        wv = np.asarray(self.wv, dtype=np.float64)
        if wv.shape != (N_JOINTS,) or not np.isfinite(wv).all() or (wv <= 0).any():
            raise ValueError(f"ControlConfig.wv must be {N_JOINTS} finite values > 0, got {self.wv!r}")
        if self.posture is not None:
            p = np.asarray(self.posture, dtype=np.float64)
            if p.shape != (len(ARM_JOINTS),) or not np.isfinite(p).all():
                raise ValueError(
                    f"ControlConfig.posture must be {len(ARM_JOINTS)} finite arm angles [rad] or None, "
                    f"got {self.posture!r}"
                )


# parameter vector layout (float64) passed to the kernels
P_DT, P_WTIP, P_KTIP, P_WSL, P_KSL, P_WLIM, P_KLIM, P_KPOST, P_LAM0, P_LAMMAX, P_EPS, P_LINK, P_MODE, \
    P_EVERY, P_SPACING = range(15)
N_PRM = 15
# per-joint configuration rows (6, n)
C_WV, C_POSTURE, C_WPOST, C_LOWER, C_UPPER, C_MARGIN = range(6)
# per-row information (6, max rows)
I_Z, I_ZD, I_ZDOT, I_W, I_K, I_COL = range(6)
# info outputs
O_LAM2, O_SIGMA, O_NROWS, O_NDENSE, O_STATUS = range(5)
MAX_ROWS = 3 + 18 + 2 * N_JOINTS

STATUS_OK, STATUS_BAD_X, STATUS_BAD_XDOT, STATUS_NONFINITE, STATUS_CHOLESKY = range(5)


# --------------------------------------------------------------------------- kernels
@numba.njit(cache=True, inline="always")
def _perp_basis(ux, uy, uz):  # pragma: no cover - jitted
    """Orthonormal n1, n2 perpendicular to unit u (Duff et al. 2017, branch-free)."""
    sign = 1.0 if uz >= 0.0 else -1.0
    a = -1.0 / (sign + uz)
    b = ux * uy * a
    return (1.0 + sign * ux * ux * a, sign * b, -sign * ux), (b, sign + uy * uy * a, -uy)


@numba.njit(cache=True)
def _build_rows(alpha, a, d, theta, prismatic, point_frames, q, x_d, xdot_d, yd, ydot, prm, cfg,
                F, Jp, R, info):  # pragma: no cover - jitted
    """Kinematics at ``q`` and all task rows into ``R`` (rows, n) / ``info`` (6, rows).

    Returns (number of rows, number of dense rows); dense rows come first.
    """
    n = q.shape[0]
    frames_into(alpha, a, d, theta, prismatic, q, F)
    point_jacobians_into(F, prismatic, point_frames, Jp)
    mode = int(prm[P_MODE])
    r = 0
    # tip (point 0)
    f0 = point_frames[0]
    for c in range(3):
        for j in range(n):
            R[r, j] = Jp[0, c, j]
        info[I_Z, r] = F[f0, c, 3]
        info[I_ZD, r] = x_d[c]
        info[I_ZDOT, r] = xdot_d[c]
        info[I_W, r] = prm[P_WTIP]
        info[I_K, r] = prm[P_KTIP]
        info[I_COL, r] = -1.0
        r += 1
    # slithering of J1..J6 (points 1..6)
    if mode != 0:
        px, py, pz = x_d[0], x_d[1], x_d[2]
        for i in range(yd.shape[0]):
            f = point_frames[i + 1]
            qx, qy, qz = yd[i, 0], yd[i, 1], yd[i, 2]
            if mode == 1:
                ux, uy, uz = px - qx, py - qy, pz - qz
                un = math.sqrt(ux * ux + uy * uy + uz * uz)
                n1, n2 = _perp_basis(ux / un, uy / un, uz / un)
                for b in range(2):
                    nb = n1 if b == 0 else n2
                    z = 0.0
                    zd = 0.0
                    zdot = 0.0
                    for c in range(3):
                        z += nb[c] * F[f, c, 3]
                        zd += nb[c] * yd[i, c]
                        zdot += nb[c] * ydot[i, c]
                    for j in range(n):
                        R[r, j] = nb[0] * Jp[i + 1, 0, j] + nb[1] * Jp[i + 1, 1, j] + nb[2] * Jp[i + 1, 2, j]
                    info[I_Z, r] = z
                    info[I_ZD, r] = zd
                    info[I_ZDOT, r] = zdot
                    info[I_W, r] = prm[P_WSL]
                    info[I_K, r] = prm[P_KSL]
                    info[I_COL, r] = -1.0
                    r += 1
            else:
                for c in range(3):
                    for j in range(n):
                        R[r, j] = Jp[i + 1, c, j]
                    info[I_Z, r] = F[f, c, 3]
                    info[I_ZD, r] = yd[i, c]
                    info[I_ZDOT, r] = ydot[i, c]
                    info[I_W, r] = prm[P_WSL]
                    info[I_K, r] = prm[P_KSL]
                    info[I_COL, r] = -1.0
                    r += 1
            px, py, pz = qx, qy, qz
    n_dense = r
    # posture: unit rows
    for j in range(n):
        if cfg[C_WPOST, j] > 0.0:
            for jj in range(n):
                R[r, jj] = 0.0
            R[r, j] = 1.0
            info[I_Z, r] = q[j]
            info[I_ZD, r] = cfg[C_POSTURE, j]
            info[I_ZDOT, r] = 0.0
            info[I_W, r] = cfg[C_WPOST, j]
            info[I_K, r] = prm[P_KPOST]
            info[I_COL, r] = j
            r += 1
    # joint-limit avoidance: unit rows, smooth weight inside the margin
    for j in range(n):
        for jj in range(n):
            R[r, jj] = 0.0
        R[r, j] = 1.0
        m = cfg[C_MARGIN, j]
        lo = cfg[C_LOWER, j] + m
        hi = cfg[C_UPPER, j] - m
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
            x = depth / m
            if x > 1.0:
                x = 1.0
            wgt = prm[P_WLIM] * x * x * (3.0 - 2.0 * x)
        info[I_Z, r] = q[j]
        info[I_ZD, r] = target
        info[I_ZDOT, r] = 0.0
        info[I_W, r] = wgt
        info[I_K, r] = prm[P_KLIM]
        info[I_COL, r] = j
        r += 1
    return r, n_dense


@numba.njit(cache=True)
def _sigma_min(Jp, x_d, yd, prm, cfg, G, Jh):  # pragma: no cover - jitted
    """Smallest singular value of W^1/2 J W_v^-1/2 over the tip + projected slither rows."""
    n = Jp.shape[2]
    mode = int(prm[P_MODE])
    r = 0
    sw = math.sqrt(prm[P_WTIP])
    for c in range(3):
        for j in range(n):
            Jh[r, j] = sw * Jp[0, c, j] / math.sqrt(cfg[C_WV, j])
        r += 1
    if mode != 0:
        sw = math.sqrt(prm[P_WSL])
        px, py, pz = x_d[0], x_d[1], x_d[2]
        for i in range(yd.shape[0]):
            ux, uy, uz = px - yd[i, 0], py - yd[i, 1], pz - yd[i, 2]
            un = math.sqrt(ux * ux + uy * uy + uz * uz)
            n1, n2 = _perp_basis(ux / un, uy / un, uz / un)
            for b in range(2):
                nb = n1 if b == 0 else n2
                for j in range(n):
                    Jh[r, j] = sw * (nb[0] * Jp[i + 1, 0, j] + nb[1] * Jp[i + 1, 1, j]
                                     + nb[2] * Jp[i + 1, 2, j]) / math.sqrt(cfg[C_WV, j])
                r += 1
            px, py, pz = yd[i, 0], yd[i, 1], yd[i, 2]
    for i in range(r):
        for k in range(i + 1):
            s = 0.0
            for j in range(n):
                s += Jh[i, j] * Jh[k, j]
            G[i, k] = s
            G[k, i] = s
    ev = np.linalg.eigvalsh(G[:r, :r])
    lo = ev[0]
    return math.sqrt(lo) if lo > 0.0 else 0.0


@numba.njit(cache=True)
def _damping(sigma, prm):  # pragma: no cover - jitted
    """lambda^2 = lambda0^2 + lambda_max^2 (1 - (sigma/eps)^2) if sigma < eps else lambda0^2."""
    lam2 = prm[P_LAM0] * prm[P_LAM0]
    eps = prm[P_EPS]
    if sigma < eps:
        r = sigma / eps
        lam2 += prm[P_LAMMAX] * prm[P_LAMMAX] * (1.0 - r * r)
    return lam2


@numba.njit(cache=True)
def _solve_rows(R, info, n_rows, n_dense, wv, lam2, H, g, out):  # pragma: no cover - jitted
    """Equation (4) on the stacked rows; unit rows (after ``n_dense``) add to the diagonal only.

    Solves by Cholesky into ``out``; returns False if the matrix is not positive definite.
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
        if r >= n_dense:
            j = int(info[I_COL, r])
            H[j, j] += w
            g[j] += rhs
            continue
        for i in range(n):
            ri = R[r, i]
            if ri == 0.0:
                continue
            wri = w * ri
            g[i] += ri * rhs
            for j in range(i + 1):
                H[i, j] += wri * R[r, j]
    # Cholesky H = L L^T in the lower triangle
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
    for i in range(n):  # L y = g
        s = g[i]
        for k in range(i):
            s -= H[i, k] * out[k]
        out[i] = s / H[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        s = out[i]
        for k in range(i + 1, n):
            s -= H[k, i] * out[k]
        out[i] = s / H[i, i]
    return True


@numba.njit(cache=True)
def _step_kernel(alpha, a, d, theta, prismatic, point_frames, q, qdot, x_d, xdot_d,
                 nst, yd, ydot,
                 prm, cfg, F, Jp, R, rinfo, H, g, G, Jh, qnew, out):  # pragma: no cover - jitted
    """One controller step; ``out`` gets [lam2, sigma, rows, dense rows, status]. Returns status."""
    for c in range(3):
        if not math.isfinite(x_d[c]):
            out[O_STATUS] = STATUS_BAD_X
            return STATUS_BAD_X
        if not math.isfinite(xdot_d[c]):
            out[O_STATUS] = STATUS_BAD_XDOT
            return STATUS_BAD_XDOT
    # kinematic loop: tasks at z = f(theta_d)
    n_rows, n_dense = _build_rows(alpha, a, d, theta, prismatic, point_frames, q, x_d, xdot_d, yd, ydot,
                                  prm, cfg, F, Jp, R, rinfo)
    every = int(prm[P_EVERY])
    if nst[1] % every == 0:
        sigma = _sigma_min(Jp, x_d, yd, prm, cfg, G, Jh)
        out[O_SIGMA] = sigma
        out[O_LAM2] = _damping(sigma, prm)
    nst[1] += 1
    out[O_NROWS] = n_rows
    out[O_NDENSE] = n_dense
    ok = _solve_rows(R, rinfo, n_rows, n_dense, cfg[C_WV], out[O_LAM2], H, g, qnew)
    if not ok:
        out[O_STATUS] = STATUS_CHOLESKY
        return STATUS_CHOLESKY
    n = q.shape[0]
    dt = prm[P_DT]
    for j in range(n):
        if not math.isfinite(qnew[j]):
            out[O_STATUS] = STATUS_NONFINITE
            return STATUS_NONFINITE
    for j in range(n):
        v = q[j] + dt * qnew[j]
        if v < cfg[C_LOWER, j]:
            v = cfg[C_LOWER, j]
        elif v > cfg[C_UPPER, j]:
            v = cfg[C_UPPER, j]
        qdot[j] = (v - q[j]) / dt
        q[j] = v
    out[O_STATUS] = STATUS_OK
    return STATUS_OK


# --------------------------------------------------------------------------- controller
@dataclass(frozen=True)
class TaskRows:
    """The stacked task of equation (4) at one configuration.

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


class SlitherController:
    """Equation (4) slithering controller for the 20-DOF JPL robot (see the module docstring).

    ``SlitherController(chain, config, q0)`` starts with ``theta_d = q0`` and a
    :class:`PathMemory` holding ``q0``'s backbone.  Each :meth:`step` records
    the desired tip, builds the tasks at ``z = f(theta_d)`` (kinematic loop),
    solves (4), integrates over ``config.dt`` and clips into the limits.
    """

    def __init__(self, chain: Chain, config: ControlConfig | None = None, q0: ArrayLike | None = None) -> None:
        cfg = ControlConfig() if config is None else config
        if not isinstance(cfg, ControlConfig):
            raise TypeError(f"config must be a ControlConfig, got {type(cfg).__name__}")
        if chain.n != N_JOINTS or len(chain.point_frames) != 7:
            raise ValueError(
                f"SlitherController needs the JPL layout (20 joints, 7 backbone points), got chain "
                f"{chain.name!r} with {chain.n} joints and {len(chain.point_frames)} points"
            )
        q = chain.check(chain.q_default if q0 is None else q0).copy()
        out_of = np.flatnonzero((q < chain.lower) | (q > chain.upper))
        if out_of.size:
            j = int(out_of[0])
            raise ValueError(
                f"q0[{j}] (joint {j + 1}) = {q[j]} is outside its limits [{chain.lower[j]}, {chain.upper[j]}]"
            )
        self.chain = chain
        self.config = cfg
        self._q = q
        self._qdot = np.zeros(chain.n)
        backbone = chain.points_and_jacobians(q)[0]
        self.path = PathMemory(backbone, link_length=LINK_LENGTH, spacing=cfg.path_spacing)

        prm = np.zeros(N_PRM)
        prm[P_DT] = cfg.dt
        prm[P_WTIP], prm[P_KTIP] = cfg.w_tip, cfg.k_tip
        prm[P_WSL], prm[P_KSL] = cfg.w_slither, cfg.k_slither
        prm[P_WLIM], prm[P_KLIM] = cfg.w_limit, cfg.k_limit
        prm[P_KPOST] = cfg.k_posture
        prm[P_LAM0], prm[P_LAMMAX], prm[P_EPS] = cfg.lambda0, cfg.lambda_max, cfg.sigma_eps
        prm[P_LINK] = LINK_LENGTH
        prm[P_MODE] = MODES[cfg.slither]
        prm[P_EVERY] = cfg.sigma_every
        prm[P_SPACING] = cfg.path_spacing
        self._prm = prm
        c = np.zeros((6, chain.n))
        c[C_WV] = cfg.wv
        posture = q[ARM_JOINTS] if cfg.posture is None else np.asarray(cfg.posture, dtype=np.float64)
        c[C_POSTURE] = q
        c[C_POSTURE, ARM_JOINTS] = posture
        c[C_WPOST, ARM_JOINTS] = cfg.w_posture
        c[C_LOWER] = chain.lower
        c[C_UPPER] = chain.upper
        c[C_MARGIN] = np.where(chain.prismatic, cfg.limit_margin_prismatic, cfg.limit_margin)
        self._cfg = c
        span = chain.upper - chain.lower
        tight = np.flatnonzero(2.0 * c[C_MARGIN] >= span)
        if tight.size:
            j = int(tight[0])
            name = "limit_margin_prismatic" if chain.prismatic[j] else "limit_margin"
            raise ValueError(f"ControlConfig.{name}={c[C_MARGIN, j]} leaves no free range for joint {j + 1} "
                             f"(range {span[j]})")
        outside = np.flatnonzero((posture < chain.lower[ARM_JOINTS]) | (posture > chain.upper[ARM_JOINTS]))
        if outside.size:
            j = int(ARM_JOINTS[outside[0]])
            raise ValueError(f"ControlConfig.posture for joint {j + 1} = {c[C_POSTURE, j]} is outside its limits "
                             f"[{chain.lower[j]}, {chain.upper[j]}]")

        n = chain.n
        self._F = np.empty((chain.n_frames, 4, 4))
        self._Jp = np.empty((7, 3, n))
        self._R = np.zeros((MAX_ROWS, n))
        self._rinfo = np.zeros((6, MAX_ROWS))
        self._H = np.empty((n, n))
        self._g = np.empty(n)
        self._G = np.empty((15, 15))
        self._Jh = np.empty((15, n))
        self._qnew = np.zeros(n)
        self._out = np.zeros(5)
        self._nst = np.array([0, 0], dtype=np.int64)
        self._x_d = backbone[0].copy()
        self._xdot_d = np.zeros(3)
        self._steps = 0

    # ---- state ---------------------------------------------------------
    @property
    def theta_d(self) -> NDArray[np.float64]:
        """Desired joint positions (copy) [m for joint 1, rad otherwise]."""
        return self._q.copy()

    @property
    def thetadot_d(self) -> NDArray[np.float64]:
        """Effective joint rates of the last step, ``(theta_d(t+dt) - theta_d(t)) / dt`` (copy) [m/s, rad/s].

        Equal to equation (4)'s rate except for joints clipped at a limit
        (see :attr:`rate_eq4`); a servo velocity feed-forward.
        """
        return self._qdot.copy()

    @property
    def rate_eq4(self) -> NDArray[np.float64]:
        """Equation (4)'s rate of the last step, before clipping (copy) [m/s, rad/s]."""
        return self._qnew.copy()

    @property
    def desired_points(self) -> NDArray[np.float64]:
        """The last desired joint points y_d (6, 3) [m], J1 first (copy)."""
        return self.path.pts.copy()

    @property
    def desired_velocities(self) -> NDArray[np.float64]:
        """The last desired joint-point velocities (6, 3) [m/s] (copy)."""
        return self.path.vel.copy()

    @property
    def lam(self) -> float:
        """Damping lambda of the last step (sqrt of the adaptive lambda^2)."""
        return math.sqrt(self._out[O_LAM2])

    @property
    def sigma_min(self) -> float:
        """Smallest singular value of the weighted task Jacobian (last refresh)."""
        return float(self._out[O_SIGMA])

    @property
    def steps(self) -> int:
        """Number of completed steps."""
        return self._steps

    @property
    def posture(self) -> NDArray[np.float64]:
        """The arm posture held by the posture task (7,) [rad]."""
        return self._cfg[C_POSTURE, ARM_JOINTS].copy()

    # ---- stepping ------------------------------------------------------
    def step(self, x_d: ArrayLike, xdot_d: ArrayLike) -> NDArray[np.float64]:
        """Advance one period with desired tip ``x_d`` [m] and velocity ``xdot_d`` [m/s]; returns theta_d (copy).

        Both are in the robot's base frame (DH frame 0) at time ``t``.  The rate
        of (4) is evaluated at ``theta_d(t)`` and integrated, so the returned
        ``theta_d(t + dt)`` has ``f(theta_d(t + dt)) ~ x_d(t) + dt * xdot_d(t)``:
        the servo target for the end of the period.

        Raises ``ValueError`` for a non-3-vector or non-finite input (nothing is
        recorded then) and :class:`ControlError` if no finite rate results.
        """
        x = np.asarray(x_d, dtype=np.float64)
        xd = np.asarray(xdot_d, dtype=np.float64)
        if x.shape != (3,):
            raise ValueError(f"x_d must be a 3-vector [m], got shape {x.shape}")
        if xd.shape != (3,):
            raise ValueError(f"xdot_d must be a 3-vector [m/s], got shape {xd.shape}")
        path = self.path
        if np.isfinite(x).all() and np.isfinite(xd).all():
            path.advance(x, xd)
        ch = self.chain
        status = _step_kernel(
            ch.alpha, ch.a, ch.d, ch.theta, ch.prismatic, ch.point_frames, self._q, self._qdot, x, xd,
            self._nst, path.pts, path.vel,
            self._prm, self._cfg, self._F, self._Jp, self._R, self._rinfo, self._H, self._g, self._G,
            self._Jh, self._qnew, self._out,
        )
        if status != STATUS_OK:
            self._fail(status, x, xd)
        self._x_d = x.copy()
        self._xdot_d = xd.copy()
        self._steps += 1
        return self._q.copy()

    def _fail(self, status: int, x: NDArray[np.float64], xd: NDArray[np.float64]) -> None:
        if status == STATUS_BAD_X:
            raise ValueError(f"x_d must be finite [m], got {x.tolist()} at step {self._steps}")
        if status == STATUS_BAD_XDOT:
            raise ValueError(f"xdot_d must be finite [m/s], got {xd.tolist()} at step {self._steps}")
        bad = np.flatnonzero(~np.isfinite(self._qnew))
        what = f"joint {int(bad[0]) + 1} rate is {self._qnew[bad[0]]}" if bad.size else "normal matrix not SPD"
        raise ControlError(f"equation (4) gave no finite rate at step {self._steps} ({what}); theta_d held")

    def tasks(self, q: ArrayLike | None = None) -> TaskRows:
        """The stacked task rows at ``q`` (default ``theta_d``) for the last desired tip and chain points.

        For inspection and tests; does not change the controller's state.
        """
        qv = self.chain.check(self._q if q is None else q).copy()
        F = np.empty_like(self._F)
        Jp = np.empty_like(self._Jp)
        R = np.zeros_like(self._R)
        info = np.zeros_like(self._rinfo)
        ch = self.chain
        n_rows, n_dense = _build_rows(ch.alpha, ch.a, ch.d, ch.theta, ch.prismatic, ch.point_frames, qv,
                                      self._x_d, self._xdot_d, self.path.pts, self.path.vel,
                                      self._prm, self._cfg, F, Jp, R, info)
        names: list[str] = ["tip.x", "tip.y", "tip.z"]
        mode = self.config.slither
        for i in range(1, 7):
            if mode == "projected":
                names += [f"slither.J{i}.n1", f"slither.J{i}.n2"]
            elif mode == "full":
                names += [f"slither.J{i}.x", f"slither.J{i}.y", f"slither.J{i}.z"]
        names += [f"posture.q{j + 1}" for j in range(ch.n) if self._cfg[C_WPOST, j] > 0]
        names += [f"limit.q{j + 1}" for j in range(ch.n)]
        assert len(names) == n_rows and n_dense == 3 + (12 if mode == "projected" else 18 if mode == "full" else 0)
        return TaskRows(
            J=R[:n_rows].copy(), z=info[I_Z, :n_rows].copy(), z_d=info[I_ZD, :n_rows].copy(),
            zdot_d=info[I_ZDOT, :n_rows].copy(), w=info[I_W, :n_rows].copy(), k=info[I_K, :n_rows].copy(),
            names=tuple(names),
        )

    @property
    def wv(self) -> NDArray[np.float64]:
        """Diagonal of W_v (20,)."""
        return self._cfg[C_WV].copy()

    @property
    def lam2(self) -> float:
        """lambda^2 used by the last step."""
        return float(self._out[O_LAM2])
