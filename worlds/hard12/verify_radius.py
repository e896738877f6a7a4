"""Radius check of hard5's checker on kept trials (batch 12 helper). hard5's verify.py is used UNCHANGED and imported
as a library (importlib). It already takes the radii from each trial's world.json
(`w['robot'].get('serpentine_radius', 0.025)`, `.get('arm_radius', 0.06)`) in `clearances`, the only place radii
enter (goals are judged on the tip POINT, spec 2). This script shows that it does, and what a radius-blind check
would have said: for every kept trial it recomputes the per-step least clearance with verify.clearances (exact
capsule-to-primitive distances, movers at each sample's time) twice, with the world's radii and with the defaults
(0.025 / 0.06), split into serpentine and arm, and prints both, with the contact-step counts.
Usage: python verify_radius.py RUN_DIR [trial-substring ...]   (one JSON line per trial)"""
import importlib.util, json, glob, os, sys
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
V5 = os.path.join(HERE, '..', 'hard5')
sys.path.insert(0, V5)
_spec = importlib.util.spec_from_file_location("hard5_verify", os.path.join(V5, 'verify.py'))
v = importlib.util.module_from_spec(_spec); _spec.loader.exec_module(v)


def per_step(w, Q, ts, rs, ra):
    w2 = dict(w, robot=dict(w['robot'], serpentine_radius=rs, arm_radius=ra))
    best, which, lab, tt = v.clearances(w2, {}, Q, ts)
    n = len(best) // len(ts); B = best.reshape(len(ts), n)
    serp = np.array([l.startswith('serp') for l in lab[:n]])
    return B.min(axis=1), B[:, serp].min(axis=1), B[:, ~serp].min(axis=1)


def run(d):
    w = json.load(open(d + '/world.json')); r = json.load(open(d + '/result.json')); z = np.load(d + '/trajectory.npz')
    rs = w['robot'].get('serpentine_radius', 0.025); ra = w['robot'].get('arm_radius', 0.06)
    own, os_, oa = per_step(w, z['q'], z['t'], rs, ra)
    dfl, ds, da = per_step(w, z['q'], z['t'], 0.025, 0.06)
    mm = lambda x: round(float(x.min()) * 1e3, 3)
    return dict(trial=os.path.basename(d), radii=[rs, ra], nav=[r['success'], r['reason'], r['metrics']['contacts'],
                None if r['metrics']['min_clearance'] is None else round(r['metrics']['min_clearance'] * 1e3, 3)],
                own_radii=dict(min_mm=mm(own), serp_mm=mm(os_), arm_mm=mm(oa), contact_steps=int((own < 0).sum())),
                default_radii=dict(min_mm=mm(dfl), serp_mm=mm(ds), arm_mm=mm(da), contact_steps=int((dfl < 0).sum())),
                serp_shift_mm=round((float(os_.min()) - float(ds.min())) * 1e3, 3),
                arm_shift_mm=round((float(oa.min()) - float(da.min())) * 1e3, 3),
                expected_shift_mm=[round((0.025 - rs) * 1e3, 3), round((0.06 - ra) * 1e3, 3)],
                nav_agrees_with_own=bool(r['metrics']['contacts'] == int((own < 0).sum()) or any('motion' in o for o in w['obstacles'])))


if __name__ == '__main__':
    for d in sorted(glob.glob(sys.argv[1] + '/trials/*')):
        if len(sys.argv) > 2 and not any(s in d for s in sys.argv[2:]): continue
        print(json.dumps(run(d)), flush=True)
