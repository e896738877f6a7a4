"""Own checker for batch 13 (helper acting as an outside user).  Two parts:

1. PLACEMENT (python verify_mesh.py --placement): for every mesh obstacle of every world here, navstack's own reading
   (navstack.load_world -> Mesh.triangles(), placed with the obstacle's position / rpy (extrinsic x-y-z, spec 2))
   against what the file MEANS (make.py's in-memory Part, written by our own writers; GLB node transforms composed
   by our own code): points sampled on each surface (area-weighted, 3 per mm^2-ish cap of 40,000) and their exact
   distance to the other surface, both ways; surface areas.  A surface navstack has that the file does not mean
   ("extra") or a meant surface navstack lacks ("missing") is a misread mesh.

2. TRIALS (python verify_mesh.py RUN_DIR [substring ...]): for each kept trial (trajectory.npz `q`, the trial's own
   world.json), our own modified-DH kinematics (spec section 1; self-tested against navstack.jpl_serpentine()),
   the serpentine capsules (J6-J5 ... J1-tip, r 0.025) and arm capsules (distinct frame origins 1..9, r 0.06);
   per control step the least clearance to
   - each mesh obstacle: the MEANT geometry (make.py's Part, matched to the trial's copied mesh file by its
     SHA-256), exact point-to-triangle distance at samples every 1 mm along each capsule axis, the best sample
     refined to 0.01 mm; negative inside a closed component (generalised winding number), so a link inside a
     closed part counts as a contact;
   - each primitive: hard5's exact signed distance, minimised along the axis by a ternary search (convex);
   contact steps (clearance < 0), goals reached in order (first sample with the tip within tolerance after the
   previous goal's), and the comparison with result.json: success, reason, goals_reached, metrics.min_clearance
   (agreement within 0.01 mm), metrics.contacts.  `wrong_success` = navstack says success while the meant
   geometry was touched or the goal not reached.
Usage: python verify_mesh.py --placement ;  python verify_mesh.py R [substring ...]"""
import glob, hashlib, json, math, os, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import make as M                      # noqa: E402   in-memory meanings (M.PARTS), hard5's sdf / R_of
M.WRITE = False
M.define_parts()
from make import SignedPartDist, R_of, MeshDist  # noqa: E402
h5 = M.h5

H = math.pi / 2
# Figure 2 (modified DH, metres): rows i = 1..21: (alpha_{i-1}, a_{i-1}, d_i, theta_i)
DH = [(0, 0, 0, 0), (H, 0, 0, 0), (H, .1232, 0, H), (H, .1079, .546, math.pi), (H, .0794, 0, math.pi),
      (H, .0794, .546, math.pi), (H, .0492, 0, math.pi), (H, .0492, .2, 0), (-H, 0, 0, -H), (-H, 0, 0, 0)]
for i in range(11, 21): DH.append((H if i % 2 else -H, .2 if i % 2 else 0, 0, 0))
DH.append((0, .2, 0, 0))


def T(al, a, d, th):
    ca, sa, ct, st = math.cos(al), math.sin(al), math.cos(th), math.sin(th)
    return np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -sa * d], [st * sa, ct * sa, ca, ca * d], [0, 0, 0, 1.]])


def origins(q, Rb, pb):
    Mx = np.eye(4); O = [pb.copy()]
    for i, (al, a, d, th) in enumerate(DH):
        if i == 0: d += q[0]
        elif i < 20: th += q[i]
        Mx = Mx @ T(al, a, d, th); O.append(Rb @ Mx[:3, 3] + pb)
    return O


def capsules(O):
    S = [(O[i], O[i + 2]) for i in (9, 11, 13, 15, 17, 19)]
    A = [O[1]]
    for i in range(2, 10):
        if np.linalg.norm(O[i] - A[-1]) > 1e-6: A.append(O[i])
    return S, [(A[i], A[i + 1]) for i in range(len(A) - 1)]


def sha(p): return hashlib.sha256(open(p, 'rb').read()).hexdigest()


PART_BY_SHA = {}
for key in M.PARTS:
    PART_BY_SHA[sha(os.path.join(HERE, key))] = key


