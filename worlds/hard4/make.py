"""Own generator, held-out batch 4 (session 35 helper, outside user). Does not use navstack.generate.
Adapted from worlds/hard3/make.py. Each world is built in a canonical frame (the default base, start tip
P0 = (1.8085, 0.1079, 1.1668) heading +x) around a reference tip path (straight legs and arcs of radius
>= 0.28 m), checked with exact distances (primitives: exact signed distance; meshes: trimesh closest point),
then (kind g) moved rigidly with the robot base.
Moving obstacles are checked with an assumed timing: the tip at arc length s at t(s) = T0 + s / V
(T0 = 1 s, V = 0.055 m/s, measured on hard3's field trials), the body left at s at that same time.
Usage: python make.py [name ...]   (writes <this folder>/<name>.json and parts/*.stl)"""
import json, math, sys, os
import numpy as np
import trimesh
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from geom import MeshDist
from scipy.spatial.transform import Rotation as Rot

OUT = os.path.dirname(os.path.abspath(__file__))
P0 = np.array([1.8085499, 0.1079, 1.166846])
X0, Y0, Z0 = P0
Q0 = [0.0, 0.0, 0.0, -1.5707963, 1.0471976, 0.0, 0.5235988] + [0.0] * 13
BASE = {"position": [0.0, 0.0, 0.3], "rpy": [0.0, -1.5707963, 3.1415927]}
UP, DOWN, LEFT, RIGHT = (0, 0, 1), (0, 0, -1), (0, 1, 0), (0, -1, 0)
DS = 0.002
EX = np.array([1.0, 0, 0])
T0, V = 1.0, 0.055


def unit(v): v = np.array(v, float); return v / np.linalg.norm(v)


class Path:
    def __init__(self, cmds, start=P0):
        self.cmds = cmds; self.start = np.array(start, float)
        p = self.start.copy(); h = EX.copy(); pts = [p.copy()]; hs = [h.copy()]; s = 0.0; self.first_arc = None
        for c in cmds:
            if c[0] == 'S':
                n = max(1, int(round(c[1] / DS)))
                for i in range(n):
                    p = p + h * (c[1] / n); pts.append(p.copy()); hs.append(h.copy())
                s += c[1]
            else:
                _, R, deg, v = c
                assert R >= 0.28 - 1e-9
                if self.first_arc is None: self.first_arc = s
                v = np.array(v, float); nrm = v - v.dot(h) * h; nrm /= np.linalg.norm(nrm)
                ctr = p + R * nrm; ax = np.cross(h, nrm); th = math.radians(deg)
                n = max(1, int(round(R * th / DS))); ps, hs0 = p.copy(), h.copy()
                for i in range(1, n + 1):
                    r = Rot.from_rotvec(ax * th * i / n)
                    p = ctr + r.apply(ps - ctr); h = r.apply(hs0)
                    pts.append(p.copy()); hs.append(h.copy())
                s += R * th
        self.P = np.array(pts); self.H = np.array(hs)
        self.s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(self.P, axis=0), axis=1))])
        self.L = self.s[-1]
        if self.first_arc is None: self.first_arc = self.L

    def at(self, s):
        if s <= 0: return self.start + EX * s, EX.copy()
        i = min(len(self.P) - 1, int(np.searchsorted(self.s, s)))
        return self.P[i].copy(), self.H[i].copy()

    def end(self): return self.P[-1].copy(), self.H[-1].copy()

    def joints(self, s):
        J = [self.at(s)[0]]; cur = s
        for k in range(6):
            prev = J[-1]; a, b = cur - 0.2, cur - 0.26
            for _ in range(40):
                m = 0.5 * (a + b)
                if np.linalg.norm(self.at(m)[0] - prev) < 0.2: a = m
                else: b = m
            cur = 0.5 * (a + b); J.append(self.at(cur)[0])
        return J, cur


def S_curve(R, off): return math.degrees(math.acos(1 - off / (2 * R)))


# ---------------- primitives ----------------
def R_of(rpy): return Rot.from_euler('xyz', rpy).as_matrix()
def box(c, h, rpy=(0, 0, 0), **kw): return dict({"type": "box", "center": [float(v) for v in c], "half_extents": [float(v) for v in h], "rpy": [float(v) for v in rpy]}, **kw)
def cyl(a, b, r, **kw): return dict({"type": "cylinder", "p0": [float(v) for v in a], "p1": [float(v) for v in b], "radius": float(r)}, **kw)
def sph(c, r, **kw): return dict({"type": "sphere", "center": [float(v) for v in c], "radius": float(r)}, **kw)

def frame_box(c, u, v, hu, hv, hn, **kw):
    u, v = unit(u), unit(v); n = np.cross(u, v)
    return box(c, [hu, hv, hn], Rot.from_matrix(np.column_stack([u, v, n])).as_euler('xyz'), **kw)

def plate_hole(center, u, v, n, half_u, half_v, hole_uv, hole_half, t=0.006):
    u, v, n = (np.array(a, float) for a in (u, v, n)); hu, hv = hole_uv; ah, bh = hole_half; out = []
    for (u0, u1, v0, v1) in [(-half_u, hu - ah, -half_v, half_v), (hu + ah, half_u, -half_v, half_v),
                             (hu - ah, hu + ah, -half_v, hv - bh), (hu - ah, hu + ah, hv + bh, half_v)]:
        if u1 - u0 < 1e-3 or v1 - v0 < 1e-3: continue
        c = np.array(center, float) + u * (u0 + u1) / 2 + v * (v0 + v1) / 2
        out.append(frame_box(c, u, v, (u1 - u0) / 2, (v1 - v0) / 2, t))
    return out


