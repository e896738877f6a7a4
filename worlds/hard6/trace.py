"""tip trace of a kept trial against the world's reference path: per interval, t, tip, s along ref, distance off it"""
import sys, json, numpy as np
import os
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from verify import origins, R_of
d = sys.argv[1]; dt = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
w = json.load(open(d + '/world.json')); z = np.load(d + '/trajectory.npz')
Rb = R_of(w['robot']['base']['rpy']); pb = np.array(w['robot']['base']['position'])
ref = np.array(w['extra']['reference_path']['points']); sref = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(ref, axis=0), axis=1))])
# densify
P = []; S = []
for i in range(len(ref) - 1):
    for f in np.linspace(0, 1, 26)[:-1]: P.append(ref[i] + f * (ref[i + 1] - ref[i])); S.append(sref[i] + f * (sref[i + 1] - sref[i]))
P = np.array(P); S = np.array(S)
g = np.array([x['position'] for x in w['goals']])
last = -1e9
for k, t in enumerate(z['t']):
    if t - last < dt - 1e-9 and k != len(z['t']) - 1: continue
    last = t; tip = origins(z['q'][k], Rb, pb)[21]; dd = np.linalg.norm(P - tip, axis=1); j = dd.argmin()
    des = z['tip_des'][k]
    print(f"t={t:6.2f} tip={np.round(tip,3)} s_ref={S[j]:.3f}/{sref[-1]:.3f} off_ref={dd[j]*1000:6.1f}mm to_goal={[round(float(np.linalg.norm(tip-x)),3) for x in g]} lathe={z['q'][k][0]:.3f}")
