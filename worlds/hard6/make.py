"""Own generator, held-out batch 6 (session 40 helper, outside user). Does not use navstack.generate.
Adapted from worlds/hard5/make.py (itself from hard4; its Path, primitives, exact distances and checks kept). Each world is built in
the canonical frame (the default base, start tip P0 = (1.8085, 0.1079, 1.1668) heading +x) around a reference tip
path (straight legs and arcs of radius >= 0.28 m), checked with exact distances (primitives: exact signed
distance; meshes: exact point-triangle distance, geom.MeshDist). Worlds whose goal cannot be reached carry only
the approach as their path ("unreachable" in extra.reference_path.note).
Moving obstacles are checked with an assumed timing: the tip at arc length s at t(s) = T0 + s / V
(T0 = 1 s, V = 0.055 m/s, hard3's field trials), the body left at s at that same time.
Usage: python make.py [name ...]   (writes <this folder>/<name>.json and parts/*.stl)"""
import importlib.util, json, math, sys, os
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation as Rot

HERE = os.path.dirname(os.path.abspath(__file__))
# hard5's generator as a library: its path, primitives, exact distances, checks and mesh writer (its lines 17-274,
# which this file held a byte-identical copy of); its worlds stay in its own registry, and its OUT is pointed here so
# that mesh_of and write_mesh read and write this folder's parts/
_spec = importlib.util.spec_from_file_location("hard5_make", os.path.join(HERE, '..', 'hard5', 'make.py'))
h5 = sys.modules['hard5_make'] = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(h5)
h5.OUT = OUT = HERE
from hard5_make import (P0, X0, Y0, Z0, Q0, BASE, UP, DOWN, LEFT, RIGHT, EX, unit, Path, S_curve, R_of,  # noqa: E402
                        box, cyl, sph, frame_box, plate_hole, sdf, seg, check, sweep_tube, ring_faces, write_mesh,
                        end_wall)

W = {}
def world(fn): W[fn.__name__] = fn; return fn


# ---- kind 3: order ----
def duct(x0, x1, hw, t=0.006, yc=None, zc=None):
    yc = Y0 if yc is None else yc; zc = Z0 if zc is None else zc; xm = (x0 + x1) / 2; hx = (x1 - x0) / 2
    return [box([xm, yc + hw + t, zc], [hx, t, hw + 2 * t]), box([xm, yc - hw - t, zc], [hx, t, hw + 2 * t]),
            box([xm, yc, zc + hw + t], [hx, hw + 2 * t, t]), box([xm, yc, zc - hw - t], [hx, hw + 2 * t, t])]


# ======== batch 6 worlds (session 40) ========
def wallx(x, y0, y1, z0, z1, t=0.006):
    """plate in the plane x = x, spanning y0..y1, z0..z1"""
    return box([x, (y0 + y1) / 2, (z0 + z1) / 2], [t, (y1 - y0) / 2, (z1 - z0) / 2])

def wally(y, x0, x1, z0, z1, t=0.006):
    return box([(x0 + x1) / 2, y, (z0 + z1) / 2], [(x1 - x0) / 2, t, (z1 - z0) / 2])

def wallz(z, x0, x1, y0, y1, t=0.006):
    return box([(x0 + x1) / 2, (y0 + y1) / 2, z], [(x1 - x0) / 2, (y1 - y0) / 2, t])


