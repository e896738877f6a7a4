"""Own generator, held-out batch 8 (session 44 helper, outside user). Does not use navstack.generate.
hard5's generator (worlds/hard5/make.py) is imported as a library (importlib), as worlds/hard6/make.py and
worlds/hard7/make.py do: its Path (straight legs and arcs of radius >= 0.28 m from the start tip P0 heading +x),
primitives, exact signed distances (meshes: exact point-triangle distance), `check` (tip / serpentine body / arm
clearances along the reference path, lathe travel, flange off the lathe axis, movers with its assumed timing
t = 1 + s/0.055 s), `sweep_tube`, `transform_world` and its mesh writer; nothing of it is copied here. Its OUT is
pointed at this folder so that mesh_of and write_mesh read and write this folder's parts/.
Every world is built round its reference tip path in the canonical frame (far_site is then moved rigidly);
goals give only the destination.
Usage: python make.py [name ...]   (writes <this folder>/<name>.json and parts/*.stl; prints each world's checks)"""
import importlib.util, json, math, sys, os
import numpy as np
import warnings
warnings.filterwarnings('ignore', message='Gimbal lock')

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("hard5_make", os.path.join(HERE, '..', 'hard5', 'make.py'))
h5 = sys.modules['hard5_make'] = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(h5)
h5.OUT = OUT = HERE
from hard5_make import (P0, X0, Y0, Z0, Q0, BASE, UP, DOWN, LEFT, RIGHT, EX, unit, Path, S_curve,  # noqa: E402
                        box, cyl, sph, plate_hole, sdf, seg, check, write_mesh, sweep_tube, ring_faces,
                        transform_world, motion_offset, rnd)

W = {}
def world(fn): W[fn.__name__] = fn; return fn

EZ = np.array([0, 0, 1.0])
EY = np.array([0, 1.0, 0])


def plate(x0, x1, y0, y1, z0, z1):
    """axis-aligned box spanning the given ranges"""
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def s_path(legs, R=0.3):
    """commands for a chain of lateral offsets: legs = [(straight before, offset vector (y, z) or None), ...]"""
    cmds = []
    for L, off in legs:
        if L > 0: cmds.append(('S', L))
        if off is not None:
            o = np.array([0.0, off[0], off[1]]); d = unit(o); th = S_curve(R, float(np.linalg.norm(o)))
            cmds += [('A', R, th, tuple(d)), ('A', R, th, tuple(-d))]
    return cmds


# ---------------- 1. the site far from the origin (the corner of the allowed 1 km box) ----------------
FAR_T = (-997.9, 996.9, 998.2); FAR_YAW = math.radians(117.0)

@world
def far_site():
    """an S-bend through two offset holes, the whole world (base included) yawed and moved to the corner of the 1 km box"""
    path = Path(s_path([(0.08, (-0.11, 0.05)), (0.14, (0.2, -0.02)), (0.1, None)]))
    s1 = 0.08 + 2 * 0.3 * math.radians(S_curve(0.3, float(np.hypot(0.11, 0.05)))) + 0.06
    p1, _ = path.at(s1)
    s2 = s1 - 0.06 + 0.14 + 2 * 0.3 * math.radians(S_curve(0.3, float(np.hypot(0.2, 0.02)))) + 0.05
    p2, _ = path.at(s2); e, he = path.end()
    obs = plate_hole([p1[0], Y0, Z0], EY, EZ, EX, 0.5, 0.4, (p1[1] - Y0, p1[2] - Z0), (0.08, 0.08), 0.006)
    obs += plate_hole([p2[0], Y0, Z0], EY, EZ, EX, 0.5, 0.4, (p2[1] - Y0, p2[2] - Z0), (0.08, 0.08), 0.006)
    obs += [sph([p1[0] + 0.15, Y0 - 0.17, Z0 - 0.05], 0.04), cyl([p1[0] + 0.17, Y0 + 0.25, Z0 - 0.35], [p1[0] + 0.17, Y0 + 0.25, Z0 + 0.35], 0.02),
            plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.35, Y0 + 0.35, Z0 - 0.35, Z0 + 0.35)]
    opt = {"expected": "reached", "transform": (FAR_YAW, FAR_T)}
    return (f"Far from the origin: the whole world, robot base included, yawed 117 deg and moved by {list(FAR_T)} m, so "
            f"that it lies in the corner of the allowed box (navstack accepts coordinates within 1000 m of the origin; "
            f"survey coordinates such as UTM are refused): every obstacle within 0.2-3 m of x = -1000, y = +1000 and "
            f"z = +1000 m. The "
            f"structure itself is plain: a wall {p1[0] - X0:.2f} m ahead with a 0.16 m hole 0.11 m right and 0.05 m up, a "
            f"second wall {p2[0] - X0:.2f} m ahead with its hole 0.09 m left and 0.03 m up, a ball and a post between "
            f"them, the goal {e[0] - p2[0]:.2f} m behind the second wall on its hole's axis, an end wall behind it."), obs, [e], path, opt


