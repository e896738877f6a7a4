"""Own generator, held-out batch 7 (session 43 helper, outside user). Does not use navstack.generate.
hard5's generator (worlds/hard5/make.py) is imported as a library, as worlds/hard6/make.py does: its Path (straight
legs and arcs of radius >= 0.28 m from the start tip P0 heading +x), primitives, exact signed distances (meshes:
exact point-triangle distance), `check` (tip / serpentine body / arm clearances along the reference path, lathe
travel, flange off the lathe axis, movers with its assumed timing t = 1 + s/0.055 s and their worst over all later
times for the body) and its mesh writer; nothing of it is copied here. Its OUT is pointed at this folder so that
mesh_of and write_mesh read and write this folder's parts/.
Every world is built round its reference tip path; goals give only the destination.
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
                        box, cyl, sph, frame_box, plate_hole, sdf, seg, check, write_mesh, ring_faces, rnd)

W = {}
def world(fn): W[fn.__name__] = fn; return fn

EZ = np.array([0, 0, 1.0])


def plate(x0, x1, y0, y1, z0, z1):
    """axis-aligned box spanning the given ranges"""
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def body_points(path, step=0.02):
    B = []
    for s in np.arange(0.0, path.L + 1e-9, step):
        J, _ = path.joints(s); B.append(np.vstack([seg(J[k], J[k + 1], 0.01) for k in range(6)]))
    return np.unique(np.round(np.vstack(B), 3), axis=0)


def clutter(path, inside, lo, hi, n_sph, n_cyl, seed, tip_need=0.07, body_need=0.045, keep_from=()):
    """balls (r 15-35 mm) and rods (r 6-14 mm, 0.1-0.25 m) at random in the box lo..hi where inside(c) holds,
    kept tip_need from the tip path, body_need from the body's axes (plus 25 mm) and 20 mm from keep_from's obstacles"""
    rng = np.random.default_rng(seed); TP = path.P[::2]; BP = body_points(path)
    lo, hi = np.array(lo, float), np.array(hi, float); out = []; cnt = [0, 0]; tries = 0
    while (cnt[0] < n_sph or cnt[1] < n_cyl) and tries < 20000:
        tries += 1; c = lo + rng.random(3) * (hi - lo)
        if not inside(c): continue
        if cnt[0] < n_sph:
            o = sph(c, 0.015 + 0.02 * rng.random()); k = 0; pts = c[None]
        else:
            dv = unit(rng.normal(size=3)); L = 0.1 + 0.15 * rng.random()
            o = cyl(c - dv * L / 2, c + dv * L / 2, 0.006 + 0.008 * rng.random()); k = 1; pts = seg(c - dv * L / 2, c + dv * L / 2, 0.01)
        if float(sdf(o, TP).min()) < tip_need or float(sdf(o, BP).min()) < 0.025 + body_need: continue
        if any(float(sdf(q, pts).min()) < 0.02 + (o.get('radius', 0) if k else o['radius']) for q in keep_from + out): continue
        out.append(o); cnt[k] += 1
    return out, cnt


def crossing(path, x):
    """first point of the path at x (plane x = const)"""
    i = int(np.argmax(path.P[:, 0] >= x)); return path.P[i].copy(), path.H[i].copy()


# ---------------- 1. a whole structure rotated about z ----------------
@world
def rot_bay():
    """bulkhead + closed bay + clutter, the whole built 40 deg yawed (left) from the start heading; offset hole"""
    th = S_curve(0.3, 0.07)
    yaw = math.radians(40); h = np.array([math.cos(yaw), math.sin(yaw), 0]); u = np.array([-math.sin(yaw), math.cos(yaw), 0])
    dS = unit(u * 0.13 + EZ * 0.035)                        # behind the hole: left-up, in the rotated frame
    offS = float(np.linalg.norm([0.13, 0.035])); thS = S_curve(0.3, offS)
    path = Path([('S', 0.1), ('A', 0.3, 40, LEFT), ('S', 0.16), ('A', 0.3, thS, dS), ('A', 0.3, thS, -dS), ('S', 0.03)])
    sw = 0.1 + 0.3 * yaw + 0.08; pw, _ = path.at(sw)      # hole centre (path point 0.08 m after the turn)
    e, _ = path.end()
    # plate 0.9 x 0.7 m, normal h, its centre 0.2 m left (u) of the hole and 0.05 m down: the hole is off-centre
    pc = pw + u * 0.2 - EZ * 0.05
    obs = plate_hole(pc, u, EZ, h, 0.45, 0.35, (-0.2, 0.05), (0.075, 0.075), 0.006)
    # a closed bay behind it (0.5 deep), walls square to the rotated frame
    a0, a1 = 0.0, 0.62; bl, br = 0.27, -0.22; zl, zh = -0.2, 0.2
    def at(a, b, z): return pw + h * a + u * b + EZ * z
    obs += [frame_box(at((a0 + a1) / 2, bl, 0), h, EZ, (a1 - a0) / 2, 0.2, 0.006),
            frame_box(at((a0 + a1) / 2, br, 0), h, EZ, (a1 - a0) / 2, 0.2, 0.006),
            frame_box(at((a0 + a1) / 2, (bl + br) / 2, zh), h, u, (a1 - a0) / 2, (bl - br) / 2 + 0.006, 0.006),
            frame_box(at((a0 + a1) / 2, (bl + br) / 2, zl), h, u, (a1 - a0) / 2, (bl - br) / 2 + 0.006, 0.006),
            frame_box(at(a1, (bl + br) / 2, 0), u, EZ, (bl - br) / 2 + 0.006, 0.206, 0.006)]
    def inside(c):
        r = c - pw; a, b, z = r @ h, r @ u, r[2]
        return 0.04 < a < a1 - 0.04 and br + 0.04 < b < bl - 0.04 and zl + 0.04 < z < zh - 0.04
    cl, cnt = clutter(path, inside, pw - 0.6, pw + 0.6, 7, 5, 7041, keep_from=obs)
    obs += cl
    return (f"The whole structure is yawed 40 deg left of the start heading: a bulkhead (0.9 x 0.7 m) whose 0.15 m hole "
            f"is 0.2 m right of the plate's centre and 0.05 m above it, {np.round(pw - P0, 3).tolist()} m from the start "
            f"tip, and behind it a closed bay (0.62 m deep, 0.49 x 0.4 m) with {cnt[0]} balls and {cnt[1]} rods; the goal in "
            "the bay 0.13 m left and 0.035 m up of the hole's axis. Way: 40 deg left, through the hole square to the "
            "plate, a small S-bend among the clutter."), obs, [e], path, {"expected": "reached"}


# ---------------- 2. goal below the start line under an overhang ----------------
@world
def dive_under():
    """forward, dive 180 deg down round a shelf's front edge, back underneath it: a vertical U"""
    path = Path([('S', 0.40), ('A', 0.3, 180, DOWN), ('S', 0.22)])
    e, _ = path.end(); xc = X0 + 0.40; zc = Z0 - 0.3
    obs = [plate(X0 - 0.15, xc + 0.16, Y0 - 0.45, Y0 + 0.45, zc - 0.006, zc + 0.006),       # the shelf (overhang)
           plate(xc + 0.3 + 0.13, xc + 0.3 + 0.145, Y0 - 0.45, Y0 + 0.45, Z0 - 0.8, Z0 + 0.25),  # wall ahead
           plate(X0 - 0.15, xc + 0.445, Y0 - 0.45, Y0 + 0.45, Z0 - 0.77, Z0 - 0.758),        # floor
           plate(X0 - 0.15, xc + 0.16, Y0 + 0.25, Y0 + 0.262, Z0 - 0.758, zc - 0.006),       # side walls under the shelf
           plate(X0 - 0.15, xc + 0.16, Y0 - 0.262, Y0 - 0.25, Z0 - 0.758, zc - 0.006),
           plate(e[0] - 0.14, e[0] - 0.128, Y0 - 0.25, Y0 + 0.25, Z0 - 0.758, zc - 0.006),   # back of the pocket
           sph([xc - 0.05, Y0 + 0.14, Z0 - 0.12], 0.04), cyl([xc + 0.05, Y0 - 0.4, zc - 0.19], [xc + 0.05, Y0 - 0.12, zc - 0.19], 0.02)]
    return ("A shelf 0.3 m below the start line, from behind the start tip to 0.56 m ahead of it; the goal is 0.6 m "
            "below the start line and 0.18 m ahead of the start tip, UNDER the shelf, in a pocket closed at its sides "
            "and back and open only towards the shelf's front edge. Way: forward 0.4 m, dive 180 deg down (radius 0.3 m) "
            "round the shelf's front edge (0.16 m inside the arc), back under it. A wall ahead, a floor, a ball above "
            "the shelf, a rod under it."), obs, [e], path, {"expected": "reached"}


