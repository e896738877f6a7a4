"""Own check of kept trials: own modified-DH forward kinematics (table of `navstack model`), exact distances
from sampled capsule axes to every primitive (make.sdf), goals in order within tolerance.
Usage: python verify.py RUN_DIR [trial-substring ...]"""
import sys, json, glob, math, os
import numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make import sdf, R_of
H = math.pi / 2
# i: alpha_{i-1}, a_{i-1}, d_i, theta_i  (i = 1..21; 1 prismatic, 2..20 revolute, 21 fixed)
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
    return O
def pts(a, b, st=0.004):
    n = max(2, int(np.linalg.norm(b - a) / st) + 2); return a + np.outer(np.linspace(0, 1, n), b - a)
def check(d):
    w = json.load(open(d + '/world.json')); r = json.load(open(d + '/result.json')); z = np.load(d + '/trajectory.npz')
    Rb = R_of(w['robot']['base']['rpy']); pb = np.array(w['robot']['base']['position'], float); obs = w['obstacles']
    goals = [(np.array(g['position']), g.get('tolerance', 0.02)) for g in w['goals']]
    gi = 0; gmin = [9.0] * len(goals); treach = []; minc = 9.0; where = None; ncont = 0
    for k in range(len(z['t'])):
        O = origins(z['q'][k], Rb, pb); tip = O[21]
        for j in range(len(goals)):
            if j >= gi: gmin[j] = min(gmin[j], float(np.linalg.norm(tip - goals[j][0])))
        if gi < len(goals) and np.linalg.norm(tip - goals[gi][0]) <= goals[gi][1]:
            gi += 1; treach.append(round(float(z['t'][k]), 2))
        S = np.vstack([pts(O[i], O[i + 2]) for i in (9, 11, 13, 15, 17, 19)])
        A = [O[1]]
        for i in range(2, 10):
            if np.linalg.norm(O[i] - A[-1]) > 1e-6: A.append(O[i])
        AP = np.vstack([pts(A[i], A[i + 1]) for i in range(len(A) - 1)])
        ds = min(sdf(o, S).min() for o in obs) - w['robot']['serpentine_radius']
        da = min(sdf(o, AP).min() for o in obs) - w['robot']['arm_radius']
        c = min(ds, da); ncont += c < 0
        if c < minc: minc, where = c, (round(float(z['t'][k]), 2), 'serp' if ds < da else 'arm')
    fin = origins(z['q'][-1], Rb, pb)[21]
    return dict(trial=os.path.basename(d), nav=(r['success'], r['reason'], r['goals_reached']), own_goals=gi, own_t_reach=treach,
                goal_min_mm=[round(g * 1e3, 1) for g in gmin], final_tip_to_next_goal_mm=round(float(np.linalg.norm(fin - goals[min(gi, len(goals) - 1)][0])) * 1e3, 1),
                own_min_clear_mm=round(minc * 1e3, 2), at=where, nav_min_clear_mm=round(r['metrics']['min_clearance'] * 1e3, 2),
                own_contact_steps=int(ncont), nav_contacts=r['metrics']['contacts'], sim_time=r['sim_time'],
                wrong_success=bool(r['success'] and (gi < len(goals) or ncont > 0)))
if __name__ == '__main__':
    sys.path.insert(0, '/work/main'); import navstack
    m = navstack.jpl_serpentine(); qq = np.random.default_rng(0).uniform(-0.6, 0.6, 20); F = m.frames(qq)
    O = origins(qq, np.eye(3), np.zeros(3))
    print('FK self-test max diff vs navstack (m):', max(np.linalg.norm(F[i][:3, 3] - O[i]) for i in range(22)), flush=True)
    for d in sorted(glob.glob(sys.argv[1] + '/trials/*')):
        if len(sys.argv) > 2 and not any(s in d for s in sys.argv[2:]): continue
        print(json.dumps(check(d)), flush=True)
