"""Own generator, held-out batch 3 (session 34 helper). Does not use navstack.generate.
Each world is built around a reference tip path (straight segments and arcs of radius >= 0.28 m) from the
start tip (1.8085, 0.1079, 1.1668) heading +x; then checked: tip >= 50 mm from every surface, serpentine
(6 capsules r 25 mm whose joints lie on the path, 0.2 m chords apart) >= 25 mm, arm (carried by the lathe
along x) clear, lathe travel <= 2.0 m, curved part (after the first arc) <= 1.2 m so the flange stays on
the lathe axis, and how close the straight legs between goals come to obstacles (scripted control).
Usage: python make.py [name ...]   (writes /work/s34/hard3/<name>.json)"""
import json, math, sys, os
import numpy as np
from scipy.spatial.transform import Rotation as Rot

OUT = os.path.dirname(os.path.abspath(__file__))
P0 = np.array([1.8085499, 0.1079, 1.166846])
X0, Y0, Z0 = P0
ROBOT = {"base": {"position": [0.0, 0.0, 0.3], "rpy": [0.0, -1.5707963, 3.1415927]},
         "q0": [0.0, 0.0, 0.0, -1.5707963, 1.0471976, 0.0, 0.5235988] + [0.0] * 13,
         "serpentine_radius": 0.025, "arm_radius": 0.06}
UP, DOWN, LEFT, RIGHT = (0, 0, 1), (0, 0, -1), (0, 1, 0), (0, -1, 0)
DS = 0.002
EX = np.array([1.0, 0, 0])


# ---------------- path ----------------
class Path:
    def __init__(self, cmds):
        self.cmds = cmds
        p = P0.copy(); h = EX.copy(); pts = [p.copy()]; hs = [h.copy()]; s = 0.0; self.first_arc = None
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
        """point and heading at arc length s (s < 0: on the straight line behind the start)"""
        if s <= 0: return P0 + EX * s, EX.copy()
        i = min(len(self.P) - 1, int(np.searchsorted(self.s, s)))
        return self.P[i].copy(), self.H[i].copy()

    def end(self): return self.P[-1].copy(), self.H[-1].copy()

    def joints(self, s):
        """7 serpentine joint points (tip first), each 0.2 m chord behind the previous, on the path."""
        J = [self.at(s)[0]]; cur = s
        for k in range(6):
            prev = J[-1]; lo, hi = cur - 0.2, cur - 0.3
            # find s' < cur with |P(s') - prev| = 0.2 (chord); bisection on [cur-0.25, cur-0.2]
            a, b = cur - 0.2, cur - 0.26
            for _ in range(40):
                m = 0.5 * (a + b)
                if np.linalg.norm(self.at(m)[0] - prev) < 0.2: a = m
                else: b = m
            cur = 0.5 * (a + b); J.append(self.at(cur)[0])
        return J, cur


# ---------------- primitives and distances ----------------
def R_of(rpy): return Rot.from_euler('xyz', rpy).as_matrix()
def box(c, h, rpy=(0, 0, 0)): return {"type": "box", "center": [float(v) for v in c], "half_extents": [float(v) for v in h], "rpy": [float(v) for v in rpy]}
def cyl(a, b, r): return {"type": "cylinder", "p0": [float(v) for v in a], "p1": [float(v) for v in b], "radius": float(r)}
def sph(c, r): return {"type": "sphere", "center": [float(v) for v in c], "radius": float(r)}

def frame_box(c, u, v, n, hu, hv, hn):
    """box with local axes u, v, n (orthonormal) and half extents along them"""
    u, v = unit(u), unit(v); n = np.cross(u, v)  # right-handed (a box is symmetric, the sign of n is free)
    M = np.column_stack([u, v, n]); return box(c, [hu, hv, hn], Rot.from_matrix(M).as_euler('xyz'))

def plate_hole(center, u, v, n, half_u, half_v, hole_uv, hole_half, t=0.006):
    """plate (normal n) with a rectangular hole, as 4 boxes"""
    u, v, n = (np.array(a, float) for a in (u, v, n)); hu, hv = hole_uv; ah, bh = hole_half; out = []
    for (u0, u1, v0, v1) in [(-half_u, hu - ah, -half_v, half_v), (hu + ah, half_u, -half_v, half_v),
                             (hu - ah, hu + ah, -half_v, hv - bh), (hu - ah, hu + ah, hv + bh, half_v)]:
        if u1 - u0 < 1e-3 or v1 - v0 < 1e-3: continue
        c = np.array(center, float) + u * (u0 + u1) / 2 + v * (v0 + v1) / 2
        out.append(frame_box(c, u, v, n, (u1 - u0) / 2, (v1 - v0) / 2, t))
    return out

