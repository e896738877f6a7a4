"""Own generator, held-out batch 11 (a helper acting as an outside user). Does not use navstack.generate.
hard5's generator (worlds/hard5/make.py) is imported as a library (importlib), as worlds/hard6..10/make.py do:
its Path (straight legs and arcs of radius >= 0.28 m from the start tip P0 heading +x), primitives, exact signed
distances, `check` (tip / serpentine body / arm clearances along the reference path, lathe travel, flange off the
lathe axis; movers at the assumed timing and at their worst over later times) and `rnd`; nothing is copied.
Every world is built round its reference tip path in the canonical frame; goals give only the destination
(`tilt_spiral`: five inspection points in order). Three are not counted as reachable: `pinhole_goal` is unreachable
by design (its goal ball lies wholly inside a hole narrower than the body); `arm_graze` (a rod flicks over the arm
at 5 m/s, 0.5 mm deep) and `dust_line` (motes of 0.1-0.2 mm on the straight way, below any ray's resolution) are
built to collide: they test the contact check, not the planner.
Usage: python make.py [name ...]   (writes <this folder>/<name>.json; prints each world's checks, OK/BAD)"""
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
                        box, cyl, sph, plate_hole, sdf, dist, check, rnd, arm_pts)

W = {}
def world(fn): W[fn.__name__] = fn; return fn

EY, EZ = np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
DT = 1.0 / 30.0          # navstack's default control period (30 Hz)


def plate(x0, x1, y0, y1, z0, z1):
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def s_curve(off, R=0.3):
    o = np.array([0.0, off[0], off[1]]); d = unit(o); th = S_curve(R, float(np.linalg.norm(o)))
    return [('A', R, th, tuple(d)), ('A', R, th, tuple(-d))]


def s_len(off, R=0.3):
    """x advance of an S-bend of lateral offset |off|"""
    return 2 * R * math.sin(math.radians(S_curve(R, off)))


def closed_room(x0, depth, hy, hz, t=0.006, yc=Y0, zc=Z0):
    """side, top, bottom and back walls of a room behind a front wall at x0 (inner |y-yc| < hy, |z-zc| < hz)"""
    x1 = x0 + depth
    return [plate(x0, x1, yc - hy - 2 * t, yc - hy, zc - hz - 2 * t, zc + hz + 2 * t),
            plate(x0, x1, yc + hy, yc + hy + 2 * t, zc - hz - 2 * t, zc + hz + 2 * t),
            plate(x0, x1, yc - hy, yc + hy, zc + hz, zc + hz + 2 * t),
            plate(x0, x1, yc - hy, yc + hy, zc - hz - 2 * t, zc - hz),
            plate(x1, x1 + 2 * t, yc - hy - 2 * t, yc + hy + 2 * t, zc - hz - 2 * t, zc + hz + 2 * t)]


# ---------------- 1. a slit 3 mm wider than the body on each side, in a 1 mm sheet ----------------
@world
def slit_3mm():
    """a 1 mm sheet across the way, its only opening a 56 mm slit on the start line (3 mm each side of the
    50 mm body); a closed room behind; the goal 0.25 m in on the line"""
    xw = X0 + 0.35; h = 0.0005
    path = Path([('S', 0.6)]); e, _ = path.end()
    obs = plate_hole([xw + h, Y0, Z0], EY, EZ, EX, 0.6, 0.5, (0.0, 0.0), (0.028, 0.1), h)
    obs += closed_room(xw + 2 * h, 0.4, 0.2, 0.2)
    obs += [sph([X0 + 0.15, Y0 + 0.15, Z0 + 0.1], 0.03)]
    return ("A sheet 1 mm thick (1.2 x 1.0 m) 0.35 m ahead across the start line; its only opening a vertical slit 56 mm wide, "
            "0.2 m tall, centred on the line: 3 mm each side of the 50 mm body, the slit's edges the sheet's 1 mm faces. A "
            "closed room behind it (0.4 m square, 0.4 m deep). The goal 0.25 m behind the sheet on the line. Way: straight "
            "on (body 3.0 mm from both edges, tip 28 mm)."), obs, [e], path, \
        {"expected": "reachable only 3 mm a side; a stall without contact is honest, any contact is a collision",
         "need": (0.027, 0.0029)}


