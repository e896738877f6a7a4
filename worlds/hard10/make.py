"""Own generator, held-out batch 10 (session 47 helper, outside user). Does not use navstack.generate.
hard5's generator (worlds/hard5/make.py) is imported as a library (importlib), as worlds/hard6..9/make.py do:
its Path (straight legs and arcs of radius >= 0.28 m from the start tip P0 heading +x), primitives, exact signed
distances, `check` (tip / serpentine body / arm clearances along the reference path, lathe travel, flange off the
lathe axis; movers at the assumed timing and at their worst over all later times) and `rnd`; nothing is copied.
Every world is built round its reference tip path in the canonical frame; goals give only the destination
(`tour8`: eight inspection points in order). `shut_gap` is unreachable by design (its only opening is 46 mm wide,
the body 50 mm).
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
                        box, cyl, sph, frame_box, plate_hole, sdf, dist, seg, check, rnd)

W = {}
def world(fn): W[fn.__name__] = fn; return fn

EZ = np.array([0, 0, 1.0])


def plate(x0, x1, y0, y1, z0, z1):
    return box([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2], [(x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2])


def s_curve(off, R=0.3):
    o = np.array([0.0, off[0], off[1]]); d = unit(o); th = S_curve(R, float(np.linalg.norm(o)))
    return [('A', R, th, tuple(d)), ('A', R, th, tuple(-d))]


def local_box(c, u, v, n, lo, hi):
    """box spanning [lo, hi] (3-vectors) in the local orthonormal frame (u, v, n = u x v) about c"""
    lo, hi = np.array(lo, float), np.array(hi, float); m = (lo + hi) / 2; h = (hi - lo) / 2
    return frame_box(np.array(c) + u * m[0] + v * m[1] + n * m[2], u, v, h[0], h[1], h[2])


def chamber(c, u, v, n, hu, hv, depth, slot_half_u, slot_half_v, t=0.006):
    """closed box behind a wall through c (normal n): inner |u| < hu, |v| < hv, 0 < n < depth; the front wall
    (big: 0.8 x 0.5 m half) has one slot |u| < slot_half_u, |v| < slot_half_v at c"""
    out = plate_hole(c, u, v, n, 0.8, 0.5, (0.0, 0.0), (slot_half_u, slot_half_v), t)
    out += [local_box(c, u, v, n, [-hu - 2 * t, -hv - 2 * t, 0], [-hu, hv + 2 * t, depth]),
            local_box(c, u, v, n, [hu, -hv - 2 * t, 0], [hu + 2 * t, hv + 2 * t, depth]),
            local_box(c, u, v, n, [-hu, -hv - 2 * t, 0], [hu, -hv, depth]),
            local_box(c, u, v, n, [-hu, hv, 0], [hu, hv + 2 * t, depth]),
            local_box(c, u, v, n, [-hu - 2 * t, -hv - 2 * t, depth], [hu + 2 * t, hv + 2 * t, depth + 2 * t])]
    return out


# ---------------- 1. a whole structure pitched and rolled (not yawed only) ----------------
@world
def pitch_roll_bay():
    """bulkhead (hole off its centre) + a closed bay with clutter, the whole structure facing 25 deg down and
    20 deg right and rolled 35 deg about its own axis"""
    p, y, roll = math.radians(25), math.radians(-20), math.radians(35)
    ax = unit([math.cos(p) * math.cos(y), math.cos(p) * math.sin(y), -math.sin(p)])
    ang = math.degrees(math.acos(ax[0])); bend = tuple(unit(ax - ax[0] * EX))
    u0 = unit(np.cross(EZ, ax)); v0 = np.cross(ax, u0)
    u = math.cos(roll) * u0 + math.sin(roll) * v0; v = np.cross(ax, u)
    b2 = -(np.array(bend) - np.dot(bend, ax) * ax); b2 = unit(b2)
    path = Path([('S', 0.1), ('A', 0.3, ang, bend), ('S', 0.16), ('A', 0.3, 60.0, tuple(b2))])
    C, _ = path.at(0.1 + 0.3 * math.radians(ang) + 0.12)
    e, _ = path.end()
    obs = plate_hole(C - u * 0.15 - v * 0.1, u, v, ax, 0.45, 0.4, (0.15, 0.1), (0.075, 0.075), 0.006)
    hb, dep, t = 0.22, 0.45, 0.006
    obs += [local_box(C, v, ax, u, [-hb - 2 * t, t, hb], [hb + 2 * t, dep, hb + 2 * t]),
            local_box(C, v, ax, u, [-hb - 2 * t, t, -hb - 2 * t], [hb + 2 * t, dep, -hb]),
            local_box(C, ax, u, v, [t, -hb, hb], [dep, hb, hb + 2 * t]),
            local_box(C, ax, u, v, [t, -hb, -hb - 2 * t], [dep, hb, -hb]),
            local_box(C, u, v, ax, [-hb - 2 * t, -hb - 2 * t, dep], [hb + 2 * t, hb + 2 * t, dep + 2 * t])]
    obs += [sph(C + ax * 0.15 - u * 0.11 + v * 0.09, 0.03), cyl(C + ax * 0.22 - u * 0.1 - v * 0.18, C + ax * 0.22 - u * 0.1 + v * 0.18, 0.012),
            sph(C + ax * 0.33 + u * 0.1 - v * 0.09, 0.025), cyl(C + ax * 0.28 - u * 0.22 + v * 0.15, C + ax * 0.28 + u * 0.22 + v * 0.15, 0.01),
            cyl(C - ax * 0.12 + u * 0.2 - v * 0.4, C - ax * 0.12 + u * 0.2 + v * 0.4, 0.02)]
    L = seg(P0, e, 0.005); dl = np.array([np.linalg.norm(path.P - q, axis=1).min() for q in L]); k = int(dl.argmax())
    print('  pitch_roll_bay: straight line to the goal at most', round(float(dl[k]), 4), 'm from the way', file=sys.stderr)
    if dl[k] - 0.08 >= 0.012: obs.append(sph(L[k], min(0.03, float(dl[k]) - 0.08)))   # a ball on the straight line, 80 mm off the way
    return ("A bulkhead (0.9 x 0.8 m, 12 mm) whose 0.15 m square hole lies off its centre, and behind it a closed bay "
            "(0.36 m square inside, 0.40 m deep) holding two balls and two rods; a pipe in front. The WHOLE structure is "
            "pitched and rolled, not yawed only: it faces 25 deg down and 20 deg right of the start heading and is rolled "
            f"35 deg about its own axis. The hole's centre {C[0] - X0:.2f} m ahead, {C[1] - Y0:.2f} m left, {C[2] - Z0:.2f} m up; "
            "the goal in the bay 0.30 m beyond the hole, 0.15 m off its axis towards the start line's side. Way: 0.1 m on, one arc "
            "(radius 0.3 m) onto the hole's axis, straight through it (0.04 m past it), then 60 deg back (an S). The straight "
            "line from the start tip passes the hole 33 mm from its edge (8 mm for the body)."), obs, [e], path, {"expected": "reached"}


# ---------------- 2. two holes close together, offset: thread them obliquely ----------------
@world
def diag_holes():
    """two walls 0.14 m apart (less than a link); holes offset so that only a straight line at 30 deg threads both;
    the way first rises left-up, then comes down through them"""
    d = unit([0.0, 0.8, 0.6])
    path = Path([('S', 0.08), ('A', 0.3, 30.0, tuple(d)), ('A', 0.3, 60.0, tuple(-d)), ('S', 0.30), ('A', 0.3, 30.0, tuple(d)), ('S', 0.05)])
    s0 = 0.08 + 0.3 * math.radians(90.0)
    M, h = path.at(s0 + 0.15)
    obs = []
    for k, dx in enumerate((-0.076, 0.076)):
        xw = M[0] + dx; sc = (xw - M[0]) / h[0]; hc = M + h * sc      # where the straight crosses the wall's mid-plane
        obs += plate_hole([xw, Y0, Z0], np.array([0, 1.0, 0]), EZ, EX, 0.7, 0.6, (hc[1] - Y0, hc[2] - Z0), (0.075, 0.075), 0.006)
    e, _ = path.end()
    obs += [sph([e[0] - 0.02, e[1] + 0.14, e[2] - 0.05], 0.035), cyl([M[0] - 0.25, Y0 - 0.2, Z0 - 0.5], [M[0] - 0.25, Y0 - 0.2, Z0 + 0.5], 0.02),
            plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5)]
    return ("Two parallel walls (1.4 x 1.2 m, 12 mm) 0.14 m apart (less than one 0.2 m link), each with one 0.15 m square hole; "
            "the second hole is offset 0.088 m right-down of the first (direction 0.8 left / 0.6 up reversed), so looking "
            "along the start heading the holes overlap by 62 mm only, and the body (50 mm) must thread them on a straight "
            "line 30 deg off the walls' normal. The goal 0.27 m behind the second wall, 0.15 m right-down of the start line. "
            "Way: 0.08 m on, 30 deg left-up, 60 deg back (now heading 30 deg right-down), 0.30 m straight through both holes, "
            "30 deg back, 0.05 m on. A post before the walls, a ball behind them, an end wall."), obs, [e], path, {"expected": "reached"}


# ---------------- 3. goal in a box whose only opening is on its far side ----------------
@world
def far_side_box():
    """a closed box left-ahead, its only opening facing away (+x); go past it and turn 180 deg back into it"""
    path = Path([('S', 0.75), ('A', 0.3, 180.0, LEFT), ('S', 0.12)])
    e, _ = path.end(); yc = Y0 + 0.6; t = 0.006; hi = 0.11
    x0, x1 = X0 + 0.42, X0 + 0.70
    obs = [plate(x0 - 2 * t, x0, yc - hi - 2 * t, yc + hi + 2 * t, Z0 - hi - 2 * t, Z0 + hi + 2 * t),            # back (near) wall
           plate(x0, x1, yc - hi - 2 * t, yc - hi, Z0 - hi - 2 * t, Z0 + hi + 2 * t), plate(x0, x1, yc + hi, yc + hi + 2 * t, Z0 - hi - 2 * t, Z0 + hi + 2 * t),
           plate(x0, x1, yc - hi, yc + hi, Z0 + hi, Z0 + hi + 2 * t), plate(x0, x1, yc - hi, yc + hi, Z0 - hi - 2 * t, Z0 - hi),
           cyl([X0 + 0.3, Y0 + 0.3, Z0 - 0.5], [X0 + 0.3, Y0 + 0.3, Z0 + 0.5], 0.02),
           sph([X0 + 0.5, Y0 + 0.2, Z0 + 0.16], 0.04),
           plate(X0 + 0.1, X0 + 1.2, Y0 + 0.95, Y0 + 0.962, Z0 - 0.4, Z0 + 0.4),
           cyl([X0 + 1.2, Y0 - 0.1, Z0 - 0.5], [X0 + 1.2, Y0 - 0.1, Z0 + 0.5], 0.025),
           sph([e[0] - 0.13, yc + 0.05, Z0 - 0.04], 0.025)]
    return ("A closed box (0.22 m cube inside, 12 mm walls) 0.42-0.70 m ahead and 0.6 m left of the start line; its only "
            "opening is the face looking AWAY from the robot (+x). The goal 0.07 m inside that opening (a small ball at the back "
            "of the box, off the way). The straight line runs into the box's back. Way: 0.75 m on past the box, a 180 deg "
            "turn left (radius 0.3 m), 0.12 m straight back into the box. A post and a ball in front of the box, a wall 0.95 m "
            "left, a post 1.2 m ahead."), obs, [e], path, {"expected": "reached"}


# ---------------- 4. the arm in a tight tunnel (ceiling and walls 55 mm from it) ----------------
@world
def arm_tunnel():
    """lathe bed and arm inside a tunnel whose ceiling and walls clear the arm's start posture by 55 mm all along the
    lathe's travel; the goal 0.3 m left behind a wall with one hole: any sideways or upward use of the arm hits"""
    path = Path([('S', 0.1)] + s_curve((0.3, 0.0)) + [('S', 0.25)])
    e, _ = path.end(); xw = e[0] - 0.2
    obs = plate_hole([xw, Y0 + 0.1, Z0], np.array([0, 1.0, 0]), EZ, EX, 0.7, 0.6, (0.2, 0.0), (0.08, 0.08), 0.006)
    top = 1.2160 + 0.06 + 0.055
    obs += [plate(-0.6, 1.65, -0.35, 0.45, top, top + 0.012),
            plate(-0.6, 1.65, -0.115 - 0.012, -0.115, 0.25, top), plate(-0.6, 1.65, 0.108 + 0.115, 0.108 + 0.127, 0.25, top),
            sph([e[0] + 0.02, e[1] - 0.14, e[2] + 0.05], 0.03), cyl([xw + 0.2, Y0 - 0.4, Z0 + 0.1], [xw + 0.2, Y0 + 0.7, Z0 + 0.1], 0.015)]
    return ("The lathe bed and arm run in a tunnel: a ceiling 55 mm above the arm's highest point (z 1.216 m + 60 mm radius) "
            "and two side walls 55 mm from the arm's column, from 0.6 m behind the base to 0.16 m behind the start tip, so "
            "the arm can go along the lathe but not up or sideways. Ahead, a wall (1.4 x 1.2 m) whose only opening, a 0.16 m "
            f"square hole, lies 0.3 m left of the start line {xw - X0:.2f} m ahead; the goal 0.2 m behind it, 0.3 m left. Way: "
            "0.1 m on, S-bend 0.3 m left (two 60 deg arcs, radius 0.3 m), 0.25 m on; the flange stays on the lathe axis."), \
        obs, [e], path, {"expected": "reached"}