def sdf(o, P):
    P = np.atleast_2d(P)
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
    raise ValueError(o['type'])

def dist(obs, P):
    P = np.atleast_2d(P)
    return np.min([sdf(o, P) for o in obs], axis=0)

def seg(a, b, step=0.004):
    n = max(2, int(np.linalg.norm(b - a) / step) + 2); return a + np.outer(np.linspace(0, 1, n), b - a)


# ---------------- checks ----------------
_ARM = None
def arm_pts(d):
    global _ARM
    if _ARM is None:
        sys.path.insert(0, '/work/main'); import navstack; _ARM = navstack.jpl_serpentine()
    q = np.array(ROBOT['q0']); q[0] = d; F = _ARM.frames(q)
    Rb = R_of(ROBOT['base']['rpy']); pb = np.array(ROBOT['base']['position'])
    O = [Rb @ F[i][:3, 3] + pb for i in range(1, 10)]
    D = [O[0]]
    for o in O[1:]:
        if np.linalg.norm(o - D[-1]) > 1e-6: D.append(o)
    return np.vstack([seg(D[k], D[k + 1], 0.01) for k in range(len(D) - 1)])

def check(obs, path, goals, s_stop=None):
    s_stop = path.L if s_stop is None else s_stop
    tip = float(dist(obs, path.P).min())
    body = 9.0; arm = 9.0; worst = None; lathe = 0.0; flange_off = 0.0
    for s in np.arange(0.0, s_stop + 1e-9, 0.01):
        J, sf = path.joints(s)
        B = np.vstack([seg(J[k], J[k + 1]) for k in range(6)])
        db = float(dist(obs, B).min()) - 0.025
        if db < body: body, worst = db, round(float(s), 3)
        fl = J[-1]; d = fl[0] - 0.6085499; lathe = max(lathe, d)
        flange_off = max(flange_off, float(np.hypot(fl[1] - Y0, fl[2] - Z0)))
        if int(round(s * 100)) % 3 == 0: arm = min(arm, float(dist(obs, arm_pts(d)).min()) - 0.06)
    gs = [np.array(g, float) for g in goals]
    gpath = [float(np.linalg.norm(path.P - g, axis=1).min()) for g in gs]
    gclear = [float(dist(obs, g)[0]) for g in gs]
    legs = []; prev = P0
    for g in gs:
        legs.append(round(float(dist(obs, seg(prev, g, 0.002)).min()), 4)); prev = g
    return dict(tip_clearance=round(tip, 4), body_clearance=round(body, 4), body_worst_at_s=worst,
                arm_clearance=round(arm, 4), path_length=round(float(path.L), 4), lathe_travel=round(lathe, 4),
                flange_off_axis=round(flange_off, 4), curved_part=round(float(path.L - path.first_arc), 4),
                goal_on_path=[round(x, 4) for x in gpath], goal_clearance=[round(x, 4) for x in gclear],
                straight_leg_clearance=legs)


# ---------------- worlds ----------------
W = {}
def world(fn): W[fn.__name__] = fn; return fn

def S_curve(R, off):
    """angle (deg) of the two arcs of an S-curve of radius R giving lateral offset off"""
    return math.degrees(math.acos(1 - off / (2 * R)))

def unit(v): v = np.array(v, float); return v / np.linalg.norm(v)


@world
def bundle_a():
    """square pipe bundle along the approach, one pipe missing diagonally (up-left) off the start line"""
    p, r = 0.105, 0.04; d = unit([0, 1, 1]); off = p * math.sqrt(2); th = S_curve(0.3, off)
    path = Path([('S', 0.12), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.42)])
    e, _ = path.end(); c = np.array([0, Y0 + p, Z0 + p]); x1 = e[0] - 0.34; x2 = e[0] + 0.25
    obs = []
    for i in range(-2, 3):
        for j in range(-2, 3):
            if (i, j) == (0, 0): continue
            obs.append(cyl([x1, c[1] + i * p, c[2] + j * p], [x2, c[1] + i * p, c[2] + j * p], r))
    obs.append(box([x2 + 0.03, c[1], c[2]], [0.03, 0.3, 0.3]))  # header the bundle ends in
    goal = e
    return ("Pipe bundle: 24 pipes (r 40 mm, pitch 105 mm, square) running along the approach, ending in a header; "
            "one pipe is missing, one pitch up and one left of the start line (diagonal). Goal: 0.34 m inside the "
            "missing pipe's channel."), obs, [goal], path