# ---------------- 2. thin rods pointing straight at the tip ----------------
@world
def rod_endon():
    """five thin rods (r 5 mm) along the approach, their ends facing the tip; the goal just beyond their far ends"""
    path = Path(s_path([(0.05, (0.11, 0.0)), (0.3, (-0.11, 0.0)), (0.05, None)]))
    L1 = 0.05 + 2 * 0.3 * math.radians(S_curve(0.3, 0.11))
    e, he = path.end(); xa, xb = path.at(L1)[0][0] + 0.025, path.at(L1 + 0.3)[0][0] + 0.04
    offs = [(0.0, 0.0), (0.0, 0.065), (0.0, -0.065), (-0.065, 0.0), (-0.11, 0.06), (0.02, 0.13), (0.03, -0.14)]
    obs = [cyl([xa + 0.02 * k, Y0 + dy, Z0 + dz], [xb, Y0 + dy, Z0 + dz], 0.005) for k, (dy, dz) in enumerate(offs)]
    obs += [plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.35, Y0 + 0.35, Z0 - 0.35, Z0 + 0.35), sph(e + np.array([0.0, -0.12, 0.07]), 0.035)]
    return (f"Seven thin rods (r 5 mm), parallel to the start heading, their ends {xa - X0:.2f}-{xa - X0 + 0.12:.2f} m ahead "
            f"pointing straight at the tip (each shows a 10 mm disc to forward rays), running to {xb - X0:.2f} m; one on the "
            f"start line, others 65-140 mm round it. The goal on the start line {e[0] - xb:.2f} m beyond their far ends (the straight "
            "line runs along the middle rod's axis); an end wall behind it, a ball beside it. Way: S-bend 0.11 m left, "
            "0.3 m along the rods 0.11 m off the line, back."), obs, [e], path, {"expected": "reached"}


# ---------------- 3. a fast thin rod crossing where the body will be (late: a race; early: hold back) ----------------
def sweep_world(t0, wait):
    """a wall with an offset hole, the goal back near the line; a thin vertical rod (r 6 mm) that sweeps across the
    way 0.18 m ahead of the start tip at 1 m/s from t0: behind the tip, where the body is"""
    path = Path(s_path([(0.1, (-0.14, 0.05)), (0.1, (0.12, -0.04)), (0.06, None)]))
    s1 = 0.1 + 2 * 0.3 * math.radians(S_curve(0.3, float(np.hypot(0.14, 0.05)))) + 0.05; p1, _ = path.at(s1); e, he = path.end()
    obs = plate_hole([p1[0], Y0, Z0], EY, EZ, EX, 0.5, 0.4, (p1[1] - Y0, p1[2] - Z0), (0.08, 0.08), 0.006)
    xr = X0 + 0.18; y0, v = 0.9, 1.0; T = 2 * y0 / v
    obs.append(cyl([xr, Y0 + y0, Z0 - 0.4], [xr, Y0 + y0, Z0 + 0.4], 0.006,
                   motion={"type": "linear", "velocity": [0.0, -v, 0.0], "start": t0, "stop": t0 + T}))
    obs += [sph([p1[0] + 0.16, e[1] + 0.13, Z0 + 0.02], 0.04), plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.35, Y0 + 0.35, Z0 - 0.35, Z0 + 0.35)]
    desc = (f"A wall {p1[0] - X0:.2f} m ahead, its 0.16 m hole 0.14 m right and 0.05 m up; the goal {e[0] - p1[0]:.2f} m behind "
            f"it, 0.02 m right and 0.01 m up of the line. A thin vertical rod (r 6 mm, 0.8 m tall) waits 0.9 m left of the "
            f"line, 0.18 m ahead of the start tip, and at t = {t0} s sweeps across the way at 1 m/s to 0.9 m right of it "
            f"(stops at {t0 + T:.1f} s), crossing the line at {t0 + 0.9:.1f} s: it passes where the body (not the tip) is once "
            "the tip is past 0.18 m. ")
    return desc, obs, path, (t0, t0 + T)