def scatter(path, region, n_sph, n_cyl, n_box, seed, tip_need=0.062, body_need=0.037, rs=(0.012, 0.03), near=None):
    """random clutter in region (lo, hi) kept tip_need from the tip path and body_need from the body's axes"""
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(seed); TP = path.P[::2]; BP = []
    for s in np.arange(0.0, path.L + 1e-9, 0.02):
        J, _ = path.joints(s); BP.append(np.vstack([seg(J[k], J[k + 1], 0.01) for k in range(6)]))
    BP = np.unique(np.round(np.vstack(BP), 3), axis=0); tT, tB = cKDTree(TP), cKDTree(BP)
    lo, hi = (np.array(a, float) for a in region); obs = []; cnt = [0, 0, 0]; tries = 0
    while (cnt[0] < n_sph or cnt[1] < n_cyl or cnt[2] < n_box) and tries < 100000:
        tries += 1; c = lo + rng.random(3) * (hi - lo)
        if near is not None and np.linalg.norm(c - near[0]) > near[1]: continue
        if cnt[0] < n_sph:
            r = rs[0] + (rs[1] - rs[0]) * rng.random(); o = sph(c, r); pts = c[None]; R = r; k = 0
        elif cnt[1] < n_cyl:
            dv = unit(rng.normal(size=3)); L = 0.08 + 0.15 * rng.random(); r = 0.006 + 0.008 * rng.random()
            o = cyl(c - dv * L / 2, c + dv * L / 2, r); pts = seg(c - dv * L / 2, c + dv * L / 2, 0.003); R = r; k = 1
        else:
            h = 0.025 + 0.045 * rng.random(3); o = box(c, h, rng.uniform(-math.pi, math.pi, 3)); pts = c[None]; R = float(np.linalg.norm(h)); k = 2
        if tT.query(pts)[0].min() - R < tip_need - 0.0 and k != 2: continue
        if float(sdf(o, TP).min()) < tip_need or float(sdf(o, BP).min()) < 0.025 + body_need: continue
        obs.append(o); cnt[k] += 1
    return obs, cnt


