"""Own generator, held-out batch 5 (session 37 helper, outside user). Does not use navstack.generate.
Adapted from worlds/hard4/make.py (its Path, primitives, exact distances and checks kept). Each world is built in
the canonical frame (the default base, start tip P0 = (1.8085, 0.1079, 1.1668) heading +x) around a reference tip
path (straight legs and arcs of radius >= 0.28 m), checked with exact distances (primitives: exact signed
distance; meshes: exact point-triangle distance, geom.MeshDist). Worlds whose goal cannot be reached carry only
the approach as their path ("unreachable" in extra.reference_path.note).
Moving obstacles are checked with an assumed timing: the tip at arc length s at t(s) = T0 + s / V
(T0 = 1 s, V = 0.055 m/s, hard3's field trials), the body left at s at that same time.
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

def end_wall(e, d=0.12, half=0.3):
    return box([e[0] + d, Y0, Z0], [0.01, half, half])


def hollow_box(c, hi, t=0.006):
    """six plates (thickness 2t) closing a cube of inner half size hi round c; edges overlap (closed)"""
    c = np.array(c, float); o = hi + t; out = []
    for ax in range(3):
        for sg in (1, -1):
            cc = c.copy(); cc[ax] += sg * o
            h = [o + t] * 3; h[ax] = t
            out.append(box(cc, h))
    return out


def cage(c, a, rb, gap):
    """bars of radius rb round a cube of half size a about c: vertical bars on the +-x and +-y faces, bars along
    x on the top and bottom faces, bars along the 12 edges; clear gap between neighbouring bars = gap"""
    c = np.array(c, float); pitch = 2 * rb + gap
    n = int(math.floor(2 * a / pitch)); ks = (np.arange(n + 1) - n / 2) * pitch   # symmetric positions
    out = []
    for u in ks:
        for sg in (1, -1):
            out.append(cyl(c + [sg * a, u, -a], c + [sg * a, u, a], rb))      # x faces, vertical
            out.append(cyl(c + [u, sg * a, -a], c + [u, sg * a, a], rb))      # y faces, vertical
            out.append(cyl(c + [-a, u, sg * a], c + [a, u, sg * a], rb))      # top/bottom, along x
    for s1 in (1, -1):
        for s2 in (1, -1):
            out.append(cyl(c + [-a, s1 * a, s2 * a], c + [a, s1 * a, s2 * a], rb))
            out.append(cyl(c + [s1 * a, -a, s2 * a], c + [s1 * a, a, s2 * a], rb))
            out.append(cyl(c + [s1 * a, s2 * a, -a], c + [s1 * a, s2 * a, a], rb))
    return out, pitch, ks


# ---- kind 1: goals that cannot be reached ----
@world
def goal_in_box():
    """(1) goal at the centre of a closed hollow box (6 plates, inner cube 0.2 m)"""
    c = P0 + EX * 0.55
    obs = hollow_box(c, 0.1)
    obs.append(cyl([X0 + 0.25, Y0 - 0.4, Z0 - 0.16], [X0 + 0.25, Y0 + 0.4, Z0 - 0.16], 0.03))
    path = Path([('S', 0.36)])
    return ("A closed box (six 12 mm plates, inner cube 0.2 m, centre 0.55 m ahead on the start line); the goal is "
            "its centre, 0.1 m from every inner face. No opening: unreachable. A pipe below the approach. The "
            "reference path is only the approach up to 50 mm of the box."), obs, [c], path, \
        {"unreachable": True, "expected": "not a success (timeout or stalled), 0 goals"}


@world
def goal_in_cage():
    """(1) goal at the centre of a cage of bars whose gaps (40 mm) are narrower than the body (50 mm)"""
    c = P0 + EX * 0.55
    obs, pitch, ks = cage(c, 0.12, 0.008, 0.040)
    path = Path([('S', 0.37)])
    # every point of the cube surface |p - c|_inf = a lies within 25 mm of some bar's axis-surface?
    a = 0.12; g = np.linspace(-a, a, 121); worst = 0.0
    for ax in range(3):
        for sg in (1, -1):
            U, Vv = np.meshgrid(g, g); P = np.zeros((U.size, 3)); ids = [i for i in range(3) if i != ax]
            P[:, ax] = sg * a; P[:, ids[0]] = U.ravel(); P[:, ids[1]] = Vv.ravel()
            worst = max(worst, float(dist(obs, P + c).max()))
    return (f"A cage of bars (r 8 mm, {len(obs)} bars, clear gaps 40 mm < the 50 mm body) round a cube of half size "
            "0.12 m, 0.55 m ahead on the start line; the goal is its centre. Unreachable (every point of the cage's "
            "surface lies within 25 mm of a bar)."), obs, [c], path, \
        {"unreachable": True, "expected": "not a success, 0 goals", "cage_surface_max_distance_to_bar": round(worst, 5)}


@world
def goal_far():
    """(1) goal 2.7 m ahead on the start line: beyond the lathe's 2.0 m travel plus the serpentine"""
    g = P0 + EX * 2.7
    obs = [cyl([X0 + 0.6, Y0 + 0.15, Z0 - 0.4], [X0 + 0.6, Y0 + 0.15, Z0 + 0.4], 0.03),
           sph([X0 + 1.2, Y0 - 0.15, Z0 - 0.05], 0.05)]
    path = Path([('S', 2.0)])
    return ("Free space with a post and a ball beside the start line; the goal is 2.7 m ahead on the start line, "
            "0.7 m beyond where the tip gets with the lathe bed at the end of its travel (2.0 m) and the arm in its "
            "start posture; within check-world's conservative reach bound (2.66 m from the lathe's travel; the bound is 2.77 m). "
            "Expected: not reached (a joint limit, stall or timeout), unless the arm unfolds."), obs, [g], path, \
        {"unreachable": True, "expected": "not a success unless the arm straightens towards it"}