@world
def late_sweep():
    """the rod sweeps at t = 29.5 s: the goal must be reached before (reference about 21 s)"""
    desc, obs, path, _ = sweep_world(29.5, None)
    e, _ = path.end()
    return desc + (f"So the goal must be reached before 29.5 s (the reference timing: {1 + path.L / 0.055:.1f} s); a robot "
                   "still on its way then is hit by it (and must be told so)."), obs, [e], path, \
        {"expected": "reached before 29.5 s, else collision", "late_mover": (None, None)}


@world
def early_sweep():
    """the rod sweeps at t = 9 s: a robot that goes on is hit in the body; one that holds the tip short of the rod's
    plane until 11 s and then goes is not (reference: goal at about 29 s)"""
    desc, obs, path, _ = sweep_world(9.0, 0.1)
    e, _ = path.end()
    return desc + ("At the usual pace the tip is past the rod's plane by about 5 s, so the rod hits the body at about "
                   "9.7 s unless the robot has held back; reachable by waiting (the reference: the tip holds 80 mm short "
                   f"of the rod's plane until 11 s, then goes on, goal at {11 + (path.L - 0.1) / 0.055:.1f} s). The rod is "
                   "out of the tip's forward view until it moves; a robot that is hit must be told so."), obs, [e], path, \
        {"expected": "collision unless the robot holds back (reachable by waiting)", "late_mover": (0.1, 11.0)}


# ---------------- 4. retraction after a zig-zag tour through clutter ----------------
@world
def retract_zigzag():
    """retract: true; three goals in a zig-zag (on the line, 0.15 m right, back on the line) beside thin posts,
    clutter 66-80 mm outside the way, then back out along the way in"""
    a = -0.15
    path = Path([('S', 0.1)] + s_path([(0.0, (a, 0.0)), (0.06, (-a, 0.0)), (0.04, None)]))
    L2 = 2 * 0.3 * math.radians(S_curve(0.3, abs(a)))
    sg = [0.07, 0.1 + L2 + 0.03, path.L]
    goals = [path.at(s)[0] for s in sg]; yc = Y0 + a / 2
    obs = []
    for g in goals:                                        # thin posts on the inner side of each goal
        yp = g[1] - 0.09 if g[1] > yc else g[1] + 0.09
        obs.append(cyl([g[0], yp, Z0 - 0.35], [g[0], yp, Z0 + 0.35], 0.015))
    rng = np.random.default_rng(8044)
    for s in np.arange(0.1, path.L + 0.1, 0.07):          # clutter outside the way, 66-80 mm from the tip path
        p, h = path.at(min(s, path.L)); p = p + h * max(0.0, s - path.L); n = unit(np.cross(EZ, h))
        side = 1 if (p[1] - yc) > 0 else -1
        d = 0.066 + 0.014 * rng.random(); r = 0.015 + 0.01 * rng.random(); zz = (rng.random() - 0.5) * 0.1
        c = p + n * side * (d + r) * np.sign(n[1] if abs(n[1]) > 0.3 else 1.0) + EZ * zz
        o = sph(c, r)
        if float(sdf(o, path.P[::5]).min()) >= 0.066 and min(float(sdf(q, c[None])[0]) for q in obs) > r + 0.02: obs.append(o)
    e, he = path.end()
    nb = len(obs) - 3
    obs += [plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.4, Y0 + 0.3, Z0 - 0.35, Z0 + 0.35),
            plate(X0 + 0.05, e[0] + 0.12, yc - 0.30, yc - 0.288, Z0 - 0.35, Z0 + 0.35),
            plate(X0 + 0.05, e[0] + 0.12, yc + 0.288, yc + 0.30, Z0 - 0.35, Z0 + 0.35)]
    return (f"retract: true. Three goals in a zig-zag: on the start line {goals[0][0] - X0:.2f} m ahead, 0.15 m right of it "
            f"{goals[1][0] - X0:.2f} m ahead, back on the line {goals[2][0] - X0:.2f} m ahead; beside each a thin post (r 15 mm) "
            f"90 mm to its inner side; {nb} balls (r 15-25 mm) 66-80 mm outside the way all along it; side walls 0.29 m "
            "either side, an end wall. After the third goal the robot must back out along its own path to within 20 mm "
            "of its start, past the same clutter."), obs, goals, path, {"expected": "reached 3/3, retracted", "retract": True}