# ---------------- 5. a tour of eight inspection points through clutter ----------------
@world
def tour8():
    """eight goals in order along a 3-D weave through 150 random clutter items (none within 80 mm of the way)"""
    path = Path([('S', 0.06)] + s_curve((0.08, 0.0)) + [('S', 0.04)] + s_curve((0.0, 0.08)) + [('S', 0.04)]
                + s_curve((-0.12, 0.0)) + [('S', 0.04)])
    rng = np.random.default_rng(1047)
    ss = [0.12, 0.27, 0.42, 0.57, 0.72, 0.87, 1.02, path.L]
    goals = [path.at(s)[0] for s in ss]
    obs = []; lo = np.array([X0 + 0.08, Y0 - 0.3, Z0 - 0.3]); hi = np.array([X0 + 1.25, Y0 + 0.35, Z0 + 0.4])
    while len(obs) < 150:
        c = lo + rng.random(3) * (hi - lo); k = rng.integers(3)
        if k == 0: o = sph(c, 0.012 + 0.02 * rng.random())
        elif k == 1:
            a = unit(rng.normal(size=3)); L = 0.06 + 0.12 * rng.random(); o = cyl(c - a * L, c + a * L, 0.006 + 0.01 * rng.random())
        else: o = box(c, 0.01 + 0.025 * rng.random(3), rng.uniform(-math.pi, math.pi, 3))
        if float(sdf(o, path.P[::5]).min()) < 0.08: continue
        obs.append(o)
    obs.append(plate(X0 + 1.33, X0 + 1.342, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5))
    return ("An inspection tour of EIGHT points in order (0.15 m apart along the way, the last one 1.12 m ahead) through 150 "
            "random clutter items (balls r 12-32 mm, rods r 6-16 mm at random angles, boxes rotated about three axes) filling "
            "a 1.2 x 0.65 x 0.7 m block, none within 80 mm of the way; tolerances alternate 20 / 12 mm. Way: 0.06 m on, "
            "S-bends 0.08 m left, 0.08 m up, 0.12 m right (radius 0.3 m), 0.04 m straights between."), obs, goals, path, \
        {"expected": "reached, 8 goals", "tolerances": [0.02, 0.012] * 4}