# ---------------- 2. a goal whose tolerance ball barely reaches out of a wall's forbidden zone ----------------
@world
def near_wall_goal():
    """the goal 2 mm in front of a wall, tolerance 27 mm: the tip (capsule radius 25 mm) must come within 4 mm of
    the wall head-on (less if oblique)"""
    xf = X0 + 0.55; yg = Y0 + 0.1
    g = np.array([xf - 0.002, yg, Z0])
    sl = s_len(0.1)
    path = Path([('S', 0.05)] + s_curve((0.1, 0.0)) + [('S', xf - 0.028 - (X0 + 0.05 + sl))])
    obs = [plate(xf, xf + 0.012, Y0 - 0.6, Y0 + 0.6, Z0 - 0.5, Z0 + 0.5),
           cyl([X0 + 0.3, Y0 - 0.12, Z0 - 0.4], [X0 + 0.3, Y0 - 0.12, Z0 + 0.4], 0.02),
           sph([xf - 0.06, yg + 0.12, Z0 + 0.05], 0.03)]
    return ("A wall 0.55 m ahead (1.2 x 1.0 m); the goal 2 mm in front of its face, 0.1 m left of the line, tolerance 27 mm: "
            "the tip's capsule (radius 25 mm) may come no nearer than the wall itself, so the goal counts only with the tip "
            "within 4 mm of the wall head-on (at 3 mm the tip is 26 mm from the goal). A post right of the line, a ball near "
            "the goal. Way: 0.05 m on, S-bend 0.1 m left, straight to the tip 28 mm from the face (clearance 3 mm)."), \
        obs, [g], path, {"expected": "reached only with the tip <= 4 mm from the wall; a stall is honest",
                         "tolerance": 0.027, "offpath": True, "need": (0.0279, 0.0029)}


# ---------------- 3. a goal ball wholly inside a hole narrower than the body ----------------
@world
def pinhole_goal():
    """a block 50 mm thick with a 46 mm square hole; the goal mid-way in the hole, tolerance 10 mm: every point of
    the goal ball is < 25 mm from the hole's walls, so the tip cannot count it without touching: unreachable"""
    xb = X0 + 0.5; yh = Y0 + 0.05
    g = np.array([xb + 0.025, yh, Z0])
    sl = s_len(0.05)
    path = Path([('S', 0.05)] + s_curve((0.05, 0.0)) + [('S', xb - 0.03 - (X0 + 0.05 + sl))])
    obs = plate_hole([xb + 0.025, Y0, Z0], EY, EZ, EX, 0.6, 0.5, (0.05, 0.0), (0.023, 0.023), 0.025)
    obs += [cyl([X0 + 0.25, Y0 + 0.2, Z0 - 0.4], [X0 + 0.25, Y0 + 0.2, Z0 + 0.4], 0.02)]
    return ("A block 50 mm thick (1.2 x 1.0 m) 0.5 m ahead with one square hole 46 mm wide, 0.05 m left of the line; the goal "
            "in the middle of the hole (25 mm in from either face), tolerance 10 mm. Every point of the goal ball lies inside "
            "the hole, < 25 mm (at most 23 mm) from its walls, and the tip's capsule has radius 25 mm: no tip position that "
            "counts the goal is free. UNREACHABLE by design. The reference path is the approach, ending 30 mm in front."), \
        obs, [g], path, {"expected": "never a success: stalled or timeout, 0 contacts", "unreachable": True,
                         "tolerance": 0.01, "offpath": True}


# ---------------- 4. a blade edge-on on the start line ----------------
@world
def blade_edge():
    """a 0.5 mm x 0.9 m x 0.6 m blade standing on the start line, its 0.5 mm edge facing the tip; the goal 70 mm to
    its left, 0.75 m ahead"""
    path = Path([('S', 0.05)] + s_curve((0.07, 0.0)) + [('S', 0.75 - 0.05 - s_len(0.07))])
    e, _ = path.end()
    obs = [box([X0 + 0.8, Y0, Z0], [0.45, 0.00025, 0.3]),
           plate(X0 + 1.3, X0 + 1.312, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5),
           sph([X0 + 0.55, Y0 + 0.2, Z0 - 0.08], 0.035)]
    return ("A blade (box 0.5 mm x 0.9 m x 0.6 m, half extents 0.25 mm, 0.45 m, 0.3 m) standing on the start line from 0.35 "
            "to 1.25 m ahead, its plane vertical and along the line: the tip meets its 0.5 mm edge head-on (an aspect ratio "
            "of 1800). The goal 70 mm left of the blade's plane, 0.75 m ahead. A wall behind, a ball to the left. Way: 0.05 m "
            "on, S-bend 70 mm left, on beside the blade (body >= 36.7 mm from it)."), obs, [e], path, {"expected": "reached", "need": (0.058, 0.0269)}