def motion_offset(m, t):
    """displacement of a mover at time t (spec 2b)"""
    if m is None: return np.zeros(3)
    if m['type'] == 'linear':
        st = m.get('start', 0.0); sp = m.get('stop', math.inf)
        return np.array(m['velocity'], float) * min(max(t - st, 0.0), sp - st)
    a = unit(m['axis']); return m['amplitude'] * a * math.sin(2 * math.pi * t / m['period'] + m.get('phase', 0.0))


_MESH = {}
def mesh_of(o):
    """trimesh in world coordinates for a mesh obstacle (o['_file'] absolute or relative to OUT)"""
    key = (o['path'], tuple(o['position']), tuple(o['rpy']), o.get('scale', 1.0))
    if key not in _MESH:
        m = trimesh.load(os.path.join(OUT, o['path']), force='mesh', process=False)
        V = m.vertices * o.get('scale', 1.0)
        V = V @ R_of(o['rpy']).T + np.array(o['position'])
        _MESH[key] = MeshDist(V, m.faces)
    return _MESH[key]


def sdf(o, P, off=None):
    """exact signed distance (primitives) / unsigned distance (meshes) of points P (N,3) to obstacle o,
    o translated by off ((3,) or (N,3))"""
    P = np.atleast_2d(np.asarray(P, float))
    if off is not None: P = P - off
    if o['type'] == 'sphere':
        return np.linalg.norm(P - o['center'], axis=1) - o['radius']
    if o['type'] == 'box':
        L = (P - o['center']) @ R_of(o['rpy']); q = np.abs(L) - o['half_extents']
        return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)
    if o['type'] == 'cylinder':
        a = np.array(o['p1'], float) - o['p0']; Ln = np.linalg.norm(a); a /= Ln
        d = P - o['p0']; t = d @ a; rad = np.linalg.norm(d - np.outer(t, a), axis=1) - o['radius']
        ax = np.maximum(-t, t - Ln)
        out = np.sqrt(np.maximum(rad, 0) ** 2 + np.maximum(ax, 0) ** 2)
        return np.where((rad <= 0) & (ax <= 0), np.maximum(rad, ax), out)
    if o['type'] == 'mesh':
        return mesh_of(o)(P, cap=0.3)
    raise ValueError(o['type'])


def dist(obs, P, t=None):
    P = np.atleast_2d(P)
    out = []
    for o in obs:
        m = o.get('motion')
        off = None if m is None or t is None else motion_offset(m, t)
        out.append(sdf(o, P, off))
    return np.min(out, axis=0)


def seg(a, b, step=0.004):
    n = max(2, int(np.linalg.norm(b - a) / step) + 2); return a + np.outer(np.linspace(0, 1, n), b - a)


_ARM = None
def arm_pts(d):
    global _ARM
    if _ARM is None:
        sys.path.insert(0, '/work/main'); import navstack; _ARM = navstack.jpl_serpentine()
    q = np.array(Q0); q[0] = d; F = _ARM.frames(q)
    Rb = R_of(BASE['rpy']); pb = np.array(BASE['position'])
    O = [Rb @ F[i][:3, 3] + pb for i in range(1, 10)]
    D = [O[0]]
    for o in O[1:]:
        if np.linalg.norm(o - D[-1]) > 1e-6: D.append(o)
    return np.vstack([seg(D[k], D[k + 1], 0.01) for k in range(len(D) - 1)])


def check(obs, path, goals, timing=True):
    """clearances along the reference path; movers at t(s) = T0 + s/V, and (any_time) their worst over
    their whole motion (oscillate: one period, linear: start..stop)"""
    movers = [o for o in obs if 'motion' in o]; static = [o for o in obs if 'motion' not in o]
    tip = 9.0; body = 9.0; arm = 9.0; worst = None; lathe = -9.0; flange_off = 0.0; body_any = 9.0; tip_any = 9.0
    ts = np.linspace(0, 40, 401)
    for s in np.arange(0.0, path.L + 1e-9, 0.01):
        J, sf = path.joints(s); t = T0 + s / V
        B = np.vstack([seg(J[k], J[k + 1]) for k in range(6)])
        db = float(dist(obs, B, t).min()) - 0.025
        dt = float(dist(obs, J[0], t).min())
        tip = min(tip, dt)
        if db < body: body, worst = db, round(float(s), 3)
        if movers:
            for o in movers:
                dd = min(float(sdf(o, B, motion_offset(o['motion'], tt)).min()) for tt in ts if tt >= t - 0.01)
                body_any = min(body_any, dd - 0.025)
        fl = J[-1]; d = fl[0] - 0.6085499; lathe = max(lathe, d)
        flange_off = max(flange_off, float(np.hypot(fl[1] - Y0, fl[2] - Z0)))
        if int(round(s * 100)) % 3 == 0 and static: arm = min(arm, float(dist(static, arm_pts(d)).min()) - 0.06)
    gs = [np.array(g, float) for g in goals]
    gpath = [float(np.linalg.norm(path.P - g, axis=1).min()) for g in gs]
    gclear = [float(dist(static, g).min()) for g in gs] if static else []
    legs = []; prev = path.start
    for g in gs:
        legs.append(round(float(dist(static, seg(prev, g, 0.002)).min()), 4) if static else None); prev = g
    ck = dict(tip_clearance=round(tip, 4), body_clearance=round(body, 4), body_worst_at_s=worst,
              arm_clearance=round(arm, 4), path_length=round(float(path.L), 4), lathe_travel=round(lathe, 4),
              flange_off_axis=round(flange_off, 4), curved_part=round(float(path.L - path.first_arc), 4),
              goal_on_path=[round(x, 4) for x in gpath], goal_clearance_static=[round(x, 4) for x in gclear],
              straight_leg_clearance_static=legs)
    if movers:
        ck['timing_assumed'] = f"tip at arc length s at t = {T0} + s/{V} s; body at s from then on"
        ck['body_clearance_movers_worst_over_later_times'] = round(body_any, 4)
    return ck