# ---------------- 3. three walls, holes left / right / up ----------------
@world
def three_walls():
    """three walls 0.28 m apart; holes left, then right of it, then up"""
    path = Path([('S', 0.08), ('A', 0.3, 38, LEFT), ('A', 0.3, 76, RIGHT), ('A', 0.3, 38, LEFT),
                 ('A', 0.3, 30, UP), ('A', 0.3, 30, DOWN), ('S', 0.06)])
    xs = []; obs = []
    k = int(np.argmax(path.P[:, 1])); x1 = path.P[k][0]
    for i, x in enumerate((x1, x1 + 0.28, x1 + 0.56)):
        p, _ = crossing(path, x); xs.append(p)
        obs += plate_hole([x, Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (p[1] - Y0, p[2] - Z0), (0.076, 0.076), 0.006)
    e, _ = path.end()
    obs += [sph([xs[0][0] + 0.14, Y0 - 0.09, Z0 + 0.02], 0.04), cyl([xs[1][0] + 0.14, Y0 + 0.15, Z0 - 0.3], [xs[1][0] + 0.14, Y0 + 0.15, Z0 + 0.3], 0.02),
            plate(e[0] + 0.12, e[0] + 0.135, Y0 - 0.3, Y0 + 0.3, Z0 - 0.3, Z0 + 0.3)]
    offs = [np.round((p - P0)[1:] * 1e3).astype(int).tolist() for p in xs]
    return (f"Three walls 0.28 m apart ({xs[0][0] - X0:.2f}, {xs[1][0] - X0:.2f}, {xs[2][0] - X0:.2f} m ahead), each with "
            f"one 0.152 m square hole, centred (y, z mm from the start line) at {offs[0]} (left), {offs[1]} (right of the "
            f"first) and {offs[2]} (up); the first blocks the start line. A ball and a post between the walls, the goal "
            "behind the third, an end wall behind it."), obs, [e], path, {"expected": "reached"}


# ---------------- 4. start boxed in ----------------
@world
def start_boxed():
    """at t = 0 plates 65-70 mm right of, above and below the tip; a wall ahead; the way out forward-left"""
    path = Path([('S', 0.03), ('A', 0.3, 45, LEFT), ('S', 0.1), ('A', 0.3, 75, RIGHT), ('S', 0.2)])
    e, _ = path.end()
    xw = X0 + 0.32
    obs = [plate(X0 - 0.15, xw, Y0 - 0.082, Y0 - 0.07, Z0 - 0.3, Z0 + 0.3),            # right, 70 mm
           plate(X0 - 0.15, X0 + 0.22, Y0 - 0.082, Y0 + 0.06, Z0 + 0.065, Z0 + 0.077),   # above, 65 mm
           plate(X0 - 0.15, X0 + 0.22, Y0 - 0.082, Y0 + 0.06, Z0 - 0.077, Z0 - 0.065),   # below, 65 mm
           plate(xw, xw + 0.012, Y0 - 0.3, Y0 + 0.08, Z0 - 0.3, Z0 + 0.3),             # wall ahead, open on the left
           ]
    e, he = path.end(); lft = lambda s: (path.at(s)[0], unit(np.cross(EZ, path.at(s)[1])))
    p, n = lft(path.L - 0.12); obs.append(sph(p - n * 0.1, 0.04))
    p, n = lft(path.L - 0.3); obs.append(cyl(p + n * 0.12 - EZ * 0.3, p + n * 0.12 + EZ * 0.3, 0.02))
    obs.append(frame_box(e + he * 0.13, unit(np.cross(EZ, he)), EZ, 0.3, 0.3, 0.006))
    d0 = [round(float(sdf(o, P0[None])[0]) * 1e3, 1) for o in obs[:4]]
    return (f"At t = 0 the tip sits in a slot: plates {d0[0]:.0f} mm to its right, {d0[1]:.0f} mm above and {d0[2]:.0f} mm "
            f"below (along the body too), a wall {d0[3] * 1e-3:.2f} m ahead that leaves only its left end open (0.08 m left of "
            "the line). Way out: forward-left (45 deg), then 75 deg right behind the wall; a ball and a post there, the goal "
            "0.2 m on, an end wall behind it."), obs, [e], path, {"expected": "reached"}


# ---------------- 5. a beam the arm would hit ----------------
@world
def arm_beam():
    """a low beam across the lathe's way that only the arm (never the serpentine or its sensors) can reach"""
    th = S_curve(0.3, 0.1)
    path = Path([('S', 0.02), ('A', 0.3, th, LEFT), ('A', 0.3, th, RIGHT), ('A', 0.3, th, RIGHT), ('A', 0.3, th, LEFT)])
    e, _ = path.end(); k = int(np.argmax(path.P[:, 1])); pw = path.P[k]
    obs = plate_hole([pw[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (pw[1] - Y0, 0.0), (0.075, 0.075), 0.006)
    obs += [plate(e[0] + 0.13, e[0] + 0.142, Y0 - 0.3, Y0 + 0.3, Z0 - 0.3, Z0 + 0.3), sph(e + np.array([-0.02, 0.13, 0.03]), 0.04)]
    xb = 0.89                                             # beam axis x: the arm's vertical column is at x = lathe travel
    obs.append(cyl([xb, -0.5, 0.9], [xb, 0.7, 0.9], 0.03))
    return (f"A wall {pw[0] - X0:.2f} m ahead whose only hole (0.15 m) is 0.1 m left of the line; the goal on the start line "
            f"{e[0] - X0:.2f} m ahead, behind the wall (the tip path {path.L:.2f} m long: S-bend left through the hole and back). Hidden from the "
            "tip: a low beam (r 30 mm, across y at x 0.89 m, z 0.9 m, just below the elbow's height) in front of the arm's "
            "column: the arm touches it if the lathe bed travels more than about 0.80 m (the reference uses 0.71 m). "
            "Tests also that the lathe is not advanced further than the way needs."), \
        obs, [e], path, {"expected": "reached (lathe travel < 0.80 m)"}


# ---------------- 6. a narrow corridor that bends twice ----------------
def corridor(path, s0, s1, w, t=0.006, ds=0.025):
    """square corridor of plates (inner half width w) round the path from arc length s0 to s1; frames transported"""
    n = np.array(LEFT, float); out = []; i0 = int(np.searchsorted(path.s, s0)); i1 = int(np.searchsorted(path.s, s1))
    N = [None] * len(path.P)
    for i in range(len(path.P)):
        hh = path.H[i]; n = unit(n - n.dot(hh) * hh); N[i] = n
    idx = list(range(i0, i1, max(1, int(round(ds / 0.002))))) + [i1]
    for a, b in zip(idx[:-1], idx[1:]):
        pa, pb = path.P[a], path.P[b]; hh = unit(pb - pa); m = (a + b) // 2
        nn = unit(N[m] - N[m].dot(hh) * hh); bb = np.cross(hh, nn); L = np.linalg.norm(pb - pa)
        c = (pa + pb) / 2
        # half length: enough to close the outer side of a bend of radius >= 0.3 m
        hl = L / 2 * (0.3 + w + 2 * t) / 0.3 + 0.001
        for v, ww in ((nn, bb), (-nn, bb), (bb, nn), (-bb, nn)):
            out.append(frame_box(c + v * (w + t), hh, ww, hl, w + 2 * t, t))
    return out


@world
def bent_corridor():
    """a closed corridor of plates 0.14 m wide (45 mm clear round the body) bending 75 deg left, then 75 deg up"""
    path = Path([('S', 0.15), ('A', 0.3, 75, LEFT), ('S', 0.08), ('A', 0.3, 75, UP), ('S', 0.12)])
    e, h = path.end(); w = 0.07
    px = Path([('S', 0.15), ('A', 0.3, 75, LEFT), ('S', 0.08), ('A', 0.3, 75, UP), ('S', 0.2)])
    obs = corridor(px, 0.06, px.L, w)
    # a cap 0.08 m beyond the goal: the mouth is the only way in
    c = e + h * 0.08
    obs.append(box(c + h * 0.006, [w + 0.02, w + 0.02, 0.006]))
    return ("A closed square corridor of 12 mm plates, 0.14 m wide inside (45 mm round the 50 mm body on its centre "
            "line; less on the inside of the bends), its mouth 0.06 m ahead: 0.09 m straight, 75 deg "
            "left (radius 0.3 m), 0.08 m, 75 deg up, 0.12 m to the goal, capped 0.08 m beyond it. The arm's flange "
            "must stay out of the mouth (the lathe travel the reference needs leaves it 0.1 m short)."), obs, [e], path, \
        {"expected": "reached"}


# ---------------- 7. a slot in a curved shell (mesh) ----------------
@world
def shell_slot():
    """a closed cylindrical tank (zero-thickness mesh) with one vertical slot 25 deg off the approach; goal inside"""
    path = Path([('S', 0.05), ('A', 0.3, 40, RIGHT), ('S', 0.1), ('A', 0.3, 65, LEFT), ('S', 0.28)])
    e, h = path.end(); sw = path.L - 0.22; pw, hw = path.at(sw)
    R = 0.42; c = pw + hw * R; c[2] = Z0
    ang0 = math.atan2(-hw[1], -hw[0])                       # slot direction seen from the axis
    nseg = 120; dA = 2 * math.pi / nseg; zs = np.linspace(-0.3, 0.3, 13)   # 50 mm rows
    V = []; F = []
    for j, z in enumerate(zs):
        for i in range(nseg):
            a = ang0 + (i - 0.0) * dA; V.append([R * math.cos(a), R * math.sin(a), z])
    def vid(i, j): return j * nseg + (i % nseg)
    for j in range(len(zs) - 1):
        for i in range(nseg):
            ia = i if i < nseg // 2 else i - nseg           # angle index relative to the slot: -60..59
            if -3 <= ia < 3 and -0.15 - 1e-9 <= zs[j] and zs[j + 1] <= 0.15 + 1e-9: continue   # slot: 6 x 3 deg, 0.3 m tall
            F += [[vid(i, j), vid(i + 1, j), vid(i + 1, j + 1)], [vid(i, j), vid(i + 1, j + 1), vid(i, j + 1)]]
    for j, z in ((0, zs[0]), (len(zs) - 1, zs[-1])):        # caps
        ci = len(V); V.append([0, 0, z])
        for i in range(nseg): F.append([ci, vid(i, j), vid(i + 1, j)])
    write_mesh('tank.stl', V, F)
    obs = [{"type": "mesh", "path": "parts/tank.stl", "position": [float(v) for v in c], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    obs += [sph(c + np.array([0.05, 0.12, 0.05]), 0.05), cyl([X0 + 0.25, Y0 + 0.07, Z0 - 0.35], [X0 + 0.25, Y0 + 0.07, Z0 + 0.35], 0.02)]
    sl = 2 * R * math.sin(3 * dA)
    return (f"A closed cylindrical tank (zero-thickness mesh, {len(F)} triangles; radius 0.42 m, 0.6 m tall, axis vertical "
            f"{np.round(c - P0, 3).tolist()} m from the start tip), its only opening a vertical slot {sl * 1e3:.0f} mm wide "
            f"and 0.3 m tall whose centre faces {math.degrees(math.atan2(-hw[1], -hw[0])) % 360 - 180:.0f} deg from the start "
            "heading, right of the line. The goal is inside, 0.22 m in from the slot. A post on the way, a ball inside. Way: "
            "40 deg right, 65 deg left, in through the slot radially."), obs, [e], path, {"expected": "reached"}


# ---------------- 8. false openings ----------------
def pocket(c, n, u, v, hu, hv, depth, t=0.006):
    """closed box behind a hole of half sizes hu, hv centred at c (the wall's back face), going depth along n"""
    m = c + n * depth / 2
    return [frame_box(m + u * (hu + t), n, v, depth / 2, hv + 2 * t, t), frame_box(m - u * (hu + t), n, v, depth / 2, hv + 2 * t, t),
            frame_box(m + v * (hv + t), n, u, depth / 2, hu + 2 * t, t), frame_box(m - v * (hv + t), n, u, depth / 2, hu + 2 * t, t),
            frame_box(c + n * (depth + t), u, v, hu + 2 * t, hv + 2 * t, t)]


@world
def false_holes():
    """a wall with three equal holes: on the line and up-left they open into closed pockets; only right-down goes through"""
    off = np.array([0, -0.17, -0.1]); d = unit(off); th = S_curve(0.3, float(np.linalg.norm(off)))
    back = np.array([0, 0.17, 0.1]) - np.array([0, 0.04, 0.03]); d2 = unit(back); th2 = S_curve(0.3, float(np.linalg.norm(back)))
    path = Path([('S', 0.05), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.24), ('A', 0.3, th2, d2), ('A', 0.3, th2, -d2), ('S', 0.03)])
    xw = X0 + 0.05 + 2 * 0.3 * math.sin(math.radians(th)) + 0.04
    e, _ = path.end(); hs = 0.075
    holes = [(0.0, 0.0), (0.19, 0.12), (-0.17, -0.1)]
    W_ = []
    # wall: three holes, built from strips (rows between the hole bands, then the pieces beside each hole)
    Y = lambda y: Y0 + y; Z = lambda z: Z0 + z; t = 0.006; x0, x1 = xw - t, xw + t
    zb = sorted(set([-0.45, 0.45] + [z + s * hs for _, z in holes for s in (-1, 1)]))
    for za, zb_ in zip(zb[:-1], zb[1:]):
        band = [(y, z) for y, z in holes if z - hs <= za + 1e-9 and zb_ <= z + hs + 1e-9]
        ys = sorted([-0.5, 0.5] + [y + s * hs for y, _ in band for s in (-1, 1)])
        for ya, yb in zip(ys[0::2], ys[1::2]):
            if yb - ya > 1e-6: W_.append(plate(x0, x1, Y(ya), Y(yb), Z(za), Z(zb_)))
    obs = W_
    for (y, z), dep in zip(holes[:2], (0.22, 0.2)):
        obs += pocket(np.array([x1, Y(y), Z(z)]), EX, np.array([0, 1.0, 0]), EZ, hs, hs, dep)
    obs += [plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.3, Y0 + 0.3, Z0 - 0.3, Z0 + 0.3), sph([xw + 0.15, Y0 - 0.3, Z0 - 0.1], 0.04)]
    return (f"A wall {xw - X0:.2f} m ahead with three equal 0.15 m holes: on the start line, 0.19 m left and 0.12 m up, "
            "0.17 m right and 0.1 m down. The first two open into closed pockets (0.22 and 0.2 m deep); only the third "
            "goes through. The goal is behind the wall, 0.04 m right and 0.03 m down of the line, 0.2 m behind the "
            "line's pocket; an end wall behind it. Way: S-bend down-right through the third hole, 0.24 m on, S-bend back "
            "up-left behind the pocket."), obs, [e], path, {"expected": "reached"}


# ---------------- 9. a way grazing a plate ----------------
@world
def graze_plate():
    """a tall plate slanting 15 deg across the line; the way runs along it 60 mm off, round its end, behind it"""
    path = Path([('S', 0.05), ('A', 0.3, 15, LEFT), ('S', 0.55), ('A', 0.3, 60, RIGHT), ('S', 0.14)])
    s1 = 0.05 + 0.3 * math.radians(15); a, h = path.at(s1); b, _ = path.at(s1 + 0.55)
    rn = np.array([h[1], -h[0], 0]); off = 0.065
    pa = a + rn * off - h * 0.35; pb = b + rn * off + h * 0.01            # plate trace (its face 65 mm right of the leg)
    mid = (pa + pb) / 2; L = np.linalg.norm(pb - pa)
    obs = [frame_box(mid + rn * 0.005, h, EZ, L / 2, 0.45, 0.005)]
    e, he = path.end()
    for f in (0.3, 0.65, 0.95):                                            # posts on the left of the leg
        p = a + h * (f * 0.55) - rn * 0.13
        obs.append(cyl(p - EZ * 0.4, p + EZ * 0.4, 0.02))
    obs += [sph(e + he * 0.13, 0.045), sph(b + rn * 0.3 + h * 0.05, 0.05)]
    return ("A tall plate (0.9 m) slanting 15 deg to the left of the start heading crosses the start line 0.3 m ahead at a "
            "grazing angle; the goal is behind it, beyond its far end. Way: 15 deg left, 0.55 m along the plate's face "
            "65 mm off (40 mm round the body), 60 deg right round its end and back behind it. Three posts 0.13 m left of "
            "the way, a ball behind the goal, one behind the plate."), obs, [e], path, {"expected": "reached"}


# ---------------- 10. a mover crossing near the goal ----------------
@world
def sweep_goal():
    """a vertical bar oscillating sideways 78 mm beyond the goal (period 7 s); the goal behind a right-up window, off its axis"""
    off = np.array([0, -0.10, 0.09]); d = unit(off); th = S_curve(0.3, float(np.linalg.norm(off)))
    bk = np.array([0, 0.07, -0.06]); d2 = unit(bk); th2 = S_curve(0.3, float(np.linalg.norm(bk)))
    path = Path([('S', 0.05), ('A', 0.3, th, d), ('A', 0.3, th, -d), ('S', 0.1), ('A', 0.3, th2, d2), ('A', 0.3, th2, -d2), ('S', 0.1)])
    sw = 0.05 + 2 * 0.3 * math.radians(th) + 0.05; pw, _ = path.at(sw); e, _ = path.end()
    obs = plate_hole([pw[0], Y0, Z0], [0, 1, 0], [0, 0, 1], [1, 0, 0], 0.45, 0.4, (pw[1] - Y0, pw[2] - Z0), (0.075, 0.075), 0.006)
    xb = e[0] + 0.078
    obs.append(cyl([xb, e[1], Z0 - 0.35], [xb, e[1], Z0 + 0.35], 0.022,
                   motion={"type": "oscillate", "axis": [0, 1, 0], "amplitude": 0.28, "period": 7.0, "phase": 0.0}))
    obs += [sph([pw[0] + 0.17, e[1] + 0.15, e[2] - 0.05], 0.04), plate(e[0] + 0.2, e[0] + 0.212, Y0 - 0.4, Y0 + 0.4, Z0 - 0.4, Z0 + 0.4)]
    return (f"A window (0.15 m) 0.1 m right and 0.09 m up of the line in a wall {pw[0] - X0:.2f} m ahead; the goal {e[0] - pw[0]:.2f} m behind "
            "it, 0.03 m right and 0.03 m up of the line (back towards the line: off the window's axis). A vertical bar (r 22 mm) "
            "oscillates along y (amplitude 0.28 m, period 7 s) with its axis 78 mm beyond the goal: it crosses in front of the "
            "goal twice a period, 56 mm from the goal point (31 mm from a tip resting there). An end wall 0.2 m beyond the goal."), \
        obs, [e], path, {"expected": "reached"}


# ---------------- 11. an inspection tour of three bays ----------------
def cell_edges(lo, hi, r):
    lo, hi = np.array(lo, float), np.array(hi, float); out = []
    for ax in range(3):
        o1, o2 = [i for i in range(3) if i != ax]
        for a in (lo[o1], hi[o1]):
            for b in (lo[o2], hi[o2]):
                p = np.zeros(3); p[o1] = a; p[o2] = b; q = p.copy(); p[ax] = lo[ax]; q[ax] = hi[ax]
                out.append((tuple(np.round(p, 6)), tuple(np.round(q, 6))))
    return out


def face(lo, hi, ax, side, t=0.004):
    lo, hi = np.array(lo, float), np.array(hi, float); c = (lo + hi) / 2; h = (hi - lo) / 2
    c[ax] = (hi if side > 0 else lo)[ax]; h[ax] = t
    return box(c, h)


@world
def bay_tour():
    """three goals in three bays of a truss (members on every edge, some faces plated): bay A entered through its
    side, bay B from A through their shared face, bay C (below and ahead) from above"""
    path = Path([('S', 0.05), ('A', 0.3, 50, LEFT), ('A', 0.3, 50, RIGHT), ('A', 0.3, 90, DOWN)])
    o = P0; A = (o + [0.13, 0.1, -0.15], o + [0.45, 0.34, 0.15]); B = (o + [0.45, 0.1, -0.15], o + [0.85, 0.34, 0.15])
    C = (o + [0.65, 0.1, -0.45], o + [0.95, 0.34, -0.15])
    edges = []
    for lo, hi in (A, B, C):
        for e in cell_edges(lo, hi, 0.012):
            if e not in edges: edges.append(e)
    obs = [cyl(p, q, 0.012) for p, q in edges]
    obs += [face(*A, 0, -1), face(*A, 1, 1), face(*A, 2, 1), face(*A, 2, -1),       # A: open on -y (entry) and +x (to B)
            face(*B, 0, 1), face(*B, 1, 1), face(*B, 1, -1), face(*B, 2, 1),         # B: open on -x (from A), bottom over C
            face(B[0], o + [0.65, 0.34, 0.15], 2, -1),                                # B's bottom where C is not under it
            face(*C, 0, 1), face(*C, 0, -1), face(*C, 1, 1), face(*C, 1, -1), face(*C, 2, -1)]   # C: open on top only
    obs += [sph(o + [0.12, -0.12, 0.05], 0.04), cyl(o + [0.62, -0.1, -0.5], o + [0.62, -0.1, 0.3], 0.02)]
    g1, _ = crossing(path, X0 + 0.37); g2, _ = crossing(path, X0 + 0.6); g3, _ = path.end()
    return ("A truss of three bays (members r 12 mm on every edge, 8 mm plates on some faces), 0.1-0.34 m left of the "
            "start line: bay A 0.13-0.45 m ahead, open only on its right side (facing the start line) and towards bay B; "
            "bay B 0.45-0.85 m ahead, open only towards A and below where bay C is; bay C 0.65-0.95 m ahead and 0.15-0.45 m "
            "below the line, open only on top. Goals: one in each bay (A, B, C, in that order). Way: 50 deg left into A through its side, "
            "50 deg right into B, dive 90 deg into C from above."), obs, [g1, g2, g3], path, {"expected": "reached 3/3"}


def write(name):
    desc, obs, goals, path, opt = W[name]()
    goals = [np.array(g, float) for g in goals]
    ck = check(obs, path, goals)
    ck['obstacles'] = len(obs)
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    pts = path.P[::25].tolist() + [path.P[-1].tolist()]
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h7-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": 0.02} for g in goals],
         "time_limit": 75.0,
         "extra": {"reference_path": {
                       "commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [round(float(x), 6) for x in c[3]]] for c in path.cmds],
                       "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm",
                       "start_tip_world": [round(float(v), 6) for v in path.start],
                       "points": [[round(float(v), 4) for v in p] for p in pts]},
                   "checks": ck, "expected": opt.get('expected'),
                   "generator": "worlds/hard7/make.py (session 43 helper; hard5's make.py imported as a library)"}}
    json.dump(rnd(w), open(os.path.join(OUT, name + '.json'), 'w'), indent=1)
    return ck


if __name__ == '__main__':
    for n in sys.argv[1:] or list(W):
        ck = write(n)
        ok = (ck['tip_clearance'] >= 0.05 and ck['body_clearance'] >= 0.025 and ck['arm_clearance'] >= 0.03
              and ck['lathe_travel'] <= 2.0 and ck['flange_off_axis'] < 0.005 and max(ck['goal_on_path']) < 0.003
              and ck.get('body_clearance_movers_worst_over_later_times', 1.0) >= 0.025)
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
