"""Own generator, held-out batch 12 (a helper acting as an outside user). Does not use navstack.generate.
hard5's generator (worlds/hard5/make.py) is imported as a library (importlib), as worlds/hard6..11/make.py do:
its Path, primitives, exact signed distances, `check`, `arm_pts`, `rnd`; nothing is copied.
This batch: robots that are NOT the default size (robot.serpentine_radius / robot.arm_radius set per world).
hard5's `check` subtracts the DEFAULT radii (0.025 body, 0.06 arm) from axis distances; every clearance it reports
is therefore converted here to the world's own radii: body_r = body_clearance + 0.025 - rs, arm_r = arm_clearance
+ 0.06 - ra, tip_r = tip_clearance (a raw axis distance) - rs. Arm-to-rod clearances (rods parallel to the lathe)
are computed exactly (2-D point-to-segment in the y-z plane, the arm only slides along x) with the world's ra.
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
from hard5_make import (P0, X0, Y0, Z0, Q0, BASE, EX, unit, Path, S_curve,  # noqa: E402
                        box, cyl, sph, plate_hole, sdf, dist, check, rnd, arm_pts, seg)

W = {}
def world(fn): W[fn.__name__] = fn; return fn

EY, EZ = np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
ARM_TOP_Z = 1.21605


def plate(x0, x1, y0, y1, z0, z1):
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def s_curve(off, R=0.3):
    o = np.array([0.0, off[0], off[1]]); d = unit(o); th = S_curve(R, float(np.linalg.norm(o)))
    return [('A', R, th, tuple(d)), ('A', R, th, tuple(-d))]


def s_len(off, R=0.3):
    return 2 * R * math.sin(math.radians(S_curve(R, off)))


def closed_room(x0, depth, hy, hz, t=0.006, yc=Y0, zc=Z0):
    x1 = x0 + depth
    return [plate(x0, x1, yc - hy - 2 * t, yc - hy, zc - hz - 2 * t, zc + hz + 2 * t),
            plate(x0, x1, yc + hy, yc + hy + 2 * t, zc - hz - 2 * t, zc + hz + 2 * t),
            plate(x0, x1, yc - hy, yc + hy, zc + hz, zc + hz + 2 * t),
            plate(x0, x1, yc - hy, yc + hy, zc - hz - 2 * t, zc - hz),
            plate(x1, x1 + 2 * t, yc - hy - 2 * t, yc + hy + 2 * t, zc - hz - 2 * t, zc + hz + 2 * t)]


def arm_rod_clear(y, z, r, ra):
    """exact least distance from an x-parallel rod at (y, z), radius r, to the arm's capsules (radius ra) in the
    start posture: 2-D point-to-segment distance in the y-z plane (consecutive arm_pts samples lie on the arm's
    straight segments, so the union of their chords is the arm's axis)"""
    P = arm_pts(0.0)[:, 1:]; A, B = P[:-1], P[1:]; c = np.array([y, z])
    ab = B - A; L2 = np.einsum('ij,ij->i', ab, ab)
    t = np.clip(np.einsum('ij,ij->i', c - A, ab) / np.maximum(L2, 1e-18), 0, 1)
    return float(np.min(np.linalg.norm(A + ab * t[:, None] - c, axis=1))) - ra - r


def end_wall(e, d=0.15):
    return plate(e[0] + d, e[0] + d + 0.012, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)


def slot_world(rs, half_w, gap_note):
    xw = X0 + 0.5; yc = Y0 + 0.05
    path = Path([('S', 0.05)] + s_curve((0.05, 0.0)) + [('S', 0.75 - 0.05 - s_len(0.05))]); e, _ = path.end()
    obs = plate_hole([xw + 0.006, Y0, Z0], EY, EZ, EX, 0.6, 0.5, (0.05, 0.0), (half_w, 0.1), 0.006)
    obs += closed_room(xw + 0.012, 0.4, 0.2, 0.2, yc=yc)
    obs += [cyl([X0 + 0.18, Y0 - 0.12, Z0 - 0.4], [X0 + 0.18, Y0 - 0.12, Z0 + 0.4], 0.015)]
    return path, e, obs


# ---------------- 1. thick robot through a slot that fits it with 12 mm a side ----------------
@world
def thick_slot():
    rs = 0.045; hw = rs + 0.012
    path, e, obs = slot_world(rs, hw, "")
    return ("serpentine_radius 0.045 m (body 90 mm). A wall 12 mm thick 0.5 m ahead (1.2 x 1.0 m); its only opening a "
            "vertical slot 114 mm wide, 0.2 m tall, centred 50 mm left of the start line: 12 mm a side for this body. A "
            "closed room behind (0.4 m square, 0.4 m deep); the goal 0.25 m behind the wall, 50 mm left. A post right of "
            "the line. Way: 0.05 m on, S-bend 50 mm left, straight through the slot's middle."), obs, [e], path, \
        {"rs": rs, "expected": "reached (12 mm a side)", "need": (0.012 - 1e-4,)}


# ---------------- 2. the same layout, thin robot, slot 12 mm a side for IT (the default body would touch) ------
@world
def thin_slot():
    rs = 0.013; hw = rs + 0.012
    path, e, obs = slot_world(rs, hw, "")
    return ("serpentine_radius 0.013 m (body 26 mm). The same wall, room and post as thick_slot, the slot 50 mm wide "
            "(12 mm a side for this body; exactly the default 50 mm body's width, which would graze it). The goal 0.25 m "
            "behind the wall, 50 mm left. Way: 0.05 m on, S-bend 50 mm left, straight through the slot's middle."), \
        obs, [e], path, {"rs": rs, "expected": "reached (12 mm a side)", "need": (0.012 - 1e-4,)}


# ---------------- 3. thick robot, square hole 2 mm narrower than its diameter: unreachable ----------------
@world
def thick_gap_unreach():
    rs = 0.045; xw = X0 + 0.35
    path = Path([('S', 0.35 - 0.075)])
    g = np.array([X0 + 0.6, Y0, Z0])
    obs = plate_hole([xw + 0.006, Y0, Z0], EY, EZ, EX, 0.6, 0.5, (0.0, 0.0), (0.044, 0.044), 0.006)
    obs += closed_room(xw + 0.012, 0.4, 0.2, 0.2)
    obs += [sph([X0 + 0.15, Y0 + 0.15, Z0 + 0.1], 0.03)]
    return ("serpentine_radius 0.045 m (body 90 mm). A wall 12 mm thick 0.35 m ahead (1.2 x 1.0 m) whose only opening is a "
            "square hole 88 mm wide on the start line: 2 mm narrower than the body (the default 50 mm body would pass with "
            "19 mm a side). A closed room behind; the goal 0.25 m behind the wall on the line, tolerance 20 mm. No tip "
            "ball of radius 45 mm can cross the wall's plane through an 88 mm square: UNREACHABLE by design. The "
            "reference path is the approach only, ending 75 mm before the wall."), obs, [g], path, \
        {"rs": rs, "expected": "never a success: stalled or timeout (or collision if it pushes in)", "unreachable": True,
         "offpath": True}


# ---------------- 4. fat arm (0.1 m) beside a rod parallel to the lathe, 12 mm clear ----------------
@world
def fat_arm_rod():
    ra = 0.1; r = 0.01; z = 1.10; y = Y0 + ra + r + 0.012
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([-0.4, y, z], [2.5, y, z], r),
           cyl([-0.4, Y0 - 0.108 - ra - r - 0.03, 1.0], [2.5, Y0 - 0.108 - ra - r - 0.03, 1.0], r),
           sph([X0 + 0.3, Y0 - 0.15, Z0 + 0.05], 0.03), end_wall(e)]
    return ("arm_radius 0.1 m (default 0.06). A rod (r 10 mm, x -0.4 .. 2.5 m, parallel to the lathe) at z 1.10 m, 12 mm "
            "from the fat arm's capsule, whatever the lathe's position (52 mm from a default arm). A second rod on the "
            "right, lower. The goal 0.5 m straight ahead; a ball right of the line, a wall behind the goal. A success "
            "with the arm 12 mm from the rod."), obs, [e], path, \
        {"ra": ra, "expected": "reached; arm 12 mm from the rod", "arm_rod": [(y, z, r), (Y0 - 0.108 - ra - r - 0.03, 1.0, r)]}