@world
def bundle_b():
    """hex pipe bundle, the missing pipe lower-right; pipes end on a tube sheet"""
    p, r = 0.11, 0.045
    off_v = np.array([0, -p / 2, -p * math.sqrt(3) / 2])  # lower-right neighbour in the hex
    c = np.array([0, Y0, Z0]) + off_v + np.array([0, 0, 0])
    d = unit(off_v); th = S_curve(0.3, np.linalg.norm(off_v))
    path = Path([('S', 0.15), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.40)])
    e, _ = path.end(); x1 = e[0] - 0.30; x2 = e[0] + 0.07
    obs = []
    # hex lattice round the missing cell c, excluding c; lattice vectors (p,0) and (p/2, p*sqrt3/2) in (y,z)
    for i in range(-3, 4):
        for j in range(-3, 4):
            y = c[1] + i * p + j * p / 2; z = c[2] + j * p * math.sqrt(3) / 2
            if (i, j) == (0, 0) or math.hypot(y - c[1], z - c[2]) > 0.3: continue
            obs.append(cyl([x1, y, z], [x2, y, z], r))
    obs.append(box([x2 + 0.01, c[1], c[2]], [0.01, 0.35, 0.35]))  # tube sheet (closed)
    return ("Hex pipe bundle (r 45 mm, pitch 110 mm) along the approach, ending on a closed tube sheet; the missing "
            "pipe is the lower-right neighbour of the start line's position (offset 110 mm at -120 deg). Goal: 70 mm "
            "before the tube sheet, in the missing pipe's channel."), obs, [e], path

@world
def node_a():
    """truss node on the start line, members converging; goal just behind the node"""
    d = unit([0, 0.6, 0.8]); th = 36.0
    path = Path([('S', 0.10), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.10), ('A', 0.3, th, -d), ('A', 0.3, th, d), ('S', 0.06)])
    # node at the middle of the flat part
    sm = 0.10 + 2 * 0.3 * math.radians(th) + 0.05; pm, _ = path.at(sm); N = np.array([pm[0], Y0, Z0])
    obs = [sph(N, 0.055)]
    rng = np.random.default_rng(34)
    dirs = [(-0.5, -0.8, 0.3), (0.3, -0.7, -0.65), (-0.2, 0.6, -0.8), (0.6, 0.5, -0.6), (-0.7, 0.1, 0.7),
            (0.5, -0.2, 0.85), (0.9, 0.4, 0.1), (-0.4, 0.9, 0.2), (0.2, -0.95, 0.1)]
    kept = []
    for dv in dirs:
        u = unit(dv); o = cyl(N, N + 0.7 * u, 0.025)
        if sdf(o, path.P).min() > 0.06: obs.append(o); kept.append([round(x, 3) for x in u])
    e, _ = path.end()
    return (f"Truss node: a ball (r 55 mm) on the start line with {len(kept)} members (r 25 mm, 0.7 m) converging on it "
            "from all sides; the goal is 0.2 m behind the node, reached by swinging round it between members "
            "(up-left)."), obs, [e], path

@world
def manhole_a():
    """floor plate below the start line with a square manhole; reached from the side, dive down through it"""
    path = Path([('S', 0.30), ('A', 0.3, 90, DOWN), ('S', 0.26)])
    e, _ = path.end(); xh = e[0]; zp = Z0 - 0.36
    obs = plate_hole([xh, Y0, zp], [1, 0, 0], [0, 1, 0], [0, 0, 1], 0.8, 0.7, (0.0, 0.0), (0.10, 0.10), t=0.008)
    # coaming (collar) round the hole, 70 mm high
    for sx in (-1, 1):
        obs.append(box([xh + sx * 0.106, Y0, zp + 0.043], [0.006, 0.112, 0.035]))
        obs.append(box([xh, Y0 + sx * 0.106, zp + 0.043], [0.1, 0.006, 0.035]))
    obs.append(cyl([xh - 0.22, Y0 - 0.6, Z0 - 0.52], [xh - 0.22, Y0 + 0.6, Z0 - 0.52], 0.06))  # pipe under the plate
    obs.append(box([xh + 0.35, Y0, Z0 - 0.1], [0.02, 0.4, 0.25]))  # bulkhead beyond the manhole
    return ("Floor plate (16 mm) 0.36 m below the start line with a 0.2 m square manhole and a 70 mm collar, 0.6 m "
            "ahead; a bulkhead beyond it and a pipe under the plate. Goal: 0.2 m below the plate, under the manhole "
            "(dive down 90 deg through it)."), obs, [e], path

