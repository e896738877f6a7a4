"""Own check of kept trials (session 37 helper), adapted from worlds/hard4/verify.py. Changes for batch 5:
- primitives whose bounding sphere is more than 0.2 m from a capsule are skipped for it (a lower bound is used;
  worlds with ~300 obstacles); every clearance under 0.2 m is exact;
- closed convex meshes (the icosphere) get a sign: a sample inside the hull counts as negative distance;
- goals counted in order are compared with navstack's goals_reached in EVERY trial (not only successes), and the
  sample index of each goal is printed; a goal counts at the first sample within tolerance after the previous
  goal's sample (the same sample may count several equal goals: spec 2 does not say "strictly later");
- retraction: all goals first, then the tip back within 0.02 m of its t = 0 position at the last sample, navstack's
  "retracted" compared; contact steps after the last goal (during the retraction) counted separately;
- agreement flags: min clearance within 0.01 mm, contacts equal, goals equal, success equal.
- own modified-DH forward kinematics (Figure 2's table, spec section 1), the world's base;
- EXACT capsule-to-primitive distances: the signed distance of a convex primitive is convex along a capsule's
  axis segment, so a ternary search on the segment parameter finds the minimum (to 1e-10 m);
- meshes: exact point-to-triangle distance (geom.MeshDist) sampled every 1 mm along each axis segment, the best
  sample refined at 0.01 mm (so within ~0.01 mm); unsigned (a link inside a closed mesh is not detected: it
  would have to cross the surface first, which is seen);
- movers at their place at each sample's time t (spec 2b), and for worlds with movers also at 8 sub-steps
  between control steps (joints interpolated linearly: an approximation of the motion in between);
- goals reached in order within tolerance (first sample within it after the previous goal);
- retract worlds: after the last goal, the tip back within 0.02 m of its t = 0 position at the end.
Usage: python verify.py RUN_DIR [trial-substring ...]"""
import sys, json, glob, math, os
import numpy as np
import trimesh
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make import sdf as _sdf, R_of, motion_offset
from geom import MeshDist

H = math.pi / 2
SUB = int(os.environ.get('SUB', '8'))   # sub-steps per control step for movers
DH = [(0, 0, 0, 0), (H, 0, 0, 0), (H, .1232, 0, H), (H, .1079, .546, math.pi), (H, .0794, 0, math.pi),
      (H, .0794, .546, math.pi), (H, .0492, 0, math.pi), (H, .0492, .2, 0), (-H, 0, 0, -H), (-H, 0, 0, 0)]
for i in range(11, 21): DH.append((H if i % 2 else -H, .2 if i % 2 else 0, 0, 0))
DH.append((0, .2, 0, 0))


def T(al, a, d, th):
    ca, sa, ct, st = math.cos(al), math.sin(al), math.cos(th), math.sin(th)
    return np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -sa * d], [st * sa, ct * sa, ca, ca * d], [0, 0, 0, 1.]])


def origins(q, Rb, pb):
    M = np.eye(4); O = [pb.copy()]
    for i, (al, a, d, th) in enumerate(DH):
        if i == 0: d += q[0]
        elif i < 20: th += q[i]
        M = M @ T(al, a, d, th); O.append(Rb @ M[:3, 3] + pb)
    return O          # O[i] = origin of DH frame i in the world, i = 0..21 (21 = tip)


def capsules(O):
    """serpentine segments (J6-J5 ... J1-tip) and arm segments between distinct consecutive origins 1..9"""
    S = [(O[i], O[i + 2]) for i in (9, 11, 13, 15, 17, 19)]
    A = [O[1]]
    for i in range(2, 10):
        if np.linalg.norm(O[i] - A[-1]) > 1e-6: A.append(O[i])
    return S, [(A[i], A[i + 1]) for i in range(len(A) - 1)]


def bound(o):
    if o['type'] == 'sphere': return np.array(o['center'], float), o['radius']
    if o['type'] == 'box': return np.array(o['center'], float), float(np.linalg.norm(o['half_extents']))
    p0, p1 = np.array(o['p0'], float), np.array(o['p1'], float)
    return (p0 + p1) / 2, float(math.hypot(np.linalg.norm(p1 - p0) / 2, o['radius']))


