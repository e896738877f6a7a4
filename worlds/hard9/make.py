"""Own generator, held-out batch 9 (session 46 helper, outside user). Does not use navstack.generate.
hard5's generator (worlds/hard5/make.py) is imported as a library (importlib), as worlds/hard6/7/8's make.py do:
its Path (straight legs and arcs of radius >= 0.28 m from the start tip P0 heading +x), primitives, exact signed
distances (meshes: exact point-triangle distance), `check` (tip / serpentine body / arm clearances along the
reference path, lathe travel, flange off the lathe axis), `sweep_tube`, `ring_faces` and its mesh writer; nothing of
it is copied. Its OUT is pointed at this folder so that its mesh reader and writer use this folder's parts/.
Every world is built round its reference tip path in the canonical frame; goals give only the destination.
The one mover world (slow_leader) is checked with its own timing (the tip held back behind the mover), below.
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
                        box, cyl, sph, frame_box, plate_hole, sdf, seg, check, write_mesh, sweep_tube, ring_faces,
                        motion_offset, rnd)
from scipy.spatial.transform import Rotation as Rot  # noqa: E402

W = {}
def world(fn): W[fn.__name__] = fn; return fn

EZ = np.array([0, 0, 1.0])
EY = np.array([0, 1.0, 0])


def plate(x0, x1, y0, y1, z0, z1):
    """axis-aligned box spanning the given ranges"""
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def end_wall(e, d=0.12, half=0.35):
    return plate(e[0] + d, e[0] + d + 0.012, Y0 - half, Y0 + half, Z0 - half, Z0 + half)


def s_path(legs, R=0.3):
    """commands for a chain of lateral offsets: legs = [(straight before, offset vector (y, z) or None), ...]"""
    cmds = []
    for L, off in legs:
        if L > 0: cmds.append(('S', L))
        if off is not None:
            o = np.array([0.0, off[0], off[1]]); d = unit(o); th = S_curve(R, float(np.linalg.norm(o)))
            cmds += [('A', R, th, tuple(d)), ('A', R, th, tuple(-d))]
    return cmds


def s_len(off, R=0.3):
    return 2 * R * math.radians(S_curve(R, float(np.hypot(*off))))


# ---------------- 1. a narrow ring the body must thread, its axis oblique ----------------
def torus(name, Rmaj, rmin, n_major=72, n_minor=16):
    """closed torus mesh about the local z axis (centre at the origin)"""
    a = np.linspace(0, 2 * math.pi, n_major, endpoint=False)
    C = [np.array([Rmaj * math.cos(t), Rmaj * math.sin(t), 0.0]) for t in a]
    Tn = [np.array([-math.sin(t), math.cos(t), 0.0]) for t in a]
    V, rings = sweep_tube(C, Tn, rmin, n_minor)
    F = []
    for k in range(n_major): F += ring_faces(rings[k], rings[(k + 1) % n_major])
    write_mesh(name, V, F)
    return len(F)


@world
def ring_thread():
    """a collar ring (torus, 58 mm clear radius) set in a wall whose axis points 45 deg left and 15 deg up of the
    start heading; the goal beyond it, off its axis: thread the ring, then turn"""
    yaw, pitch = 45.0, 15.0
    ax = unit([math.cos(math.radians(pitch)) * math.cos(math.radians(yaw)), math.cos(math.radians(pitch)) * math.sin(math.radians(yaw)), math.sin(math.radians(pitch))])
    ang = math.degrees(math.acos(ax[0]))
    bend = tuple(unit(ax - ax[0] * EX))
    path = Path([('S', 0.12), ('A', 0.3, ang, bend), ('S', 0.34), ('A', 0.3, 40.0, (0.0, -1.0, 0.0)), ('S', 0.06)])
    sr = 0.12 + 0.3 * math.radians(ang) + 0.2
    c, h = path.at(sr); e, he = path.end()
    nf = torus('ring.stl', 0.07, 0.012)
    # ring's local z -> ax
    u = unit(np.cross(ax, EZ)); v = np.cross(ax, u); Rm = np.column_stack([u, v, ax])
    rpy = Rot.from_matrix(Rm).as_euler('xyz')
    obs = [{"type": "mesh", "path": "parts/ring.stl", "position": [float(x) for x in c], "rpy": [float(x) for x in rpy], "scale": 1.0}]
    obs += plate_hole(c, u, v, ax, 0.55, 0.5, (0.0, 0.0), (0.075, 0.075), 0.006)
    obs += [frame_box(c + ax * 0.45, u, v, 0.35, 0.35, 0.006),                     # end wall square to the axis
            sph(c - ax * 0.2 + u * 0.16 + v * 0.05, 0.035), cyl(c - ax * 0.12 - u * 0.17 - v * 0.4, c - ax * 0.12 - u * 0.17 + v * 0.4, 0.015)]
    return (f"A collar ring (a closed torus mesh, {nf} triangles: centre-line radius 70 mm, tube radius 12 mm, so 58 mm "
            f"clear radius: the 25 mm body passes with 33 mm to spare only near its axis) set in a 12 mm wall whose 0.15 m "
            f"square hole it overlaps (the corners left between ring and hole are 21 mm across at most: too small for the "
            f"body). Ring and wall face a direction 45 deg left and 15 deg up of the start heading; the ring's centre "
            f"{c[0] - X0:.2f} m ahead, {c[1] - Y0:.2f} m left, {c[2] - Z0:.2f} m up. The goal {np.linalg.norm(e - c):.2f} m beyond "
            f"it, {np.linalg.norm(np.cross(e - c, ax)):.2f} m off its axis (towards the start heading's side), an end wall square to the axis 0.45 m behind the ring; a ball and a post before the wall. Way: 0.12 m on, one arc of "
            f"{ang:.1f} deg (radius 0.3 m) onto the ring's axis, straight through it, then 40 deg right (radius 0.3 m)."), obs, [e], path, {"expected": "reached"}


# ---------------- 2. a low crawl under a plate, then a climb ----------------
@world
def crawl_climb():
    """a tunnel 0.12 m tall (the body has 35 mm above and below) 0.4 m long through a bulkhead; at its exit a
    wall 0.4 m on: climb 90 deg up; the goal 0.12 m above the end of the climb"""
    path = Path([('S', 0.6), ('A', 0.3, 90, UP), ('S', 0.12)])
    e, he = path.end(); x1, x2 = X0 + 0.12, X0 + 0.52; g = 0.06; t = 0.012
    obs = [plate(x1, x2, Y0 - 0.16, Y0 + 0.16, Z0 + g, Z0 + g + t), plate(x1, x2, Y0 - 0.16, Y0 + 0.16, Z0 - g - t, Z0 - g),      # ceiling, floor
           plate(x1, x2, Y0 + 0.16, Y0 + 0.172, Z0 - g - t, Z0 + g + t), plate(x1, x2, Y0 - 0.172, Y0 - 0.16, Z0 - g - t, Z0 + g + t),  # sides
           plate(x1 - t, x1, Y0 - 0.6, Y0 + 0.6, Z0 + g, Z0 + 0.7), plate(x1 - t, x1, Y0 - 0.6, Y0 + 0.6, Z0 - 0.6, Z0 - g),        # bulkhead
           plate(x1 - t, x1, Y0 + 0.16, Y0 + 0.6, Z0 - g, Z0 + g), plate(x1 - t, x1, Y0 - 0.6, Y0 - 0.16, Z0 - g, Z0 + g),
           plate(e[0] + 0.1, e[0] + 0.112, Y0 - 0.5, Y0 + 0.5, Z0 - 0.6, Z0 + 0.7),                                            # wall ahead
           plate(x2, e[0] + 0.1, Y0 - 0.5, Y0 + 0.5, Z0 - 0.072, Z0 - 0.06),                                                   # floor after the tunnel
           sph([e[0] - 0.02, Y0 + 0.15, Z0 + 0.2], 0.04), cyl([x2 + 0.05, Y0 - 0.16, Z0 - 0.06], [x2 + 0.05, Y0 - 0.16, Z0 + 0.5], 0.02),
           plate(x1, x2 + 0.05, Y0 - 0.3, Y0 + 0.3, Z0 + 0.33, Z0 + 0.342)]                                                  # a shelf above the tunnel
    return (f"A bulkhead {x1 - X0:.2f} m ahead (1.2 x 1.3 m) whose only opening is a tunnel 0.12 m tall and 0.32 m wide, "
            f"0.4 m long, on the start line (the 50 mm body has 35 mm above and below it; the tip's sensors 60 mm), its "
            f"ceiling a 12 mm plate; a floor runs on past its exit. A wall {e[0] + 0.1 - X0:.2f} m ahead, 0.40 m past the "
            f"tunnel's exit, bars the way on; a shelf over the tunnel. The goal {e[2] - Z0:.2f} m above the start line, "
            f"{e[0] - X0:.2f} m ahead (0.1 m in front of the wall): crawl through, then climb 90 deg (radius 0.3 m) just "
            "after the exit and go on up. A post beside the exit and a ball near the goal."), obs, [e], path, {"expected": "reached"}


# ---------------- 3. a blind duct whose only way on is a side window ----------------
@world
def side_exit():
    """a closed duct on the start line (0.15 x 0.2 m inside), capped 0.52 m ahead; the only way on: a window in its
    left wall; the goal on the start line behind the cap"""
    xa, xc = X0 + 0.03, X0 + 0.52; hw, hh, t = 0.075, 0.1, 0.006; wx0, wx1 = X0 + 0.08, X0 + 0.46
    path = Path([('S', 0.05)] + s_path([(0.0, (0.145, 0.0))]) + [('S', 0.12)] + s_path([(0.0, (-0.145, 0.0))]) + [('S', 0.03)])
    e, he = path.end()
    obs = [plate(xa, xc, Y0 - hw - t, Y0 + hw + t, Z0 + hh, Z0 + hh + t), plate(xa, xc, Y0 - hw - t, Y0 + hw + t, Z0 - hh - t, Z0 - hh),
           plate(xa, xc, Y0 - hw - t, Y0 - hw, Z0 - hh, Z0 + hh),                                                      # right wall
           plate(xa, wx0, Y0 + hw, Y0 + hw + t, Z0 - hh, Z0 + hh), plate(wx1, xc, Y0 + hw, Y0 + hw + t, Z0 - hh, Z0 + hh),  # left wall with window
           plate(wx0, wx1, Y0 + hw, Y0 + hw + t, Z0 - hh, Z0 - hh + 0.02), plate(wx0, wx1, Y0 + hw, Y0 + hw + t, Z0 + hh - 0.02, Z0 + hh),
           plate(xc, xc + 0.012, Y0 - hw - t, Y0 + hw + t, Z0 - hh - t, Z0 + hh + t),                                   # cap
           plate(xa - 0.012, xa, Y0 - 0.6, Y0 - hw - t, Z0 - 0.6, Z0 + 0.6), plate(xa - 0.012, xa, Y0 + hw + t, Y0 + 0.6, Z0 - 0.6, Z0 + 0.6),
           plate(xa - 0.012, xa, Y0 - hw - t, Y0 + hw + t, Z0 + hh + t, Z0 + 0.6), plate(xa - 0.012, xa, Y0 - hw - t, Y0 + hw + t, Z0 - 0.6, Z0 - hh - t),
           plate(xa, e[0] + 0.2, Y0 + 0.32, Y0 + 0.332, Z0 - 0.3, Z0 + 0.3),                                            # outer wall on the left
           end_wall(e), sph([xc + 0.09, Y0 - 0.1, Z0 + 0.03], 0.04), cyl([wx1 + 0.05, Y0 + 0.24, Z0 - 0.3], [wx1 + 0.05, Y0 + 0.24, Z0 + 0.3], 0.015)]
    return (f"A bulkhead {xa - X0:.2f} m ahead whose only opening is the mouth of a closed duct on the start line (0.15 m "
            f"wide, 0.2 m tall inside, 6 mm walls), capped {xc - X0:.2f} m ahead: a blind corridor. The only way on is a "
            f"window in its left wall, {wx0 - X0:.2f}-{wx1 - X0:.2f} m ahead, 0.16 m tall. The goal on the start line "
            f"{e[0] - xc:.2f} m behind the cap (the straight line runs into it); a wall 0.32 m left of the line, an end wall, a "
            "ball behind the cap, a post by the window. Way: into the duct, S-bend 0.145 m left out through the window "
            "(the bend starts 20 mm inside the mouth; the way is short, since at the goal the arm, carried by the lathe, is already 0.14 m from the bulkhead), along the duct's outside, S-bend back onto the line behind the cap."), \
        obs, [e], path, {"expected": "reached"}


# ---------------- 4. mixed primitives and meshes, thin rods at oblique angles ----------------
def tube_mesh(name, a, b, r, n=32, m=24):
    a, b = np.array(a, float), np.array(b, float); d = b - a
    C = [a + d * k / (m - 1) for k in range(m)]; V, rings = sweep_tube(C, [d] * m, r, n)
    F = []
    for r1, r2 in zip(rings[:-1], rings[1:]): F += ring_faces(r1, r2)
    write_mesh(name, V, F); return len(F)


@world
def oblique_mix():
    """an open pipe (mesh) lying obliquely across the line, 9 thin rods (r 4 mm) at oblique angles round the way,
    a tilted box, two balls; way up-right over the pipe and back"""
    path = Path(s_path([(0.06, (-0.09, 0.12)), (0.14, (0.09, -0.12)), (0.1, None)]))
    e, he = path.end()
    pa = np.array([X0 + 0.28, Y0 - 0.35, Z0 - 0.25]); pb = np.array([X0 + 0.62, Y0 + 0.4, Z0 + 0.12])
    nf = tube_mesh('pipe.stl', [0, 0, 0], pb - pa, 0.045)
    obs = [{"type": "mesh", "path": "parts/pipe.stl", "position": [float(x) for x in pa], "rpy": [0.0, 0.0, 0.0], "scale": 1.0}]
    rng = np.random.default_rng(9046); P = path.P[::3]; rods = 0; tries = 0
    while rods < 9 and tries < 20000:
        tries += 1
        s = rng.uniform(0.15, path.L); p, h = path.at(s)
        d = unit(rng.normal(size=3)); 
        if abs(d @ h) > 0.6: continue                               # oblique to the way, not along it
        off = unit(np.cross(d, h)) * rng.uniform(0.07, 0.1) * rng.choice([-1, 1])
        c = p + off; L = rng.uniform(0.25, 0.45)
        o = cyl(c - d * L / 2, c + d * L / 2, 0.004)
        if float(sdf(o, P).min()) >= 0.066: obs.append(o); rods += 1
    obs += [box([X0 + 0.5, Y0 + 0.12, Z0 + 0.02], [0.05, 0.04, 0.12], (0.5, -0.3, 0.8)), sph([X0 + 0.18, Y0 + 0.1, Z0 + 0.1], 0.04),
            sph(e + np.array([0.02, 0.11, -0.07]), 0.03), end_wall(e)]
    return (f"Mixed primitives and a mesh, oblique: an open pipe (zero-thickness tube mesh, {nf} triangles, r 45 mm, "
            f"0.9 m long) lying across the start line {0.36:.2f}-0.55 m ahead, rising from right-low to left-high at about "
            f"60 deg to the line; {rods} thin rods (r 4 mm, 0.25-0.45 m long) at random oblique angles (at least 53 deg off "
            f"the way's heading), 70-100 mm from the way on either side; a box tilted about all three axes; two balls; the "
            f"goal on the start line {e[0] - X0:.2f} m ahead, an end wall behind it. Way: S-bend 0.09 m right and 0.12 m up over "
            "the pipe, S-bend back."), obs, [e], path, {"expected": "reached"}


# ---------------- 5. a goal near the arm's reach ----------------
@world
def edge_reach():
    """the goal 1.64 m ahead on the line behind a wall whose hole is 0.16 m right: lathe travel about 1.7 m of its
    2.0 m"""
    off = (-0.16, 0.0); Ls = s_len(off)
    path = Path([('S', 0.7)] + s_path([(0.0, off)]) + [('S', 0.04)] + s_path([(0.0, (0.16, 0.0))]) + [('S', 0.08)])
    e, he = path.end(); ph = path.at(0.7 + Ls + 0.02)[0]
    obs = plate_hole([ph[0], Y0, Z0], EY, EZ, EX, 0.5, 0.45, (ph[1] - Y0, 0.0), (0.08, 0.08), 0.006)
    obs += [end_wall(e, 0.12), sph([ph[0] + 0.12, Y0 - 0.02, Z0 + 0.12], 0.04), sph([ph[0] + 0.2, Y0 + 0.13, Z0 - 0.04], 0.035),
            cyl([ph[0] - 0.25, Y0 + 0.1, Z0 - 0.4], [ph[0] - 0.25, Y0 + 0.1, Z0 + 0.4], 0.02),
            cyl([ph[0] - 0.12, Y0 - 0.3, Z0 - 0.12], [ph[0] - 0.12, Y0 + 0.3, Z0 - 0.12], 0.015)]
    return (f"The goal on the start line {e[0] - X0:.2f} m ahead, {e[0] - ph[0]:.2f} m behind a wall ({ph[0] - X0:.2f} m ahead, 1.0 x "
            "0.9 m) whose only hole (0.16 m square) is 0.16 m right of the line; a post and a bar before the wall, two balls "
            f"behind it, an end wall. The way is {path.L:.2f} m long: a lathe travel of about 1.7 m of its 2.0 m, so the goal is "
            "near the edge of the robot's reach and a detour of more than about 0.3 m in length leaves it out of reach. "
            "Way: 0.7 m straight, S-bend 0.16 m right, through the hole, S-bend back onto the line."), obs, [e], path, {"expected": "reached"}


# ---------------- 6. a slow mover ahead in a duct: follow it ----------------
SL_V, SL_FACE0, SL_H = 0.02, 0.25, 0.055

def sl_tof(s, margin=0.07):
    """reference timing: the tip at s at the later of the usual pace (1 + s/0.055) and the mover's near face being
    `margin` ahead of it"""
    return max(1.0 + s / 0.055, (s + margin - SL_FACE0) / SL_V)


@world
def slow_leader():
    """a closed duct on the start line (0.2 m square inside); a block inside it moving away at 20 mm/s, too big to
    pass (45 mm a side); the goal 0.6 m ahead inside the duct: follow the block"""
    path = Path([('S', 0.6)]); e, he = path.end(); hw, t = 0.1, 0.006; xa, xb = X0 + 0.1, X0 + 1.0
    obs = [plate(xa, xb, Y0 - hw - t, Y0 + hw + t, Z0 + hw, Z0 + hw + t), plate(xa, xb, Y0 - hw - t, Y0 + hw + t, Z0 - hw - t, Z0 - hw),
           plate(xa, xb, Y0 + hw, Y0 + hw + t, Z0 - hw, Z0 + hw), plate(xa, xb, Y0 - hw - t, Y0 - hw, Z0 - hw, Z0 + hw),
           box([X0 + SL_FACE0 + SL_H, Y0, Z0], [SL_H, SL_H, SL_H], motion={"type": "linear", "velocity": [SL_V, 0.0, 0.0], "start": 0.0})]
    for dy, dz in [(1, 1), (1, -1), (-1, 1), (-1, -1)]:                                   # posts round the mouth
        obs.append(cyl([xa - 0.03, Y0 + dy * 0.2, Z0 + dz * 0.2], [xa - 0.03 + 0.3, Y0 + dy * 0.2, Z0 + dz * 0.2], 0.02))
    return ("A closed duct on the start line (0.2 x 0.2 m inside, 6 mm walls) from 0.1 to 1.0 m ahead. Inside it a "
            f"block (0.11 m cube, 45 mm from each wall: the 50 mm body cannot pass it) whose near face is {SL_FACE0} m ahead "
            f"of the start tip at t = 0 and which moves away along the duct at {SL_V * 1000:.0f} mm/s for ever (it leaves the "
            f"duct's far end at about 37 s). The goal on the line 0.6 m ahead, inside the duct: reachable only by following "
            "the block (its near face passes 0.67 m at 21 s); a robot at the usual pace (55 mm/s) catches it up at about "
            "7 s. The block is straight ahead of the tip all the time (visible to its sensors). Four posts round the mouth."), \
        obs, [e], path, {"expected": "reached (after about 21 s)", "mover_timing": True}


# ---------------- 7. a very small tolerance, in a pocket ----------------
@world
def tight_tol():
    """tolerance 3 mm: the goal 60 mm inside a pocket (0.12 m square, 0.16 m deep) whose mouth is 0.1 m right and
    0.05 m down of the line"""
    off = (-0.1, -0.05)
    path = Path(s_path([(0.08, off), (0.2, None)])); e, he = path.end()
    L1 = 0.08 + s_len(off); m = path.at(L1 + 0.14)[0]                                     # the pocket's mouth
    hw, t, dep = 0.06, 0.008, 0.16
    obs = [plate(m[0], m[0] + dep, m[1] - hw - t, m[1] + hw + t, m[2] + hw, m[2] + hw + t), plate(m[0], m[0] + dep, m[1] - hw - t, m[1] + hw + t, m[2] - hw - t, m[2] - hw),
           plate(m[0], m[0] + dep, m[1] + hw, m[1] + hw + t, m[2] - hw, m[2] + hw), plate(m[0], m[0] + dep, m[1] - hw - t, m[1] - hw, m[2] - hw, m[2] + hw),
           plate(m[0] + dep, m[0] + dep + t, m[1] - hw - t, m[1] + hw + t, m[2] - hw - t, m[2] + hw + t),
           sph([m[0] - 0.05, Y0 + 0.06, Z0 + 0.05], 0.04), cyl([m[0] - 0.12, Y0 - 0.3, m[2] + 0.13], [m[0] - 0.12, Y0 + 0.3, m[2] + 0.13], 0.015)]
    return (f"A pocket (a box open towards the robot, 0.12 m square inside, 0.16 m deep) whose mouth is {m[0] - X0:.2f} m "
            "ahead, 0.1 m right and 0.05 m down of the start line; the goal on its axis 60 mm inside the mouth (100 mm from "
            "its bottom, 60 mm from its sides) with a tolerance of 3 mm: the tip must pass within 3 mm of the point. A ball "
            "left of the way, a bar above it. Way: S-bend 0.1 m right and 0.05 m down, straight into the pocket."), \
        obs, [e], path, {"expected": "reached", "tolerance": 0.003}


@world
def pinpoint():
    """tolerance 1 mm: the goal 0.17 m behind a wall whose hole is 0.08 m up, back on the start line"""
    path = Path(s_path([(0.05, (0.0, 0.08)), (0.04, (0.0, -0.08)), (0.1, None)])); e, he = path.end()
    L1 = 0.05 + s_len((0.0, 0.08)); ph = path.at(L1 + 0.02)[0]
    obs = plate_hole([ph[0], Y0, Z0], EY, EZ, EX, 0.45, 0.45, (0.0, ph[2] - Z0), (0.08, 0.08), 0.006)
    obs += [end_wall(e, 0.1), sph([ph[0] + 0.1, Y0 + 0.1, Z0 + 0.03], 0.035), cyl([ph[0] + 0.08, Y0 - 0.09, Z0 - 0.3], [ph[0] + 0.08, Y0 - 0.09, Z0 + 0.3], 0.012)]
    return (f"A wall {ph[0] - X0:.2f} m ahead, its 0.16 m hole 0.08 m up of the start line; the goal on the start line "
            f"{e[0] - ph[0]:.2f} m behind it with a tolerance of 1 mm (the tip must pass within 1 mm of the point: at the "
            "usual 55 mm/s the tip moves about 1.8 mm per control step); an end wall 0.1 m behind the goal, a ball and a "
            "post beside the way behind the wall. Way: S-bend 0.08 m up, through the hole, S-bend back."), \
        obs, [e], path, {"expected": "reached", "tolerance": 0.001}


# ---------------- 8. more than 300 small clutter items ----------------
@world
def clutter400():
    """400 small items (balls r 8-16 mm, boxes 6-14 mm rotated, rods r 3-5 mm 40-90 mm long) filling a 0.64 m
    cube from 0.22 m ahead; none within 74 mm of the way (S-bend left-down and back)"""
    path = Path(s_path([(0.12, (0.1, -0.08)), (0.16, (-0.1, 0.08)), (0.12, None)])); e, he = path.end()
    from scipy.spatial import cKDTree
    tree = cKDTree(path.P); rng = np.random.default_rng(9400); obs = []; n = [0, 0, 0]
    while len(obs) < 400:
        c = np.array([X0 + rng.uniform(0.22, 0.86), Y0 + rng.uniform(-0.32, 0.32), Z0 + rng.uniform(-0.32, 0.32)])
        k = rng.integers(3)
        if k == 0: r = rng.uniform(0.008, 0.016); o = sph(c, r); R = r
        elif k == 1:
            hx = rng.uniform(0.006, 0.014, 3); o = box(c, hx, rng.uniform(-math.pi, math.pi, 3)); R = float(np.linalg.norm(hx))
        else:
            d = unit(rng.normal(size=3)); L = rng.uniform(0.04, 0.09); o = cyl(c - d * L / 2, c + d * L / 2, rng.uniform(0.003, 0.005)); R = L / 2 + 0.005
        if tree.query(c)[0] - R < 0.074: continue
        if tree.query(c)[0] < 0.12 and float(sdf(o, path.P[tree.query_ball_point(c, 0.12)]).min()) < 0.074: continue
        obs.append(o); n[k] += 1
    obs.append(end_wall(e, 0.1))
    return (f"400 small items in a 0.64 m cube from 0.22 m ahead: {n[0]} balls (r 8-16 mm), {n[1]} boxes (half sizes 6-14 mm, "
            f"random roll, pitch, yaw), {n[2]} rods (r 3-5 mm, 40-90 mm long, random directions); none within 74 mm of the "
            "reference tip path (S-bend 0.1 m left and 0.08 m down and back), so a winding lane about 0.15 m wide runs "
            f"through; elsewhere the items are about 80 mm apart on average. The goal on the start line {e[0] - X0:.2f} m "
            "ahead, just beyond the cube, an end wall behind it."), obs, [e], path, {"expected": "reached"}


# ---------------- 9. start inside a sleeve ----------------
@world
def start_sleeve():
    """the body starts inside a square sleeve (0.12 m inside: 35 mm round the body) from 0.42 m behind the start tip
    to 0.1 m ahead of it; a wall 0.52 m ahead; the goal 0.3 m right: turn right as soon as the tip is out"""
    path = Path([('S', 0.13), ('A', 0.3, 80, RIGHT), ('S', 0.1)]); e, he = path.end()
    xa, xb, hw, t = X0 - 0.42, X0 + 0.1, 0.06, 0.008
    obs = [plate(xa, xb, Y0 - hw - t, Y0 + hw + t, Z0 + hw, Z0 + hw + t), plate(xa, xb, Y0 - hw - t, Y0 + hw + t, Z0 - hw - t, Z0 - hw),
           plate(xa, xb, Y0 + hw, Y0 + hw + t, Z0 - hw, Z0 + hw), plate(xa, xb, Y0 - hw - t, Y0 - hw, Z0 - hw, Z0 + hw),
           plate(X0 + 0.52, X0 + 0.532, Y0 - 0.5, Y0 + 0.3, Z0 - 0.4, Z0 + 0.4),                # wall ahead
           plate(X0 + 0.1, X0 + 0.532, Y0 + 0.1, Y0 + 0.112, Z0 - 0.4, Z0 + 0.4),              # wall on the left
           plate(e[0] - 0.15, e[0] + 0.15, e[1] - 0.1, e[1] - 0.088, Z0 - 0.4, Z0 + 0.4),      # wall beyond the goal
           sph([X0 + 0.16, Y0 - 0.18, Z0 + 0.12], 0.035), cyl([xb + 0.03, Y0 - 0.3, Z0 - 0.12], [xb + 0.03, Y0 + 0.1, Z0 - 0.12], 0.012)]
    return (f"The serpentine starts inside a square sleeve (0.12 m inside, 8 mm walls: 35 mm round the body, 60 mm round "
            f"the tip) from 0.42 m behind the start tip to 0.1 m ahead of it. A wall 0.52 m ahead and one 0.1 m left of the "
            f"line; the goal {Y0 - e[1]:.2f} m right of the line, {e[0] - X0:.2f} m ahead, a wall beyond it: the robot must "
            "turn right (80 deg, radius 0.3 m) as soon as the tip leaves the sleeve, while the body is still in it. A ball "
            "and a bar (r 12 mm, 0.12 m below the line) by the sleeve's mouth."), obs, [e], path, {"expected": "reached"}


def mover_check(obs, path, tof, t_end=75.0):
    """tip and body (capsules r 25 mm on the path) against the movers with timing tof(s), from the start to the goal,
    and the robot left at the goal until t_end"""
    mv = [o for o in obs if 'motion' in o]; tip = 9.0; body = 9.0
    def bodyp(s): J, _ = path.joints(s); return J[0], np.vstack([seg(J[k], J[k + 1]) for k in range(6)])
    for s in np.arange(0.0, path.L + 1e-9, 0.005):
        ta, tb = tof(s), tof(min(path.L, s + 0.005)); T, B = bodyp(s)
        for o in mv:
            for tt in np.linspace(ta, tb, 3):
                off = motion_offset(o['motion'], tt)
                tip = min(tip, float(sdf(o, T[None], off)[0])); body = min(body, float(sdf(o, B, off).min()) - 0.025)
    T, B = bodyp(path.L); after = 9.0
    for o in mv:
        for tt in np.arange(tof(path.L), t_end, 0.05):
            after = min(after, float(sdf(o, B, motion_offset(o['motion'], tt)).min()) - 0.025)
    return round(tof(path.L), 2), round(tip, 4), round(body, 4), round(after, 4)


def write(name):
    desc, obs, goals, path, opt = W[name]()
    goals = [np.array(g, float) for g in goals]
    static = [o for o in obs if 'motion' not in o]
    ck = check(static, path, goals)
    ck['obstacles'] = len(obs)
    if opt.get('mover_timing'):
        tg, tp, bd, af = mover_check(obs, path, sl_tof)
        ck['mover'] = {"timing": "tip at s at t = max(1 + s/0.055, (s + 0.07 - 0.25)/0.02): the usual pace, held 70 mm behind the block",
                       "reference_goal_time": tg, "tip_to_mover": tp, "body_to_mover_until_goal": bd,
                       "body_to_mover_after_goal_until_75s": af,
                       "usual_pace_tip_to_mover": round(min(float(sdf(obs[4], path.at(s)[0][None], motion_offset(obs[4]['motion'], 1 + s / 0.055))[0])
                                                            for s in np.arange(0, path.L, 0.005)), 4)}
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    pts = np.array(path.P[::25].tolist() + [path.P[-1].tolist()])
    note = "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm"
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h9-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": opt.get('tolerance', 0.02)} for g in goals],
         "time_limit": 75.0}
    w['extra'] = {"reference_path": {
                      "commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [round(float(x), 6) for x in c[3]]] for c in path.cmds],
                      "note": note, "start_tip_world": [round(float(v), 6) for v in path.start],
                      "points": [[round(float(v), 4) for v in p] for p in pts]},
                  "checks": ck, "expected": opt.get('expected'),
                  "generator": "worlds/hard9/make.py (session 46 helper; hard5's make.py imported as a library)"}
    json.dump(rnd(w), open(os.path.join(OUT, name + '.json'), 'w'), indent=1)
    return ck


if __name__ == '__main__':
    for n in sys.argv[1:] or list(W):
        ck = write(n)
        ok = (ck['tip_clearance'] >= 0.058 and ck['body_clearance'] >= 0.0269 and ck['arm_clearance'] >= 0.052
              and ck['lathe_travel'] <= 1.8 and ck['flange_off_axis'] < 0.005 and ck['curved_part'] <= 1.2
              and max(ck['goal_on_path']) < 0.003
              and ck.get('mover', {}).get('body_to_mover_until_goal', 1.0) >= 0.0269
              and ck.get('mover', {}).get('tip_to_mover', 1.0) >= 0.058)
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