# ---------------- 5. fat arm: a rod moves in to 3 mm INSIDE its capsule (37 mm clear of a default arm) -------
@world
def fat_arm_touch():
    ra = 0.1; r = 0.01; z = 1.10; y_end = Y0 + ra + r - 0.003; y0 = y_end + 0.15
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([-0.4, y0, z], [2.5, y0, z], r, motion={"type": "linear", "velocity": [0.0, -1.0, 0.0], "start": 2.0, "stop": 2.15}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 + 0.05], 0.03), end_wall(e)]
    return ("arm_radius 0.1 m. A rod (r 10 mm, parallel to the lathe, z 1.10 m) 0.15 m left of where it ends; from t = 2.0 "
            "s to 2.15 s it moves 0.15 m right at 1 m/s and stays 3 mm INSIDE the fat arm's capsule (37 mm clear of a "
            "default 60 mm arm), whatever the lathe's position. Nothing the tip senses warns of it; the arm cannot dodge. "
            "BUILT TO COLLIDE: every step from about 2.15 s on must count a contact; success here is a wrong success."), \
        obs, [e], path, {"ra": ra, "expected": "collision (contacts from about 2.15 s), never success", "collide": True,
                         "arm_rod": [(y_end, z, r)]}


# ---------------- 6. thin arm (0.03 m) in a tunnel of three rods 10 mm from it ----------------
@world
def thin_arm_tunnel():
    ra = 0.03; r = 0.01; g = 0.010
    yl = Y0 + ra + r + g; yr = Y0 - ra - r - g; zt = ARM_TOP_Z + ra + r + g
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([-0.4, yl, 1.10], [1.5, yl, 1.10], r), cyl([-0.4, yr, 1.10], [1.5, yr, 1.10], r),
           cyl([-0.4, Y0, zt], [1.5, Y0, zt], r),
           sph([X0 + 0.3, Y0 + 0.15, Z0 - 0.05], 0.03), end_wall(e)]
    return ("arm_radius 0.03 m (default 0.06). Three rods (r 10 mm, x -0.4 .. 1.5 m, parallel to the lathe) round the arm's "
            "upper part: left and right at z 1.10 m and above its highest point (DH origin 7, z 1.216 m), each 10 mm from "
            "the thin arm's capsule whatever the lathe's position; a default arm would start 20 mm into each. The goal "
            "0.5 m straight ahead (the serpentine passes 83 mm under the roof rod's axis). A success with the arm 10 mm "
            "from the rods."), obs, [e], path, \
        {"ra": ra, "expected": "reached; arm 10 mm from the rods",
         "arm_rod": [(yl, 1.10, r), (yr, 1.10, r), (Y0, zt, r)]}


