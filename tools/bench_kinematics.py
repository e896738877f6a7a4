"""Benchmark: forward kinematics of all frames + the seven backbone point Jacobians, ours vs Pinocchio.

Ours: ``Chain.points_and_jacobians(q, copy=False)`` (validation + numba kernels),
and the bare kernels ``frames_into`` + ``point_jacobians_into``.
Peer (same run, same configurations): Pinocchio ``forwardKinematics`` +
``computeJointJacobians`` + ``updateFramePlacements`` + 7 x ``getFrameJacobian``
(LOCAL_WORLD_ALIGNED).  Prints medians in microseconds per evaluation and the
ratio ours / peer; also checks that both give the same numbers.

    python tools/bench_kinematics.py [--blocks 200] [--per-block 50]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from navstack import jpl_serpentine
from navstack.kinematics import frames_into, point_jacobians_into


def _blocks(fn: Callable[[np.ndarray], object], qs: np.ndarray, blocks: int, per_block: int) -> list[float]:
    """Per-call times [us] of ``blocks`` blocks of ``per_block`` calls (cycling through ``qs``)."""
    out = []
    n = len(qs)
    i = 0
    for _ in range(blocks):
        t0 = time.perf_counter_ns()
        for _ in range(per_block):
            fn(qs[i % n])
            i += 1
        out.append((time.perf_counter_ns() - t0) / per_block / 1e3)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=200)
    ap.add_argument("--per-block", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    import pinocchio as pin

    from navstack._pinocchio import build_pinocchio

    chain = jpl_serpentine()
    ref = build_pinocchio(chain)
    model, data = ref.model, ref.data
    fids = [int(f) for f in ref.point_frame_ids]
    rng = np.random.default_rng(args.seed)
    qs = np.ascontiguousarray(rng.uniform(chain.lower, chain.upper, size=(256, chain.n)))

    def ours(q: np.ndarray) -> object:
        return chain.points_and_jacobians(q, copy=False)

    F = np.empty((chain.n_frames, 4, 4))
    Jb = np.empty((len(chain.point_frames), 3, chain.n))
    al, a, d, th, pr, pf = chain.alpha, chain.a, chain.d, chain.theta, chain.prismatic, chain.point_frames

    def kernels(q: np.ndarray) -> object:
        frames_into(al, a, d, th, pr, q, F)
        point_jacobians_into(F, pr, pf, Jb)
        return Jb

    LWA = pin.LOCAL_WORLD_ALIGNED

    def peer(q: np.ndarray) -> object:
        pin.forwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        return [pin.getFrameJacobian(model, data, f, LWA) for f in fids]

    # correctness: same points and Jacobians
    worst = 0.0
    for q in qs[:20]:
        pts, jac = chain.points_and_jacobians(q)
        peer(q)
        rj = np.stack([pin.getFrameJacobian(model, data, f, LWA)[:3] for f in fids])
        rp = np.stack([data.oMf[f].translation for f in fids])
        worst = max(worst, float(np.abs(jac - rj).max()), float(np.abs(pts - rp).max()))
    for fn in (ours, kernels, peer):  # warm up (numba is compiled/cached already)
        _blocks(fn, qs, 5, args.per_block)

    times: dict[str, list[float]] = {"ours": [], "kernels": [], "peer": []}
    rounds = 4
    for _ in range(rounds):  # interleave so that machine load affects all alike
        times["ours"] += _blocks(ours, qs, args.blocks // rounds, args.per_block)
        times["kernels"] += _blocks(kernels, qs, args.blocks // rounds, args.per_block)
        times["peer"] += _blocks(peer, qs, args.blocks // rounds, args.per_block)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"FK of {chain.n_frames} frames + {len(fids)} point Jacobians (3x{chain.n}), "
          f"{args.blocks} blocks x {args.per_block} calls, median per call:")
    print(f"  ours  Chain.points_and_jacobians(copy=False) : {med['ours']:8.2f} us")
    print(f"  ours  bare numba kernels                     : {med['kernels']:8.2f} us")
    print(f"  peer  Pinocchio FK+JJ+frames+7 getFrameJac   : {med['peer']:8.2f} us")
    print(f"  ratio ours/peer = {med['ours'] / med['peer']:.3f}   kernels/peer = {med['kernels'] / med['peer']:.3f}")
    print(f"  max |ours - Pinocchio| (points, Jacobians) = {worst:.2e}")


if __name__ == "__main__":
    main()