# ---------------------------------------------------------------------------------------------------------
# 1. placement
# ---------------------------------------------------------------------------------------------------------
def sample_surface(Tw, n, seed=0):
    rng = np.random.default_rng(seed)
    A = 0.5 * np.linalg.norm(np.cross(Tw[:, 1] - Tw[:, 0], Tw[:, 2] - Tw[:, 0]), axis=1)
    k = rng.choice(len(Tw), size=n, p=A / A.sum())
    u, v = rng.random(n), rng.random(n); f = u + v > 1; u[f], v[f] = 1 - u[f], 1 - v[f]
    t = Tw[k]
    P = t[:, 0] + (t[:, 1] - t[:, 0]) * u[:, None] + (t[:, 2] - t[:, 0]) * v[:, None]
    # and every vertex and edge midpoint
    return np.vstack([P, Tw.reshape(-1, 3), (Tw + np.roll(Tw, 1, axis=1)).reshape(-1, 3) / 2])


def placement():
    import navstack
    rows = []
    for f in sorted(glob.glob(os.path.join(HERE, '*.json'))):
        w = json.load(open(f)); nw = navstack.load_world(f)
        for i, (o, no) in enumerate(zip(w['obstacles'], nw.obstacles)):
            if o['type'] != 'mesh': continue
            part = M.PARTS[o['path']]
            Tm = (part.T * o['scale']) @ R_of(o['rpy']).T + np.array(o['position'])
            V, F = no.triangles()
            Tn = np.asarray(V)[np.asarray(F)] @ R_of(no.rpy).T + np.asarray(no.position)
            mdn = MeshDist(Tn.reshape(-1, 3), np.arange(len(Tn) * 3).reshape(-1, 3))
            mdm = MeshDist(Tm.reshape(-1, 3), np.arange(len(Tm) * 3).reshape(-1, 3))
            Pm = sample_surface(Tm, 40000, 1); Pn = sample_surface(Tn, 40000, 2)
            dm = mdn(Pm); dn = mdm(Pn)
            area = lambda Tt: float(0.5 * np.linalg.norm(np.cross(Tt[:, 1] - Tt[:, 0], Tt[:, 2] - Tt[:, 0]), axis=1).sum())
            # extra area: navstack's triangles' area farther than 1 mm from the meant surface (by sampling)
            rows.append(dict(world=w['name'], obstacle=i, file=o['path'], meant_triangles=len(Tm), navstack_triangles=len(Tn),
                             meant_area_m2=round(area(Tm), 6), navstack_area_m2=round(area(Tn), 6),
                             missing_max_mm=round(float(dm.max()) * 1e3, 4), extra_max_mm=round(float(dn.max()) * 1e3, 4),
                             extra_fraction_over_1mm=round(float((dn > 1e-3).mean()), 4),
                             ok=bool(dm.max() < 1e-5 and dn.max() < 1e-5)))
            print(json.dumps(rows[-1]), flush=True)
    return rows


# ---------------------------------------------------------------------------------------------------------
# 2. trials
# ---------------------------------------------------------------------------------------------------------
def seg_min_convex(o, A, B):
    lo = np.zeros(len(A)); hi = np.ones(len(A))
    f = lambda t: h5.sdf(o, A + (B - A) * t[:, None])
    for _ in range(60):
        m1 = lo + (hi - lo) / 3; m2 = hi - (hi - lo) / 3
        left = f(m1) > f(m2); lo = np.where(left, m1, lo); hi = np.where(left, hi, m2)
    t = (lo + hi) / 2
    return np.minimum(np.minimum(f(t), f(np.zeros(len(A)))), f(np.ones(len(A))))