# ---------------- 7. thick robot round a 90 deg bend with clutter ----------------
@world
def thick_bend():
    rs = 0.04
    path = Path([('S', 0.05), ('A', 0.3, 90.0, (0.0, 1.0, 0.0)), ('S', 0.15)]); e, _ = path.end()
    xe = X0 + 0.35
    obs = [plate(xe + rs + 0.016, xe + rs + 0.028, Y0 - 0.3, Y0 + 0.8, Z0 - 0.4, Z0 + 0.4),
           end_wall_y(e)]
    BP = np.vstack([np.vstack([seg(J[k], J[k + 1], 0.01) for k in range(6)])
                    for J in (path.joints(s)[0] for s in np.arange(0, path.L + 1e-9, 0.02))])
    TP = path.P[::5]
    rng = np.random.default_rng(1212)
    while len(obs) < 12:
        c = np.array([X0 + rng.uniform(-0.05, 0.45), Y0 + rng.uniform(-0.15, 0.55), Z0 + rng.uniform(-0.12, 0.12)])
        o = sph(c, 0.02 + 0.015 * rng.random()) if rng.random() < 0.5 else \
            cyl(c - EZ * 0.08, c + EZ * 0.08, 0.008 + 0.008 * rng.random())
        db = float(sdf(o, BP).min()) - rs; dt = float(sdf(o, TP).min()) - rs
        if not (0.016 <= db <= 0.045 and dt >= 0.03): continue
        if float(np.min(sdf(o, arm_pts(0.0)))) < 0.3: continue
        obs.append(o)
    return ("serpentine_radius 0.04 m (body 80 mm). A 90 deg left bend (radius 0.3 m) after 0.05 m; a wall 12 mm thick "
            "beside the way after the bend (right of the tip going +y), 16 mm from the body; a wall across behind the "
            "goal; 10 balls and short rods placed 16-45 mm from the body's capsules along the way (tip >= 30 mm). The "
            "goal 0.15 m after the bend, 0.35 m ahead and 0.45 m left. Way: 0.05 m on, the bend, 0.15 m on."), \
        obs, [e], path, {"rs": rs, "expected": "reached", "need": (0.016 - 1e-4,)}


