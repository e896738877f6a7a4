"""Benchmark: one whole slithering controller step, ours vs a Pinocchio-plus-numpy step.

All follow the same tip trajectory (the 90 deg turn of tests/test_control.py, at
the given rate) from the default posture, with the same configuration:

* ours: ``SlitherController.step`` (input checks, path recording and chord
  lookup, kinematics, the four tasks' rows, adaptive damping, equation (4),
  integration: the tasks' and the path memory's kernels in one compiled call,
  navstack/control/fast.py),
* ours, task by task: the same controller through ``TaskSolver`` (one compiled
  call per task, as a controller with extra tasks runs; a zero-weight extra task
  selects it),
* peer: the same algorithm with Pinocchio kinematics (``computeJointJacobians``
  + ``updateFramePlacements`` + 7 x ``getFrameJacobian``), numpy task rows,
  ``numpy.linalg.svd`` for the damping's singular value (same refresh period),
  :func:`navstack.control.dls_rate` (``numpy.linalg.solve``), and the same
  :class:`~navstack.path.PathMemory` for the chord points.

Prints median microseconds per step, the ratio ours / peer (target <= 0.5) and
the largest difference between the theta_d trajectories (same algorithm:
should be round-off).

    python tools/bench_control.py [--rounds 5] [--hz 60] [--mode projected]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
from numpy.typing import NDArray

from navstack import jpl_serpentine
from navstack.control import MODES, ControlConfig, SlitherController, dls_rate
from navstack.control.tasks import Task
from navstack.jpl import ARM_JOINTS, LINK_LENGTH
from navstack.kinematics import Chain
from navstack.path import PathMemory


def _perp_bases(U: NDArray[np.float64]) -> NDArray[np.float64]:
    """(m, 2, 3) orthonormal rows perpendicular to the unit rows of ``U`` (the kernel's construction)."""
    ux, uy, uz = U[:, 0], U[:, 1], U[:, 2]
    sign = np.where(uz >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + uz)
    b = ux * uy * a
    n1 = np.stack([1.0 + sign * ux * ux * a, sign * b, -sign * ux], axis=1)
    n2 = np.stack([b, sign + uy * uy * a, -uy], axis=1)
    return np.stack([n1, n2], axis=1)


class PeerController:
    """Equation (4) slithering with Pinocchio kinematics and vectorised numpy (the benchmark's peer)."""

    def __init__(self, chain: Chain, cfg: ControlConfig, q0: NDArray[np.float64]) -> None:
        import pinocchio as pin

        from navstack._pinocchio import build_pinocchio

        self.pin = pin
        ref = build_pinocchio(chain)
        self.model, self.data = ref.model, ref.data
        self.fids = [int(f) for f in ref.point_frame_ids]
        self.cfg = cfg
        self.chain = chain
        n = chain.n
        self.q = np.array(q0, dtype=np.float64)
        pts = chain.points_and_jacobians(self.q)[0]
        self.path = PathMemory(pts, link_length=LINK_LENGTH, spacing=cfg.path_spacing)
        self.wv = np.asarray(cfg.wv, dtype=np.float64)
        self.sqrt_wv = np.sqrt(self.wv)
        posture = self.q[ARM_JOINTS].copy() if cfg.posture is None else np.asarray(cfg.posture)
        self.margin = np.where(chain.prismatic, cfg.limit_margin_prismatic, cfg.limit_margin)
        self.safe_margin = np.where(self.margin > 0, self.margin, 1.0)
        self.lo = chain.lower + self.margin
        self.hi = chain.upper - self.margin
        self.mode = MODES[cfg.slither]
        n_sl = {0: 0, 1: 12, 2: 18}[self.mode]
        self.n_sl = n_sl
        na = len(ARM_JOINTS)
        rows = 3 + n_sl + na + n
        # constant parts of the stacked task (unit rows, weights, gains, posture targets)
        self.J = np.zeros((rows, n))
        self.J[3 + n_sl + np.arange(na), ARM_JOINTS] = 1.0
        self.J[3 + n_sl + na :] = np.eye(n)
        self.z, self.zd, self.zdot = np.zeros(rows), np.zeros(rows), np.zeros(rows)
        self.w = np.concatenate([np.full(3, cfg.w_tip), np.full(n_sl, cfg.w_slither), np.full(na, cfg.w_posture),
                                 np.zeros(n)])
        self.k = np.concatenate([np.full(3, cfg.k_tip), np.full(n_sl, cfg.k_slither), np.full(na, cfg.k_posture),
                                 np.full(n, cfg.k_limit)])
        self.zd[3 + n_sl : 3 + n_sl + na] = posture
        self.prim_w = np.concatenate([np.full(3, math.sqrt(cfg.w_tip)), np.full(12, math.sqrt(cfg.w_slither))])
        self.steps = 0
        self.lam2 = cfg.lambda0**2

    def step(self, x_d: NDArray[np.float64], xdot_d: NDArray[np.float64]) -> NDArray[np.float64]:
        pin, cfg, q = self.pin, self.cfg, self.q
        x = np.asarray(x_d, dtype=np.float64)
        xd = np.asarray(xdot_d, dtype=np.float64)
        if not (np.isfinite(x).all() and np.isfinite(xd).all()):
            raise ValueError("x_d and xdot_d must be finite")
        self.path.record(x)
        yd, ydot = self.path.chain(x, xd)
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        pts = np.stack([self.data.oMf[f].translation for f in self.fids])
        jac = np.stack([pin.getFrameJacobian(self.model, self.data, f, pin.LOCAL_WORLD_ALIGNED)[:3]
                        for f in self.fids])
        J, z, zd, zdot, n_sl = self.J, self.z, self.zd, self.zdot, self.n_sl
        J[:3], z[:3], zd[:3], zdot[:3] = jac[0], pts[0], x, xd
        U = np.vstack([x, yd[:-1]]) - yd
        U /= np.linalg.norm(U, axis=1)[:, None]
        N = _perp_bases(U)
        proj = np.einsum("ibc,icj->ibj", N, jac[1:]).reshape(12, -1)
        if self.mode == 1:
            J[3:15] = proj
            z[3:15] = np.einsum("ibc,ic->ib", N, pts[1:]).ravel()
            zd[3:15] = np.einsum("ibc,ic->ib", N, yd).ravel()
            zdot[3:15] = np.einsum("ibc,ic->ib", N, ydot).ravel()
        elif self.mode == 2:
            J[3:21] = jac[1:].reshape(18, -1)
            z[3:21], zd[3:21], zdot[3:21] = pts[1:].ravel(), yd.ravel(), ydot.ravel()
        na = len(ARM_JOINTS)
        z[3 + n_sl : 3 + n_sl + na] = q[ARM_JOINTS]
        lim = slice(3 + n_sl + na, None)
        target = np.clip(q, self.lo, self.hi)
        xin = np.where(self.margin > 0, np.minimum(np.abs(target - q) / self.safe_margin, 1.0), 0.0)
        z[lim], zd[lim] = q, target
        self.w[lim] = cfg.w_limit * xin * xin * (3 - 2 * xin)
        if self.steps % cfg.sigma_every == 0:
            prim = np.vstack([jac[0], proj]) if self.mode else jac[0]
            Jh = prim * self.prim_w[: len(prim), None] / self.sqrt_wv
            sigma = float(np.linalg.svd(Jh, compute_uv=False).min())
            self.lam2 = cfg.lambda0**2
            if sigma < cfg.sigma_eps:
                self.lam2 += cfg.lambda_max**2 * (1 - (sigma / cfg.sigma_eps) ** 2)
        self.steps += 1
        qdot = dls_rate(J, self.w, self.wv, self.lam2, zdot, self.k, zd - z)
        if not np.isfinite(qdot).all():
            raise FloatingPointError("non-finite rate")
        self.q = np.clip(q + cfg.dt * qdot, self.chain.lower, self.chain.upper)
        return self.q.copy()


class _Idle(Task):
    """One row of weight 0: changes nothing, but makes the controller stack its tasks one by one."""

    name = "idle"

    @property
    def size(self) -> int:
        return 1

    def row_names(self) -> tuple[str, ...]:
        return ("idle.q1",)

    def fill(self, kin, R, info, r0) -> None:
        R[r0] = 0.0
        info[:, r0] = (kin.q[0], kin.q[0], 0.0, 0.0, 0.0, -1.0)


def _task_by_task(chain: Chain, cfg: ControlConfig, q0: NDArray[np.float64]) -> SlitherController:
    return SlitherController(chain, cfg, q0, extra_tasks=[_Idle(weight=0.0, gain=0.0)])


def _turn_commands(tip0: NDArray[np.float64], v: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """x_d, xdot_d samples of the 90 deg turn (0.1 m +z0, arc r = 0.3 m to +x0, 0.3 m +x0)."""
    ez, ex = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    r, s1 = 0.3, 0.1
    s2 = s1 + r * math.pi / 2
    s3 = s2 + 0.3
    xs, vs = [], []
    for kk in range(int(math.ceil(s3 / (v * dt))) + 1):
        s = min(kk * v * dt, s3)
        if s <= s1:
            p, t = tip0 + s * ez, ez
        elif s <= s2:
            ph = (s - s1) / r
            p = tip0 + s1 * ez + r * ex - r * math.cos(ph) * ex + r * math.sin(ph) * ez
            t = math.sin(ph) * ex + math.cos(ph) * ez
        else:
            p = tip0 + s1 * ez + r * ex + r * ez + (s - s2) * ex
            t = ex
        xs.append(p)
        vs.append(v * t if s < s3 else 0 * t)
    return np.array(xs), np.array(vs)


def _run(ctl, xs: np.ndarray, vs: np.ndarray, block: int) -> tuple[list[float], np.ndarray]:
    """Step through all commands; per-step times [us] of blocks of ``block`` steps, and the theta_d's."""
    times = []
    out = np.empty((len(xs), 20))
    for b0 in range(0, len(xs), block):
        b1 = min(b0 + block, len(xs))
        t0 = time.perf_counter_ns()
        for i in range(b0, b1):
            out[i] = ctl.step(xs[i], vs[i])
        times.append((time.perf_counter_ns() - t0) / (b1 - b0) / 1e3)
    return times, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--hz", type=float, default=60.0)
    ap.add_argument("--speed", type=float, default=0.05, help="tip speed [m/s]")
    ap.add_argument("--mode", choices=sorted(MODES), default="projected")
    ap.add_argument("--block", type=int, default=50)
    args = ap.parse_args()

    chain = jpl_serpentine()
    cfg = ControlConfig(dt=1.0 / args.hz, slither=args.mode)
    q0 = chain.q_default
    tip0 = chain.points_and_jacobians(q0)[0][0]
    xs, vs = _turn_commands(tip0, args.speed, cfg.dt)

    _run(SlitherController(chain, cfg, q0), xs[:100], vs[:100], args.block)  # warm up
    _run(_task_by_task(chain, cfg, q0), xs[:100], vs[:100], args.block)
    _run(PeerController(chain, cfg, q0), xs[:100], vs[:100], args.block)
    ours_t: list[float] = []
    tasks_t: list[float] = []
    peer_t: list[float] = []
    worst = 0.0
    for _ in range(args.rounds):  # interleaved: machine load affects all alike
        t, q_ours = _run(SlitherController(chain, cfg, q0), xs, vs, args.block)
        ours_t += t
        t, q_tasks = _run(_task_by_task(chain, cfg, q0), xs, vs, args.block)
        tasks_t += t
        t, q_peer = _run(PeerController(chain, cfg, q0), xs, vs, args.block)
        peer_t += t
        worst = max(worst, float(np.abs(q_ours - q_peer).max()), float(np.abs(q_ours - q_tasks).max()))
    mo, mt, mp = statistics.median(ours_t), statistics.median(tasks_t), statistics.median(peer_t)
    print(f"controller step, mode={args.mode}, {len(xs)} steps x {args.rounds} rounds at {args.hz:g} Hz, "
          f"sigma refreshed every {cfg.sigma_every} steps; median per step:")
    print(f"  ours  SlitherController.step (one compiled call)  : {mo:8.2f} us")
    print(f"  ours  task by task (TaskSolver, a call per task)  : {mt:8.2f} us")
    print(f"  peer  Pinocchio + numpy (same algorithm)          : {mp:8.2f} us")
    print(f"  ratio ours/peer = {mo / mp:.3f}  (target <= 0.5)")
    print(f"  max |theta_d difference| (ours vs task by task and vs peer) over the run = {worst:.2e}")


if __name__ == "__main__":
    main()