# ---------------- 5. a 1 mm-radius wire slanted across the only hole ----------------
@world
def wire_slant():
    """a 0.2 m square hole in a wall; a wire of radius 1 mm slants across it at 35 deg, 30 mm in front of the wall,
    20 mm off the hole's centre: the straight line hits it; the lower right quarter is clear"""
    xw = X0 + 0.45
    path = Path([('S', 0.05)] + s_curve((-0.045, -0.045)) + [('S', 0.7 - 0.05 - s_len(math.hypot(0.045, 0.045)))])
    e, _ = path.end()
    obs = plate_hole([xw + 0.006, Y0, Z0], EY, EZ, EX, 0.7, 0.6, (0.0, 0.0), (0.1, 0.1), 0.006)
    d = np.array([0.0, math.cos(math.radians(35)), -math.sin(math.radians(35))])
    c = np.array([xw - 0.03, Y0 + 0.02, Z0])
    obs += [cyl(c - 0.2 * d, c + 0.2 * d, 0.001),
            cyl([X0 + 0.2, Y0 + 0.18, Z0 - 0.4], [X0 + 0.2, Y0 + 0.18, Z0 + 0.4], 0.02),
            plate(xw + 0.5, xw + 0.512, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("A wall 0.45 m ahead (1.4 x 1.2 m) with one 0.2 m square hole centred on the start line. 30 mm in front of the "
            "wall a wire (radius 1 mm, 0.4 m long, ends free) slants across the hole at 35 deg (rising to the left), "
            "passing 20 mm left of the hole's centre: the straight line meets it (body 11 mm into it). Above-left of the wire "
            "the body would have 26 mm; below-right 30 mm from the hole's edges, 49 mm from the wire. The goal 0.25 m "
            "behind the wall, 45 mm right, 45 mm down. Way: 0.05 m on, S-bend (45, 45) mm right-down, straight through (tip 55 mm, body 30 mm)."), \
        obs, [e], path, {"expected": "reached", "need": (0.054, 0.0269)}


# ---------------- 6. an obstacle that drops onto the straight way after the start ----------------
@world
def drop_in():
    """a ball (r 50 mm) 0.45 m above the start line 0.35 m ahead descends at 0.15 m/s from t = 1 s to 4 s and stays
    on the line: the straight way, free at t = 0, is closed from 4 s"""
    xb = X0 + 0.35
    off = 0.13; sl = s_len(off)
    path = Path([('S', 0.02)] + s_curve((off, 0.0)) + s_curve((-off, 0.0)) + [('S', 0.85 - 0.02 - 2 * sl)])
    e, _ = path.end()
    obs = [sph([xb, Y0, Z0 + 0.45], 0.05, motion={"type": "linear", "velocity": [0.0, 0.0, -0.15], "start": 1.0, "stop": 4.0}),
           plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5),
           cyl([X0 + 0.55, Y0 - 0.1, Z0 - 0.4], [X0 + 0.55, Y0 - 0.1, Z0 + 0.4], 0.02),
           sph([X0 + 0.6, Y0 + 0.25, Z0 + 0.05], 0.03)]
    return ("Open ahead at t = 0: the straight line to the goal (0.85 m ahead, on the line) is free. A ball (r 50 mm) hangs "
            "0.45 m above the line 0.35 m ahead; from t = 1 s to 4 s it descends at 0.15 m/s and then stays ON the line, "
            "closing the straight way (the tip is about 0.17 m ahead at 4 s at 0.055 m/s). A post right, a ball left, a "
            "wall behind the goal. Way: 0.02 m on, S-bend 0.13 m left, S-bend back (body >= 32 mm from the ball at its place for the assumed timing and later)."), \
        obs, [e], path, {"expected": "reached"}


# ---------------- 7/8. a rod that flicks in beside the arm (stays 3 mm off) / flicks over it (0.5 mm deep) ----------------
ARM_TOP = np.array([0.108, 1.21605])      # (y, z) of DH origin 7, the arm's highest capsule end (start posture)


def _arm_rod_clear(y, z, r):
    """least distance (m) from an x-parallel line at (y, z) to the arm's capsules (r 0.06), minus the rod's radius r
    (the arm only translates along x with the lathe, so this holds at any lathe position)"""
    P = arm_pts(0.0)[:, 1:]
    return float(np.min(np.hypot(P[:, 0] - y, P[:, 1] - z))) - 0.06 - r


@world
def arm_blip():
    """a rod parallel to the lathe, 0.15 m left of the arm's side, jumps in at 3 m/s at t = 2.0-2.05 s and stays 3 mm
    from the arm (whatever the lathe's travel): a boundary success"""
    r = 0.01; z = 1.07; y = 0.108 + 0.06 + r + 0.003
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([-0.4, y + 0.15, z], [2.5, y + 0.15, z], r,
               motion={"type": "linear", "velocity": [0.0, -3.0, 0.0], "start": 2.0, "stop": 2.05}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 + 0.05], 0.03),
           plate(e[0] + 0.15, e[0] + 0.162, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("A rod (r 10 mm, x -0.4 .. 2.5 m, parallel to the lathe) 0.15 m left of the arm's side at z 1.07 m; at t = 2.0 s "
            "it moves 0.15 m right at 3 m/s (for 0.05 s, 1.5 control steps) and stays 3 mm from the arm's capsule (r 60 mm), "
            "whatever the lathe's position (the arm only slides along x). The goal 0.5 m straight ahead (rod 0.12 m from "
            "the serpentine on the line). A ball right of the line, a wall behind the goal. Success with the arm 3 mm from "
            "the rod, unless the arm's joints move towards it."), obs, [e], path, \
        {"expected": "reached; least clearance 3.0 mm (arm to rod)", "arm_rod": (y, z, r)}


@world
def arm_graze():
    """a rod parallel to the lathe flicks across over the arm's top at 5 m/s (0.6 m in 0.12 s), passing 0.5 mm INTO
    the arm's capsule for about 3 ms, between two control steps: built to collide"""
    r = 0.01; z = ARM_TOP[1] + 0.06 + r - 0.0005
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([0.0, ARM_TOP[0] - 0.3, z], [1.2, ARM_TOP[0] - 0.3, z], r,
               motion={"type": "linear", "velocity": [0.0, 5.0, 0.0], "start": 3.01, "stop": 3.13}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 + 0.05], 0.03),
           plate(e[0] + 0.15, e[0] + 0.162, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("A rod (r 10 mm, x 0 .. 1.2 m, parallel to the lathe) 0.3 m right of the arm, 0.5 mm lower than would clear the "
            "arm's top (DH origin 7, z 1.216 m + 60 mm); from t = 3.01 s to 3.13 s it flicks 0.6 m left at 5 m/s over the "
            "arm and stays 0.3 m left of it. It overlaps the arm's capsule by up to 0.5 mm for about 3.3 ms (16.7 mm of its "
            "travel), between two control steps. Unavoidable (nothing warns of it): BUILT TO COLLIDE; a test of the contact "
            "check. The goal 0.5 m straight ahead."), obs, [e], path, \
        {"expected": "collision (1 contact step, about -0.5 mm) at about 3.05 s", "collide": True, "arm_rod": (ARM_TOP[0], z, r)}


# ---------------- 9. a post vibrating at exactly the control rate beside a slot ----------------
@world
def alias_post():
    """the left edge of a slot is a post vibrating 20 mm along the slot at 30 Hz (period = the control period),
    phased so that at every control step it is at its retracted extreme: the sensors always see it there, it comes
    40 mm further into the slot in between"""
    xw = X0 + 0.4; A = 0.02; r = 0.01; cp = 0.06
    path = Path([('S', 0.05)] + s_curve((-0.02, 0.0)) + [('S', 0.7 - 0.05 - s_len(0.02))])
    e, _ = path.end()
    obs = [plate(xw, xw + 0.012, Y0 - 0.6, Y0 - 0.07, Z0 - 0.5, Z0 + 0.5),
           plate(xw, xw + 0.012, Y0 + 0.095, Y0 + 0.6, Z0 - 0.5, Z0 + 0.5),
           plate(xw, xw + 0.012, Y0 - 0.07, Y0 + 0.095, Z0 + 0.1, Z0 + 0.5),
           plate(xw, xw + 0.012, Y0 - 0.07, Y0 + 0.095, Z0 - 0.5, Z0 - 0.1),
           cyl([xw + 0.006, Y0 + cp, Z0 - 0.098], [xw + 0.006, Y0 + cp, Z0 + 0.098], r,
               motion={"type": "oscillate", "axis": [0.0, -1.0, 0.0], "amplitude": A, "period": DT, "phase": -math.pi / 2}),
           plate(xw + 0.45, xw + 0.462, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5),
           sph([X0 + 0.2, Y0 + 0.15, Z0 - 0.05], 0.03)]
    worst = [o if 'motion' not in o else cyl([xw + 0.006, Y0 + cp - A, Z0 - 0.098], [xw + 0.006, Y0 + cp - A, Z0 + 0.098], r)
             for o in obs]
    return ("A wall 0.4 m ahead with one slot 0.2 m tall between y -70 mm (the wall's edge) and +95 mm; its left part is a "
            "vertical post (r 10 mm) vibrating along the slot, amplitude 20 mm, period 1/30 s (= navstack's control period, "
            "peak 3.8 m/s), phase -pi/2: at every control step it sits at its retracted extreme (slot side at +70 mm), so "
            "the sensors see a slot from -70 to +70 mm; between steps it reaches +30 mm. The body on the start line keeps "
            "5 mm; the true free part is -70 .. +30 mm (centre -20 mm). The goal 0.3 m behind the wall, 20 mm right. Way: "
            "S-bend 20 mm right, straight (body 25 mm from both at their worst)."), obs, [e], path, \
        {"expected": "reached; contact if the body goes more than 5 mm left of the line at the slot", "check_obs": worst, "need": (0.049, 0.0249)}


# ---------------- 10. five goals on a descending, turning-back arc round a post ----------------
@world
def tilt_spiral():
    """five inspection points in order on a 150 deg arc (radius 0.3 m) bending left and down (plane tilted 31 deg),
    round a post: the tour turns back towards the robot while descending 0.29 m"""
    bend = tuple(unit([0.0, 1.0, -0.6]))
    path = Path([('S', 0.05), ('A', 0.3, 150.0, bend)])
    c = P0 + EX * 0.05 + 0.3 * np.array(bend)
    ss = [0.05 + 0.3 * math.radians(a) for a in (30, 60, 90, 120, 150)]
    goals = [path.at(s)[0] for s in ss]
    rng = np.random.default_rng(1148)
    obs = [cyl(c - EZ * 0.5, c + EZ * 0.5, 0.05)]
    while len(obs) < 26:
        p = c + np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-0.5, 0.4)])
        o = sph(p, 0.02 + 0.02 * rng.random()) if rng.random() < 0.5 else \
            cyl(p - EZ * 0.1, p + EZ * 0.1, 0.01 + 0.01 * rng.random())
        if float(sdf(o, path.P[::5]).min()) < 0.09 or float(sdf(o, [P0 - EX * 0.3]).min()) < 0.4: continue
        if float(np.min(sdf(o, arm_pts(0.0)))) < 0.3: continue
        obs.append(o)
    return ("An inspection tour of FIVE points in order, every 30 deg along a 150 deg arc of radius 0.3 m bending left and "
            "down (its plane tilted 31 deg from horizontal), round a vertical post (r 50 mm) at the arc's centre: the last "
            "points lie behind the first, 0.29 m lower, the tip heading back towards the robot. 25 random balls and short "
            "rods around, none within 90 mm of the way. Tolerances 15 mm. Way: 0.05 m on, the arc (body >= 0.2 m from the "
            "post)."), obs, goals, path, {"expected": "reached, 5 goals", "tolerances": [0.015] * 5}