# ---------------- 5. a corrugated duct of small triangles ----------------
@world
def bellows():
    """an open corrugated (flexible-hose) duct, zero-thickness mesh of ~1-2 mm x 9 mm triangles, bending 45 deg left-up"""
    d = tuple(unit([0, 1, 1])); cm = [('S', 0.22), ('A', 0.3, 45, d), ('S', 0.2)]
    path = Path(cm); e, he = path.end()
    px = Path(cm[:-1] + [('S', 0.26)])
    s0 = 0.12; i0 = int(np.searchsorted(px.s, s0))
    C = px.P[i0:]; Tn = px.H[i0:]; S = px.s[i0:] - s0
    pitch, rmax, amp = 0.012, 0.100, 0.008
    rad = rmax - amp * (0.5 - 0.5 * np.cos(2 * math.pi * S / pitch))   # crests 100 mm, troughs 92 mm
    n = 64
    V, rings = sweep_tube(list(C - C[0]), list(Tn), 1.0, n)
    V = np.array(V)
    for k, ring in enumerate(rings):
        c = C[k] - C[0]; V[ring] = c + rad[k] * (V[ring] - c)
    F = []
    for r1, r2 in zip(rings[:-1], rings[1:]): F += ring_faces(r1, r2)
    write_mesh('bellows.stl', V, F)
    obs = [{"type": "mesh", "path": "parts/bellows.stl", "position": [float(v) for v in C[0]], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    obs += [sph(C[0] + np.array([-0.05, -0.16, 0.07]), 0.04), sph(e + he * 0.2, 0.05)]
    return (f"An open corrugated duct (a flexible hose: zero-thickness mesh, {len(F)} triangles about 2 x 9.5 mm; crests "
            "100 mm, troughs 92 mm from its axis, 12 mm pitch), its mouth 0.12 m ahead on the start line: 0.1 m straight, "
            "45 deg bend towards left-up (radius 0.3 m), then 0.26 m straight to its exit; the goal on its axis 0.06 m "
            "before the exit. A ball beside the mouth, one beyond the exit."), obs, [e], path, {"expected": "reached"}


# ---------------- 6. two slots, the one on the line 4 mm wider than the body on each side ----------------
@world
def twin_slots():
    """a wall with two slots of equal height: on the line 58 mm wide (the 50 mm body passes with 4 mm a side), and
    0.15 m wide 0.19 m left; the goal on the line behind the wall"""
    path = Path(s_path([(0.03, (0.19, 0.0)), (0.06, (-0.19, 0.0)), (0.1, None)]))
    L1 = 0.03 + 2 * 0.3 * math.radians(S_curve(0.3, 0.19))
    xw = path.at(L1 + 0.03)[0][0]; e, he = path.end(); t = 0.006; hz = 0.1
    # wall from strips: y edges of the slots (relative to the line): narrow -0.029..0.029, wide 0.115..0.265
    ys = [-0.5, -0.029, 0.029, 0.115, 0.265, 0.5]
    obs = [plate(xw - t, xw + t, Y0 - 0.5, Y0 + 0.5, Z0 + hz, Z0 + 0.45), plate(xw - t, xw + t, Y0 - 0.5, Y0 + 0.5, Z0 - 0.45, Z0 - hz)]
    for ya, yb in zip(ys[0::2], ys[1::2]): obs.append(plate(xw - t, xw + t, Y0 + ya, Y0 + yb, Z0 - hz, Z0 + hz))
    obs += [plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.35, Y0 + 0.35, Z0 - 0.35, Z0 + 0.35),
            sph([xw + 0.12, Y0 + 0.33, Z0 - 0.05], 0.04), cyl([xw - 0.2, Y0 - 0.15, Z0 - 0.4], [xw - 0.2, Y0 - 0.15, Z0 + 0.4], 0.02)]
    return (f"A wall {xw - X0:.2f} m ahead with two vertical slots, both 0.2 m tall: one on the start line only 58 mm "
            "wide (the 50 mm body fits with 4 mm a side; a straight run along the line passes it), and one 0.15 m wide "
            f"0.19 m left of the line. The goal on the start line {e[0] - xw:.2f} m behind the wall, an end wall behind it, a ball "
            "behind the wall, a post in front of it on the right. The reference uses the wide slot (S-bend left and back)."), \
        obs, [e], path, {"expected": "reached (without contact)"}


# ---------------- 7. up through a hatch in a ceiling, back over it ----------------
@world
def climb_hatch():
    """ceiling 0.3 m above the start line; the goal above it, 0.1 m ahead of the start tip: up 90 deg through a hatch
    0.45 m ahead, 90 deg back over the ceiling"""
    path = Path([('S', 0.15), ('A', 0.3, 90, UP), ('A', 0.3, 90, (-1, 0, 0)), ('S', 0.12)])
    e, he = path.end(); zc = Z0 + 0.3; xh = X0 + 0.45; hh = 0.085; t = 0.006
    obs = [plate(X0 - 0.4, xh - hh, Y0 - 0.6, Y0 + 0.6, zc - t, zc + t), plate(xh + hh, X0 + 1.0, Y0 - 0.6, Y0 + 0.6, zc - t, zc + t),
           plate(xh - hh, xh + hh, Y0 - 0.6, Y0 - hh, zc - t, zc + t), plate(xh - hh, xh + hh, Y0 + hh, Y0 + 0.6, zc - t, zc + t),
           plate(X0 - 0.08, X0 - 0.068, Y0 - 0.3, Y0 + 0.3, zc + t, zc + 0.55),       # wall behind the goal, above the ceiling
           plate(X0 - 0.08, X0 + 0.75, Y0 - 0.3, Y0 + 0.3, zc + 0.49, zc + 0.502),     # a low roof over it
           sph([xh + 0.2, Y0 + 0.1, Z0 + 0.05], 0.045), cyl([xh + 0.1, Y0 - 0.2, Z0 - 0.3], [xh + 0.1, Y0 - 0.2, zc - t], 0.02),
           sph([X0 + 0.2, Y0 - 0.14, zc + 0.2], 0.04)]
    return (f"A ceiling plate 0.3 m above the start line (from 0.4 m behind the start tip to 1.0 m ahead, 1.2 m wide) "
            "with one 0.17 m square hatch 0.45 m ahead; above it, a roof 0.49 m over the ceiling and a wall behind. The goal "
            f"is above the ceiling, {e[2] - Z0:.2f} m above the start line and {e[0] - X0:.2f} m ahead of the start tip (the "
            "start tip is under it). Way: 0.15 m on, 90 deg up through the hatch, 90 deg back over the ceiling towards the "
            "start. A ball and a post under the ceiling, a ball above it."), obs, [e], path, {"expected": "reached"}


# ---------------- 8. a wire-mesh fence with one cut-out ----------------
@world
def wire_fence():
    """a fence of thin wires (r 4 mm, 45 mm pitch both ways: 37 mm clear) across the way, one 0.17 m cut-out"""
    hy, hz = -0.14, 0.07
    path = Path(s_path([(0.05, (hy, hz)), (0.1, (-hy, -hz)), (0.12, None)]))
    L1 = 0.05 + 2 * 0.3 * math.radians(S_curve(0.3, float(np.hypot(hy, hz))))
    xf = path.at(L1 + 0.05)[0][0]; e, he = path.end(); p, r = 0.045, 0.004; half = 0.45
    ks = np.arange(-10, 11)
    obs = []
    for k in ks:                       # vertical wires (along z) at y = hy + k p, cut at the hole
        y = Y0 + hy + k * p
        if abs(k) <= 1:
            obs += [cyl([xf, y, Z0 - half], [xf, y, Z0 + hz - 2 * p], r), cyl([xf, y, Z0 + hz + 2 * p], [xf, y, Z0 + half], r)]
        else: obs.append(cyl([xf, y, Z0 - half], [xf, y, Z0 + half], r))
    for k in ks:                       # horizontal wires (along y) 4 mm behind, at z = hz + k p
        z = Z0 + hz + k * p
        if abs(k) <= 1:
            obs += [cyl([xf + 0.008, Y0 - half, z], [xf + 0.008, Y0 + hy - 2 * p, z], r), cyl([xf + 0.008, Y0 + hy + 2 * p, z], [xf + 0.008, Y0 + half, z], r)]
        else: obs.append(cyl([xf + 0.008, Y0 - half, z], [xf + 0.008, Y0 + half, z], r))
    obs += [plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.35, Y0 + 0.35, Z0 - 0.35, Z0 + 0.35), sph([xf + 0.14, Y0 + 0.12, Z0 - 0.04], 0.04)]
    return (f"A fence of thin wires {xf - X0:.2f} m ahead, 0.9 x 0.9 m: vertical and horizontal wires (r 4 mm, 45 mm pitch, "
            f"37 mm clear between them: the tip's rays can pass, the 50 mm body cannot), 42 wires in {len(obs) - 2} cylinders; one "
            f"cut-out (three wires each way removed, 0.172 m clear between the wires round it) 0.14 m right and 0.07 m up of "
            f"the line. The goal on the start line {e[0] - xf:.2f} m behind the fence, an end wall behind it, a ball beside the way."), \
        obs, [e], path, {"expected": "reached (without contact)"}