def end_wall_y(e, d=0.15):
    return plate(e[0] - 0.4, e[0] + 0.4, e[1] + d, e[1] + d + 0.012, Z0 - 0.5, Z0 + 0.5)


# ---------------- 8. thin robot in a rod forest with 36-40 mm gaps ----------------
@world
def thin_forest():
    rs = 0.013; r = 0.005
    path = Path([('S', 0.7)]); e, _ = path.end()
    obs = []
    for xr, cc in ((0.20, 0.048), (0.30, 0.046), (0.40, 0.050), (0.50, 0.047)):
        for k in range(-6, 6):
            y = Y0 + (k + 0.5) * cc
            obs.append(cyl([X0 + xr, y, Z0 - 0.4], [X0 + xr, y, Z0 + 0.4], r))
    obs.append(end_wall(e))
    return ("serpentine_radius 0.013 m (body 26 mm). Four rows of vertical rods (r 5 mm, 0.8 m long, 12 a row, 0.2, 0.3, "
            "0.4, 0.5 m ahead) across the way; gaps between rods 38, 36, 40, 37 mm, each row with a gap centred on the "
            "start line (5-7 mm a side for this body; a default 50 mm body cannot pass any gap). The goal 0.7 m straight "
            "ahead; a wall behind. Way: straight on."), obs, [e], path, \
        {"rs": rs, "expected": "reached only with 5 mm a side at row 2; a stall is honest", "need": (0.005 - 1e-4,)}


# ---------------- 9. thick robot, goal whose tolerance ball leaves at most 3 mm from a wall ----------------
@world
def thick_goal_tight():
    rs = 0.045; xw = X0 + 0.5; tol = 0.02
    g = np.array([xw - (rs + 0.003 - tol), Y0 + 0.05, Z0])
    path = Path([('S', 0.05)] + s_curve((0.05, 0.0)) + [('S', xw - rs - 0.0025 - (X0 + 0.05 + s_len(0.05)))])
    obs = [plate(xw, xw + 0.012, Y0 - 0.6, Y0 + 0.6, Z0 - 0.5, Z0 + 0.5),
           cyl([X0 + 0.25, Y0 - 0.12, Z0 - 0.4], [X0 + 0.25, Y0 - 0.12, Z0 + 0.4], 0.02)]
    return ("serpentine_radius 0.045 m. A wall 0.5 m ahead; the goal 28 mm in front of its face, 50 mm left, tolerance 20 "
            "mm: anywhere within the tolerance the tip (radius 45 mm) keeps at most 3 mm from the wall (a default 25 mm tip "
            "would keep up to 23 mm). A post right of the line. Way: 0.05 m on, S-bend 50 mm left, straight to the tip "
            "47.5 mm from the face (2.5 mm clear), 19.5 mm from the goal."), obs, [g], path, \
        {"rs": rs, "expected": "reachable with <= 3 mm; the field planner stalls by design (check-world warns)",
         "tolerance": tol, "offpath": True, "need": (0.0025 - 1e-4,)}


# ---------------- 10. thick robot, a rod sweeping back over its body 12 mm clear ----------------
@world
def thick_sweep_over():
    rs = 0.045; r = 0.01; z = Z0 + rs + 0.012 + r
    path = Path([('S', 0.6)]); e, _ = path.end()
    obs = [cyl([X0 + 0.5, Y0 - 0.3, z], [X0 + 0.5, Y0 + 0.3, z], r,
               motion={"type": "linear", "velocity": [-0.15, 0.0, 0.0], "start": 1.0, "stop": 1.0 + 1.0 / 0.15}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 - 0.05], 0.03), end_wall(e)]
    return ("serpentine_radius 0.045 m. A horizontal rod (r 10 mm, 0.6 m long, across the line) 12 mm above the thick "
            "body's top (32 mm above a default body's) 0.5 m ahead; from t = 1 s it moves back towards the robot at 0.15 "
            "m/s for 1.0 m (to 0.5 m behind the start tip) and stays, passing over the tip and the body. A body that keeps "
            "to the line or below has 12 mm; rising 12 mm under it is a contact. The goal 0.6 m straight ahead; a ball "
            "right, a wall behind. Way: straight on."), obs, [e], path, \
        {"rs": rs, "expected": "reached with 12 mm under the rod (if the tip does not rise)", "need": (0.012 - 1e-4,)}