def pt_seg(c, A, B):
    ab = B - A; t = np.clip(np.einsum('ij,ij->i', c - A, ab) / np.maximum(np.einsum('ij,ij->i', ab, ab), 1e-18), 0, 1)
    return np.linalg.norm(A + ab * t[:, None] - c, axis=1)


FAR = 0.2
def seg_min_convex(o, A, B, off):
    """min over each segment of the signed distance to primitive o: exact where it can be under FAR, else a lower bound"""
    c, R = bound(o); cc = c if off is None else c + off
    lb = (pt_seg(cc, A, B) if off is None else np.linalg.norm(
        A + (B - A) * np.clip(np.einsum('ij,ij->i', cc - A, B - A) / np.maximum(np.einsum('ij,ij->i', B - A, B - A), 1e-18), 0, 1)[:, None] - cc, axis=1)) - R
    near = lb < FAR
    out = lb.copy(); tt = np.zeros(len(A))
    if near.any():
        d, t = _seg_min_convex(o, A[near], B[near], None if off is None else off[near])
        out[near] = d; tt[near] = t
    return out, tt


def _seg_min_convex(o, A, B, off):
    """exact min over each segment A[n]->B[n] of the signed distance to primitive o (translated by off[n])"""
    lo = np.zeros(len(A)); hi = np.ones(len(A))
    f = lambda t: _sdf(o, A + (B - A) * t[:, None], off)
    for _ in range(70):
        m1 = lo + (hi - lo) / 3; m2 = hi - (hi - lo) / 3
        f1, f2 = f(m1), f(m2); left = f1 > f2
        lo = np.where(left, m1, lo); hi = np.where(left, hi, m2)
    t = (lo + hi) / 2
    return np.minimum(np.minimum(f(t), f(np.zeros(len(A)))), f(np.ones(len(A)))), t


def seg_min_mesh(md, A, B):
    n = 201; ts = np.linspace(0, 1, n)
    P = (A[:, None, :] + (B - A)[:, None, :] * ts[None, :, None]).reshape(-1, 3)
    d = md(P, cap=0.1)   # farther than 0.1 m: a lower bound >= 0.1 m
    if md.hull is not None:
        inside = md.hull.find_simplex(P) >= 0
        d = np.where(inside, -d, d)
    d = d.reshape(len(A), n)
    j = d.argmin(axis=1); best = d[np.arange(len(A)), j]; tb = ts[j]
    near = np.where(best < 0.02)[0]
    for i in near:   # refine within +-1 sample at 0.01 mm
        L = np.linalg.norm(B[i] - A[i]); t2 = np.clip(np.linspace(tb[i] - 1.0 / (n - 1), tb[i] + 1.0 / (n - 1), 201), 0, 1)
        P2 = A[i] + np.outer(t2, B[i] - A[i]); dd = md(P2)
        if md.hull is not None: dd = np.where(md.hull.find_simplex(P2) >= 0, -dd, dd)
        k = dd.argmin()
        if dd[k] < best[i]: best[i] = dd[k]; tb[i] = t2[k]
    return best, tb


def load_meshes(w, d):
    out = {}
    for k, o in enumerate(w['obstacles']):
        if o['type'] != 'mesh': continue
        p = o['path'] if os.path.isabs(o['path']) else os.path.join(d, o['path'])
        m = trimesh.load(p, force='mesh', process=False)
        V = m.vertices * o.get('scale', 1.0) @ R_of(o.get('rpy', [0, 0, 0])).T + np.array(o.get('position', [0, 0, 0]))
        md = MeshDist(V, m.faces); md.hull = None
        mp = trimesh.load(p, force='mesh')             # merged vertices, for the watertight / convex test only
        if mp.is_watertight and mp.is_convex:
            from scipy.spatial import Delaunay
            md.hull = Delaunay(np.unique(np.round(V, 12), axis=0))   # inside test: find_simplex >= 0
        out[k] = md
    return out