# ---------------- 9. a dense lattice with one tunnel ----------------
def cut_rod(a, b, r, tree, D, step=0.002):
    """pieces of the rod a-b left after removing every part whose axis comes within D of the points in tree"""
    n = max(2, int(np.linalg.norm(b - a) / step) + 1); T = np.linspace(0, 1, n); P = a + np.outer(T, b - a)
    keep = tree.query(P)[0] >= D; out = []; i = 0
    while i < n:
        if not keep[i]: i += 1; continue
        j = i
        while j + 1 < n and keep[j + 1]: j += 1
        if (T[j] - T[i]) * np.linalg.norm(b - a) > 0.005: out.append(cyl(P[i], P[j], r))
        i = j + 1
    return out


@world
def lattice_tunnel():
    """a cubic lattice of rods (r 7 mm, 60 mm pitch: 46 mm clear, the 50 mm body cannot pass a cell) 0.6 m deep,
    in a wall; one tunnel (rods cut back 78 mm from the tip path) winds through it"""
    from scipy.spatial import cKDTree
    path = Path(s_path([(0.1, (0.1, 0.05)), (0.1, (-0.1, -0.05)), (0.1, None)]))
    e, he = path.end(); tree = cKDTree(path.P); p, r, D = 0.06, 0.007, 0.078
    xs = X0 + 0.25 + p * np.arange(11); ys = Y0 + p * np.arange(-5, 6); zs = Z0 + p * np.arange(-5, 6)
    obs = []
    for y in ys:
        for z in zs: obs += cut_rod(np.array([xs[0], y, z]), np.array([xs[-1], y, z]), r, tree, D)
    for x in xs:
        for z in zs: obs += cut_rod(np.array([x, ys[0], z]), np.array([x, ys[-1], z]), r, tree, D)
        for y in ys: obs += cut_rod(np.array([x, y, zs[0]]), np.array([x, y, zs[-1]]), r, tree, D)
    nl = len(obs); t = 0.006; xw = xs[0] - 0.02; h = 0.3 + 0.01
    obs += [plate(xw - t, xw + t, Y0 - 0.8, Y0 - h, Z0 - 0.8, Z0 + 0.8), plate(xw - t, xw + t, Y0 + h, Y0 + 0.8, Z0 - 0.8, Z0 + 0.8),
            plate(xw - t, xw + t, Y0 - h, Y0 + h, Z0 - 0.8, Z0 - h), plate(xw - t, xw + t, Y0 - h, Y0 + h, Z0 + h, Z0 + 0.8),
            plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.35, Y0 + 0.35, Z0 - 0.35, Z0 + 0.35)]
    return (f"A cubic lattice of rods (r 7 mm, 60 mm pitch, so 46 mm clear in every cell face: the 50 mm body passes no "
            f"cell; forward rays see through) filling a 0.6 m cube from {xs[0] - X0:.2f} m ahead, set in a wall (1.6 x 1.6 m) "
            f"round it; {nl} rod pieces. One tunnel winds through it: every rod cut back to 78 mm from a tip path that "
            "starts its S-bend 0.1 m ahead, goes 0.1 m left and 0.05 m up inside the lattice and comes back to the line just past "
            f"its far side. The goal on the start line {e[0] - xs[-1]:.2f} m behind the lattice, an end wall behind it."), obs, [e], path, \
        {"expected": "reached"}