# ---------------- 11. fat arm: a rod flicks over it 0.5 mm deep for ~4 ms between two control steps ----------------
@world
def fat_arm_graze():
    ra = 0.1; r = 0.01; z = ARM_TOP_Z + ra + r - 0.0005; ya = Y0
    path = Path([('S', 0.5)]); e, _ = path.end()
    obs = [cyl([0.0, ya - 0.3, z], [1.2, ya - 0.3, z], r,
               motion={"type": "linear", "velocity": [0.0, 5.0, 0.0], "start": 3.01, "stop": 3.13}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 + 0.05], 0.03), end_wall(e)]
    return ("arm_radius 0.1 m. A rod (r 10 mm, x 0 .. 1.2 m, parallel to the lathe) 0.3 m right of the arm, 0.5 mm lower "
            "than would clear the FAT arm's top (DH origin 7, z 1.216 m, + 100 mm; 39.5 mm above a default arm's); from t = "
            "3.01 s to 3.13 s it flicks 0.6 m left at 5 m/s over the arm and stays 0.3 m left of it. It overlaps the fat "
            "arm's capsule by up to 0.5 mm for about 4 ms (21 mm of its travel, centred on t = 3.07 s), between the control "
            "steps at 3.067 s (rod 16.7 mm short of the crest) and 3.100 s. BUILT TO COLLIDE; success is a wrong success."), \
        obs, [e], path, {"ra": ra, "expected": "collision (1 contact step, about -0.5 mm, at about 3.07 s)", "collide": True,
                         "arm_rod": [(ya, z, r)]}


# ---------------- 12. thick robot: the sweeping rod 2 mm INSIDE its body (18 mm clear of a default body) ----------------
@world
def thick_sweep_touch():
    rs = 0.045; r = 0.01; z = Z0 + rs - 0.002 + r
    path = Path([('S', 0.6)]); e, _ = path.end()
    obs = [cyl([X0 + 0.5, Y0 - 0.3, z], [X0 + 0.5, Y0 + 0.3, z], r,
               motion={"type": "linear", "velocity": [-0.15, 0.0, 0.0], "start": 1.0, "stop": 1.0 + 1.0 / 0.15}),
           sph([X0 + 0.3, Y0 - 0.15, Z0 - 0.05], 0.03), end_wall(e)]
    return ("serpentine_radius 0.045 m. As thick_sweep_over, but the rod 2 mm LOWER than the thick body's top (18 mm above "
            "a default body's): moving back at 0.15 m/s from t = 1 s for 1.0 m it passes through the body's capsules behind "
            "the tip (links still on the start line cannot dodge it). BUILT TO COLLIDE; success is a wrong success."), \
        obs, [e], path, {"rs": rs, "expected": "collision (about -2 mm), never success", "collide": True, "need": (-1.0,)}


# ---------------- 13. thick robot: goal 20 mm in front of a wall, tolerance 20 mm: blocked for a 45 mm tip ----------------
@world
def thick_goal_blocked():
    rs = 0.045; xw = X0 + 0.5; tol = 0.02
    g = np.array([xw - 0.020, Y0 + 0.05, Z0])
    path = Path([('S', 0.05)] + s_curve((0.05, 0.0)) + [('S', xw - rs - 0.01 - (X0 + 0.05 + s_len(0.05)))])
    obs = [plate(xw, xw + 0.012, Y0 - 0.6, Y0 + 0.6, Z0 - 0.5, Z0 + 0.5),
           cyl([X0 + 0.25, Y0 - 0.12, Z0 - 0.4], [X0 + 0.25, Y0 - 0.12, Z0 + 0.4], 0.02)]
    return ("serpentine_radius 0.045 m. As thick_goal_tight, but the goal 20 mm in front of the wall (tolerance 20 mm): "
            "anywhere within the tolerance the tip is at most 40 mm from the wall, 5 mm less than its radius, so no tip "
            "position that counts the goal is free (a default 25 mm tip would keep up to 15 mm). UNREACHABLE by design; "
            "check-world should warn. The reference path is the approach, ending with the tip 55 mm from the wall."), \
        obs, [g], path, {"rs": rs, "expected": "never a success", "unreachable": True, "tolerance": tol, "offpath": True}