def clearances(w, meshes, Qs, ts, names=False):
    """per sample: min clearance of the robot (serpentine and arm capsules) to every obstacle; and the argmin"""
    Rb = R_of(w['robot']['base'].get('rpy', [0, 0, 0])); pb = np.array(w['robot']['base'].get('position', [0, 0, 0]), float)
    rs = w['robot'].get('serpentine_radius', 0.025); ra = w['robot'].get('arm_radius', 0.06)
    segs = []; rad = []; lab = []; tt = []
    for q, t in zip(Qs, ts):
        S, A = capsules(origins(q, Rb, pb))
        for i, (a, b) in enumerate(S): segs.append((a, b)); rad.append(rs); lab.append(f'serp link {6 - i} (J{6 - i}->{"J%d" % (5 - i) if i < 5 else "tip"})'); tt.append(t)
        for i, (a, b) in enumerate(A): segs.append((a, b)); rad.append(ra); lab.append(f'arm seg {i}'); tt.append(t)
    Aa = np.array([s[0] for s in segs]); Bb = np.array([s[1] for s in segs]); rad = np.array(rad); tt = np.array(tt)
    best = np.full(len(segs), np.inf); which = np.full(len(segs), -1)
    for k, o in enumerate(w['obstacles']):
        if o['type'] == 'mesh':
            d, _ = seg_min_mesh(meshes[k], Aa, Bb)
        else:
            m = o.get('motion'); off = None
            if m is not None: off = np.array([motion_offset(m, t) for t in tt])
            d, _ = seg_min_convex(o, Aa, Bb, off)
        d = d - rad
        better = d < best; best = np.where(better, d, best); which = np.where(better, k, which)
    return best, which, lab, tt