@world
def cables_a():
    """corridor of hanging cables (thin vertical cylinders), a winding way through"""
    path = Path([('S', 0.10), ('A', 0.3, 35, LEFT), ('A', 0.3, 70, RIGHT), ('A', 0.3, 35, LEFT), ('S', 0.25)])
    e, _ = path.end(); rng = np.random.default_rng(3434); obs = []; top = Z0 + 0.55
    tries = 0
    while len(obs) < 48 and tries < 5000:
        tries += 1
        x = rng.uniform(X0 + 0.15, e[0] + 0.15); y = rng.uniform(Y0 - 0.35, Y0 + 0.35)
        rr = rng.uniform(0.006, 0.011); bot = rng.choice([Z0 - 0.6, Z0 - 0.45, Z0 - 0.3, Z0 + 0.12 + rng.uniform(0, 0.2)])
        o = cyl([x, y, bot], [x, y, top], rr)
        if sdf(o, path.P).min() < 0.07: continue
        if min(np.hypot(x - q['p0'][0], y - q['p0'][1]) for q in obs) < 0.06 if obs else False: continue
        obs.append(o)
    obs.append(box([(X0 + e[0]) / 2 + 0.1, Y0, top + 0.02], [0.6, 0.45, 0.02]))  # cable tray above
    goal = e
    # make sure the direct line is blocked: a cable on it
    mid = P0 + 0.55 * (goal - P0)
    o = cyl([mid[0], mid[1], Z0 - 0.6], [mid[0], mid[1], top], 0.01)
    if sdf(o, path.P).min() > 0.07: obs.append(o)
    return (f"Corridor of {len(obs) - 1} hanging cables (r 6-11 mm) from a tray above, some ending above the start "
            "line, most below it; the only way keeps 70 mm from all winds left-right-left (S-curves of 35/70/35 deg). "
            "Goal: beyond the cables."), obs, [goal], path

@world
def vessel_a():
    """closed vessel, inlet offset left, internal baffle from the left leaving a gap on the right"""
    th1 = S_curve(0.3, 0.11); th2 = S_curve(0.3, 0.21)
    path = Path([('S', 0.10), ('A', 0.3, th1, LEFT), ('A', 0.3, th1, RIGHT), ('S', 0.14),
                 ('A', 0.3, th2, RIGHT), ('A', 0.3, th2, LEFT), ('S', 0.12)])
    s_in = 0.10 + 2 * 0.3 * math.radians(th1) + 0.05; pin, _ = path.at(s_in)
    e, _ = path.end(); xf = pin[0]; xb = e[0] + 0.08; yc = Y0; zc = Z0; t = 0.006
    obs = plate_hole([xf, yc, zc], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.3, 0.3, (pin[1] - yc, 0.0), (0.085, 0.085), t)
    obs += [box([xb, yc, zc], [t, 0.3, 0.3]),
            box([(xf + xb) / 2, yc + 0.3, zc], [(xb - xf) / 2, t, 0.3]), box([(xf + xb) / 2, yc - 0.3, zc], [(xb - xf) / 2, t, 0.3]),
            box([(xf + xb) / 2, yc, zc + 0.3], [(xb - xf) / 2, 0.3, t]), box([(xf + xb) / 2, yc, zc - 0.3], [(xb - xf) / 2, 0.3, t])]
    xbaf = e[0] - 0.10; yedge = e[1] + 0.07
    obs.append(box([xbaf, (yedge + yc + 0.3) / 2, zc], [t, (yc + 0.3 - yedge) / 2, 0.3]))
    return ("Closed box vessel (0.6 m square section) entered through a 0.17 m inlet 0.11 m left of the start line; "
            "inside, a baffle from the left wall leaves a gap on the right, 0.21 m right of the inlet. Goal: behind "
            "the baffle, 0.18 m before the back wall."), obs, [e], path

