"""A trial's cost per control step against the simulator floor: the same steps with raw PyBullet calls only.

For each world the benchmark runs a closed-loop trial (slither controller, field planner, seed 0) and
times its control loop (``TrialResult.wall_time`` / ``steps``).  Then, in the same process, it replays
the trial's recorded ``q_des``
with nothing but the PyBullet calls a trial makes, in a fresh client holding the same robot body and
scene (same physics rate, substeps and solver iterations, the robot's contacts with the obstacles
filtered out as in a trial):

* the servo's physics: per physics step one ``setJointMotorControlArray`` in position control (the
  set-point interpolated between the step's ``q_des``, its rate, the servo's forces and gains), one in
  torque control (the holding torques at that set-point) and ``stepSimulation``;
* ``getJointStates`` of the 20 joints;
* one ``rayTestBatch`` of the sensor's rays (numpy arrays in, the cheapest form) from the tip pose the
  trial measured at that step;
* the clearance queries: ``getClosestPoints`` of the robot against every obstacle body, staged at the
  thresholds of :data:`navstack.sim.scene.CLEARANCE_STAGES` then the trial's horizon, as navstack
  asked them before issue 11 (stopping at the first stage that finds a point).

Set-points, rates, holding torques and ray end points are computed before the timed loop, and the calls
go to the ``pybullet`` module with ``physicsClientId`` (no ``BulletClient`` wrapper): what is left out is
everything navstack computes (kinematics, sensing, estimator, planner, controller, metrics), the work the
ratio measures.  The ``held`` column is the same replay with one motor command per control step (the new
``q_des`` held over the period, the issue's first definition of the floor): PyBullet's solver then works
harder (servo docstring), so it is not the same physics and is printed for reference only.

Printed per world, as medians over ``--repeats`` (runs interleaved: trial, floor, held floor, trial, ...)
in ms per control step: navstack, the floor, navstack's own part (navstack - floor), the ratio
navstack / floor, the held floor, and the floor's parts (physics with the motor commands and joint
states, rays, clearance).  Then the growth rows of issue 11: the paper demo with 57, 114 and 228 rays, and
the paper truss with 500 extra members far (more than 3 m) from the path.  Usage::

    python tools/bench_floor.py [--repeats N] [--no-growth] [--worlds W.json ...]

Timing varies with the machine's load: compare numbers of one run only.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from _bench_worlds import HELP, bench_worlds

from navstack.jpl import jpl_serpentine
from navstack.sensing import SensorConfig, ray_directions, ray_start_distances
from navstack.sim._bullet import direct_client, pybullet
from navstack.sim.body import RobotBody
from navstack.sim.scene import CLEARANCE_STAGES, Scene, SceneOptions
from navstack.sim.servo import JointServo
from navstack.trial import TrialConfig, run_trial
from navstack.world import World, load_world, world_from_dict

ROOT = Path(__file__).resolve().parents[1]

RAY_PATTERNS = {
    57: SensorConfig(),
    114: SensorConfig(cone_rays_per_ring=24, side_rays=25, back_rays=16),
    228: SensorConfig(cone_rays_per_ring=48, side_rays=51, back_rays=32),
}
"""Sensor patterns of 57 (the default), 114 and 228 rays: same cone, rings and range, denser rings."""


@dataclass
class Replay:
    """What the floor needs from a finished trial."""

    world: World
    config: TrialConfig
    q: np.ndarray
    """(steps + 1, 20) measured joints (index k: at the start of control step k)."""
    q_des: np.ndarray
    """(steps + 1, 20) the servo's set-points (index k + 1: commanded during step k)."""
    outcome: str
    steps: int
    ms_per_step: float


def run_navstack(world: World, config: TrialConfig, seed: int = 0) -> Replay:
    """One trial; its control loop's ms per step and its recorded trajectory."""
    with tempfile.TemporaryDirectory(prefix="bench-floor-") as tmp:
        result = run_trial(world, seed=seed, config=config, out_dir=tmp)
        data = np.load(Path(tmp) / "trajectory.npz")
        q, q_des = data["q"], data["q_des"]
    if result.reason == "error":
        raise RuntimeError(f"trial on {world.name} failed: {result.error}")
    return Replay(world, config, q, q_des, f"{result.reason} {result.goals_reached}/{len(world.goals)}",
                  result.steps, 1e3 * result.wall_time / result.steps)