def late_mover_check(obs, path, s_w=None, t_w=None):
    """body (capsules r 25 mm on the path) against the mover with the reference timing t(s) = 1 + s/0.055 (if s_w:
    the tip holds at s_w until t_w, then goes on at the same pace), from the start to the goal; and the body left at
    the goal from then to 40 s"""
    mv = [o for o in obs if 'motion' in o]
    def tof(s): return 1.0 + s / 0.055 if s_w is None or s <= s_w else t_w + (s - s_w) / 0.055
    tg = tof(path.L); best_before = 9.0; best_after = 9.0
    def body(s): J, _ = path.joints(s); return np.vstack([seg(J[k], J[k + 1]) for k in range(6)])
    spans = [(s, tof(s), tof(min(path.L, s + 0.01))) for s in np.arange(0.0, path.L + 1e-9, 0.01)]
    if s_w is not None: spans.append((s_w, tof(s_w), t_w))
    for s, ta, tb in spans:
        Bs = body(s)
        for o in mv:
            for tt in np.arange(ta, tb + 1e-9, 0.005) if tb - ta > 0.05 else np.linspace(ta, tb, 3):
                best_before = min(best_before, float(sdf(o, Bs, motion_offset(o['motion'], tt)).min()) - 0.025)
    B = body(path.L)
    for o in mv:
        for tt in np.arange(tg, 40.0, 0.005):
            best_after = min(best_after, float(sdf(o, B, motion_offset(o['motion'], tt)).min()) - 0.025)
    return round(tg, 2), round(best_before, 4), round(best_after, 4)