@world
def traybend_a():
    """open-sided cable tray with a 90 deg bend, clutter at the bend, covered after it"""
    path = Path([('S', 0.25), ('A', 0.3, 90, LEFT), ('S', 0.32)])
    e, _ = path.end(); xb = X0 + 0.25 + 0.3; yb = Y0 + 0.3; zb = Z0 - 0.085; t = 0.005
    obs = [box([(X0 - 0.1 + xb + 0.17) / 2, Y0 + 0.1, zb], [(xb + 0.17 - X0 + 0.1) / 2, 0.17, t]),   # tray bottom, run 1 + corner
           box([xb, (Y0 + e[1] + 0.1) / 2 + 0.05, zb], [0.17, (e[1] + 0.1 - Y0) / 2, t])]          # run 2
    # cover over run 2 (after the bend) and its end wall
    obs.append(box([xb, (yb + 0.06 + e[1] + 0.12) / 2, Z0 + 0.085], [0.17, (e[1] + 0.12 - yb - 0.06) / 2, t]))
    obs.append(box([xb, e[1] + 0.12, Z0], [0.17, t, 0.09]))
    # clutter: junction box inside the bend, cable coils outside, a riser on the diagonal
    ctr = np.array([X0 + 0.25, Y0 + 0.3, Z0])
    obs.append(box(ctr + np.array([0.06, -0.06, -0.02]), [0.09, 0.09, 0.065], [0, 0, math.radians(45)]))
    for ang in (20, 45, 70):
        a = math.radians(ang); pnt = ctr + 0.3 * 1.28 * np.array([math.sin(a), -math.cos(a), 0]) * 1.0
        obs.append(cyl([pnt[0], pnt[1], zb], [pnt[0], pnt[1], Z0 + 0.04], 0.022))
    obs.append(cyl([X0 + 0.3, Y0 + 0.12, zb], [X0 + 0.3, Y0 + 0.12, Z0 + 0.3], 0.03))  # riser
    return ("Open-sided cable tray (bottom 85 mm below the start line) bending 90 deg left (radius 0.3 m); a "
            "junction box on the inside of the bend, cable coils (upright cylinders) on its outside, a riser pipe "
            "inside; after the bend the tray is covered (0.17 m high channel, closed end). Goal: in the covered part."
            ), obs, [e], path

@world
def windows_a():
    """wall with two windows; the one on the line leads into a dead-end pocket; the way is the right window,
    then back left behind the pocket"""
    th1 = S_curve(0.28, 0.20); th2 = S_curve(0.28, 0.15)
    path = Path([('S', 0.05), ('A', 0.28, th1, RIGHT), ('A', 0.28, th1, LEFT), ('S', 0.12),
                 ('A', 0.28, th2, LEFT), ('A', 0.28, th2, RIGHT), ('S', 0.04)])
    s_w = 0.05 + 2 * 0.28 * math.radians(th1) + 0.05; pw, _ = path.at(s_w); xw = pw[0]; t = 0.008
    # wall with two holes: build as a plate with window 2 and cut window 1 by splitting: use boxes on a grid
    yA, yB = Y0, pw[1]; hw = 0.085
    ys = sorted([(yB - hw, yB + hw), (yA - hw, yA + hw)])
    obs = [box([xw, Y0, Z0 + (0.6 + hw) / 2], [t, 0.7, (0.6 - hw) / 2]), box([xw, Y0, Z0 - (0.6 + hw) / 2], [t, 0.7, (0.6 - hw) / 2])]
    edges = [Y0 - 0.7, ys[0][0], ys[0][1], ys[1][0], ys[1][1], Y0 + 0.7]
    for a, b in [(edges[0], edges[1]), (edges[2], edges[3]), (edges[4], edges[5])]:
        obs.append(box([xw, (a + b) / 2, Z0], [t, (b - a) / 2, hw]))
    # dead-end pocket behind window 1 (depth 0.18), closed at the back
    dp = 0.12; pw2 = 0.09
    obs += [box([xw + dp / 2, Y0 + pw2 + t, Z0], [dp / 2, t, pw2 + 2 * t]), box([xw + dp / 2, Y0 - pw2 - t, Z0], [dp / 2, t, pw2 + 2 * t]),
            box([xw + dp / 2, Y0, Z0 + pw2 + t], [dp / 2, pw2 + 2 * t, t]), box([xw + dp / 2, Y0, Z0 - pw2 - t], [dp / 2, pw2 + 2 * t, t]),
            box([xw + dp, Y0, Z0], [t, pw2 + 2 * t, pw2 + 2 * t])]
    e, _ = path.end()
    obs.append(box([e[0] + 0.09, Y0, Z0], [0.01, 0.4, 0.4]))  # back wall behind the goal
    return ("Wall with two 0.17 m windows: the one on the start line opens into a closed pocket 0.12 m deep (dead "
            "end); the other is 0.20 m to the right. Goal: behind the wall, 0.15 m back to the left (behind the "
            "pocket's right half), 0.09 m before a back wall."), obs, [e], path