# ---------------- meshes ----------------
def sweep_tube(centre, tangents, radius, n=40):
    """rings of n vertices round a centre line; returns (V, ring index arrays)"""
    V = []; rings = []
    ref = np.array([0, 0, 1.0]) if abs(tangents[0][2]) < 0.9 else np.array([0, 1.0, 0])
    prev_n = None
    for c, t in zip(centre, tangents):
        t = unit(t)
        nv = (prev_n if prev_n is not None else ref); nv = unit(nv - nv.dot(t) * t); prev_n = nv
        b = np.cross(t, nv)
        ring = []
        for k in range(n):
            a = 2 * math.pi * k / n
            ring.append(len(V)); V.append(c + radius * (math.cos(a) * nv + math.sin(a) * b))
        rings.append(ring)
    return V, rings

def ring_faces(r1, r2, flip=False):
    F = []; n = len(r1)
    for k in range(n):
        a, b, c, d = r1[k], r1[(k + 1) % n], r2[(k + 1) % n], r2[k]
        F += [[a, b, c], [a, c, d]] if not flip else [[a, c, b], [a, d, c]]
    return F


def write_mesh(name, V, F):
    os.makedirs(os.path.join(OUT, 'parts'), exist_ok=True)
    m = trimesh.Trimesh(np.array(V), np.array(F), process=False)
    m.export(os.path.join(OUT, 'parts', name))
    return m


# ---------------- worlds ----------------
W = {}
def world(fn): W[fn.__name__] = fn; return fn


@world
def shutter_osc():
    """(a) a shutter oscillates across a window that the way passes: the BODY sits in the window later"""
    path = Path([('S', 0.85)])
    xw = X0 + 0.35
    obs = plate_hole([xw, Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (0, 0), (0.1, 0.1), t=0.006)
    # shutter just behind the wall: a box 0.1 x 0.26 (y x z) oscillating along y, amplitude 0.2, period 10 s
    obs.append(box([xw + 0.04, Y0 + 0.2, Z0], [0.015, 0.05, 0.13],
                   motion={"type": "oscillate", "axis": [0, 1, 0], "amplitude": 0.2, "period": 10.0, "phase": -3.08}))
    obs.append(box([X0 + 1.0, Y0, Z0], [0.01, 0.3, 0.3]))
    e, _ = path.end()
    return ("A wall with a 0.2 m window 0.35 m ahead on the start line; behind it a shutter (0.1 m wide) "
            "oscillates across the window (amplitude 0.2 m, period 10 s, phase -3.08: at the far left, the "
            "window open, at t = 7.4 s when the tip should pass it, back across the line at 12.4 s). The tip can time its passage, but the body then lies in the window when the shutter "
            "comes back: by design NOT feasible, the honest outcome is collision. Goal 0.5 m beyond the wall."), obs, [e], path, \
        {"expected": "collision (infeasible by design: the oscillating shutter sweeps the body's place)"}


@world
def osc_side():
    """(a) a sphere oscillates towards the way, stopping 30 mm short of the body; a wall on the other side"""
    th = S_curve(0.3, 0.10)
    path = Path([('S', 0.1), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.45)])
    e, _ = path.end(); yl = e[1]
    # sphere r 0.05 beside the final straight, on the right, oscillating along y with amplitude 0.08
    xs = e[0] - 0.25; A = 0.08; r = 0.05; D = 0.025 + 0.030 + r + A
    obs = [sph([xs, yl - D, Z0], r, motion={"type": "oscillate", "axis": [0, 1, 0], "amplitude": A, "period": 6.0, "phase": 1.0}),
           box([e[0] - 0.2, yl + 0.085 + 0.01, Z0], [0.3, 0.01, 0.25]),   # wall on the left, 60 mm from the body
           cyl([X0 + 0.25, Y0 - 0.06, Z0 - 0.4], [X0 + 0.25, Y0 - 0.06, Z0 + 0.4], 0.03),  # post right of the start line
           box([e[0] + 0.12, yl, Z0], [0.01, 0.3, 0.3])]
    return ("Past a post on the start line (S-curve 0.1 m left), a straight run along a wall on its left; a ball "
            "(r 50 mm) on the right oscillates towards the way (amplitude 80 mm, period 6 s) and stops 30 mm short "
            "of the body's capsules. Feasible; a near miss, moving in the sensors' view. Goal 0.12 m before an end wall."), obs, [e], path, \
        {"expected": "reached (mover keeps >= 30 mm from the reference body at all times)"}


@world
def close_behind():
    """(a) a linear mover slides across the way behind the tip, onto the body"""
    th = S_curve(0.3, 0.08)
    path = Path([('S', 0.15), ('A', 0.3, th, DOWN), ('A', 0.3, th, UP), ('S', 0.45)])
    e, _ = path.end()
    s_m = 0.5; pm, _ = path.at(s_m)
    # a box beside the way (0.2 m to the right) that slides left 0.25 m from t = 18 to 23 s (the tip passes
    # s = 0.5 at about t = 10 s)
    obs = [box([pm[0], pm[1] - 0.2, pm[2]], [0.04, 0.06, 0.06],
               motion={"type": "linear", "velocity": [0, 0.05, 0], "start": 18.0, "stop": 23.0}),
           box([pm[0], Y0, Z0 + 0.1], [0.3, 0.3, 0.01]),                      # ceiling over the run
           cyl([X0 + 0.3, Y0 - 0.3, Z0 + 0.05], [X0 + 0.3, Y0 + 0.3, Z0 + 0.05], 0.025),  # pipe across, grazing the line
           box([e[0] + 0.1, Y0, Z0], [0.01, 0.3, 0.3])]
    return ("Under a pipe lying across the start line, then along a ceiling; a block beside the way slides into "
            "it from t = 18 s to 23 s, when the tip (at about 0.055 m/s) is 0.4 m past it: it lands on the body. "
            "The honest outcome is collision (or, if the tip is late, a blocked way): never success."), obs, [e], path, \
        {"expected": "collision (the mover slides onto the body after the tip has passed)"}