@world
def turn_in_chamber():
    """(a) hole facing the robot, but the goal is in a side bay: a 90 deg left turn after entering"""
    path = Path([('S', 0.45), ('A', 0.3, 90, LEFT), ('S', 0.15)])
    e, _ = path.end(); xw = X0 + 0.33; zl, zh = Z0 - 0.13, Z0 + 0.13
    obs = plate_hole([xw, Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.35, (0.0, 0.0), (0.085, 0.085), 0.006)
    xb = X0 + 0.75 + 0.13                                  # back wall of the chamber
    obs += [wally(Y0 - 0.13, xw, xb, zl, zh), wallx(xb, Y0 - 0.13, Y0 + 0.62, zl, zh),
            wally(Y0 + 0.12, xw, X0 + 0.57, zl, zh), wallx(X0 + 0.57, Y0 + 0.12, Y0 + 0.62, zl, zh),
            wally(Y0 + 0.62, X0 + 0.57, xb, zl, zh),
            wallz(zh + 0.006, xw, xb, Y0 - 0.13, Y0 + 0.62), wallz(zl - 0.006, xw, xb, Y0 - 0.13, Y0 + 0.62),
            sph([X0 + 0.66, Y0 - 0.07, Z0 + 0.06], 0.035)]
    return ("A wall 0.33 m ahead with a 0.17 m hole on the start line opens into a closed chamber (0.26 m high); the "
            "chamber's far part is a dead end, the goal is in a bay on its left: a 90 deg left turn (radius 0.3 m) after "
            "entering, past the inner corner. A ball in the dead end's corner. Goal 0.12 m from the bay's end wall."), \
        obs, [e], path, {"expected": "reached"}


@world
def two_stage():
    """(b) hole 1 on the line, a 0.2 m closed chamber, hole 2 offset 0.13 m right-down"""
    off = np.array([0, -0.10, -0.085]); d = unit(off); th = S_curve(0.3, np.linalg.norm(off))
    path = Path([('S', 0.2), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.3)])
    arc = 0.3 * math.radians(th)
    p1, _ = path.at(0.2 + 0.25 * arc); p2, _ = path.at(0.2 + 2 * arc + 0.03)
    obs = plate_hole([p1[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (p1[1] - Y0, p1[2] - Z0), (0.085, 0.085), 0.006)
    obs += plate_hole([p2[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (p2[1] - Y0, p2[2] - Z0), (0.085, 0.085), 0.006)
    x0, x1 = p1[0], p2[0]
    obs += [wally(Y0 + 0.2, x0, x1, Z0 - 0.25, Z0 + 0.2), wally(Y0 - 0.27, x0, x1, Z0 - 0.25, Z0 + 0.2),
            wallz(Z0 + 0.2, x0, x1, Y0 - 0.27, Y0 + 0.2), wallz(Z0 - 0.25, x0, x1, Y0 - 0.27, Y0 + 0.2)]
    e, _ = path.end(); obs.append(end_wall(e, 0.12, 0.35))
    return (f"Two walls {x1 - x0:.2f} m apart, closed round between them (a chamber 0.47 x 0.45 m): hole 1 (0.17 m) on "
            f"the start line (offset {np.round((p1 - P0)[1:], 3).tolist()} m), hole 2 offset {np.round((p2 - P0)[1:], 3).tolist()} "
            "m (right-down) from it: an S-bend of 0.13 m inside the short chamber. Goal 0.27 m past hole 2."), \
        obs, [e], path, {"expected": "reached"}


@world
def wire_gap():
    """(c) a 0.16 m x 0.36 m slot, its upper two thirds crossed by 3 mm wires 38 mm apart; the way is low"""
    th = S_curve(0.3, 0.12)
    path = Path([('S', 0.05), ('A', 0.3, th, DOWN), ('A', 0.3, th, UP), ('S', 0.35)])
    xs = X0 + 0.05 + 2 * 0.3 * math.sin(math.radians(th)) + 0.08
    obs = plate_hole([xs, Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.6, 0.5, (0.0, 0.0), (0.08, 0.18), 0.006)
    zs = np.arange(Z0 - 0.055, Z0 + 0.18, 0.041)
    obs += [cyl([xs, Y0 - 0.12, z], [xs, Y0 + 0.12, z], 0.0015) for z in zs]
    e, _ = path.end(); obs.append(end_wall(e, 0.12, 0.4))
    return (f"A wall {xs - X0:.2f} m ahead with a slot 0.16 m wide and 0.36 m tall centred on the start line; {len(zs)} "
            "horizontal wires (r 1.5 mm) cross it from 55 mm below the line upwards, 41 mm apart (too close for the 50 mm "
            "body); only the slot's lowest 0.125 m is clear. The way dips 0.12 m and stays low; goal 0.12 m before an end wall."), \
        obs, [e], path, {"expected": "reached"}


@world
def rot_grid():
    """(d) a field of boxes rotated at odd angles (random rpy), one winding way through"""
    path = Path([('S', 0.1), ('A', 0.3, 35, unit([0, -1, 0.5])), ('A', 0.3, 70, unit([0, 1, -0.5])), ('A', 0.3, 35, unit([0, -1, 0.5])), ('S', 0.25)])
    obs, cnt = scatter(path, ([X0 + 0.15, Y0 - 0.4, Z0 - 0.3], [X0 + 1.05, Y0 + 0.3, Z0 + 0.35]), 0, 0, 70, 4061,
                       tip_need=0.065, body_need=0.037)
    e, _ = path.end(); obs.append(end_wall(e, 0.12, 0.4))
    return (f"{cnt[2]} boxes (half sizes 25-70 mm, each rotated about all three axes at random angles) filling 0.15-1.05 m "
            "ahead, except round one winding way (35 deg right-up, 70 deg left-down, 35 deg right-up). Goal 0.12 m "
            "before an end wall."), obs, [e], path, {"expected": "reached"}


@world
def s_tube():
    """(e) an open zero-thickness round tube (mesh, inner r 0.085 m) with two opposite 50 deg bends, in 3D"""
    d = unit([0, 1, 0.6])
    path = Path([('S', 0.45), ('A', 0.4, 50, d), ('S', 0.05), ('A', 0.4, 50, -d), ('S', 0.2)])
    k0 = int(np.searchsorted(path.s, 0.25)); C = path.P[k0::4]; Tn = path.H[k0::4]
    Vt, rings = sweep_tube(C, Tn, 0.085, 36); F = []
    for a in range(len(rings) - 1): F += ring_faces(rings[a], rings[a + 1])
    write_mesh('stube.stl', Vt, F)
    obs = [{"type": "mesh", "path": "parts/stube.stl", "position": [0.0, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    e, h = path.end(); gl, _ = path.at(path.L - 0.06)
    obs.append(sph(e + h * 0.1, 0.05))
    return ("An open round tube (mesh, zero thickness, inner radius 85 mm, 36 facets round) starting 0.25 m ahead on "
            f"the start line, then bending 50 deg left-up and 50 deg back (radius 0.4 m): its exit is offset "
            f"{np.round((e - P0)[1:], 3).tolist()} m. Goal on its axis 0.06 m before the exit; a ball 0.16 m beyond the goal."), \
        obs, [gl], path, {"expected": "reached", "offpath": True}


@world
def edge_fin():
    """(f) sparse lattice; a 4 mm flat bar edge-on exactly across the straight line to the goal"""
    th = S_curve(0.3, 0.1)
    path = Path([('S', 0.05), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('S', 0.2), ('A', 0.3, th, RIGHT), ('A', 0.3, th, LEFT), ('S', 0.12)])
    e, _ = path.end(); xf = X0 + 0.05 + 2 * 0.3 * math.sin(math.radians(th)) + 0.03
    obs = [box([xf + 0.09, Y0, Z0], [0.09, 0.002, 0.35])]          # the fin: in the x-z plane, edge towards the robot
    for yy in (-0.28, 0.0, 0.28):
        if yy != 0.0: obs.append(cyl([xf + 0.09, Y0 + yy, Z0 - 0.4], [xf + 0.09, Y0 + yy, Z0 + 0.4], 0.015))
    for zz in (-0.2, 0.2):
        obs.append(cyl([xf + 0.09, Y0 - 0.4, Z0 + zz], [xf + 0.09, Y0 + 0.4, Z0 + zz], 0.015))
    obs.append(cyl([xf - 0.25, Y0 - 0.4, Z0 - 0.2], [xf - 0.25, Y0 + 0.4, Z0 - 0.2], 0.015))
    obs.append(cyl([xf + 0.45, Y0 - 0.4, Z0 + 0.2], [xf + 0.45, Y0 + 0.4, Z0 + 0.2], 0.015))
    obs.append(end_wall(e, 0.12, 0.4))
    return (f"A sparse lattice of round members (r 15 mm) about {xf - X0 + 0.09:.2f} m ahead, plus a flat bar 4 mm thick, "
            "0.18 m deep and 0.7 m tall lying in the vertical plane of the start line, its 4 mm edge facing the robot: "
            "the straight line to the goal runs into that edge and along the bar. Way: 0.1 m left past it and back; "
            "the goal on the start line 0.12 m before an end wall."), obs, [e], path, {"expected": "reached"}


@world
def goal_clutter():
    """(g) clutter right round the goal: 22 balls / rods 60-150 mm from it, one way in"""
    d = unit([0, 1, 1]); th = S_curve(0.3, 0.1)
    path = Path([('S', 0.15), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.35)])
    e, _ = path.end()
    obs, cnt = scatter(path, (e - 0.16, e + 0.16), 14, 8, 0, 5071, tip_need=0.058, body_need=0.035, rs=(0.012, 0.025), near=(e, 0.16))
    gc = [float(sdf(o, e[None])[0]) for o in obs]
    obs.append(end_wall(e, 0.13, 0.4))
    return (f"A ball cluster round the goal: {cnt[0]} balls (r 12-25 mm) and {cnt[1]} rods (r 6-14 mm) within 0.16 m of it, "
            f"the nearest {min(gc) * 1e3:.0f} mm from the goal point, kept clear only round one way in (0.1 m up-left "
            "S-bend, then straight); an end wall 0.13 m behind."), obs, [e], path, {"expected": "reached"}


@world
def corner_late():
    """(h) round the end of a wall; behind its corner a post and a ball the rays cannot see before the corner"""
    path = Path([('S', 0.1), ('A', 0.3, 55, LEFT), ('S', 0.06), ('A', 0.3, 110, RIGHT), ('S', 0.14)])
    e, h = path.end()
    k = int(np.argmax(path.P[:, 1])); apex = path.P[k]
    xw = apex[0]; obs = [wallx(xw, Y0 - 0.6, apex[1] - 0.08, Z0 - 0.4, Z0 + 0.4, 0.008)]
    # behind the corner: a post just past it on the right of the way, a ball beside the way down
    sp = path.s[k] + 0.2; pp, hp = path.at(sp); nrm = unit(np.cross(hp, [0, 0, 1]))
    obs.append(cyl(pp + nrm * 0.095 - [0, 0, 0.4], pp + nrm * 0.095 + [0, 0, 0.4], 0.02))
    sb = path.L - 0.18; pb, hb = path.at(sb); nb = unit(np.cross(hb, [0, 0, 1]))
    obs.append(sph(pb - nb * 0.11, 0.04))
    obs.append(wallz(Z0 + 0.16, xw, xw + 0.45, apex[1] - 0.5, apex[1] + 0.1))
    obs.append(sph(e + h * 0.15, 0.05))
    return (f"A wall {xw - X0:.2f} m ahead blocks everything right of {apex[1] - 0.08 - Y0:.2f} m left of the start line; "
            "the goal is behind it, the way goes round its end (55 deg left, then 110 deg right). Hidden behind the wall "
            "until the tip rounds the corner: a post 95 mm to the right of the way 0.2 m after it, a ball beside the way "
            "down, a low ceiling over the space behind the wall, a ball beyond the goal."), obs, [e], path, {"expected": "reached"}


@world
def cavity_mouth():
    """(i) goal 40 mm inside the mouth of a box cavity whose mouth faces 50 deg off the approach"""
    path = Path([('S', 0.12), ('A', 0.3, 50, LEFT), ('S', 0.1), ('A', 0.3, 100, RIGHT), ('S', 0.18)])
    e, h = path.end(); mouth = e - h * 0.04
    u = unit(np.cross([0, 0, 1], h)); v = np.array([0, 0, 1.0]); a = 0.1; dep = 0.22; t = 0.006
    cc = mouth + h * dep / 2
    obs = [frame_box(cc + u * (a + t), h, v, dep / 2, a + 2 * t, t), frame_box(cc - u * (a + t), h, v, dep / 2, a + 2 * t, t),
           frame_box(cc + v * (a + t), h, u, dep / 2, a + 2 * t, t), frame_box(cc - v * (a + t), h, u, dep / 2, a + 2 * t, t),
           frame_box(mouth + h * (dep + t), u, v, a + 2 * t, a + 2 * t, t)]
    obs.append(cyl([X0 + 0.45, Y0 - 0.02, Z0 - 0.4], [X0 + 0.45, Y0 - 0.02, Z0 + 0.4], 0.05))
    obs.append(sph(mouth - u * 0.2 + h * 0.05, 0.05))
    return ("A square box cavity (inner 0.2 x 0.2 m, 0.22 m deep) whose open mouth faces back-left, 50 deg off the start "
            f"heading, centred {np.round((mouth - P0), 3).tolist()} m from the start tip; the goal is on its axis 40 mm "
            "inside the mouth. A pipe (r 50 mm) on the start line; a ball beside the mouth. Way: 50 deg left, then 100 deg "
            "right into the mouth."), obs, [e], path, {"expected": "reached"}


@world
def closing_gap():
    """(j, movers) two doors slide towards each other from t = 2 to 24 s: the gap shrinks from 0.40 to 0.136 m"""
    path = Path([('S', 0.85)])
    xd = X0 + 0.5; e, _ = path.end(); v = 0.006
    obs = [box([xd, Y0 + 0.2 + 0.6, Z0], [0.006, 0.6, 0.5], motion={"type": "linear", "velocity": [0, -v, 0], "start": 2.0, "stop": 24.0}),
           box([xd, Y0 - 0.2 - 0.6, Z0], [0.006, 0.6, 0.5], motion={"type": "linear", "velocity": [0, v, 0], "start": 2.0, "stop": 24.0}),
           wallz(Z0 + 0.2, xd - 0.02, xd + 0.02, Y0 - 0.8, Y0 + 0.8), wallz(Z0 - 0.2, xd - 0.02, xd + 0.02, Y0 - 0.8, Y0 + 0.8),
           sph([X0 + 0.25, Y0 + 0.12, Z0 + 0.05], 0.04), end_wall(e, 0.12, 0.4)]
    return ("A doorway 0.5 m ahead (0.39 m high between bars above and below; the doors 1.0 m tall, 1.2 m wide): two doors slide towards each other at 6 mm/s "
            "from t = 2 s to 24 s, the gap shrinking from 0.40 m to 0.136 m round the start line (43 mm clear each side "
            "of the 50 mm body at the end). The body stays in the doorway to the end. Goal 0.35 m past it, a ball on the "
            "way in."), obs, [e], path, {"expected": "reached (the doors stop 43 mm short of the body)"}


@world
def gap_shuts():
    """(j', unreachable) the same kind of doorway shuts completely at t = 3.4 s, before the tip can reach it"""
    path = Path([('S', 0.2)])
    xd = X0 + 0.35; g = P0 + EX * 0.7; v = 0.06
    obs = [box([xd, Y0 + 0.2 + 0.45, Z0], [0.01, 0.45, 0.5], motion={"type": "linear", "velocity": [0, -v, 0], "start": 0.5, "stop": 4.0}),
           box([xd + 0.025, Y0 - 0.2 - 0.45, Z0], [0.01, 0.45, 0.5], motion={"type": "linear", "velocity": [0, v, 0], "start": 0.5, "stop": 4.0}),
           box([xd + 0.0125, Y0, Z0 + 0.5 + 0.05], [0.03, 1.1, 0.05]), box([xd + 0.0125, Y0, Z0 - 0.5 - 0.05], [0.03, 1.1, 0.05])]
    # a closed room behind the doorway (sides 5 mm behind the second door, back, top, bottom)
    x0r, x1r = xd + 0.04, xd + 0.6
    obs += [wally(Y0 + 0.6, x0r, x1r, Z0 - 0.6, Z0 + 0.6, 0.01), wally(Y0 - 0.6, x0r, x1r, Z0 - 0.6, Z0 + 0.6, 0.01),
            wallx(x1r, Y0 - 0.61, Y0 + 0.61, Z0 - 0.6, Z0 + 0.6, 0.01),
            wallz(Z0 + 0.6, xd, x1r, Y0 - 0.61, Y0 + 0.61, 0.01), wallz(Z0 - 0.6, xd, x1r, Y0 - 0.61, Y0 + 0.61, 0.01)]
    return ("Two doors 0.35 m ahead (1.0 m tall, each 0.9 m wide, in frames above and below) slide shut at 60 mm/s from "
            "t = 0.5 to 4.0 s: the 0.40 m gap is closed at 3.8 s (the doors then overlap by 20 mm, one 25 mm behind the other), "
            "long before the tip (about 0.055 m/s) gets there; behind them a closed room (1.2 x 1.2 x 0.56 m) whose only opening was the doorway; the goal is 0.35 m behind the doors. Unreachable after 3.8 s."), \
        obs, [g], path, {"unreachable": True, "expected": "not a success, 0 goals"}


@world
def retract_bend():
    """(k, retract) 75 deg right round a wall's end into clutter, then back out along the way in"""
    path = Path([('S', 0.15), ('A', 0.3, 75, RIGHT), ('S', 0.3)])
    e, h = path.end(); xw = X0 + 0.66
    obs = [wallx(xw, Y0 - 0.8, Y0 + 0.5, Z0 - 0.4, Z0 + 0.4, 0.008)]
    cl, cnt = scatter(Path([('S', 0.15), ('A', 0.3, 75, RIGHT), ('S', 0.3)]),
                      ([X0 + 0.3, e[1] - 0.05, Z0 - 0.2], [xw - 0.02, Y0 - 0.05, Z0 + 0.2]), 6, 5, 0, 6091,
                      tip_need=0.065, body_need=0.04)
    obs += cl + [wally(Y0 + 0.16, X0 + 0.05, xw, Z0 - 0.3, Z0 + 0.3), sph(e + h * 0.14, 0.05)]
    return (f"retract: true. A wall 0.6 m ahead and one on the left; the way turns 75 deg right (radius 0.3 m) into a "
            f"space with {cnt[0]} balls and {cnt[1]} rods beside the way (>= 65 mm from the tip path), the goal 0.3 m "
            "after the bend, a ball beyond it; then back out the same way to within 20 mm of the start."), \
        obs, [e], path, {"retract": True, "expected": "reached, retracted"}
@world
def oblique_entry():
    """(a') a window in a wall yawed 70 deg (it faces away from the approach): 70 deg left turn to pass through"""
    path = Path([('S', 0.1), ('A', 0.3, 70, LEFT), ('S', 0.42)])
    sw = 0.1 + 0.3 * math.radians(70) + 0.14; pw, h = path.at(sw); u = unit(np.cross([0, 0, 1], h)); v = np.array([0, 0, 1.0])
    obs = plate_hole(pw, u, v, h, 0.7, 0.45, (0.0, 0.03), (0.085, 0.09), 0.006)
    e, he = path.end()
    obs += [sph(pw + h * 0.16 + u * 0.12, 0.045), cyl(pw + h * 0.2 - u * 0.11 - v * 0.4, pw + h * 0.2 - u * 0.11 + v * 0.4, 0.02),
            sph(e + he * 0.15, 0.05), cyl([X0 + 0.5, Y0 - 0.4, Z0 - 0.12], [X0 + 0.5, Y0 + 0.1, Z0 - 0.12], 0.03)]
    return (f"A wall (1.4 x 0.9 m) yawed 70 deg from facing the robot, its window (0.17 x 0.18 m) "
            f"{np.round((pw - P0), 3).tolist()} m from the start tip: the way turns 70 deg left (radius 0.3 m) to pass "
            "through square to it; behind, a ball and a post beside the way, the goal 0.28 m past the window, a ball beyond it. "
            "A pipe low on the right."), obs, [e], path, {"expected": "reached"}


@world
def closing_gap_fast():
    """(j, movers) as closing_gap, but the doors close from t = 2 to 8 s (22 mm/s): narrow before the tip is there"""
    path = Path([('S', 0.85)])
    xd = X0 + 0.5; e, _ = path.end(); v = 0.022
    obs = [box([xd, Y0 + 0.2 + 0.6, Z0], [0.006, 0.6, 0.5], motion={"type": "linear", "velocity": [0, -v, 0], "start": 2.0, "stop": 8.0}),
           box([xd, Y0 - 0.2 - 0.6, Z0], [0.006, 0.6, 0.5], motion={"type": "linear", "velocity": [0, v, 0], "start": 2.0, "stop": 8.0}),
           wallz(Z0 + 0.2, xd - 0.02, xd + 0.02, Y0 - 0.8, Y0 + 0.8), wallz(Z0 - 0.2, xd - 0.02, xd + 0.02, Y0 - 0.8, Y0 + 0.8),
           sph([X0 + 0.25, Y0 + 0.12, Z0 + 0.05], 0.04), end_wall(e, 0.12, 0.4)]
    return ("As closing_gap (doorway 0.5 m ahead, 0.39 m high between bars, doors 1.0 m tall and 1.2 m wide), but the "
            "doors slide together at 22 mm/s from t = 2 s to 8 s: the gap is 0.136 m (43 mm clear each side of the body) "
            "from 8 s on, before the tip (about 0.055 m/s) reaches the doorway at about 10 s; the map's early door points "
            "lie where the doors no longer are. Goal 0.35 m past it, a ball on the way in."), obs, [e], path, \
        {"expected": "reached", "folder": "b2"}


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
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h6-" + name.split('_')[0],
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
                  "generator": "/work/s40/hard6/make.py (session 40 helper)"}
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