# ---- kind 2: tolerance ball overlapping a surface ----
@world
def goal_touch():
    """(2) goal 4 mm in front of a plate: the tip's ball (25 mm) must cut 1 mm into it to get within 20 mm"""
    e = P0 + EX * 0.5
    obs = [box([e[0] + 0.004 + 0.006, Y0, Z0], [0.006, 0.3, 0.3]),
           cyl([X0 + 0.25, Y0 + 0.08, Z0 - 0.4], [X0 + 0.25, Y0 + 0.08, Z0 + 0.4], 0.025)]
    path = Path([('S', 0.44)])
    return ("A plate 0.5 m ahead; the goal (tolerance 20 mm) is 4 mm in front of its face, so the tip point can "
            "come within 20 mm of it only with the tip's 25 mm ball 1 mm into the plate. check-world should warn. "
            "Expected: never success (collision or timeout)."), obs, [e], path, \
        {"unreachable": True, "expected": "not a success: reaching needs 1 mm of penetration"}


@world
def goal_sliver():
    """(2) goal 10 mm from a pipe's surface after a left S-bend: reachable only from a 5 mm sliver"""
    th = S_curve(0.3, 0.06)
    pre = Path([('S', 0.1), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.35)])
    e, h = pre.end()
    rp = 0.06; cp = e + EX * (0.01 + rp + 0.0)           # pipe (vertical) ahead of the goal, surface 10 mm away
    obs = [cyl([cp[0], cp[1], Z0 - 0.4], [cp[0], cp[1], Z0 + 0.4], rp),
           cyl([X0 + 0.3, Y0 - 0.03, Z0 - 0.4], [X0 + 0.3, Y0 - 0.03, Z0 + 0.4], 0.025)]
    # the reference tip ends 10 mm short of the goal: 27.5... mm from the pipe (inside the ball: 10 <= 20)
    path = Path([('S', 0.1), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.332)])
    return ("After a post on the start line (0.06 m S-bend left), the goal lies 10 mm in front of a vertical pipe "
            "(r 60 mm): the tip point within the goal's 20 mm with its 25 mm ball clear of the pipe only in a "
            "5 mm-deep sliver (25-30 mm from the surface). Any success must have 0 contacts and a clearance of at "
            "most 5 mm. The reference tip stops 18 mm short of the goal (28 mm from the pipe: tip clearance not 50 mm "
            "here by design)."), obs, [e], path, \
        {"sliver": True, "expected": "success only with 0 contacts and clearance <= 5 mm; a timeout is honest"}