@world
def vgap_a():
    """two vertical plates yawed into a V (funnel opening towards the robot), gap off the line to the left"""
    th = S_curve(0.3, 0.12)
    path = Path([('S', 0.08), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.36)])
    sg = 0.08 + 2 * 0.3 * math.radians(th) + 0.14; pg, _ = path.at(sg); yc = pg[1]; hg = 0.085; a = math.radians(35)
    obs = []; Lp = 0.45; t = 0.006
    for sgn in (1, -1):
        edge = np.array([pg[0], yc + sgn * hg, Z0]); u = np.array([-math.cos(a), sgn * math.sin(a), 0])
        n = np.cross(u, [0, 0, 1])
        obs.append(frame_box(edge + u * (Lp / 2 + 0.0) + 0 * n, u, [0, 0, 1], unit(n), Lp / 2, 0.4, t))
    e, _ = path.end()
    obs.append(box([e[0] + 0.12, yc - 0.2, Z0], [0.01, 0.25, 0.4]))  # equipment behind, right
    return ("Two tall plates yawed 35 deg into a V, a funnel opening towards the robot whose 0.17 m gap is 0.12 m "
            "left of the start line (the right plate crosses the line); equipment behind on the right. Goal: 0.22 m "
            "beyond the gap."), obs, [e], path

@world
def vgap_b():
    """hopper: two plates tilted 45 deg into a V trough; the slot at its bottom; dive through it"""
    path = Path([('S', 0.22), ('A', 0.3, 60, DOWN), ('S', 0.45)])
    s_sl = 0.22 + 0.3 * math.radians(60) + 0.25; ps, hs = path.at(s_sl); zs = ps[2]; xs = ps[0]; hg = 0.105; t = 0.006
    obs = []; Lp = 0.4; a = math.radians(45)
    for sgn in (-1, 1):
        edge = np.array([xs + sgn * hg, Y0, zs]); u = np.array([sgn * math.cos(a), 0, math.sin(a)])
        n = unit(np.cross(u, [0, 1, 0]))
        obs.append(frame_box(edge + u * Lp / 2, u, [0, 1, 0], n, Lp / 2, 0.45, t))
    e, _ = path.end()
    obs.append(box([e[0], Y0, e[2] - 0.09], [0.3, 0.4, 0.01]))  # floor below
    return ("Hopper: two plates tilted 45 deg into a V trough across the approach, below the start line; the slot "
            "at its bottom (0.21 m wide) is 0.30 m below and 0.5 m ahead of the start tip. Goal: below the slot, "
            "0.09 m above a floor (dive 60 deg down through it)."), obs, [e], path

# ---- multi-goal tours ----
@world
def tour_wind_a():
    """winding way round two posts (90 deg left, 90 deg right), inspection goals after each bend"""
    R = 0.28
    path = Path([('S', 0.10), ('A', R, 90, LEFT), ('A', R, 90, RIGHT), ('S', 0.12)])
    s1 = 0.10 + R * math.pi / 2; s2 = s1 + R * math.pi / 2
    g1, _ = path.at(s1); g2, _ = path.at(s2); g3, _ = path.end()
    c1 = P0 + np.array([0.10, R, 0]); c2 = g1 + np.array([R, 0, 0])
    obs = []
    for c, dv in ((c1, unit([1, -1, 0])), (c2, unit([-1, 1, 0]))):
        q = c + 0.155 * dv   # post inside each bend
        obs.append(cyl([q[0], q[1], Z0 - 0.5], [q[0], q[1], Z0 + 0.5], 0.04))
    # posts outside the bends
    for c, dv in ((c1, unit([1, -1.6, 0])), (c2, unit([-1, 1.6, 0]))):
        q = c + (R + 0.12) * dv
        obs.append(cyl([q[0], q[1], Z0 - 0.5], [q[0], q[1], Z0 + 0.5], 0.035))
    obs.append(box([g3[0] + 0.15, g3[1], Z0], [0.01, 0.4, 0.5]))
    obs.append(box([(X0 + g3[0]) / 2 + 0.05, (Y0 + g3[1]) / 2, Z0 - 0.5], [(g3[0] - X0) / 2 + 0.2, 0.6, 0.01]))
    return ("Winding way between upright posts (r 35-40 mm) on a deck: 90 deg left round one post, 90 deg right "
            "round the next (radius 0.28 m); inspection points after each bend and at the end, 0.15 m before a wall. "
            "The straight legs start->goal 1 and goal 1->goal 2 run through the posts. 3 goals in order."), obs, [g1, g2, g3], path

