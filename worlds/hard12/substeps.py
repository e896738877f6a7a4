"""Least clearance between control steps, EVERY obstacle (static too), with the world's radii: joints interpolated
linearly at N sub-steps per control step (hard5's verify.clearances, imported unchanged). For boundary successes
(a contact could hide between steps, where navstack does not sweep static obstacles) and fast movers.
Usage: python substeps.py N TRIAL_DIR ...   (one JSON line per trial)"""
import importlib.util, json, os, sys
import numpy as np
HERE = os.path.dirname(os.path.abspath(__file__)); V5 = os.path.join(HERE, '..', 'hard5'); sys.path.insert(0, V5)
_spec = importlib.util.spec_from_file_location("hard5_verify", os.path.join(V5, 'verify.py'))
v = importlib.util.module_from_spec(_spec); _spec.loader.exec_module(v)
N = int(sys.argv[1])
for d in sys.argv[2:]:
    w = json.load(open(d + '/world.json')); z = np.load(d + '/trajectory.npz'); Q, ts = z['q'], z['t']
    f = np.linspace(0, 1, N + 1)[:-1]
    Qs = np.vstack([Q[k - 1] + np.outer(f, Q[k] - Q[k - 1]) for k in range(1, len(ts))] + [Q[-1:]])
    Ts = np.concatenate([ts[k - 1] + f * (ts[k] - ts[k - 1]) for k in range(1, len(ts))] + [ts[-1:]])
    best, which, lab, tt = v.clearances(w, {}, Qs, Ts)
    n = len(best) // len(Ts); B = best.reshape(len(Ts), n); p = B.min(axis=1); k = int(p.argmin())
    neg = np.where(p < 0)[0]
    print(json.dumps(dict(trial=os.path.basename(d), sub=N, min_mm=round(float(p.min()) * 1e3, 3), at_t=round(float(Ts[k]), 4),
                          link=lab[int(B[k].argmin())], obstacle=int(which.reshape(len(Ts), n)[k, int(B[k].argmin())]),
                          negative_samples=int(len(neg)), negative_t=[round(float(Ts[i]), 4) for i in neg[:8]])), flush=True)