def check(d):
    w = json.load(open(d + '/world.json')); r = json.load(open(d + '/result.json')); z = np.load(d + '/trajectory.npz')
    meshes = load_meshes(w, d)
    Rb = R_of(w['robot']['base'].get('rpy', [0, 0, 0])); pb = np.array(w['robot']['base'].get('position', [0, 0, 0]), float)
    goals = [(np.array(g['position']), g.get('tolerance', 0.02)) for g in w['goals']]
    Q = z['q']; ts = z['t']
    tips = np.array([origins(q, Rb, pb)[21] for q in Q])
    gi = 0; gmin = [9.0] * len(goals); treach = []; kreach = []
    for k in range(len(ts)):
        for j in range(gi, len(goals)): gmin[j] = min(gmin[j], float(np.linalg.norm(tips[k] - goals[j][0])))
        while gi < len(goals) and np.linalg.norm(tips[k] - goals[gi][0]) <= goals[gi][1]:
            gi += 1; treach.append(round(float(ts[k]), 3)); kreach.append(k)
    best, which, lab, tt = clearances(w, meshes, Q, ts)
    nseg = len(best) // len(ts); B = best.reshape(len(ts), nseg); Wh = which.reshape(len(ts), nseg)
    per_step = B.min(axis=1); contact_steps = int((per_step < 0).sum())
    k0 = int(per_step.argmin()); j0 = int(B[k0].argmin())
    out = dict(trial=os.path.basename(d), nav=(r['success'], r['reason'], r['goals_reached'], r.get('retracted')),
               own_goals=gi, own_t_reach=treach, goal_min_mm=[round(g * 1e3, 2) for g in gmin],
               own_min_clear_mm=round(float(per_step.min()) * 1e3, 3),
               at=dict(t=round(float(ts[k0]), 3), step=k0, link=lab[j0], obstacle=int(Wh[k0, j0]),
                       obstacle_type=w['obstacles'][int(Wh[k0, j0])]['type']),
               nav_min_clear_mm=None if r['metrics']['min_clearance'] is None else round(r['metrics']['min_clearance'] * 1e3, 3),
               own_contact_steps=contact_steps, nav_contacts=r['metrics']['contacts'], sim_time=r['sim_time'], steps=len(ts) - 1)
    if contact_steps:
        ks = np.where(per_step < 0)[0]; out['first_contact'] = dict(t=round(float(ts[ks[0]]), 3), step=int(ks[0]),
            link=lab[int(B[ks[0]].argmin())], obstacle=int(Wh[ks[0], int(B[ks[0]].argmin())]))
    # movers: sub-steps between control steps
    if any('motion' in o for o in w['obstacles']):
        movers = [o for o in w['obstacles'] if 'motion' in o]; wm = dict(w, obstacles=movers)
        Qs = []; Ts = []
        for k in range(1, len(ts)):
            for f in np.linspace(0, 1, SUB + 1)[1:-1]:
                Qs.append(Q[k - 1] + f * (Q[k] - Q[k - 1])); Ts.append(ts[k - 1] + f * (ts[k] - ts[k - 1]))
        bs, _, _, tts = clearances(wm, {}, Qs, Ts)
        ps = bs.reshape(len(Ts), -1).min(axis=1)
        out['substep_mover_min_mm'] = round(float(ps.min()) * 1e3, 3); out['substep_mover_contacts'] = int((ps < 0).sum())
        out['substep_mover_min_t'] = round(float(Ts[int(ps.argmin())]), 3)
        out['mover_min_at_steps_mm'] = round(float(clearances(wm, {}, Q, ts)[0].min()) * 1e3, 3)
        # per control step k: the least of its sample and the sub-steps of (t_{k-1}, t_k) (navstack sweeps movers over the step)
        sub = ps.reshape(len(ts) - 1, SUB - 1).min(axis=1)
        comb = per_step.copy(); comb[1:] = np.minimum(comb[1:], sub)
        out['own_contact_steps_with_substeps'] = int((comb < 0).sum())
        out['own_min_clear_with_substeps_mm'] = round(float(comb.min()) * 1e3, 3)
        per_step_sw = comb
    if 'per_step_sw' not in locals(): per_step_sw = per_step
    ok_retract = True
    if w.get('retract'):
        dstart = float(np.linalg.norm(tips[-1] - tips[0])); out['final_tip_to_start_mm'] = round(dstart * 1e3, 2)
        after = kreach[-1] if len(kreach) == len(goals) else None
        ok_retract = after is not None and dstart <= 0.02
        out['own_retracted'] = ok_retract
    if r.get('error'): out['error'] = r['error']
    out['own_goal_steps'] = kreach
    if kreach and len(kreach) == len(goals):
        out['contact_steps_after_last_goal'] = int((per_step[kreach[-1]:] < 0).sum())
    if w.get('retract'): out['retracted_agree'] = bool(r.get('retracted')) == bool(ok_retract)
    nmc = r['metrics']['min_clearance']
    csw = int((per_step_sw < 0).sum())
    out['agree'] = dict(goals=gi == r['goals_reached'], contacts=csw == r['metrics']['contacts'],
                        min_clear=(nmc is not None and abs(nmc - float(per_step_sw.min())) <= 1e-5),
                        success=bool(r['success']) == bool(gi == len(goals) and contact_steps == 0 and ok_retract
                                                          and out.get('substep_mover_contacts', 0) == 0 and r['sim_time'] <= w.get('time_limit', 60.0) + 1e-9))
    out['sim_time_ok'] = bool(r['sim_time'] <= w.get('time_limit', 60.0) + 1e-9)
    out['wrong_success'] = bool(r['success'] and (gi < len(goals) or contact_steps > 0 or not ok_retract
                                                 or out.get('substep_mover_contacts', 0) > 0 or not out['sim_time_ok']))
    return out


if __name__ == '__main__':
    sys.path.insert(0, '/work/main'); import navstack
    m = navstack.jpl_serpentine(); qq = np.random.default_rng(0).uniform(-0.6, 0.6, 20); F = m.frames(qq)
    O = origins(qq, np.eye(3), np.zeros(3))
    print('FK self-test max diff vs navstack (m):', max(np.linalg.norm(F[i][:3, 3] - O[i]) for i in range(22)), flush=True)
    for d in sorted(glob.glob(sys.argv[1] + '/trials/*')):
        if len(sys.argv) > 2 and not any(s in d for s in sys.argv[2:]): continue
        print(json.dumps(check(d)), flush=True)