def floor_ms_per_step(rep: Replay, held: bool = False) -> tuple[float, np.ndarray]:
    """Replay ``rep``'s set-points with raw PyBullet calls; ms per control step of the timed loop, and its
    parts (physics with the motor commands and joint states, rays, clearance) [ms per step].

    ``held``: one motor command per control step (the new ``q_des`` held over the period) instead of the
    servo's eight interpolated set-points.
    """
    p = pybullet
    world, cfg = rep.world, rep.config
    chain = jpl_serpentine()
    client = direct_client()
    try:
        cid = client._client
        T0 = world.robot.base.transform()
        body = RobotBody.build(client, chain, T0, serpentine_radius=world.robot.serpentine_radius,
                               arm_radius=world.robot.arm_radius, visuals=False)  # as a trial's (no pictures)
        body.reset(chain.check(world.robot.q0))
        scene = Scene.build(client, world, SceneOptions(visuals=False))
        robot = body.body_id
        n_links = p.getNumJoints(robot, physicsClientId=cid)
        for b in scene.body_ids:
            for link in range(-1, n_links):
                p.setCollisionFilterPair(robot, b, link, -1, 0, physicsClientId=cid)
        servo = JointServo(body, cfg.servo)  # rate, gravity, solver; its forces, gains and holding torques
        forces = [float(f) for f in servo.forces]
        kp, kd = servo.kp, servo.kd
        joints = list(range(chain.n))
        steps, substeps = rep.steps, cfg.servo.substeps
        # everything navstack would compute, computed before the timed loop
        prev, target = rep.q_des[:steps], rep.q_des[1:steps + 1]
        rates = ((target - prev) * cfg.servo.control_hz).tolist()
        if held:
            setpoints = target[:, None, :].repeat(substeps, axis=1)
        else:
            frac = (np.arange(substeps) / substeps)[None, :, None]
            setpoints = prev[:, None, :] + (target - prev)[:, None, :] * frac
        torques = [[servo.gravity_torques(q).tolist() for q in qs] for qs in setpoints]
        setpoints = setpoints.tolist()
        dirs_tip = ray_directions(cfg.sensor)
        start = ray_start_distances(cfg.sensor)[:, None]
        ray_from, ray_to = [], []
        for k in range(steps):  # from the tip pose the trial measured at the start of step k
            T = T0 @ chain.frames(rep.q[k])[21]
            dirs = dirs_tip @ T[:3, :3].T
            ray_from.append(T[:3, 3] + start * dirs)
            ray_to.append(T[:3, 3] + cfg.sensor.max_range * dirs)
        horizon = cfg.clearance_horizon
        stages = [t for t in CLEARANCE_STAGES if t < horizon] + [horizon]
        bodies = scene.body_ids
        position_control, torque_control = p.POSITION_CONTROL, p.TORQUE_CONTROL
        motors, physics_step, states = p.setJointMotorControlArray, p.stepSimulation, p.getJointStates
        rays, closest = p.rayTestBatch, p.getClosestPoints

        def clearance() -> float:
            for d in stages:
                best = d
                for b in bodies:
                    for pt in closest(robot, b, d, physicsClientId=cid):
                        if pt[8] < best:
                            best = pt[8]
                if best < d:
                    return best
            return horizon

        clock = time.perf_counter
        parts = np.zeros(3)  # physics (motors + steps + joint states), rays, clearance [s]
        t0 = clock()
        p.performCollisionDetection(physicsClientId=cid)
        states(robot, joints, physicsClientId=cid)
        clearance()
        for k in range(steps):
            ta = clock()
            rays(ray_from[k], ray_to[k], physicsClientId=cid)
            tb = clock()
            qs, taus = setpoints[k], torques[k]
            for i in range(substeps):
                if i == 0 or not held:
                    motors(robot, joints, position_control, targetPositions=qs[i], targetVelocities=rates[k],
                           forces=forces, positionGains=kp, velocityGains=kd, physicsClientId=cid)
                motors(robot, joints, torque_control, forces=taus[i], physicsClientId=cid)
                physics_step(physicsClientId=cid)
            states(robot, joints, physicsClientId=cid)
            tc = clock()
            clearance()
            parts += (tc - tb, tb - ta, clock() - tc)
        return 1e3 * (clock() - t0) / steps, 1e3 * parts / steps
    finally:
        client.disconnect()