# ---------------- 6. an obstacle oscillating across part of the only opening ----------------
@world
def osc_slot():
    """a wide slot (0.4 x 0.16 m); a post oscillates across its left and middle part (5 s period) and crosses the
    straight line; only the right 0.17 m is never swept"""
    path = Path([('S', 0.1)] + s_curve((-0.115, 0.0)) + [('S', 0.1)] + s_curve((0.115, 0.0)) + [('S', 0.05)])
    sc = 0.1 + 2 * 0.3 * math.sin(math.radians(S_curve(0.3, 0.115)))
    xw = X0 + sc + 0.05
    obs = plate_hole([xw, Y0, Z0], np.array([0, 1.0, 0]), EZ, EX, 0.7, 0.6, (0.0, 0.0), (0.2, 0.08), 0.006)
    obs.append(cyl([xw, Y0 + 0.085, Z0 - 0.09], [xw, Y0 + 0.085, Z0 + 0.09], 0.015,
                   motion={"type": "oscillate", "axis": [0.0, 1.0, 0.0], "amplitude": 0.1, "period": 5.0, "phase": 0.0}))
    e, _ = path.end()
    obs += [plate(e[0] + 0.12, e[0] + 0.132, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, Z0 + 0.5), sph([xw + 0.2, Y0 + 0.12, Z0 - 0.02], 0.035)]
    return (f"A wall {xw - X0:.2f} m ahead whose only opening is a slot 0.40 m wide, 0.16 m tall, centred on the start line. A "
            "vertical post (r 15 mm, the slot's full height) oscillates along the slot between y -15 and +185 mm of the line "
            "(amplitude 0.1 m, period 5 s, 0.13 m/s at most): it sweeps the slot's left and middle and crosses the straight "
            "line; only the right 0.17 m is never swept. The goal on the start line 0.45 m behind the wall. Way: S-bend "
            "0.115 m right, through the slot's unswept part (the body 60 mm from the post at its nearest), S-bend back."), \
        obs, [e], path, {"expected": "reached (body must stay right of the swept part)"}