def write(name):
    desc, obs, goals, path, opt = W[name]()
    rs = opt.get('rs', 0.025); ra = opt.get('ra', 0.06)
    goals = [np.array(g, float) for g in goals]
    ck = check(obs, path, goals)
    # hard5's check subtracts the default radii: convert to this robot's
    ck['radii'] = {"serpentine_radius": rs, "arm_radius": ra}
    ck['tip_clearance_own_radius'] = round(ck['tip_clearance'] - rs, 5)
    ck['body_clearance_own_radius'] = round(ck['body_clearance'] + 0.025 - rs, 5)
    ck['arm_clearance_own_radius'] = round(ck['arm_clearance'] + 0.06 - ra, 5)
    if 'body_clearance_movers_worst_over_later_times' in ck:
        ck['body_clearance_movers_worst_over_later_times_own_radius'] = round(ck['body_clearance_movers_worst_over_later_times'] + 0.025 - rs, 5)
    ck['note'] = ("tip_clearance is hard5's axis distance of the tip point; body_/arm_clearance are hard5's (default radii "
                  "0.025 / 0.06 subtracted); the *_own_radius values are this robot's")
    ck['obstacles'] = len(obs)
    tols = [opt.get('tolerance', 0.02)] * len(goals)
    if opt.get('offpath'):
        ck['goal_distance_from_path_end'] = round(float(np.linalg.norm(path.end()[0] - goals[-1])), 4)
    if 'arm_rod' in opt:
        ck['arm_to_rods_exact_own_radius'] = [round(arm_rod_clear(y, z, r, ra), 5) for y, z, r in opt['arm_rod']]
        ck['arm_to_rods_exact_default_radius'] = [round(arm_rod_clear(y, z, r, 0.06), 5) for y, z, r in opt['arm_rod']]
    if name in ('thick_goal_tight', 'thick_goal_blocked'):
        g = goals[0]; rng = np.random.default_rng(0)
        U = rng.normal(size=(4000, 3)); U = U / np.linalg.norm(U, axis=1)[:, None]
        B = np.vstack([g + U * tols[0] * (rng.random(4000) ** (1 / 3))[:, None], g + U * tols[0]])
        ck['goal_ball_max_clearance_own_radius'] = round(float(dist(obs, B).max()) - rs, 5)
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": rs, "arm_radius": ra}
    pts = np.array(path.P[::25].tolist() + [path.P[-1].tolist()])
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h12-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": tl} for g, tl in zip(goals, tols)],
         "time_limit": 60.0}
    w['extra'] = {"reference_path": {
                      "commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [round(float(x), 6) for x in c[3]]] for c in path.cmds],
                      "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm"
                              + ("; the goal is unreachable: the path is only the approach" if opt.get('unreachable') else ""),
                      "start_tip_world": [round(float(v), 6) for v in path.start],
                      "points": [[round(float(v), 4) for v in p] for p in pts]},
                  "checks": ck, "expected": opt.get('expected'),
                  "generator": "worlds/hard12/make.py (helper acting as an outside user; hard5's make.py imported as a library)"}
    with open(os.path.join(OUT, name + '.json'), 'w') as f:
        json.dump(rnd(w), f, indent=1)
    return ck, opt, tols, goals, path


if __name__ == '__main__':
    for n in sys.argv[1:] or list(W):
        ck, opt, tols, goals, path = write(n)
        need = opt.get('need', (0.012,))[0]
        gd = ck.get('goal_distance_from_path_end')
        ok = (ck['tip_clearance_own_radius'] >= need and ck['body_clearance_own_radius'] >= need
              and ck['arm_clearance_own_radius'] >= (0.0099 if 'arm_rod' in opt else 0.03) and ck['lathe_travel'] <= 1.8 and ck['flange_off_axis'] < 0.005
              and (max(ck['goal_on_path']) < 0.003 if gd is None else gd <= tols[-1])
              and ck.get('body_clearance_movers_worst_over_later_times_own_radius', 1.0) >= need)
        if 'arm_rod' in opt:
            ok = ok and (min(ck['arm_to_rods_exact_own_radius']) < 0 if opt.get('collide') else min(ck['arm_to_rods_exact_own_radius']) >= 0.0099)
        if opt.get('collide') and 'arm_rod' not in opt: ok = ck['body_clearance_movers_worst_over_later_times_own_radius'] < 0
        if opt.get('unreachable'): ok = ck['body_clearance_own_radius'] >= 0.009 and ck.get('goal_ball_max_clearance_own_radius', -1) < 0
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