def measure(label: str, world: World, config: TrialConfig, repeats: int) -> None:
    """Print one row (medians over ``repeats``, ms per control step): navstack, the floor, navstack's own
    part (navstack - floor, per repeat), navstack / floor, the held floor, and the floor's parts."""
    nav, floor, own, ratio, held, parts = [], [], [], [], [], []
    outcome, steps = "", 0
    for _ in range(repeats):
        rep = run_navstack(world, config)
        f, fp = floor_ms_per_step(rep)
        held.append(floor_ms_per_step(rep, held=True)[0])
        nav.append(rep.ms_per_step)
        floor.append(f)
        own.append(rep.ms_per_step - f)
        ratio.append(rep.ms_per_step / f)
        parts.append(fp)
        outcome, steps = rep.outcome, rep.steps
    med = statistics.median
    fp = np.median(parts, axis=0)
    print(f"{label:34s} {outcome:12s} {steps:6d} {med(nav):9.2f} {med(floor):7.2f} {med(own):7.2f} {med(ratio):6.2f} "
          f"{med(held):7.2f}   {fp[0]:5.2f} {fp[1]:5.2f} {fp[2]:5.2f}", flush=True)


def far_members(world: World, count: int, seed: int = 0) -> World:
    """``world`` with ``count`` extra cylinders (r 0.02 m, 0.5 m long) at least 3 m beyond every obstacle
    and goal in +y (away from the robot's way in)."""
    data = world.to_dict()
    points = [np.asarray(g.position) for g in world.goals]
    for o in data["obstacles"]:
        points += [np.asarray(o[k]) for k in ("p0", "p1", "center") if k in o]
    y0 = max(float(pt[1]) for pt in points) + 3.0
    rng = np.random.default_rng(seed)
    for _ in range(count):
        a = np.array([rng.uniform(0.0, 5.0), rng.uniform(y0, y0 + 4.0), rng.uniform(0.2, 2.0)])
        d = rng.normal(size=3)
        d *= 0.5 / np.linalg.norm(d)
        data["obstacles"].append({"type": "cylinder", "p0": a.round(6).tolist(), "p1": (a + d).round(6).tolist(),
                                  "radius": 0.02})
    data["name"] = f"{world.name}+{count}far"
    return world_from_dict(data)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=None, help=HELP)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-growth", action="store_true", help="skip the rays and far-obstacle rows")
    args = ap.parse_args()
    paper = load_world(ROOT / "worlds" / "paper_truss.json")
    worlds = bench_worlds(args.worlds)
    base = TrialConfig()
    run_trial(paper, seed=0, config=base)  # compile and load everything once
    print(f"{'':53s} {'ms per control step, medians of ' + str(args.repeats):^40s}   {'floor parts':^17s}")
    print(f"{'world':34s} {'outcome':12s} {'steps':>6s} {'navstack':>9s} {'floor':>7s} {'own':>7s} {'ratio':>6s} "
          f"{'held':>7s}   {'phys':>5s} {'rays':>5s} {'clear':>5s}")
    for label, world in worlds:
        measure(label, world, base, args.repeats)
    if args.no_growth:
        return
    print("growth: rays (paper demo)")
    for n, sensor in RAY_PATTERNS.items():
        assert sensor.n_rays == n, (sensor.n_rays, n)
        measure(f"  {n} rays", paper, replace(base, sensor=sensor), args.repeats)
    print("growth: obstacles (paper demo)")
    measure(f"  paper truss ({len(paper.obstacles)} members)", paper, base, args.repeats)
    far = far_members(paper, 500)
    measure(f"  + 500 far members ({len(far.obstacles)})", far, base, args.repeats)


if __name__ == "__main__":
    main()