# ---------------- 7/8. a slot only just wider (or narrower) than the body, after a bend ----------------
def _bend_gap(width):
    path = Path([('S', 0.1), ('A', 0.3, 50.0, LEFT), ('S', 0.35)])
    sA = 0.1 + 0.3 * math.radians(50.0)
    C, h = path.at(sA + 0.15)
    n = unit(h); u = unit(np.cross(EZ, n)); v = np.cross(n, u)
    obs = chamber(C, u, v, n, 0.2, 0.2, 0.35, width / 2, 0.15)
    obs += [cyl(C - n * 0.15 + u * 0.2 - v * 0.5, C - n * 0.15 + u * 0.2 + v * 0.5, 0.02)]
    return path, obs, C


@world
def tight_gap():
    """the chamber's only opening: a vertical slot 86 mm wide (18 mm each side of the 50 mm body), in a wall facing the
    heading after a 50 deg left turn"""
    path, obs, C = _bend_gap(0.086)
    e, _ = path.end()
    return ("A closed chamber (0.4 m square inside, 0.35 m deep) behind a wall (1.6 x 1.0 m, 12 mm) that faces 50 deg left "
            f"of the start heading, {C[0] - X0:.2f} m ahead and {C[1] - Y0:.2f} m left; its only opening a vertical slot 86 mm wide, "
            "0.3 m tall: 18 mm each side of the body, 43 mm round the tip's axis. The goal 0.2 m inside. Way: 0.1 m on, 50 deg "
            "left (radius 0.3 m), 0.35 m straight through the middle of the slot. A post before the wall."), obs, [e], path, \
        {"expected": "reachable in principle (18 mm each side); a stall without contact is an honest outcome", "slot_width": 0.086}


