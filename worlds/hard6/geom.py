"""Exact point-to-triangle-mesh distance without rtree (numpy + scipy cKDTree). Used by make.py and verify.py."""
import numpy as np
from scipy.spatial import cKDTree


def closest_on_tri(P, A, B, C):
    """closest points on triangles (A,B,C) to points P, all (N,3) (Ericson, Real-Time Collision Detection 5.1.5)"""
    ab = B - A; ac = C - A; ap = P - A
    d1 = np.einsum('ij,ij->i', ab, ap); d2 = np.einsum('ij,ij->i', ac, ap)
    bp = P - B; d3 = np.einsum('ij,ij->i', ab, bp); d4 = np.einsum('ij,ij->i', ac, bp)
    cp = P - C; d5 = np.einsum('ij,ij->i', ab, cp); d6 = np.einsum('ij,ij->i', ac, cp)
    va = d3 * d6 - d5 * d4; vb = d5 * d2 - d1 * d6; vc = d1 * d4 - d3 * d2
    den = va + vb + vc; den = np.where(np.abs(den) < 1e-300, 1e-300, den)
    v = vb / den; w = vc / den
    out = A + ab * v[:, None] + ac * w[:, None]                      # interior
    # edge BC
    m = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
    wbc = np.where(m, (d4 - d3) / np.where(m, (d4 - d3) + (d5 - d6), 1), 0)
    out = np.where(m[:, None], B + (C - B) * wbc[:, None], out)
    # edge AC
    m = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    wac = np.where(m, d2 / np.where(m, d2 - d6, 1), 0)
    out = np.where(m[:, None], A + ac * wac[:, None], out)
    # edge AB
    m = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    vab = np.where(m, d1 / np.where(m, d1 - d3, 1), 0)
    out = np.where(m[:, None], A + ab * vab[:, None], out)
    # vertices
    out = np.where(((d6 >= 0) & (d5 <= d6))[:, None], C, out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[:, None], B, out)
    out = np.where(((d1 <= 0) & (d2 <= 0))[:, None], A, out)
    return out


class MeshDist:
    def __init__(self, V, F):
        self.T = np.asarray(V, float)[np.asarray(F)]            # (M,3,3)
        self.c = self.T.mean(axis=1)
        self.rmax = float(np.linalg.norm(self.T - self.c[:, None, :], axis=2).max())
        self.tree = cKDTree(self.c)

    def __call__(self, P, cap=None):
        """exact unsigned distance of each point to the surface; points farther than cap (if given) get >= cap"""
        P = np.atleast_2d(np.asarray(P, float))
        d0, _ = self.tree.query(P)
        out = np.full(len(P), np.inf)
        idx = np.arange(len(P))
        if cap is not None:
            far = d0 - self.rmax > cap
            out[far] = d0[far] - self.rmax; idx = idx[~far]
        if len(idx) == 0: return out
        lists = self.tree.query_ball_point(P[idx], d0[idx] + self.rmax + 1e-9)
        pi = np.concatenate([np.full(len(l), i) for i, l in zip(idx, lists)])
        ti = np.concatenate([np.asarray(l, int) for l in lists])
        for a in range(0, len(pi), 400000):
            p = P[pi[a:a + 400000]]; t = self.T[ti[a:a + 400000]]
            q = closest_on_tri(p, t[:, 0], t[:, 1], t[:, 2])
            d = np.linalg.norm(p - q, axis=1)
            np.minimum.at(out, pi[a:a + 400000], d)
        return out