# ---------------- 11. motes far below the rays' resolution on the straight way (built to collide) ----------------
@world
def dust_line():
    """four motes (a ball r 0.1 mm, a cube of 0.2 mm rotated about three axes, a cylinder r 0.1 mm 0.4 mm long, a
    ball r 0.1 mm at 24.9 mm from the line) on the straight way: no ray can be relied on to see them, the body
    must pass over them: BUILT TO COLLIDE (a test of the contact check for tiny primitives)"""
    path = Path([('S', 0.75)]); e, _ = path.end()
    obs = [sph([X0 + 0.15, Y0 + 0.01, Z0 + 0.005], 0.0001),
           box([X0 + 0.30, Y0 - 0.012, Z0], [0.0001, 0.0001, 0.0001], [0.3, 0.5, 0.7]),
           cyl([X0 + 0.45, Y0, Z0 + 0.015 - 0.0002], [X0 + 0.45, Y0, Z0 + 0.015 + 0.0002], 0.0001),
           sph([X0 + 0.60, Y0, Z0 - 0.0249], 0.0001),
           plate(e[0] + 0.15, e[0] + 0.162, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("Four motes on the straight way to a goal 0.75 m ahead: a ball r 0.1 mm 0.15 m ahead 11 mm off the line; a cube "
            "0.2 mm wide (rotated 0.3, 0.5, 0.7 rad) 0.30 m ahead 12 mm right; a cylinder r 0.1 mm, 0.4 mm long, 0.45 m ahead "
            "15 mm up; a ball r 0.1 mm 0.60 m ahead 24.9 mm below the line (0.2 mm inside the body's surface). Nothing else "
            "but a wall behind the goal. The body passes over each (the first three stay inside it, 10-15 mm from its axis, "
            "as the body slides on; the last is brushed 0.2 mm deep). BUILT TO COLLIDE: every control step with a mote "
            "inside a link must count."), obs, [e], path, \
        {"expected": "collision (contact steps from the tip's arrival at 0.15 m on)", "collide": True, "need": (0.0, -1.0)}


# ---------------- 12. a sheet 9.98 m tall, 0.2 mm thick, its face 0.2 mm inside the straight way ----------------
@world
def tall_sheet():
    """a sheet 0.2 mm thick, 0.3 m long and 9.98 m tall (just under navstack's 10 m "large" threshold) beside the
    way, its face 24.8 mm from the line: the straight way brushes it 0.2 mm deep; reachable 40 mm to its left"""
    off = 0.04; sl = s_len(off)
    path = Path([('S', 0.02)] + s_curve((off, 0.0)) + [('S', 0.47 - 0.02 - sl)] + s_curve((-off, 0.0))
                + [('S', 0.7 - 0.47 - sl)])
    e, _ = path.end()
    obs = [box([X0 + 0.3, Y0 - 0.0249, Z0 + 1.0], [0.15, 0.0001, 4.99]),
           plate(e[0] + 0.15, e[0] + 0.162, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("A sheet (box half extents 0.15 m, 0.1 mm, 4.99 m: 0.3 m x 0.2 mm x 9.98 m) 0.15-0.45 m ahead, standing in the "
            "plane y = line - 24.9 mm, its face 24.8 mm right of the start line: the straight way to the goal (0.7 m ahead on "
            "the line) brushes it 0.2 mm deep (the body's surface 24.9-25 mm off the line) over 0.3 m plus the body's "
            "length. Its size is just below the 10 m from which navstack measures every primitive exactly at every step. "
            "Way: 0.02 m on, S-bend 40 mm left, on past the sheet, S-bend back to the line."), obs, [e], path, \
        {"expected": "reached if the body keeps left of the sheet; collision (0.2 mm deep) if it keeps to the line",
         "need": (0.04, 0.015)}


# ---------------- 13. a rod buzzing at 1 kHz 0.21 mm from the arm at its nearest ----------------
@world
def buzz_arm():
    """a rod parallel to the lathe beside the arm (1.0 mm from its capsule at rest) vibrating towards it at 1 kHz
    (period 1 ms, the spec's least; amplitude 0.79 mm, peak 4.96 m/s): the arm comes within 0.21 mm of it about
    33 times per control step, the whole trial long, never touching: a boundary success"""
    r = 0.01; z = 1.07; A = 0.00079; y = Y0 + 0.06 + r + 0.001
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([-0.4, y, z], [2.5, y, z], r,
               motion={"type": "oscillate", "axis": [0.0, -1.0, 0.0], "amplitude": A, "period": 0.001, "phase": 0.0}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 + 0.05], 0.03),
           plate(e[0] + 0.15, e[0] + 0.162, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("A rod (r 10 mm, x -0.4 .. 2.5 m, parallel to the lathe) beside the arm's left side at z 1.07 m, 1.0 mm from the "
            "arm's capsule (r 60 mm) at rest, vibrating along y towards the arm: amplitude 0.79 mm, period 1 ms (the least "
            "the spec allows; peak speed 4.96 m/s, under the 5 m/s limit), so the arm comes within 0.21 mm of it 33 times "
            "per control step, whatever the lathe's position (the arm only slides along x). The goal 0.5 m straight ahead "
            "(the rod 0.12 m from the serpentine). A success with least clearance 0.21 mm, unless the arm's joints move "
            "towards it; a contact reported here would be a wrong failure."), obs, [e], path, \
        {"expected": "reached; least clearance 0.21 mm (arm to rod at the rod's extreme)", "arm_rod": (y - A, z, r), "need": (0.058, 0.0269)}


def write(name):
    desc, obs, goals, path, opt = W[name]()
    goals = [np.array(g, float) for g in goals]
    ck = check(opt.get('check_obs', obs), path, goals)
    ck['obstacles'] = len(obs)
    tols = opt.get('tolerances') or [opt.get('tolerance', 0.02)] * len(goals)
    if opt.get('offpath'):
        ck['goal_distance_from_path_end'] = round(float(np.linalg.norm(path.end()[0] - goals[-1])), 4)
    if 'check_obs' in opt:
        ck['movers_checked_at'] = "the post fixed at its extreme into the slot (hard5's any-time scan samples every 0.1 s, a whole number of its periods)"
    if 'arm_rod' in opt:
        ck['arm_to_rod_at_rest'] = round(_arm_rod_clear(*opt['arm_rod']), 5)
    if opt.get('unreachable'):
        g = goals[-1]; rng = np.random.default_rng(0)
        U = rng.normal(size=(4000, 3)); U = U / np.linalg.norm(U, axis=1)[:, None] * (rng.random(4000) ** (1 / 3))[:, None]
        B = np.vstack([g + U * tols[-1], g + U / np.linalg.norm(U, axis=1)[:, None] * tols[-1]])
        ck['goal_ball_max_clearance'] = round(float(dist(obs, B).max()), 5)
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    pts = np.array(path.P[::25].tolist() + [path.P[-1].tolist()])
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h11-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": tl} for g, tl in zip(goals, tols)],
         "time_limit": 75.0}
    w['extra'] = {"reference_path": {
                      "commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [round(float(x), 6) for x in c[3]]] for c in path.cmds],
                      "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm"
                              + ("; the goal is unreachable: the path is only the approach" if opt.get('unreachable') else ""),
                      "start_tip_world": [round(float(v), 6) for v in path.start],
                      "points": [[round(float(v), 4) for v in p] for p in pts]},
                  "checks": ck, "expected": opt.get('expected'),
                  "generator": "worlds/hard11/make.py (helper acting as an outside user; hard5's make.py imported as a library)"}
    with open(os.path.join(OUT, name + '.json'), 'w') as f:
        json.dump(rnd(w), f, indent=1)
    return ck, opt, tols, goals, path


if __name__ == '__main__':
    for n in sys.argv[1:] or list(W):
        ck, opt, tols, goals, path = write(n)
        tip_need, body_need = opt.get('need', (0.058, 0.0269))
        gd = ck.get('goal_distance_from_path_end')
        ok = (ck['tip_clearance'] >= tip_need and ck['body_clearance'] >= body_need and ck['arm_clearance'] >= 0.052
              and ck['lathe_travel'] <= 1.8 and ck['flange_off_axis'] < 0.005 and ck['curved_part'] <= 1.2
              and (max(ck['goal_on_path']) < 0.003 if gd is None else gd <= tols[-1])
              and ck.get('body_clearance_movers_worst_over_later_times', 1.0) >= body_need)
        if 'arm_rod' in opt:
            ok = ok and (ck['arm_to_rod_at_rest'] < 0 if opt.get('collide') else ck['arm_to_rod_at_rest'] >= (0.0002 if n == 'buzz_arm' else 0.0029))
        if opt.get('collide') and 'arm_rod' not in opt: ok = ck['body_clearance'] < 0
        if opt.get('unreachable'): ok = ck["goal_ball_max_clearance"] < 0.025 and ck["body_clearance"] >= 0.004
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