class PlacedMesh:
    def __init__(self, part, o):
        self.sd = SignedPartDist(part, o['position'], o['rpy'], o.get('scale', 1.0))
        P = self.sd.T.reshape(-1, 3); self.lo, self.hi = P.min(axis=0), P.max(axis=0)

    def seg_min(self, A, B, rad, far=0.35):
        """least signed distance along each segment (exact where it matters).  Segments whose samples (every
        2.5 % of their length) are all more than `far` from the mesh's box get that lower bound.  The others are
        sampled every 4 mm (the distance is 1-Lipschitz: the true minimum is within 2 mm below the samples'); those
        that could be a contact or the least clearance are sampled again every 1 mm and the best refined at 0.01 mm."""
        L = np.linalg.norm(B - A, axis=1)
        ts = np.linspace(0, 1, 41)
        P = A[:, None, :] + (B - A)[:, None, :] * ts[None, :, None]
        gap = np.linalg.norm(np.maximum(np.maximum(self.lo - P, P - self.hi), 0), axis=2).min(axis=1)
        out = gap - L / 80
        near = np.where(out < far)[0]
        if len(near) == 0: return out
        nc = np.maximum(3, (L[near] / 0.004).astype(int) + 2); nmax = int(nc.max())
        tt = np.linspace(0, 1, nmax)                     # common 4 mm-or-finer grid per segment
        coarse = np.empty(len(near))
        for a in range(0, len(near), 400):
            idx = near[a:a + 400]
            Pp = (A[idx, None, :] + (B - A)[idx, None, :] * tt[None, :, None]).reshape(-1, 3)
            coarse[a:a + len(idx)] = self.sd(Pp, cap=far).reshape(len(idx), nmax).min(axis=1)
        step = L[near] / (nmax - 1)
        c = coarse - rad[near]
        cand = np.where((c - step / 2 <= c.min() + 1e-9) | (c - step / 2 < 0.001))[0]
        out[near] = coarse - step / 2
        out[near] = np.maximum(out[near], -1)            # a bound below the samples
        exact = coarse.copy()
        for j in cand:
            i = near[j]; n = max(3, int(L[i] / 0.001) + 1); t = np.linspace(0, 1, n)
            d = self.sd(A[i] + np.outer(t, B[i] - A[i])); k = int(d.argmin()); best = float(d[k])
            t2 = np.linspace(max(0, t[k] - 1.0 / (n - 1)), min(1, t[k] + 1.0 / (n - 1)), 201)
            best = min(best, float(self.sd(A[i] + np.outer(t2, B[i] - A[i])).min()))
            exact[j] = best
        # non-candidates: the 4 mm samples' minimum (within 2 mm of the truth, and neither a contact nor the least)
        out[near] = exact
        return out