def write(name):
    desc, obs, goals, path, opt = W[name]()
    goals = [np.array(g, float) for g in goals]
    ck = check(obs, path, goals)
    ck['obstacles'] = len(obs)
    if opt.get('late_mover'):
        sw, tw = opt['late_mover']
        tg, bb, ba = late_mover_check(obs, path, sw, tw)
        ck['body_clearance_static'] = check([o for o in obs if 'motion' not in o], path, goals)['body_clearance']
        ck['late_mover'] = {"timing": "t(s) = 1 + s/0.055" + (f"; the tip holds at s = {sw} m until t = {tw} s, then goes on at that pace" if sw else ""),
                            "reference_goal_time": tg, "body_to_mover_until_goal": bb,
                            "body_to_mover_if_still_there_after_goal_until_40s": ba,
                            "note": "hard5's movers check (body_clearance_movers_worst_over_later_times) counts the mover over all "
                                    "later times, for the body left at each s, with no waiting: negative by design here"}
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    pts = np.array(path.P[::25].tolist() + [path.P[-1].tolist()]); start = path.start
    note = "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm"
    if 'transform' in opt:
        yaw, tr = opt['transform']
        obs, goals, pts, base = transform_world(obs, goals, pts, yaw, tr)
        robot['base'] = base
        start = transform_world([], [start], [start], yaw, tr)[1][0]
        note += (f"; commands in the canonical frame (default base), points and start_tip_world in this world's frame "
                 f"(canonical frame rotated {math.degrees(yaw):.0f} deg about z, then moved by {list(tr)} m); checks computed in the canonical frame")
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h8-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": 0.02} for g in goals],
         "time_limit": 75.0}
    if opt.get('retract'): w['retract'] = True
    w['extra'] = {"reference_path": {
                      "commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [round(float(x), 6) for x in c[3]]] for c in path.cmds],
                      "note": note,
                      "start_tip_world": [round(float(v), 6) for v in start],
                      "points": [[round(float(v), 4) for v in p] for p in pts]},
                  "checks": ck, "expected": opt.get('expected'),
                  "generator": "worlds/hard8/make.py (session 44 helper; hard5's make.py imported as a library)"}
    json.dump(rnd(w), open(os.path.join(OUT, name + '.json'), 'w'), indent=1)
    return ck


if __name__ == '__main__':
    for n in sys.argv[1:] or list(W):
        ck = write(n)
        ok = (ck['tip_clearance'] >= 0.06 and ck.get('body_clearance_static', ck['body_clearance']) >= 0.0269 and ck['arm_clearance'] >= 0.052
              and ck['lathe_travel'] <= 1.54 and ck['flange_off_axis'] < 0.005 and ck['curved_part'] <= 1.2
              and max(ck['goal_on_path']) < 0.003
              and (ck.get('body_clearance_movers_worst_over_later_times', 1.0) >= 0.0269
                   or ck.get('late_mover', {}).get('body_to_mover_until_goal', 0) >= 0.0269))
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