@world
def door_opens():
    """(a) a window offset up-left is shut by a door that slides away (diagonally) from t = 4 to 9 s"""
    off = np.array([0, 0.09, 0.06]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    path = Path([('S', 0.1), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.5)])
    s_w = 0.1 + 2 * 0.3 * math.radians(th) + 0.12; pw, _ = path.at(s_w)
    obs = plate_hole([pw[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (pw[1] - Y0, pw[2] - Z0), (0.09, 0.09), 0.006)
    obs.append(box([pw[0] + 0.03, pw[1], pw[2]], [0.012, 0.12, 0.12],
                   motion={"type": "linear", "velocity": [0, -0.036, -0.048], "start": 4.0, "stop": 9.0}))
    e, _ = path.end()
    obs.append(box([e[0] + 0.12, Y0, Z0], [0.01, 0.35, 0.35]))
    return ("A wall 0.5 m ahead with a 0.18 m window 0.108 m off the start line (up-left); behind it a door shuts "
            "the window at t = 0 and slides away diagonally (down-right, 0.3 m) from t = 4 s to 9 s. Feasible once "
            "open. Goal 0.38 m beyond the wall."), obs, [e], path, {"expected": "reached"}


@world
def retract_wind():
    """(b) two baffles with offset windows (left, then right); goal beyond; back out"""
    th1 = S_curve(0.3, 0.12); th2 = S_curve(0.3, 0.20)
    path = Path([('S', 0.1), ('A', 0.3, th1, LEFT), ('A', 0.3, th1, RIGHT), ('S', 0.1),
                 ('A', 0.3, th2, RIGHT), ('A', 0.3, th2, LEFT), ('S', 0.13)])
    s1 = 0.1 + 2 * 0.3 * math.radians(th1) + 0.05; p1, _ = path.at(s1)
    e, _ = path.end(); p2, _ = path.at(path.L - 0.06)
    obs = plate_hole([p1[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.4, 0.35, (p1[1] - Y0, 0), (0.09, 0.1), 0.006)
    obs += plate_hole([p2[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.4, 0.35, (p2[1] - Y0, 0), (0.09, 0.1), 0.006)
    # clutter between the baffles: a pipe low, a cable
    xm = 0.5 * (p1[0] + p2[0])
    obs.append(cyl([xm, Y0 - 0.4, Z0 - 0.1], [xm, Y0 + 0.4, Z0 - 0.1], 0.03))
    obs.append(cyl([xm + 0.05, Y0 + 0.17, Z0 - 0.35], [xm + 0.05, Y0 + 0.17, Z0 + 0.35], 0.008))
    obs.append(box([e[0] + 0.1, Y0, Z0], [0.01, 0.35, 0.35]))
    return ("Two baffles 0.3 m apart: the first window 0.12 m left of the start line, the second 0.08 m right of it; "
            "a pipe and a cable between them; goal 0.07 m past the second window, 0.1 m before an end plate. "
            "retract: back out through both windows to the start."), obs, [e], path, {"retract": True, "expected": "reached, retracted"}


@world
def retract_3d():
    """(b) up over a pipe under a beam, then 60 deg left into a pocket; back out"""
    th = S_curve(0.3, 0.09)
    path = Path([('S', 0.1), ('A', 0.3, th, UP), ('A', 0.3, th, DOWN), ('S', 0.05), ('A', 0.3, 60, LEFT), ('S', 0.26)])
    e, h = path.end(); n = np.array([-h[1], h[0], 0])
    xp = X0 + 0.1 + 0.3 * math.sin(math.radians(th))
    zc = Z0 + 0.09
    obs = [cyl([xp, Y0 - 0.4, Z0 - 0.075], [xp, Y0 + 0.4, Z0 - 0.075], 0.04),          # pipe across the line
           cyl([xp + 0.06, Y0 - 0.4, zc + 0.13], [xp + 0.06, Y0 + 0.4, zc + 0.13], 0.04)]  # beam above
    mid = e - 0.12 * h; t = 0.006
    obs += [frame_box(mid + n * (0.09 + t), h, [0, 0, 1], 0.17, 0.15, t), frame_box(mid - n * (0.09 + t), h, [0, 0, 1], 0.17, 0.15, t),
            frame_box(mid + np.array([0, 0, 0.1 + t]), h, n, 0.17, 0.1, t),
            frame_box(e + 0.08 * h, n, [0, 0, 1], 0.1, 0.15, t)]
    obs.append(cyl([e[0] + 0.25, Y0 - 0.1, Z0 - 0.4], [e[0] + 0.25, Y0 - 0.1, Z0 + 0.4], 0.08))  # column ahead
    return ("Up over a pipe lying on the start line and under a beam (0.09 m up), then 60 deg left into a roofed "
            "pocket (0.18 m wide, 0.34 m deep); goal 0.08 m before its back plate. retract: back out the same way."), obs, [e], path, \
        {"retract": True, "expected": "reached, retracted"}


@world
def mesh_shell():
    """(c) an open, zero-thickness cylindrical cup (triangle surface) offset down-left; goal inside"""
    off = np.array([0, 0.09, -0.07]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    path = Path([('S', 0.12), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.42)])
    e, _ = path.end(); s_m = 0.12 + 2 * 0.3 * math.radians(th) + 0.04; pm, _ = path.at(s_m)
    Lc = e[0] + 0.09 - pm[0]; R = 0.125; n = 48; m = 12
    # local frame: axis +x from the mouth (x = 0) to the bottom (x = Lc)
    V = []; rings = []
    for i in range(m + 1):
        x = Lc * i / m; ring = []
        for k in range(n):
            a = 2 * math.pi * k / n; ring.append(len(V)); V.append([x, R * math.cos(a), R * math.sin(a)])
        rings.append(ring)
    F = []
    for i in range(m): F += ring_faces(rings[i], rings[i + 1])
    c = len(V); V.append([Lc, 0, 0])
    for k in range(n): F.append([rings[-1][k], rings[-1][(k + 1) % n], c])   # bottom disc (fan)
    mm = write_mesh('cup.stl', V, F)
    assert not mm.is_watertight
    obs = [{"type": "mesh", "path": "parts/cup.stl", "position": [float(pm[0]), float(e[1]), float(e[2])], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    obs.append(cyl([X0 + 0.3, Y0 - 0.5, Z0 + 0.06], [X0 + 0.3, Y0 + 0.5, Z0 + 0.06], 0.025))  # rail across the line
    return ("An open cup: a zero-thickness triangle surface (cylinder r 0.125 m, 0.42 m long, bottom closed, mouth "
            "open towards the robot; not watertight) whose axis is 0.114 m off the start line (down-left); a rail "
            "across the start line in front. Goal inside, 0.09 m from the bottom."), obs, [e], path, {"expected": "reached"}


@world
def mesh_elbow():
    """(c) a closed (watertight) thick-walled 90 deg pipe elbow, turning up through a deck; goal above it"""
    Rb = 0.30; ri, ro = 0.105, 0.115; s_in = 0.2; L1 = 0.12; L2 = 0.12
    path = Path([('S', s_in + L1), ('A', 0.3, 90, UP), ('S', L2 + 0.14)])
    # centre line of the elbow from the mouth
    cl = []; tg = []
    for i in range(7): cl.append(P0 + EX * (s_in + L1 * i / 6)); tg.append(EX)
    c0 = P0 + EX * (s_in + L1) + np.array([0, 0, Rb])
    for i in range(1, 31):
        a = math.radians(90 * i / 30); cl.append(c0 + Rb * np.array([math.sin(a), 0, -math.cos(a)])); tg.append(np.array([math.cos(a), 0, math.sin(a)]))
    top = cl[-1]
    for i in range(1, 7): cl.append(top + np.array([0, 0, L2 * i / 6])); tg.append(np.array([0, 0, 1.0]))
    Vi, ri_ = sweep_tube(cl, tg, ri); Vo, ro_ = sweep_tube(cl, tg, ro)
    off = len(Vi); ro_ = [[k + off for k in r] for r in ro_]
    V = Vi + Vo; F = []
    for i in range(len(cl) - 1):
        F += ring_faces(ri_[i], ri_[i + 1], flip=True); F += ring_faces(ro_[i], ro_[i + 1])
    F += ring_faces(ri_[0], ro_[0]); F += ring_faces(ri_[-1], ro_[-1], flip=True)
    mm = write_mesh('elbow.stl', V, F)
    trimesh.repair.fix_normals(mm)
    mm.export(os.path.join(OUT, 'parts', 'elbow.stl'))
    assert mm.is_watertight
    obs = [{"type": "mesh", "path": "parts/elbow.stl", "position": [0.0, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    zt = top[2] - 0.04
    obs += plate_hole([top[0], Y0, zt], [1, 0, 0], [0, 1, 0], [0, 0, 1], 0.8, 0.7, (0, 0), (ro + 0.004, ro + 0.004), t=0.008)
    obs.append(box([top[0] + 0.25, Y0, Z0 + 0.15], [0.01, 0.4, 0.25]))  # bulkhead beyond the elbow, below the deck
    e, _ = path.end()
    return ("A 90 deg pipe elbow (mesh, watertight thick wall: bore r 0.105 m, outer r 0.115 m, bend radius 0.3 m) "
            "on the start line, its mouth 0.2 m ahead, turning up through a deck (with a hole only for the pipe); a "
            "bulkhead below the deck beyond it. Goal 0.14 m above the elbow's upper end, above the deck."), obs, [e], path, {"expected": "reached"}


@world
def oblique_slot():
    """(d) two plates rotated on all three axes leave an oblique slot, offset right-up"""
    off = np.array([0, -0.08, 0.06]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    path = Path([('S', 0.1), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.45)])
    s_sl = 0.1 + 2 * 0.3 * math.radians(th) + 0.15; ps, _ = path.at(s_sl)
    Rm = R_of([0.7, 0.3, 0.35])          # plate frame: col0 = normal, col1 = across the slot, col2 = along it
    nrm, acr, alg = Rm[:, 0], Rm[:, 1], Rm[:, 2]
    hw = 0.068; t = 0.01; wy = 0.25
    obs = []
    for sg in (1, -1):
        c = ps + sg * acr * (hw + wy)
        obs.append(box(c, [t, wy, 0.4], Rot.from_matrix(Rm).as_euler('xyz')))
    e, _ = path.end()
    obs.append(box(e + np.array([0.12, 0.05, 0]), [0.02, 0.2, 0.2], [0.3, -0.25, 0.4]))   # tilted block beyond
    obs.append(sph([ps[0] - 0.2, Y0 + 0.12, Z0 - 0.08], 0.06))
    return ("Two 20 mm plates rotated rpy (0.7, 0.3, 0.35) rad leave a 0.136 m slot between them, tilted about "
            "every axis, its centre 0.1 m off the start line (right-up); the tip crosses it 19 deg off its normal. "
            "A ball before it, a tilted block beyond. Goal 0.3 m past the slot."), obs, [e], path, {"expected": "reached"}


@world
def tight_goal():
    """(e) goal tolerance 0.01, 50 mm from a vertical pipe's surface, after a 60 deg left turn"""
    path = Path([('S', 0.2), ('A', 0.3, 60, LEFT), ('S', 0.25)])
    e, h = path.end(); n = np.array([-h[1], h[0], 0])
    rp = 0.07; cp = e + n * (0.05 + rp)          # pipe on the left of the goal (inside of the turn), surface 50 mm away
    obs = [cyl([cp[0], cp[1], Z0 - 0.5], [cp[0], cp[1], Z0 + 0.5], rp),
           cyl([X0 + 0.47, Y0 - 0.07, Z0 - 0.5], [X0 + 0.47, Y0 - 0.07, Z0 + 0.5], 0.06),   # column just right of the start line
           frame_box(e + h * 0.16, n, [0, 0, 1], 0.25, 0.3, 0.01)]
    return ("Inspection of a vertical pipe (r 70 mm): the goal, tolerance 0.01 m, is 50 mm from its surface, "
            "on the inside of a 60 deg left turn round a column just right of the start line; a wall 0.16 m beyond. (The "
            "reference tip passes the goal with the capsule 25 mm from the pipe.)"), obs, [e], path, {"tolerance": 0.01, "expected": "reached"}


@world
def tour_weave():
    """(f) 5 inspection goals weaving between posts and under/over bars"""
    path = Path([('S', 0.08), ('A', 0.28, 30, LEFT), ('A', 0.28, 60, RIGHT), ('A', 0.28, 60, LEFT), ('A', 0.28, 30, RIGHT), ('S', 0.14)])
    a30 = 0.28 * math.radians(30); a60 = 2 * a30
    ss = [0.08 + a30, 0.08 + a30 + a60 / 2, 0.08 + a30 + a60 + a60 / 2, 0.08 + 2 * a30 + 2 * a60, None]
    goals = [path.at(s)[0] for s in ss[:4]] + [path.end()[0]]
    obs = []
    # posts inside each bend (at the arcs' middles) and outside them, r 25 mm
    for s, side in ((0.08 + a30 / 2, -1), (0.08 + a30 + a60 / 2, -1), (0.08 + a30 + a60 + a60 / 2, 1), (0.08 + 2 * a30 + 2 * a60 - a30 / 2, -1)):
        p, h = path.at(s); n = np.array([-h[1], h[0], 0])
        for sg, dd in ((side, 0.085), (-side, 0.11)):
            q = p + sg * n * (0.025 + dd)
            obs.append(cyl([q[0], q[1], Z0 - 0.45], [q[0], q[1], Z0 + 0.45], 0.025))
    # bars across: one 0.08 above the way at goal 2, one 0.08 below at goal 4 (r 20 mm)
    for g, dz in ((goals[1], 0.1), (goals[3], -0.1)):
        obs.append(cyl([g[0], g[1] - 0.4, g[2] + dz], [g[0], g[1] + 0.4, g[2] + dz], 0.02))
    g5 = goals[-1]; obs.append(box([g5[0] + 0.12, g5[1], Z0], [0.01, 0.3, 0.3]))
    return ("Slalom between upright posts (r 25 mm, one each side of every bend: left 30, right 60, left 60, right "
            "30 deg, radius 0.28 m), bars across above and below the way; 5 inspection points: each inflection, the "
            "two apices, the end. 5 goals in order."), obs, goals, path, {"expected": "reached"}


@world
def base_yaw():
    """(g) robot base translated and yawed 90 deg, lathe q0[0] = 0.15: wall with a window up-right, a pipe behind"""
    off = np.array([0, -0.1, 0.07]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    start = P0 + EX * 0.15
    path = Path([('S', 0.1), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.45)], start=start)
    s_w = 0.1 + 2 * 0.3 * math.radians(th) + 0.08; pw, _ = path.at(s_w)
    obs = plate_hole([pw[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (pw[1] - Y0, pw[2] - Z0), (0.085, 0.085), 0.008)
    e, _ = path.end()
    obs.append(cyl([pw[0] + 0.2, Y0 - 0.4, Z0 - 0.05], [pw[0] + 0.2, Y0 + 0.4, Z0 - 0.05], 0.05))  # pipe behind, on the line
    obs.append(box([e[0] + 0.12, Y0, Z0], [0.01, 0.35, 0.35]))
    return ("Robot base moved by (0.5, -1.2, 0.2) to (0.5, -1.2, 0.5) and yawed +90 deg (the lathe runs along world +y), q0's lathe "
            "0.15 m out; a wall with a 0.17 m window 0.12 m off the line (up and to the robot's right), a pipe behind "
            "it on the line. Goal 0.37 m past the wall."), obs, [e], path, \
        {"transform": {"yaw": math.pi / 2, "translate": [0.5, -1.2, 0.2]}, "q0_lathe": 0.15, "expected": "reached"}


@world
def thin_plates():
    """(h) 2 mm plates met edge-on: a splitter on the start line, a channel wall, a shelf; 2 mm end plate"""
    off = 0.10; th = S_curve(0.3, off)
    path = Path([('S', 0.1), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.42)])
    e, _ = path.end(); x_end_curve = X0 + 0.1 + 2 * 0.3 * math.sin(math.radians(th))
    t = 0.001
    xa = x_end_curve - 0.02
    obs = [box([xa + 0.3, Y0 + 0.0, Z0], [0.3, t, 0.3]),                                   # splitter, vertical, edge-on
           box([xa + 0.35, Y0 + off + 0.085 + 0.0, Z0], [0.3, t, 0.3]),                   # left channel wall
           box([xa + 0.35, Y0 + off / 2, Z0 + 0.1], [0.25, 0.2, t]),                       # shelf above, edge-on
           box([e[0] + 0.1, Y0, Z0], [t, 0.35, 0.35]),                                      # end plate, 2 mm, face-on
           box([X0 + 0.2, Y0 - 0.1, Z0], [0.05, t, 0.2])]                                   # short 2 mm fin right of the line
    return ("All plates 2 mm thick: a vertical splitter edge-on on the start line (its edge 0.33 m ahead), a channel "
            "wall 0.185 m left of it, a shelf 0.1 m above the way (edge-on), a short fin right of the line, and a "
            "2 mm end plate face-on. The way: 0.1 m left into the channel. Goal 0.1 m before the end plate."), obs, [e], path, {"expected": "reached"}


@world
def thin_wires():
    """(h) two curtains of 3 mm wires; the gap in the first is left, in the second down"""
    th1 = S_curve(0.3, 0.10); th2 = S_curve(0.3, 0.10)
    path = Path([('S', 0.1), ('A', 0.3, th1, LEFT), ('A', 0.3, th1, RIGHT), ('S', 0.1), ('A', 0.3, th2, DOWN), ('A', 0.3, th2, UP), ('S', 0.2)])
    s1 = 0.1 + 2 * 0.3 * math.radians(th1) + 0.05; p1, _ = path.at(s1)
    e, _ = path.end(); s2 = path.L - 0.1; p2, _ = path.at(s2)
    r = 0.003; obs = []
    # curtain 1: vertical wires every 45 mm across y, gap 0.16 m centred on the way
    for k in range(-9, 10):
        y = p1[1] + k * 0.045
        if abs(y - p1[1]) < 0.08: continue
        obs.append(cyl([p1[0], y, Z0 - 0.4], [p1[0], y, Z0 + 0.4], r))
    # curtain 2: horizontal wires every 45 mm in z, gap 0.16 m centred on the way
    for k in range(-9, 10):
        z = p2[2] + k * 0.045
        if abs(z - p2[2]) < 0.08: continue
        obs.append(cyl([p2[0], Y0 - 0.45, z], [p2[0], Y0 + 0.45, z], r))
    obs.append(box([e[0] + 0.15, Y0, Z0], [0.01, 0.4, 0.4]))
    return ("Two curtains of wires (r 3 mm, 45 mm apart): the first vertical, its 0.16 m gap 0.1 m left of the start "
            f"line; the second 0.25 m on, horizontal, its gap 0.1 m below. {len(obs) - 1} wires. Goal 0.1 m past the "
            "second curtain, 0.15 m before a wall."), obs, [e], path, {"expected": "reached"}


@world
def close_behind_b():
    """(a) batch 2: the linear mover starts at t = 7 s (the tip, at ~0.055 m/s, is then ~0.18 m past it)"""
    th = S_curve(0.3, 0.08)
    path = Path([('S', 0.15), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.45)])
    e, _ = path.end()
    s_m = 0.2; pm, _ = path.at(s_m)
    obs = [box([pm[0], pm[1], pm[2] - 0.16], [0.04, 0.06, 0.05],
               motion={"type": "linear", "velocity": [0, 0, 0.06], "start": 7.0, "stop": 10.0}),   # rises into the way
           cyl([X0 + 0.55, Y0 - 0.06, Z0 - 0.4], [X0 + 0.55, Y0 - 0.06, Z0 + 0.4], 0.04),     # post right of the line
           box([e[0] + 0.1, Y0, Z0], [0.01, 0.3, 0.3])]
    return ("A block under the way 0.2 m ahead of the start tip rises 0.18 m into it from t = 7 s to 10 s (the tip, at "
            "about 0.055 m/s, is then 0.18-0.35 m past it, the body on top of it); the way then bends 0.08 m left past "
            "a post. The honest outcome is collision: never success."), obs, [e], path, \
        {"expected": "collision (the mover rises into the body after the tip has passed)", "folder": "b2"}


@world
def base_tilt():
    """(g) batch 2: the whole robot and world rotated rpy (0.2, -0.15, 0.5) and moved (1, 0.5, -0.2); q0 lathe -0.1"""
    off = np.array([0, 0.07, -0.09]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    start = P0 - EX * 0.1
    path = Path([('S', 0.12), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.42)], start=start)
    s_w = 0.12 + 2 * 0.3 * math.radians(th) + 0.08; pw, _ = path.at(s_w)
    obs = plate_hole([pw[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.4, 0.4, (pw[1] - Y0, pw[2] - Z0), (0.085, 0.085), 0.008)
    e, _ = path.end()
    obs.append(sph([pw[0] - 0.22, Y0 - 0.04, Z0 - 0.17], 0.05))
    obs.append(cyl([e[0] - 0.1, Y0 - 0.4, e[2] + 0.09], [e[0] - 0.1, Y0 + 0.4, e[2] + 0.09], 0.03))
    obs.append(box([e[0] + 0.12, Y0, Z0], [0.01, 0.35, 0.35], [0.1, 0.0, 0.0]))
    return ("The robot's base rotated by rpy (0.2, -0.15, 0.5) on top of the default one and moved by (1.0, 0.5, -0.2) "
            "(base rpy written as pybullet-convention Euler angles), q0's lathe at -0.1 m; the world rotated with it: a "
            "wall with a 0.17 m window 0.114 m off the start line (left-down), a ball before it, a bar above the "
            "way after it. Goal 0.34 m past the wall."), obs, [e], path, \
        {"transform": {"rpy": [0.2, -0.15, 0.5], "translate": [1.0, 0.5, -0.2]}, "q0_lathe": -0.1, "expected": "reached", "folder": "b2"}


def _fast_graze(gap):
    path = Path([('S', 0.35)])
    e, _ = path.end(); r = 0.005
    c = [X0 - 0.5, Y0 + 0.025 + r + gap, Z0]
    obs = [sph(c, r, motion={"type": "oscillate", "axis": [0, 0, 1], "amplitude": 0.1, "period": 0.16, "phase": math.pi / 2}),
           box([e[0] + 0.15, Y0, Z0], [0.01, 0.3, 0.3])]
    return obs, [e], path


@world
def fast_graze_clear():
    """(a) batch 3: a 5 mm ball at 3.9 m/s crossing beside the body, 1.0 mm clear of it (the body stays on the line)"""
    obs, g, path = _fast_graze(0.001)
    return ("A ball (r 5 mm) oscillating up and down (amplitude 0.1 m, period 0.16 s: 3.9 m/s at the crossing) "
            "0.5 m behind the start tip, its centre 31 mm beside the start line: it passes the serpentine (which stays on "
            "that line: the way is straight, 0.35 m) 1.0 mm clear, 12 times a second; the flange never reaches it. "
            "Honest outcome: success with min clearance ~1.0 mm (less the servo's deviation)."), obs, g, path, \
        {"expected": "reached, min clearance about 1.0 mm", "folder": "b3"}


@world
def fast_graze_touch():
    """(a) batch 3: the same ball 0.5 mm INTO the body at each crossing"""
    obs, g, path = _fast_graze(-0.0005)
    return ("As fast_graze_clear, but the ball's path cuts 0.5 mm into the serpentine's capsule at each crossing "
            "(3.9 m/s, 12 crossings a second; at t = 0 it is at the top of its swing, clear). Honest outcome: "
            "collision, depth ~0.5 mm."), obs, g, path, {"expected": "collision, depth about 0.5 mm", "folder": "b3"}


# ---------------- rigid transform (kind g) ----------------
def transform_world(obs, goals, path_pts, yaw, tr, rpy_g=None):
    Rg = Rot.from_euler('z', yaw).as_matrix() if rpy_g is None else R_of(rpy_g); tr = np.array(tr, float)
    f = lambda p: (Rg @ np.array(p, float) + tr)
    out = []
    for o in obs:
        o = json.loads(json.dumps(o))
        if o['type'] == 'box': o['center'] = list(f(o['center'])); o['rpy'] = list(Rot.from_matrix(Rg @ R_of(o['rpy'])).as_euler('xyz'))
        elif o['type'] == 'cylinder': o['p0'] = list(f(o['p0'])); o['p1'] = list(f(o['p1']))
        elif o['type'] == 'sphere': o['center'] = list(f(o['center']))
        elif o['type'] == 'mesh': o['position'] = list(f(o['position'])); o['rpy'] = list(Rot.from_matrix(Rg @ R_of(o['rpy'])).as_euler('xyz'))
        if 'motion' in o:
            m = o['motion']
            if 'velocity' in m: m['velocity'] = list(Rg @ np.array(m['velocity']))
            if 'axis' in m: m['axis'] = list(Rg @ np.array(m['axis']))
        out.append(o)
    if rpy_g is None:
        rpy = [0.0, BASE['rpy'][1], BASE['rpy'][2] + yaw]                 # the default base has pitch -pi/2: add the yaw
        rpy[2] = math.atan2(math.sin(rpy[2]), math.cos(rpy[2]))
    else:
        rpy = list(Rot.from_matrix(Rg @ R_of(BASE['rpy'])).as_euler('xyz'))
    assert np.allclose(R_of(rpy), Rg @ R_of(BASE['rpy']), atol=1e-6)
    base = {"position": list(f(BASE['position'])), "rpy": rpy}
    return out, [f(g) for g in goals], np.array([f(p) for p in path_pts]), base


def rnd(x):
    if isinstance(x, dict): return {k: rnd(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)): return [rnd(v) for v in x]
    if isinstance(x, (float, np.floating)): return round(float(x), 7)
    if isinstance(x, np.ndarray): return rnd(x.tolist())
    return x


def build(name):
    desc, obs, goals, path, opt = W[name]()
    goals = [np.array(g, float) for g in goals]
    ck = check(obs, path, goals)
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    if 'q0_lathe' in opt: robot['q0'][0] = opt['q0_lathe']
    ref_pts = path.P[::25].tolist() + [path.P[-1].tolist()]
    start_tip = path.start
    if 'transform' in opt:
        tf = opt['transform']
        obs, goals, ref_pts, robot['base'] = transform_world(obs, goals, ref_pts, tf.get('yaw', 0.0), tf['translate'], tf.get('rpy'))
        start_tip = transform_world([], [path.start], [], tf.get('yaw', 0.0), tf['translate'], tf.get('rpy'))[1][0]
        ref_pts = ref_pts.tolist()
    tol = opt.get('tolerance', 0.02)
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h4-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": tol} for g in goals],
         "time_limit": 75.0}
    if opt.get('retract'): w['retract'] = True
    w['extra'] = {"reference_path": {"commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [float(x) for x in c[3]]] for c in path.cmds],
                                     "note": "tip path in the canonical frame (default base) from start_tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm in world coordinates",
                                     "start_tip_world": [round(float(v), 6) for v in start_tip],
                                     "points": [[round(float(v), 4) for v in p] for p in ref_pts]},
                  "checks": ck, "expected": opt.get('expected'), "transform": opt.get('transform'),
                  "generator": "/work/s35/hard4/make.py (session 35 helper)"}
    folder = os.path.join(OUT, opt.get('folder', '.'))
    os.makedirs(folder, exist_ok=True)
    json.dump(rnd(w), open(os.path.join(folder, name + '.json'), 'w'), indent=1)
    return ck, opt


if __name__ == '__main__':
    names = sys.argv[1:] or list(W)   # batch 1 in this folder, batch 2 ('folder': 'b2') in b2/
    for n in names:
        ck, opt = build(n)
        ok = ck['tip_clearance'] >= 0.05 and ck['body_clearance'] >= 0.025 and ck['arm_clearance'] >= 0.03 and ck['lathe_travel'] <= 2.0 and ck['curved_part'] <= 1.15 and max(ck['goal_on_path']) < 0.003
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
