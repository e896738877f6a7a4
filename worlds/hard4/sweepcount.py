"""count control steps k whose interval (t_{k-1}, t_k] holds a contact with a mover (own check: joints
interpolated linearly, SUB sub-steps), and compare with navstack's contacts"""
import sys, json, numpy as np
sys.path.insert(0, '/work/s35/hard4')
import verify as V
d = sys.argv[1]; SUB = int(sys.argv[2]) if len(sys.argv) > 2 else 400
w = json.load(open(d + '/world.json')); r = json.load(open(d + '/result.json')); z = np.load(d + '/trajectory.npz'); Q = z['q']; ts = z['t']
wm = dict(w, obstacles=[o for o in w['obstacles'] if 'motion' in o])
ws = dict(w, obstacles=[o for o in w['obstacles'] if 'motion' not in o])
b, _, _, _ = V.clearances(w, {}, Q, ts); at_step = b.reshape(len(ts), -1).min(1)
cont = set(np.where(at_step < 0)[0]); mins = {}
for k in range(1, len(ts)):
    fs = np.linspace(0, 1, SUB + 1)[1:-1]
    Qs = [Q[k - 1] + f * (Q[k] - Q[k - 1]) for f in fs]; Ts = [ts[k - 1] + f * (ts[k] - ts[k - 1]) for f in fs]
    bs, _, _, _ = V.clearances(wm, {}, Qs, Ts); m = bs.reshape(len(Ts), -1).min(1).min()
    mins[k] = min(m, at_step[k])
    if m < 0: cont.add(k)
near = sorted(k for k in mins if 0 <= mins[k] < 2e-4)
print(d, 'own contact steps (samples + sweep):', len(cont), 'navstack:', r['metrics']['contacts'], 'own min:', round(min(mins.values()) * 1e3, 4), 'mm;',
      'steps with own min in [0, 0.2 mm):', [(k, round(mins[k] * 1e6, 1)) for k in near][:20])