@world
def shut_gap():
    """as tight_gap, the slot 46 mm wide: narrower than the 50 mm body; unreachable"""
    path, obs, C = _bend_gap(0.046)
    e, _ = path.end()
    return ("As tight_gap, but the chamber's only opening is 46 mm wide, narrower than the 50 mm serpentine (and the tip's "
            "50 mm capsule): UNREACHABLE by design (the goal lies 0.2 m inside the closed chamber, so no point within 20 mm "
            "of it is outside). The reference path is the way tight_gap's body takes, and passes the slot's edges -2 mm."), \
        obs, [e], path, {"expected": "never a success: stalled or timeout, 0 contacts", "unreachable": True, "slot_width": 0.046}


# ---------------- 9. the goal point inside a solid pipe, a large tolerance ----------------
@world
def goal_in_pipe():
    """inspect a pipe: the goal is its axis (inside the solid), tolerance 0.1 m; a plate in front shields the near
    side, so the ball can be entered only over the plate, from above the pipe"""
    path = Path([('S', 0.05)] + s_curve((0.0, 0.09)))
    xs = path.end()[0][0]
    path = Path([('S', 0.05)] + s_curve((0.0, 0.09)) + [('S', X0 + 0.5 - xs)])
    g = np.array([X0 + 0.5, Y0, Z0])
    obs = [cyl([X0 + 0.5, Y0 - 0.4, Z0], [X0 + 0.5, Y0 + 0.4, Z0], 0.03),
           plate(X0 + 0.404, X0 + 0.416, Y0 - 0.4, Y0 + 0.4, Z0 - 0.4, Z0 + 0.02),
           plate(X0 + 0.3, X0 + 0.7, Y0 - 0.4, Y0 + 0.4, Z0 + 0.2, Z0 + 0.212),
           plate(X0 + 0.416, X0 + 0.7, Y0 - 0.4, Y0 + 0.4, Z0 - 0.2, Z0 - 0.188),
           plate(X0 + 0.7, X0 + 0.712, Y0 - 0.4, Y0 + 0.4, Z0 - 0.4, Z0 + 0.4)]
    return ("Inspect a pipe (r 30 mm, along y, 0.5 m ahead on the start line): the goal is the pipe's axis, INSIDE the solid, "
            "with a tolerance of 0.1 m, so reaching means the tip within 70 mm of the pipe's surface. A plate in front "
            "(top edge 20 mm above the axis) shields the near side and the bottom; a floor below, a ceiling 0.2 m above, a wall "
            "behind. The tolerance ball can be entered only over the plate: way 0.05 m on, S-bend 0.09 m up, on over the "
            "plate until above the pipe (the tip 90 mm from the goal, 60 mm from the pipe)."), obs, [g], path, \
        {"expected": "reached (check-world warns: goal inside an obstacle)", "tolerance": 0.1, "offpath": True}