@world
def tour_wind_b():
    """3-D winding: up over a pipe, then left round a column, inspection goals on the way"""
    th = S_curve(0.3, 0.16)
    path = Path([('S', 0.10), ('A', 0.3, th, UP), ('A', 0.3, th, DOWN), ('S', 0.06), ('A', 0.3, 75, LEFT), ('S', 0.22)])
    s1 = 0.10 + 2 * 0.3 * math.radians(th) + 0.03; g1, _ = path.at(s1)
    s2 = s1 + 0.03 + 0.3 * math.radians(75); g2, _ = path.at(s2); g3, _ = path.end()
    xp = X0 + 0.10 + 0.3 * math.sin(math.radians(th))
    obs = [cyl([xp, Y0 - 0.5, Z0 - 0.045], [xp, Y0 + 0.5, Z0 - 0.045], 0.045)]  # pipe across, on the start line
    # column on the inside of the left turn
    p, h = path.at(s1 + 0.03 + 0.3 * math.radians(37)); c = p + np.array([0, 1, 0]) * 0.0
    ctr = path.at(s1 + 0.03)[0] + np.array([0, 0.3, 0])
    obs.append(cyl([ctr[0] + 0.02, ctr[1] - 0.02, Z0 - 0.4], [ctr[0] + 0.02, ctr[1] - 0.02, Z0 + 0.6], 0.16))
    # plate beyond the turn and a box under g3
    obs.append(box([g2[0] + 0.30, g2[1] + 0.1, g2[2]], [0.01, 0.35, 0.35]))
    obs.append(box([g3[0], g3[1] + 0.11, g3[2]], [0.15, 0.01, 0.2]))
    obs.append(box([g3[0], g3[1], g3[2] - 0.11], [0.15, 0.15, 0.01]))
    return ("Up over a pipe (r 45 mm) lying across the start line, then 75 deg left round a column (r 0.16 m); "
            "inspection points: just past the pipe, after the turn, and at the end under a ledge before a wall. 3 "
            "goals in order."), obs, [g1, g2, g3], path

@world
def tour_side_a():
    """goal 1 at the end of a straight bay; goal 2 beside it after a sharp (100 deg) left turn, behind a plate"""
    path = Path([('S', 0.45), ('A', 0.28, 100, LEFT), ('S', 0.16)])
    g1, _ = path.at(0.45); g2, _ = path.end()
    obs = [box([g1[0] - 0.05, Y0 - 0.08, Z0], [0.3, 0.01, 0.3]),                 # bay wall on the right
           box([g1[0] + 0.36, Y0 + 0.2, Z0], [0.01, 0.4, 0.3]),                   # wall ahead
           box([g1[0] - 0.075, Y0 + 0.11, Z0], [0.175, 0.008, 0.2])]                       # plate between g1 and g2
    obs.append(box([g2[0], g2[1] + 0.1, g2[2]], [0.2, 0.01, 0.3]))                 # wall behind g2
    obs.append(box([(X0 + g1[0] + 0.2) / 2, Y0 + 0.1, Z0 - 0.09], [(g1[0] + 0.2 - X0) / 2, 0.3, 0.008]))    # floor
    return ("Inspection bay: goal 1 at the end of a straight 0.45 m run along a wall; goal 2 is 0.27 m to its left "
            "and 0.1 m back, behind a plate between them: a 100 deg left turn (radius 0.28 m). 2 goals in order."), obs, [g1, g2], path

@world
def tour_side_b():
    """goal 1 under a shelf; goal 2 above the shelf, after a 110 deg turn up"""
    path = Path([('S', 0.40), ('A', 0.28, 110, UP), ('S', 0.12)])
    g1, _ = path.at(0.40); g2, _ = path.end()
    obs = [box([g1[0] - 0.12, Y0, Z0 + 0.11], [0.2, 0.3, 0.008]),        # shelf above goal 1
           box([g1[0] + 0.36, Y0, Z0 + 0.2], [0.01, 0.3, 0.45]),          # back wall
           box([X0 + 0.15, Y0, Z0 + 0.2], [0.02, 0.3, 0.05])]             # beam above the start line
    obs.append(box([(X0 + g1[0]) / 2 + 0.1, Y0, Z0 - 0.1], [0.4, 0.3, 0.008]))
    return ("Shelf: goal 1 under a shelf 0.11 m above the start line, 0.4 m in; goal 2 above the shelf, 0.11 m back "
            "towards the robot: a 110 deg turn up (radius 0.28 m) round the shelf's far edge. 2 goals in order."), obs, [g1, g2], path

