"""Own check of kept trials (session 35 helper), adapted from worlds/hard3/verify.py.
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


def seg_min_convex(o, A, B, off):
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
    d = md(P, cap=0.1).reshape(len(A), n)   # farther than 0.1 m: a lower bound >= 0.1 m
    j = d.argmin(axis=1); best = d[np.arange(len(A)), j]; tb = ts[j]
    near = np.where(best < 0.02)[0]
    for i in near:   # refine within +-1 sample at 0.01 mm
        L = np.linalg.norm(B[i] - A[i]); t2 = np.clip(np.linspace(tb[i] - 1.0 / (n - 1), tb[i] + 1.0 / (n - 1), 201), 0, 1)
        dd = md(A[i] + np.outer(t2, B[i] - A[i])); k = dd.argmin()
        if dd[k] < best[i]: best[i] = dd[k]; tb[i] = t2[k]
    return best, tb


def load_meshes(w, d):
    out = {}
    for k, o in enumerate(w['obstacles']):
        if o['type'] != 'mesh': continue
        p = o['path'] if os.path.isabs(o['path']) else os.path.join(d, o['path'])
        m = trimesh.load(p, force='mesh', process=False)
        V = m.vertices * o.get('scale', 1.0) @ R_of(o.get('rpy', [0, 0, 0])).T + np.array(o.get('position', [0, 0, 0]))
        out[k] = MeshDist(V, m.faces)
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
    ok_retract = True
    if w.get('retract'):
        dstart = float(np.linalg.norm(tips[-1] - tips[0])); out['final_tip_to_start_mm'] = round(dstart * 1e3, 2)
        after = kreach[-1] if len(kreach) == len(goals) else None
        ok_retract = after is not None and dstart <= 0.02
        out['own_retracted'] = ok_retract
    if r.get('error'): out['error'] = r['error']
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