# ---------------- 10. a long vertical climb in a narrow shaft ----------------
@world
def chimney():
    """a deck 0.36 m above the line over the whole start; a 0.15 m square shaft rising 0.53 m from a hatch in it,
    capped; the goal near its top, 0.75 m above the start line"""
    path = Path([('S', 0.25), ('A', 0.3, 90.0, UP), ('S', 0.45)])
    e, _ = path.end(); xc = e[0]; hs, t = 0.075, 0.006; zd = Z0 + 0.36; ztop = Z0 + 0.9
    obs = plate_hole([X0 + 0.1, Y0, zd + t], EX, np.array([0, 1.0, 0]), EZ, 1.2, 0.6, (xc - X0 - 0.1, 0.0), (hs + 0.012, hs + 0.012), t)
    obs += [plate(xc - hs - 2 * t, xc - hs, Y0 - hs - 2 * t, Y0 + hs + 2 * t, zd + 2 * t, ztop), plate(xc + hs, xc + hs + 2 * t, Y0 - hs - 2 * t, Y0 + hs + 2 * t, zd + 2 * t, ztop),
            plate(xc - hs, xc + hs, Y0 - hs - 2 * t, Y0 - hs, zd + 2 * t, ztop), plate(xc - hs, xc + hs, Y0 + hs, Y0 + hs + 2 * t, zd + 2 * t, ztop),
            plate(xc - hs - 2 * t, xc + hs + 2 * t, Y0 - hs - 2 * t, Y0 + hs + 2 * t, ztop, ztop + 2 * t),
            plate(xc + 0.3, xc + 0.312, Y0 - 0.5, Y0 + 0.5, Z0 - 0.5, zd),
            cyl([X0 + 0.15, Y0 + 0.15, Z0 - 0.4], [X0 + 0.15, Y0 + 0.15, zd], 0.02),
            sph([xc + 0.12, Y0 - 0.12, Z0 - 0.02], 0.04)]
    return (f"A deck (12 mm plate, 2.4 x 1.2 m) 0.36 m above the start line, over the start and ahead; one 0.174 m square hatch "
            f"in it {xc - X0:.2f} m ahead on the line, the mouth of a closed vertical shaft (0.15 m square inside, 50 mm round the "
            "body) rising 0.53 m and capped. The goal in the shaft, 0.75 m above the start line, 0.09 m below the cap. Way: 0.25 m "
            "on, 90 deg up (radius 0.3 m), 0.45 m straight up the shaft. A wall ahead under the deck, a post and a ball."), \
        obs, [e], path, {"expected": "reached"}