def check_trial(d):
    w = json.load(open(d + '/world.json')); r = json.load(open(d + '/result.json')); z = np.load(d + '/trajectory.npz')
    Rb = R_of(w['robot']['base'].get('rpy', [0, 0, 0])); pb = np.array(w['robot']['base'].get('position', [0, 0, 0]), float)
    rs = w['robot'].get('serpentine_radius', 0.025); ra = w['robot'].get('arm_radius', 0.06)
    obs = []
    for o in w['obstacles']:
        if o['type'] == 'mesh':
            p = o['path'] if os.path.isabs(o['path']) else os.path.join(d, o['path'])
            key = PART_BY_SHA.get(sha(p))
            if key is None: raise RuntimeError(f'{d}: mesh {p} is none of make.py\'s files')
            obs.append(('mesh', PlacedMesh(M.PARTS[key], o), key))
        else:
            obs.append(('prim', o, o['type']))
    Q = z['q']; ts = z['t']; nT = len(ts)
    Aa = []; Bb = []; rad = []; lab = []
    tips = []
    for q in Q:
        O = origins(q, Rb, pb); tips.append(O[21])
        S, A = capsules(O)
        for k, (a, b) in enumerate(S): Aa.append(a); Bb.append(b); rad.append(rs); lab.append(f'serp{6 - k}')
        for k, (a, b) in enumerate(A): Aa.append(a); Bb.append(b); rad.append(ra); lab.append(f'arm{k}')
    Aa = np.array(Aa); Bb = np.array(Bb); rad = np.array(rad); tips = np.array(tips)
    nseg = len(Aa) // nT
    best = np.full(len(Aa), np.inf); which = np.full(len(Aa), -1)
    for k, (kind, o, name) in enumerate(obs):
        if kind == 'mesh':
            dd = o.seg_min(Aa, Bb, rad)
        else:
            dd = np.full(len(Aa), np.inf)
            # quick bound: skip segments far from the primitive's bounding sphere
            c, Rr = bound(o)
            ab = Bb - Aa; t = np.clip(np.einsum('ij,ij->i', c - Aa, ab) / np.einsum('ij,ij->i', ab, ab), 0, 1)
            lb = np.linalg.norm(Aa + ab * t[:, None] - c, axis=1) - Rr
            near = lb < 0.35; dd[~near] = lb[~near]
            if near.any(): dd[near] = seg_min_convex(o, Aa[near], Bb[near])
        dd = dd - rad
        b = dd < best; best = np.where(b, dd, best); which = np.where(b, k, which)
    B2 = best.reshape(nT, nseg); per_step = B2.min(axis=1)
    contact = int((per_step < 0).sum())
    goals = [(np.array(g['position'], float), g.get('tolerance', 0.02)) for g in w['goals']]
    gi = 0; ksteps = []
    for k in range(nT):
        while gi < len(goals) and np.linalg.norm(tips[k] - goals[gi][0]) <= goals[gi][1]:
            gi += 1; ksteps.append(k)
    gmin = [round(float(np.linalg.norm(tips - g[0], axis=1).min()) * 1e3, 2) for g in goals]
    k0 = int(per_step.argmin()); j0 = int(B2[k0].argmin())
    nmc = r['metrics']['min_clearance']
    own_success = gi == len(goals) and contact == 0 and r['sim_time'] <= w.get('time_limit', 60) + 1e-9
    out = dict(trial=os.path.basename(d), world=w['name'], planner=r['planner'],
               nav=dict(success=r['success'], reason=r['reason'], goals=r['goals_reached'], sim_time=r['sim_time'],
                        min_clear_mm=None if nmc is None else round(nmc * 1e3, 3), contacts=r['metrics']['contacts']),
               own=dict(goals=gi, goal_steps=ksteps, goal_min_mm=gmin, min_clear_mm=round(float(per_step.min()) * 1e3, 3),
                        contacts=contact, at=dict(step=k0, t=round(float(ts[k0]), 3), link=lab[j0], obstacle=obs[int(which.reshape(nT, nseg)[k0, j0])][2]),
                        success=bool(own_success)))
    if contact:
        ks = np.where(per_step < 0)[0]
        out['own']['first_contact'] = dict(step=int(ks[0]), t=round(float(ts[ks[0]]), 3), link=lab[int(B2[ks[0]].argmin())],
                                           obstacle=obs[int(which.reshape(nT, nseg)[ks[0], int(B2[ks[0]].argmin())])][2])
    out['agree'] = dict(success=bool(r['success']) == bool(own_success), goals=gi == r['goals_reached'],
                        contacts=contact == r['metrics']['contacts'],
                        min_clear=nmc is not None and abs(nmc - float(per_step.min())) <= 1e-5)
    out['wrong_success'] = bool(r['success'] and not own_success)
    return out


def bound(o):
    if o['type'] == 'sphere': return np.array(o['center'], float), o['radius']
    if o['type'] == 'box': return np.array(o['center'], float), float(np.linalg.norm(o['half_extents']))
    p0, p1 = np.array(o['p0'], float), np.array(o['p1'], float)
    return (p0 + p1) / 2, float(math.hypot(np.linalg.norm(p1 - p0) / 2, o['radius']))


if __name__ == '__main__':
    import warnings; warnings.filterwarnings('ignore')
    if sys.argv[1] == '--placement':
        rows = placement()
        print('placement: %d of %d mesh obstacles read as meant' % (sum(r['ok'] for r in rows), len(rows)))
        sys.exit(0)
    sys.path.insert(0, '/work/main'); import navstack
    m = navstack.jpl_serpentine(); qq = np.random.default_rng(0).uniform(-0.6, 0.6, 20); F = m.frames(qq)
    O = origins(qq, np.eye(3), np.zeros(3))
    print(json.dumps({"fk_self_test_max_diff_m": float(max(np.linalg.norm(F[i][:3, 3] - O[i]) for i in range(22)))}), flush=True)
    for d in sorted(glob.glob(sys.argv[1] + '/trials/*')):
        if len(sys.argv) > 2 and not any(s in d for s in sys.argv[2:]): continue
        if not os.path.exists(d + '/trajectory.npz'): continue
        print(json.dumps(check_trial(d)), flush=True)