@world
def tour_back_a():
    """square pipe with a capped far end, mouth offset down; inspect the far end, then 0.15 m back along it"""
    th = S_curve(0.3, 0.10)
    path = Path([('S', 0.10), ('A', 0.3, th, DOWN), ('A', 0.3, th, UP), ('S', 0.46)])
    e, _ = path.end(); g1 = e; g2 = e - np.array([0.15, 0, 0]); hw = 0.085; t = 0.006
    x1 = e[0] - 0.40; x2 = e[0] + 0.06; c = np.array([0, e[1], e[2]])
    obs = [box([(x1 + x2) / 2, c[1] + hw + t, c[2]], [(x2 - x1) / 2, t, hw + 2 * t]), box([(x1 + x2) / 2, c[1] - hw - t, c[2]], [(x2 - x1) / 2, t, hw + 2 * t]),
           box([(x1 + x2) / 2, c[1], c[2] + hw + t], [(x2 - x1) / 2, hw + 2 * t, t]), box([(x1 + x2) / 2, c[1], c[2] - hw - t], [(x2 - x1) / 2, hw + 2 * t, t]),
           box([x2 + t, c[1], c[2]], [t, hw + 2 * t, hw + 2 * t])]
    obs.append(box([x1 + 0.15, c[1], c[2] + 0.22], [0.15, 0.3, 0.01]))  # deck above the pipe
    return ("Square pipe (0.17 m inside, 0.40 m long) capped at the far end, its axis 0.10 m below the start line; "
            "goal 1 at the far end (0.06 m from the cap), goal 2 0.15 m back along the axis (behind goal 1 on the "
            "way in: back out). A deck above the pipe's mouth. 2 goals in order."), obs, [g1, g2], path

@world
def tour_back_b():
    """pocket between two vessels after a left turn: entry point, back of the pocket, then 0.15 m back out"""
    path = Path([('S', 0.20), ('A', 0.3, 60, LEFT), ('S', 0.40)])
    e, h = path.end(); g1, _ = path.at(0.20 + 0.3 * math.radians(60) + 0.08); g2 = e; g3 = e - 0.15 * h
    n = np.array([-h[1], h[0], 0]); t = 0.008
    # pocket: two walls parallel to the last straight, 0.085 m off the axis, a back plate, roof and floor
    mid = e - 0.16 * h
    obs = [frame_box(mid + n * (0.085 + t), h, [0, 0, 1], n, 0.2, 0.12, t), frame_box(mid - n * (0.085 + t), h, [0, 0, 1], n, 0.2, 0.12, t),
           frame_box(mid + np.array([0, 0, 0.1 + t]), h, n, [0, 0, 1], 0.2, 0.093, t), frame_box(mid - np.array([0, 0, 0.1 + t]), h, n, [0, 0, 1], 0.2, 0.093, t),
           frame_box(e + 0.06 * h, n, [0, 0, 1], h, 0.1, 0.12, t)]
    obs.append(cyl([X0 + 0.5, Y0 - 0.10, Z0 - 0.4], [X0 + 0.5, Y0 - 0.10, Z0 + 0.4], 0.10))  # vessel on the line
    return ("Pocket (0.17 x 0.2 m, 0.36 m deep) between two vessels, entered after a 60 deg left turn past a "
            "column on the start line; goal 1 at its mouth, goal 2 at its back (0.06 m from the back plate), goal 3 "
            "0.15 m back out towards the mouth. 3 goals in order."), obs, [g1, g2, g3], path


def build(name):
    desc, obs, goals, path = W[name]()
    goals = [np.array(g, float) for g in goals]
    s_stop = path.L
    ck = check(obs, path, goals, s_stop)
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h3-" + name.split('_')[0],
         "robot": ROBOT, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": 0.02} for g in goals],
         "time_limit": 75.0,
         "extra": {"reference_path": {"commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [float(x) for x in c[3]]] for c in path.cmds],
                                      "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; goals behind an earlier one are reached by backing out along it",
                                      "start_tip": [round(float(v), 6) for v in P0]},
                   "checks": ck, "generator": "/work/s34/hard3/make.py (session 34 helper)"}}
    json.dump(w, open(os.path.join(OUT, name + '.json'), 'w'), indent=1)
    return ck

if __name__ == '__main__':
    names = sys.argv[1:] or list(W)
    for n in names:
        ck = build(n)
        ok = ck['tip_clearance'] >= 0.05 and ck['body_clearance'] >= 0.025 and ck['arm_clearance'] >= 0.03 and ck['lathe_travel'] <= 2.0 and ck['curved_part'] <= 1.2 and max(ck['goal_on_path']) < 0.003
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