# ---- kind 3: order ----
def duct(x0, x1, hw, t=0.006, yc=None, zc=None):
    yc = Y0 if yc is None else yc; zc = Z0 if zc is None else zc; xm = (x0 + x1) / 2; hx = (x1 - x0) / 2
    return [box([xm, yc + hw + t, zc], [hx, t, hw + 2 * t]), box([xm, yc - hw - t, zc], [hx, t, hw + 2 * t]),
            box([xm, yc, zc + hw + t], [hx, hw + 2 * t, t]), box([xm, yc, zc - hw - t], [hx, hw + 2 * t, t])]


@world
def tour_passby():
    """(3) goal 2 lies on the way to goal 1 (passed first, must count only after goal 1): back along a duct"""
    path = Path([('S', 0.7)])
    g1 = P0 + EX * 0.7; g2 = P0 + EX * 0.35 + np.array([0, 0.008, 0])
    obs = duct(X0 + 0.15, X0 + 0.85, 0.1) + [box([X0 + 0.86, Y0, Z0], [0.01, 0.15, 0.15])]
    return ("A square duct (inner 0.2 m) 0.15-0.85 m ahead, capped. Goal 1 at 0.7 m on the line, goal 2 at 0.35 m "
            "(8 mm off the line): the tip passes within tolerance of goal 2 on its way to goal 1, which must not "
            "count; after goal 1 it must come 0.35 m back along the duct (no room to turn)."), obs, [g1, g2], path, \
        {"expected": "2/2 only by backing up after goal 1; a success at goal 1's time would be wrong", "offpath": True}


@world
def tour_repeat():
    """(3) goals [A, A, B]: the second goal equals the first"""
    th = S_curve(0.3, 0.08)
    path = Path([('S', 0.1), ('A', 0.3, th, UP), ('A', 0.3, th, DOWN), ('S', 0.4)])
    sA = 0.1 + 2 * 0.3 * math.radians(th) + 0.1; A, _ = path.at(sA); B, _ = path.end()
    obs = [cyl([X0 + 0.45, Y0 - 0.4, Z0 - 0.02], [X0 + 0.45, Y0 + 0.4, Z0 - 0.02], 0.04),
           box([A[0] + 0.12, Y0, Z0 - 0.1], [0.05, 0.3, 0.06]), end_wall(B)]
    return ("Up 0.08 m over a pipe on the start line, along a low block; goals A, A (the same point again), B. By "
            "the spec the second counts the first time the tip is within 20 mm after the first was reached (the "
            "same control step, or any later one)."), obs, [A, A, B], path, {"expected": "reached 3/3"}