def write(name):
    desc, obs, goals, path, opt = W[name]()
    goals = [np.array(g, float) for g in goals]
    ck = check(obs, path, goals)
    ck['obstacles'] = len(obs)
    tols = opt.get('tolerances') or [opt.get('tolerance', 0.02)] * len(goals)
    if opt.get('offpath'):
        ck['goal_distance_from_path_end'] = round(float(np.linalg.norm(path.end()[0] - goals[-1])), 4)
    robot = {"base": dict(BASE), "q0": list(Q0), "serpentine_radius": 0.025, "arm_radius": 0.06}
    pts = np.array(path.P[::25].tolist() + [path.P[-1].tolist()])
    w = {"format": "navstack-world/1", "name": name, "description": desc, "family": "h10-" + name.split('_')[0],
         "robot": robot, "obstacles": obs,
         "goals": [{"position": [round(float(v), 6) for v in g], "tolerance": tl} for g, tl in zip(goals, tols)],
         "time_limit": 75.0}
    w['extra'] = {"reference_path": {
                      "commands": [list(c) if c[0] == 'S' else [c[0], c[1], round(c[2], 4), [round(float(x), 6) for x in c[3]]] for c in path.cmds],
                      "note": "tip path from the start tip heading +x: ['S', length] / ['A', radius, deg, bend direction]; points = the path sampled every 5 cm"
                              + ("; the goal is unreachable: the path is tight_gap's way, through a slot narrower than the body" if opt.get('unreachable') else ""),
                      "start_tip_world": [round(float(v), 6) for v in path.start],
                      "points": [[round(float(v), 4) for v in p] for p in pts]},
                  "checks": ck, "expected": opt.get('expected'),
                  "generator": "worlds/hard10/make.py (session 47 helper; hard5's make.py imported as a library)"}
    json.dump(rnd(w), open(os.path.join(OUT, name + '.json'), 'w'), indent=1)
    return ck, opt


if __name__ == '__main__':
    for n in sys.argv[1:] or list(W):
        ck, opt = write(n)
        body_need = 0.015 if n == 'tight_gap' else 0.0269
        tip_need = 0.04 if n == 'tight_gap' else 0.058
        ok = (ck['tip_clearance'] >= tip_need and ck['body_clearance'] >= body_need and ck['arm_clearance'] >= 0.052
              and ck['lathe_travel'] <= 1.8 and ck['flange_off_axis'] < 0.005 and ck['curved_part'] <= 1.2
              and (opt.get('offpath') or max(ck['goal_on_path']) < 0.003)
              and ck.get('body_clearance_movers_worst_over_later_times', 1.0) >= 0.0269)
        if opt.get('unreachable'): ok = ck['body_clearance'] < 0
        print(('OK  ' if ok else 'BAD ') + n, json.dumps(ck), flush=True)