@world
def start_in_goal():
    """(3) goal 1 is already within tolerance of the start tip (12 mm ahead); goal 2 beyond a window"""
    off = np.array([0, -0.07, 0.07]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    path = Path([('S', 0.1), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.35)])
    s_w = 0.1 + 2 * 0.3 * math.radians(th) + 0.1; pw, _ = path.at(s_w)
    obs = plate_hole([pw[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.4, 0.4, (pw[1] - Y0, pw[2] - Z0), (0.085, 0.085), 0.006)
    e, _ = path.end(); obs.append(end_wall(e))
    g1 = P0 + np.array([0.012, 0.0, 0.0])
    return ("Goal 1 is 12 mm ahead of the start tip (within its 20 mm tolerance at t = 0: reached at once); goal 2 "
            "lies 0.25 m beyond a wall with a 0.17 m window 0.1 m off the line (right-up)."), obs, [g1, e], path, \
        {"expected": "reached 2/2, goal 1 at t = 0"}


# ---- kind 4: movers across the way out during retraction ----
def _pocket(path_len):
    th = S_curve(0.3, 0.08)
    path = Path([('S', 0.25), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', path_len - 0.25 - 2 * 0.3 * math.radians(th))])
    e, _ = path.end()
    obs = duct(e[0] - 0.36, e[0] + 0.08, 0.1, yc=e[1]) + [box([e[0] + 0.09, e[1], Z0], [0.01, 0.13, 0.13])]
    obs.append(cyl([X0 + 0.3, Y0 - 0.085, Z0 - 0.4], [X0 + 0.3, Y0 - 0.085, Z0 + 0.4], 0.025))   # post right of the line
    return path, e, obs


@world
def retract_hit():
    """(4) a bar crosses the way out 0.12 m ahead of the start tip at t = 24-27 s (body there until fully out)"""
    path, e, obs = _pocket(1.0)
    xb = X0 + 0.12
    obs.append(cyl([xb, Y0 - 0.4, Z0 - 0.3], [xb, Y0 - 0.4, Z0 + 0.3], 0.02,
                   motion={"type": "linear", "velocity": [0, 0.25, 0], "start": 24.0, "stop": 27.2}))
    return ("retract: true. Into a capped duct (goal 1.0 m along the way, past a post and a 0.08 m S-bend left); a "
            "vertical bar (r 20 mm) sweeps across the way 0.12 m ahead of the start tip from t = 24 to 27.2 s, "
            "0.25 m/s, from 0.4 m right to 0.4 m left. The serpentine lies across that place from about 3 s until "
            "the retraction has brought the tip back within ~0.1 m of its start (at 0.055-0.06 m/s in and out: about "
            "35 s): the bar must hit the body. Honest outcome: collision (never success)."), obs, [e], path, \
        {"retract": True, "expected": "collision (the bar crosses the body on the way out)"}


@world
def retract_early():
    """(4) a bar crosses the way 0.6 m in at t = 1-4 s, before the tip gets there; then in and out"""
    path, e, obs = _pocket(1.0)
    xb = X0 + 0.6
    obs.append(cyl([xb, Y0 - 0.4, Z0 - 0.3], [xb, Y0 - 0.4, Z0 + 0.3], 0.02,
                   motion={"type": "linear", "velocity": [0, 0.25, 0], "start": 1.0, "stop": 4.2}))
    return ("retract: true. As retract_hit, but the bar sweeps across the way 0.6 m in (before the duct) at t = "
            "1-4.2 s, while the tip is still within 0.25 m of its start; it then stays 0.4 m left. Expected: reached "
            "and retracted."), obs, [e], path, {"retract": True, "expected": "reached, retracted"}


# ---- kind 5: mover through the goal ball ----
@world
def mover_goal():
    """(5) a ball passes up through the goal's tolerance ball at t = 6 s, before the tip arrives (~13 s)"""
    off = np.array([0, 0.09, 0]); th = S_curve(0.3, 0.09)
    path = Path([('S', 0.1), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.3)])
    e, _ = path.end()
    obs = [sph([e[0], e[1], e[2] - 0.4], 0.04, motion={"type": "linear", "velocity": [0, 0, 0.1], "start": 2.0, "stop": 10.0}),
           cyl([X0 + 0.28, Y0 - 0.055, Z0 - 0.4], [X0 + 0.28, Y0 - 0.055, Z0 + 0.4], 0.03), end_wall(e, 0.1)]
    return ("A 0.09 m S-bend left past a post, the goal 0.1 m before an end wall; a ball (r 40 mm) rises 0.8 m "
            "through the goal point (its centre there at t = 6 s, 0.1 m/s, moving from t = 2 to 10 s) and stops "
            "0.4 m above it. The tip (about 0.055 m/s) is 0.4 m short of the goal at 6 s. Expected: reached."), obs, [e], path, \
        {"expected": "reached"}


# ---- kinds 6-10: finding the way ----
@world
def far_slot():
    """(6) the only slot (0.11 x 0.32 m, tilted 35 deg) is 0.33 m left of the start line; goal on the line behind"""
    th = S_curve(0.3, 0.33)
    path = Path([('S', 0.05), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.12), ('A', 0.3, th, RIGHT), ('A', 0.3, th, LEFT), ('S', 0.12)])
    s_sl = 0.05 + 2 * 0.3 * math.radians(th) + 0.06; ps, _ = path.at(s_sl)
    a = math.radians(35); u = np.array([0, math.cos(a), math.sin(a)]); v = np.array([0, -math.sin(a), math.cos(a)])
    # wall in 4 tilted pieces round the slot (u across 0.055 half width, v along 0.16 half length), big enough
    hw, hl, W_, t = 0.055, 0.16, 0.9, 0.006
    obs = [frame_box(ps + u * (hw + W_ / 2), u, v, W_ / 2, W_, t), frame_box(ps - u * (hw + W_ / 2), u, v, W_ / 2, W_, t),
           frame_box(ps + v * (hl + W_ / 2), u, v, hw, W_ / 2, t), frame_box(ps - v * (hl + W_ / 2), u, v, hw, W_ / 2, t)]
    e, _ = path.end()
    obs.append(sph([ps[0] + 0.2, Y0 + 0.05, Z0 + 0.02], 0.06))
    obs.append(end_wall(e, 0.12, 0.35))
    return ("A wall 0.64 m ahead (0.9 m each way) whose only opening is a slot 0.11 m wide and 0.32 m long, tilted "
            "35 deg from vertical, centred 0.33 m left of the start line; the goal is on the start line 0.6 m behind "
            "the wall, a ball between. Way: 0.33 m left, through, 0.33 m back right (four 63 deg arcs: the curved "
            "part, 1.55 m, is longer than the serpentine, so the flange must leave the lathe's axis)."), obs, [e], path, \
        {"expected": "reached (hard: the flange must leave the lathe axis)"}


@world
def sbend_walls():
    """(7) two walls 0.3 m apart, holes up-left then down-right; clutter right after the second hole"""
    o1 = np.array([0, 0.09, 0.06]); o2 = np.array([0, -0.07, -0.05]) - o1
    th1 = S_curve(0.3, np.linalg.norm(o1)); th2 = S_curve(0.3, np.linalg.norm(o2))
    path = Path([('S', 0.08), ('A', 0.3, th1, unit(o1)), ('A', 0.3, th1, -unit(o1)), ('S', 0.1),
                 ('A', 0.3, th2, unit(o2)), ('A', 0.3, th2, -unit(o2)), ('S', 0.22)])
    s1 = 0.08 + 2 * 0.3 * math.radians(th1) + 0.05; p1, _ = path.at(s1)
    e, _ = path.end(); s2 = path.L - 0.2; p2, _ = path.at(s2)
    obs = plate_hole([p1[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.4, 0.35, (p1[1] - Y0, p1[2] - Z0), (0.085, 0.085), 0.006)
    obs += plate_hole([p2[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.4, 0.35, (p2[1] - Y0, p2[2] - Z0), (0.085, 0.085), 0.006)
    # clutter just behind hole 2: a ball up-left, a cable right, a bar below
    obs.append(sph([p2[0] + 0.09, p2[1] + 0.085, p2[2] + 0.06], 0.035))
    obs.append(cyl([p2[0] + 0.13, p2[1] - 0.085, Z0 - 0.35], [p2[0] + 0.13, p2[1] - 0.085, Z0 + 0.35], 0.01))
    obs.append(cyl([p2[0] + 0.16, Y0 - 0.4, p2[2] - 0.085], [p2[0] + 0.16, Y0 + 0.4, p2[2] - 0.085], 0.015))
    obs.append(end_wall(e, 0.1, 0.35))
    return ("Two walls 0.3 m apart: the first with a 0.17 m hole 0.108 m up-left of the start line, the second with "
            "one 0.086 m down-right of it (an S-bend of 0.18 m between them); behind the second hole a ball, a cable "
            "and a bar 55-70 mm from the way. Goal 0.2 m past the second wall."), obs, [e], path, {"expected": "reached"}


@world
def dense_field():
    """(8) ~280 small spheres and rods, one winding corridor (>= 120 mm wide round the tip path)"""
    path = Path([('S', 0.1), ('A', 0.3, 40, unit([0, 1, 0.4])), ('A', 0.3, 80, unit([0, -1, -0.4])), ('A', 0.3, 40, unit([0, 1, 0.4])), ('S', 0.25)])
    rng = np.random.default_rng(2037)
    TP = path.P[::2]
    # the body's places along the path: capsule axis samples for every s
    BP = []
    for s in np.arange(0.0, path.L + 1e-9, 0.02):
        J, _ = path.joints(s); BP.append(np.vstack([seg(J[k], J[k + 1], 0.01) for k in range(6)]))
    BP = np.unique(np.round(np.vstack(BP), 3), axis=0)
    from scipy.spatial import cKDTree
    tT, tB = cKDTree(TP), cKDTree(BP)
    lo = np.array([X0 + 0.14, Y0 - 0.3, Z0 - 0.28]); hi = np.array([X0 + 1.08, Y0 + 0.42, Z0 + 0.32])
    obs = []; ns = nc = 0; tries = 0
    while (ns < 220 or nc < 60) and tries < 200000:
        tries += 1
        if ns < 220:
            c = lo + rng.random(3) * (hi - lo); r = 0.012 + 0.018 * rng.random()
            o = sph(c, r)
            pts = c[None]
        else:
            c = lo + rng.random(3) * (hi - lo); dvec = unit(rng.normal(size=3)); L = 0.08 + 0.2 * rng.random(); r = 0.006 + 0.008 * rng.random()
            o = cyl(c - dvec * L / 2, c + dvec * L / 2, r); pts = seg(c - dvec * L / 2, c + dvec * L / 2, 0.003)
        # quick reject by distance of the axis samples, exact check after
        if tT.query(pts)[0].min() - r < 0.075 or tB.query(pts)[0].min() - r < 0.05: continue
        if float(sdf(o, TP).min()) < 0.062 or float(sdf(o, BP).min()) < 0.025 + 0.012: continue
        obs.append(o)
        if o['type'] == 'sphere': ns += 1
        else: nc += 1
    e, _ = path.end()
    obs.append(end_wall(e, 0.12, 0.35))
    return (f"A field of {ns} balls (r 12-30 mm) and {nc} rods (r 6-14 mm, 0.08-0.28 m, random directions) filling "
            "0.14-1.08 m ahead, 0.72 m wide, 0.6 m high, except a corridor kept round one winding way (40 deg "
            "left-up, 80 deg right-down, 40 deg left-up; the tip path >= 62 mm from everything, the body's capsules "
            ">= 37 mm). Goal 0.12 m before an end wall."), obs, [e], path, {"expected": "reached"}


@world
def goal_behind():
    """(9) goal behind the start: a 160 deg left U-turn round a column, clutter round the turn"""
    path = Path([('S', 0.1), ('A', 0.3, 160, LEFT), ('S', 0.3)])
    e, h = path.end()
    cc = np.array([X0 + 0.1, Y0 + 0.3, Z0])
    obs = [cyl(cc - [0, 0, 0.4], cc + [0, 0, 0.4], 0.19),                                  # column inside the turn
           box([X0 + 0.1 + 0.3 + 0.115, Y0 + 0.3, Z0], [0.01, 0.45, 0.35]),                 # wall outside the apex
           box([X0 + 0.1, Y0 + 0.42, Z0 + 0.11], [0.35, 0.33, 0.006]),                      # ceiling over the turn
           sph([X0 + 0.33, Y0 - 0.1, Z0 - 0.02], 0.05),                                      # ball right of the entry
           cyl([e[0] + 0.05, e[1] + 0.1, Z0 - 0.4], [e[0] + 0.05, e[1] + 0.1, Z0 + 0.4], 0.025),   # post beside the goal
           sph(e + h * 0.17, 0.06)]                                                          # ball beyond the goal
    return ("The goal is behind the start tip (0.08 m back in x, 0.67 m to the left): a 160 deg left U-turn (radius "
            "0.3 m) round a column (r 0.19 m) filling the inside of the turn, under a ceiling 0.11 m up, a wall 0.115 m "
            "outside the apex; a ball right of the entry, a post beside the goal, a ball beyond it."), obs, [e], path, \
        {"expected": "reached"}


@world
def mesh_ico():
    """(10) a 5120-triangle icosphere (r 0.2 m, as a unit sphere scaled 0.2) on the line; round it on the left"""
    m = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    write_mesh('ico.stl', m.vertices, m.faces)
    th = S_curve(0.3, 0.16)
    path = Path([('S', 0.05), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.5)])
    cs = np.array([X0 + 0.7, Y0 - 0.1, Z0])
    obs = [{"type": "mesh", "path": "parts/ico.stl", "position": [float(v) for v in cs], "rpy": [0.3, 0.2, 0.1], "scale": 0.2}]
    e, _ = path.end()
    obs.append(box([cs[0], Y0 + 0.16 + 0.115, Z0], [0.3, 0.01, 0.3]))     # wall on the left of the way past it
    obs.append(end_wall(e, 0.12, 0.35))
    return ("A faceted sphere mesh (icosphere, 5120 triangles, unit radius scaled 0.2, rotated) centred 0.7 m ahead, "
            "0.1 m right of the start line; the way bends 0.16 m left and runs past it with the body about 30 mm "
            "from its facets, a wall 0.09 m on the other side. Goal 0.12 m before an end wall."), obs, [e], path, {"expected": "reached"}


@world
def mesh_perf():
    """(10) a perforated sheet (zero thickness, ~6000 triangles): 45 mm holes everywhere, one 150 mm hole off the line"""
    cell = 0.015; n = 56; half = cell * n / 2
    off = np.array([0, 0.09, -0.09]); th = S_curve(0.3, np.linalg.norm(off)); d = unit(off)
    path = Path([('S', 0.05), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.2), ('A', 0.3, th, -d), ('A', 0.3, th, d), ('S', 0.15)])
    xp = X0 + 0.05 + 2 * 0.3 * math.sin(math.radians(th)) + 0.1
    # local sheet coordinates (u = y - Y0, v = z - Z0), cells [i*cell - half, (i+1)*cell - half)
    hc = (0.09, -0.09); V = []; F = []; vid = {}
    def vert(i, j):
        if (i, j) not in vid: vid[(i, j)] = len(V); V.append([0.0, i * cell - half, j * cell - half])
        return vid[(i, j)]
    nb = 0
    for i in range(n):
        for j in range(n):
            uc, vc = (i + 0.5) * cell - half, (j + 0.5) * cell - half
            small = (i % 6 in (2, 3, 4)) and (j % 6 in (2, 3, 4))
            big = abs(uc - hc[0]) < 0.075 and abs(vc - hc[1]) < 0.075
            if small or big: continue
            a, b, c, dd = vert(i, j), vert(i + 1, j), vert(i + 1, j + 1), vert(i, j + 1)
            F += [[a, b, c], [a, c, dd]]
    write_mesh('perf.stl', V, F)
    obs = [{"type": "mesh", "path": "parts/perf.stl", "position": [float(xp), float(Y0), float(Z0)], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    e, _ = path.end()
    obs.append(sph([xp + 0.2, Y0 + 0.2, Z0 + 0.03], 0.05))
    obs.append(end_wall(e, 0.12, 0.4))
    return (f"A perforated sheet (mesh, zero thickness, {len(F)} triangles, 0.84 m square) 0.56 m ahead: 45 mm square "
            "holes on a 90 mm pitch (too small for the 50 mm body) and one 150 mm square hole 0.127 m off the start "
            "line (left-down); behind the sheet the way bends back to the start line, a ball beside it. Goal on the start line 0.56 m beyond the sheet."), obs, [e], path, {"expected": "reached"}



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
    for k in ('cage_surface_max_distance_to_bar',):
        if k in opt: ck[k] = opt.pop(k)
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    ref_pts = path.P[::25].tolist() + [path.P[-1].tolist()]
    tol = opt.get('tolerance', 0.02)
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h5-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": tol} for g in goals],
         "time_limit": opt.get('time_limit', 75.0)}
    if opt.get('retract'): w['retract'] = True
    w['extra'] = {"reference_path": {"commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [float(x) for x in c[3]]] for c in path.cmds],
                                     "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm"
                                             + ("; for an unreachable goal only the approach" if opt.get('unreachable') else ""),
                                     "start_tip_world": [round(float(v), 6) for v in path.start],
                                     "points": [[round(float(v), 4) for v in p] for p in ref_pts]},
                  "checks": ck, "expected": opt.get('expected'),
                  "generator": "/work/s37/hard5/make.py (session 37 helper)"}
    folder = os.path.join(OUT, opt.get('folder', '.'))
    os.makedirs(folder, exist_ok=True)
    json.dump(rnd(w), open(os.path.join(folder, name + '.json'), 'w'), indent=1)
    return ck, opt


if __name__ == '__main__':
    names = sys.argv[1:] or list(W)
    for n in names:
        ck, opt = build(n)
        tip_need = 0.0 if opt.get('sliver') else 0.05
        body_need = 0.003 if opt.get('sliver') else 0.025
        ok = (ck['tip_clearance'] >= tip_need and ck['body_clearance'] >= body_need and ck['arm_clearance'] >= 0.03 and ck['lathe_travel'] <= 2.0
              and (opt.get('unreachable') or max(ck['goal_on_path']) < 0.003 or opt.get('sliver') or opt.get('offpath')))
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
