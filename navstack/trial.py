"""One closed-loop trial: sense -> estimate -> plan -> slither -> control -> servo.

``run_trial`` is what ``navstack run`` runs (interfaces.md sections 3 and 5).
Each trial owns one PyBullet ``BulletClient`` (DIRECT); no global simulator
state.  The obstacles go to the simulator only: the planner sees the tip
sensor readings, the controller sees the tip command and the robot's own
state.

Per control step (``ServoConfig.control_hz``, default 30 Hz):

1. read the measured joints, the actual tip; advance the goal index when the
   actual tip is within the current goal's tolerance,
2. cast the tip rays (``--planner field``) and filter the ranges,
3. the planner gives the tip command ``x_d, xdot_d`` (world frame),
4. the slithering controller (equation 4) integrates ``theta_d``,
5. the servo tracks ``theta_d`` for one control period,
6. metrics: clearance and contact of the measured robot against the obstacles,
   commanded-vs-actual tip error, serpentine deviation from the recorded path;
   and the robot against itself (:mod:`navstack.self_contact`: touching itself
   makes the trial a ``collision``, ``contacts`` still counting obstacles only).

Contact is *detected*, not simulated: the obstacles do not push the robot
(PyBullet collision response between robot and obstacles is off), so a
failing controller is seen cutting through members and the depth is reported
as a negative ``min_clearance``.  The trial ends when every goal is reached,
at ``time_limit``, when the planner reports a stall, or when the arm is pinned
at a joint limit while the tip lags its command.

Moving obstacles (interfaces.md section 2b) are placed at the step's time by
``Scene.update`` once per control step, before the sensors and the clearance
query read them; the planner and controller are told nothing of them.

Before anything is simulated, ``run_trial`` refuses (``WorldError``, naming the
field) a goal out of reach (:func:`check_reach`) and a robot that starts in
contact with or inside an obstacle (:func:`check_start`), and
(``TrialInputError``) an output folder it cannot write (:func:`check_out_dir`).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from navstack.jpl import BACKBONE_FRAMES, jpl_serpentine
from navstack.planner.field import FieldPlannerConfig
from navstack.planner.reactive import PlannerConfig
from navstack.self_contact import FIRST_SERPENTINE_FRAME, capsule_frames, pair_frames, self_clearance, self_pairs
from navstack.sensing import SensorConfig
from navstack.sim.servo import ServoConfig
from navstack.validate import instance, is_seed, positive
from navstack.world import Mesh, WorldError

REASONS = ("reached", "collision", "timeout", "stalled", "joint_limit", "error")
RETRACT_TOLERANCE = 0.02
"""A retraction is complete when the retreat's command has come back along the whole recorded path to within this
[m] of its start and the actual tip is this close [m] to where it was at t = 0, no serpentine joint point having
been farther than this [m] from the recorded path on the way out (spec 2a: "every serpentine joint point stays on
it"; ``_retracted``)."""


@dataclass(frozen=True)
class TrialConfig:
    """Everything that sets up a trial besides the world, controller, planner and seed."""

    servo: ServoConfig = field(default_factory=ServoConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    """The tip proximity sensor (``--planner field``)."""
    field_planner: FieldPlannerConfig = field(default_factory=FieldPlannerConfig)
    """The sensing planner's parameters (``--planner field``)."""
    reactive_planner: PlannerConfig = field(default_factory=PlannerConfig)
    """The previous reactive planner's parameters (``--planner reactive``)."""
    slither_mode: str = "projected"
    """Slithering task form for ``--controller slither``: ``projected`` (2 rows per joint point) or ``full``."""
    scripted_speed: float = 0.06
    """Cruise tip speed of the scripted planner [m/s]."""
    clearance_horizon: float = 0.5
    """Each control step's clearance query looks this far [m]; a trial that never comes this close is measured
    again at its end without a limit (:mod:`navstack.sim.far_clearance`), so ``min_clearance`` is exact."""
    joint_limit_time: float = 2.0
    """A joint held at its limit this long [s] while the tip lags by > ``joint_limit_lag`` ends the trial."""
    joint_limit_lag: float = 0.05
    """Tip lag [m] that, with a pinned joint, counts as a joint-limit failure."""
    retract_speed: float = 0.1
    """Tip speed [m/s] of the retraction of ``retract`` worlds (back along the recorded path), faster than the
    planner's 0.06 m/s cruise because the way back is the way the body came: tip error and slither deviation
    <= 0.1 mm at this speed on the retract worlds of ``worlds/`` (0.04 mm at 0.06 m/s, 0.15 mm at 0.12 m/s)."""
    retract_accel: float = 0.1
    """Acceleration and braking [m/s^2] of the retraction."""

    def __post_init__(self) -> None:
        if self.slither_mode not in ("projected", "full"):
            raise ValueError(f"TrialConfig.slither_mode must be 'projected' or 'full', got {self.slither_mode!r}")
        positive(self, "scripted_speed", "clearance_horizon", "joint_limit_time", "joint_limit_lag", "retract_speed",
                 "retract_accel")
        for name, cls in (("servo", ServoConfig), ("sensor", SensorConfig), ("field_planner", FieldPlannerConfig),
                          ("reactive_planner", PlannerConfig)):
            instance(self, name, cls)
        opening = self.field_planner.opening
        if opening.enabled and opening.far_range > self.sensor.max_range:
            raise ValueError(f"TrialConfig.field_planner.opening.far_range ({opening.far_range:g} m) exceeds "
                             f"TrialConfig.sensor.max_range ({self.sensor.max_range:g} m): no ray could count as far, "
                             "so no opening would ever be seen (lower it, or set OpeningConfig(enabled=False))")

    def for_robot(self, serpentine_radius: float) -> TrialConfig:
        """This configuration for a robot whose serpentine links are capsules of ``serpentine_radius`` [m] (the
        world's ``robot.serpentine_radius``): the tip's radius wherever the planners and the sensor take it
        (``Repulsion.body_radius``, ``PlannerConfig.body_radius``, ``SensorConfig.body_radius``) set to it, and
        the lengths measured from the tip's centre that reach beyond its surface grown by the same amount
        (``Repulsion.influence`` and ``unseen_radius``, ``SensorConfig.max_range``), so that clearances and
        reach beyond the surface stay as configured; for a thinner tip, the field planner's seen-free cells
        (``MapConfig.free_cell``) divided by ``ceil(configured radius / serpentine_radius)``, at most 0.8 of its
        radius as 0.02 m is of 0.025 m.  ``self`` when its radii are that radius already (the default robot's
        0.025 m)."""
        r = float(serpentine_radius)
        rep, sensor, reactive = self.field_planner.repulsion, self.sensor, self.reactive_planner
        if rep.body_radius == r and sensor.body_radius == r and reactive.body_radius == r:
            return self
        grow = r - rep.body_radius
        fp = self.field_planner
        if 0.0 < r < rep.body_radius:
            # a thinner tip: the seen-free grid, which is also the navigation function's grid, in cells the size
            # of the configured ones divided by ceil(configured radius / r) (0.02 m -> 0.01 m for a 13 mm tip), so
            # that a passage as narrow relative to this tip as the configured grid is to the configured tip is as
            # finely resolved; the cells stay nested in the configured grid (a whole fraction of it).  Measured
            # (session 49): worlds/hard12/thin_slot 4/13 -> 12/13 reached, 2-4x the wall time for thin robots
            split = math.ceil(round(rep.body_radius / r, 9))
            fp = replace(fp, map=replace(fp.map, free_cell=fp.map.free_cell / split,
                                         free_cell_fallback=fp.map.free_cell))  # coarser where a world is wide
        rep = replace(rep, body_radius=r, influence=rep.influence + grow, unseen_radius=rep.unseen_radius + grow)
        sensor = replace(sensor, body_radius=r, max_range=sensor.max_range + r - sensor.body_radius)
        return replace(self, sensor=sensor, field_planner=replace(fp, repulsion=rep),
                       reactive_planner=replace(reactive, body_radius=r))


@dataclass
class TrialResult:
    """The content of ``result.json`` (interfaces.md section 3)."""

    world: str
    seed: int
    controller: str
    planner: str
    success: bool
    reason: str
    goals_reached: int
    sim_time: float
    steps: int
    wall_time: float
    metrics: dict[str, float | int]
    error: str | None = None
    retracted: bool | None = None
    """``retract`` worlds only: whether the retraction completed (absent from ``result.json`` otherwise)."""
    self_contacts: int = 0
    """Control steps in which the robot touched itself (:mod:`navstack.self_contact`; they make ``reason``
    ``collision``).  Not in ``result.json``, whose ``contacts`` counts obstacle contacts (interfaces.md 3)."""
    self_clearance: str = ""
    """The robot's least distance to itself over the trial, and where (for a person; not in ``result.json``)."""

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        del d["self_contacts"], d["self_clearance"]
        for optional in ("error", "retracted"):
            if d[optional] is None:
                del d[optional]
        return d


@dataclass
class Trajectory:
    """Per-control-step samples written to ``trajectory.npz``."""

    t: list[float] = field(default_factory=list)
    q: list[np.ndarray] = field(default_factory=list)
    q_des: list[np.ndarray] = field(default_factory=list)
    tip_des: list[np.ndarray] = field(default_factory=list)

    def save(self, path: Path) -> None:
        n = len(self.t)
        arrays = {
            "t": np.asarray(self.t, dtype=np.float64).reshape(n),
            "q": np.asarray(self.q, dtype=np.float64).reshape(n, 20),
            "q_des": np.asarray(self.q_des, dtype=np.float64).reshape(n, 20),
            "tip_des": np.asarray(self.tip_des, dtype=np.float64).reshape(n, 3),
        }
        tmp = path.with_name(path.name + ".tmp.npz")
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)


def steps_within(time_limit: float, dt: float) -> int:
    """The most control steps of ``dt`` seconds within ``time_limit`` [s], counting a step that ends within
    1e-9 periods past it (0.7 s at 1/30 s is 20.999999999999996 periods: 21 steps)."""
    return int(np.floor(time_limit / dt + 1e-9))


def sim_time(steps: int, dt: float, time_limit: float) -> float:
    """The simulated time after ``steps`` control periods of ``dt`` seconds, as recorded (``result.json``'s
    ``sim_time``, ``trajectory.npz``'s ``t``): rounded to 1e-9 s (21 periods of 1/30 s read 0.7, not
    0.7000000000000001), and never above ``time_limit``: a step :func:`steps_within` counts though it ends
    a hair past the limit (at most 1e-9 periods) reads as the limit itself."""
    return min(round(steps * dt, 9), time_limit)


def _write_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, path)


class TrialInputError(ValueError):
    """Bad input to :func:`run_trial` other than the world (which raises ``WorldError``): an unknown
    controller or planner, a bad seed, an output folder that cannot be written."""


def _check_choice(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise TrialInputError(f"{name} must be one of {', '.join(allowed)}; got {value!r}")


def check_out_dir(out_dir: str | os.PathLike) -> Path:
    """Create the output folder ``out_dir`` if needed and check that files can be written in it, before
    any simulation; returns it as a ``Path``.

    Raises:
        TrialInputError: in one plain sentence, when the folder cannot be created or written.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        why = "a file of that name exists" if isinstance(e, FileExistsError) else _reason(e)
        raise TrialInputError(f"cannot create the output folder {out} ({why}); choose another --out") from e
    if not out.is_dir():
        raise TrialInputError(f"the output folder {out} is a file, not a folder; choose another --out")
    try:
        with tempfile.NamedTemporaryFile(dir=out, prefix=".navstack-write-test-"):
            pass
    except OSError as e:
        raise TrialInputError(f"cannot write into the output folder {out} ({_reason(e)}); "
                              f"choose another --out") from e
    return out


def _reason(e: OSError) -> str:
    return (e.strerror or type(e).__name__).lower()


def run_trial(
    world,
    *,
    controller: str = "slither",
    planner: str = "field",
    seed: int = 0,
    out_dir: str | os.PathLike | None = None,
    config: TrialConfig | None = None,
    render: bool = False,
) -> TrialResult:
    """Run one closed-loop trial headless and return its result.

    ``world`` is a :class:`navstack.world.World`, a path to a world file, or a parsed world dict.
    With ``out_dir`` the trial writes ``result.json``, ``trajectory.npz`` and the world it ran,
    ``world.json`` (:mod:`navstack.rundir`), there (and ``scene.png`` with ``render=True``).  Bad input raises before
    anything is simulated: ``WorldError`` for the world (unreadable, invalid,
    a goal out of reach, a robot starting in contact with an obstacle) and
    ``TrialInputError`` for the rest (an unknown controller or planner, a bad
    seed, an output folder that cannot be written); both are ``ValueError``.
    A failure inside the simulation is returned as reason ``error`` with the
    message in ``error`` (``navstack run`` then exits 1).
    """
    from navstack.world import World, load_world, world_from_dict

    _check_inputs(controller, planner, seed, config, render, out_dir)
    cfg = config or TrialConfig()
    if isinstance(world, dict):
        world = world_from_dict(world)
    elif not isinstance(world, World):
        world = load_world(world)
    check_reach(world)
    from navstack.sim.probe import build_scene

    built = build_scene(world, visuals=render)  # the trial's client: the start is checked in it, then simulated
    try:
        check_start(world, built)
        out = check_out_dir(out_dir) if out_dir is not None else None
        if out is not None:
            from navstack.rundir import check_run_folder

            try:
                check_run_folder(world, out)
            except ValueError as exc:
                raise TrialInputError(str(exc)) from None
        from navstack.planner.map import MapTooLarge

        try:
            sim = _Simulation(world, controller, planner, int(seed), cfg, visuals=render, built=built)
        except MapTooLarge as exc:  # settings whose cells cannot cover this world's goals: bad input, not a crash
            raise TrialInputError(f"the field planner's map cannot cover this world: {exc}; give larger cells "
                                  "(settings: field_planner.map.free_cell)") from None
        if out is not None:  # the trial is ready: only now replace what an earlier run left in the folder
            from navstack.rundir import clear_run_files, write_run_settings, write_run_world

            clear_run_files(out)
            write_run_world(world, out)  # world.json (meshes copied to out/meshes/): animate and view read it
            if cfg != TrialConfig():  # settings.json: what the run used, when it is not the defaults
                write_run_settings(cfg, out)
    except BaseException:
        built[0].disconnect()
        raise
    wall0 = time.perf_counter()
    try:
        reason = sim.run()
        error = None
    except KeyboardInterrupt:
        reason, error = "error", "interrupted"
        sim.finish_partial()
        if out is not None:
            _save(out, sim, reason, error, time.perf_counter() - wall0, render=False)
        raise
    except Exception as exc:  # noqa: BLE001 - recorded as reason "error", never a silent pass
        reason, error = "error", f"{type(exc).__name__}: {exc}"
        sim.finish_partial()
    result = _save(out, sim, reason, error, time.perf_counter() - wall0, render=render)
    return result


def _check_inputs(controller: str, planner: str, seed: int, config: TrialConfig | None, render: bool,
                  out_dir: str | os.PathLike | None) -> None:
    """:func:`run_trial`'s arguments other than the world: :class:`TrialInputError` naming the first bad one."""
    from navstack.registry import controller_names, planner_names

    _check_choice("controller", controller, controller_names())
    _check_choice("planner", planner, planner_names())
    if not is_seed(seed):
        raise TrialInputError(f"seed must be an integer from 0 to 2**63 - 1, got {seed!r}")
    if config is not None and not isinstance(config, TrialConfig):
        raise TrialInputError(f"config must be a TrialConfig (or None for the defaults), got {config!r:.80}")
    if not isinstance(render, bool):
        raise TrialInputError(f"render must be true or false, got {render!r:.40}")
    if out_dir is not None and (not isinstance(out_dir, (str, os.PathLike)) or not str(out_dir).strip()):
        raise TrialInputError(f"out_dir must be a folder path (or None to write nothing), got {out_dir!r:.80}")


# ---- factories named in navstack.registry ------------------------------------------------------------
def make_slither_controller(chain, q0, dt: float, cfg: TrialConfig):
    """The slithering controller of equation (4) (``--controller slither``)."""
    from navstack.control import ControlConfig, SlitherController

    return SlitherController(chain, ControlConfig(dt=dt, slither=cfg.slither_mode), q0)


def make_tip_only_controller(chain, q0, dt: float, cfg: TrialConfig):
    """Equation (4) with the tip task only (``--controller tip-only``)."""
    from navstack.control import ControlConfig, SlitherController

    return SlitherController(chain, ControlConfig(dt=dt, slither="none"), q0)


def make_field_planner(ctx):
    """The sensing planner (``--planner field``): map, potential, hybrid A*, steering, escape."""
    from navstack.planner.field import FieldPlanner
    from navstack.planner.search import ArmShape

    arm = None if ctx.arm is None else ArmShape(ctx.arm, ctx.flange, ctx.arm_radius, ctx.lathe_axis, ctx.lathe_travel)
    return FieldPlanner(ctx.start, ctx.heading, ctx.goals, ctx.tolerances, ctx.config.field_planner, arm=arm)


def make_reactive_planner(ctx):
    """The previous reactive potential-field planner (``--planner reactive``), kept as a baseline."""
    from navstack.guide import goal_spline
    from navstack.planner.reactive import GoalListAdapter, PotentialFieldPlanner

    inner = PotentialFieldPlanner(ctx.config.reactive_planner, start=ctx.start, heading=ctx.heading,
                                  guide=goal_spline(ctx.start, ctx.heading, ctx.goals))
    return GoalListAdapter(inner, ctx.goals, ctx.tolerances)


def make_scripted_planner(ctx):
    """A smooth spline through the goals, no sensing (``--planner scripted``)."""
    from navstack.scripted import ScriptedConfig, ScriptedPlanner

    return ScriptedPlanner(ctx.start, ctx.heading, ctx.goals, ScriptedConfig(speed=ctx.config.scripted_speed))


def lathe_travel(chain, T0: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frame 1's origin in the world [m] (base transform ``T0``, the other joints at ``q0``) with the lathe bed
    at its lower limit, at its upper limit, and at ``q0``: the segment the bed sweeps, and where it starts."""
    q = np.array(q0, dtype=np.float64)
    out = []
    for value in (chain.lower[0], chain.upper[0], q0[0]):
        q[0] = value
        out.append(T0[:3, :3] @ chain.frames(q)[1, :3, 3] + T0[:3, 3])
    return out[0], out[1], out[2]


def check_reach(world) -> None:
    """Refuse goals that no configuration can reach (``WorldError`` naming the goal).

    A conservative test: a goal farther from the lathe bed's travel (the segment swept by frame 1 over
    the lathe's joint range) than the sum of the fixed distances between consecutive frame origins 1..21
    (an upper bound on the reach of everything beyond the lathe) is out of reach whatever the joints do.
    """
    chain = jpl_serpentine()
    a, b, _ = lathe_travel(chain, world.robot.base.transform(), chain.check(world.robot.q0))
    origins = chain.frames(np.zeros(chain.n))[1:, :3, 3]
    reach = float(np.linalg.norm(np.diff(origins, axis=0), axis=1).sum())
    ab = b - a
    for k, goal in enumerate(world.goals):
        g = np.asarray(goal.position, dtype=np.float64)
        t = float(np.clip((g - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0))
        dist = float(np.linalg.norm(g - (a + t * ab)))
        if dist > reach + goal.tolerance:
            raise WorldError(
                f"{np.round(g, 3).tolist()} is {dist:.2f} m from the lathe bed's travel (placed by robot.base), "
                f"beyond the robot's reach ({reach:.2f} m): no configuration reaches it",
                file=world.source, json_path=f"goals[{k}].position")


def check_start(world, built: tuple[Any, Any, Any] | None = None) -> None:
    """Refuse a robot that starts in contact with or inside an obstacle (``WorldError`` naming it).

    Checked in PyBullet: the robot at ``q0`` and the obstacles at t = 0 (moving ones displaced by their
    ``d(0)``); an obstacle at a signed distance <= 0 m from any robot link is named by its JSON path
    (``obstacles[3]``).  Such a trial would count a contact from its first step; refusing it makes the
    world's mistake bad input.  PyBullet sees a mesh as a surface, so a robot wholly inside a closed mesh
    touches nothing there: such a mesh is named too (:mod:`navstack.sim.mesh_inside`).
    ``built``: the ``(client, body, scene)`` of :func:`navstack.sim.probe.build_scene` a trial is about to run
    in, checked there (one client per trial); else a throwaway one is built.
    """
    from navstack.sim.probe import build_scene

    client, body, scene = built if built is not None else build_scene(world)
    try:
        client.performCollisionDetection()  # as run() begins: link poses current for the distance queries
        hits = scene.touching(body.body_id)
        frames = body.link_frames_world() if any(isinstance(o, Mesh) for o in world.obstacles) else None
    finally:
        if built is None:
            client.disconnect()
    if not hits and frames is not None:
        hits = _inside_closed_meshes(world, frames[:, :3, 3])
    if hits:
        i, d = hits[0]
        how = ("is inside" if d == -math.inf else "touches" if d > -1e-6 else f"penetrates {-d:.3g} m into")
        others = "" if len(hits) == 1 else f" (so do obstacles {', '.join(f'[{j}]' for j, _ in hits[1:])})"
        raise WorldError(f"the robot at q0 {how} this {world.obstacles[i].type} at t = 0{others}; a trial must "
                         f"start clear of every obstacle", file=world.source, json_path=f"obstacles[{i}]")
    _check_self_contact_at_start(world, body)


def _check_self_contact_at_start(world, body) -> None:
    """Refuse a robot whose own capsules touch at ``q0`` (``WorldError``): every trial of it would end in
    ``collision`` (:mod:`navstack.self_contact`).  Named by what makes it so: ``robot.serpentine_radius`` or
    ``robot.arm_radius`` when the robot is clear of itself with that radius at its default, else ``robot.q0``
    (a straight serpentine's joint points two links apart are 0.2 m apart: radius 0.1 m touches there)."""
    from navstack import jpl

    origins = (body.base_transform @ body.chain.frames(world.robot.q0))[1:, :3, 3]
    a, b, r = body.capsules(origins)
    pairs = self_pairs(body.link_radii)
    gap, k = self_clearance(a, b, r, pairs)
    if gap > 0.0:
        return
    serpentine = capsule_frames(body.link_radii) >= FIRST_SERPENTINE_FRAME
    robot, path = world.robot, "robot.q0"
    for name, default, links in (("serpentine_radius", jpl.SERPENTINE_RADIUS, serpentine),
                                 ("arm_radius", jpl.ARM_RADIUS, ~serpentine)):
        if getattr(robot, name) != default and self_clearance(a, b, np.where(links, default, r), pairs)[0] > 0.0:
            path = f"robot.{name}"
            break
    f, g = pair_frames(body.link_radii, pairs, k)
    how = "touching" if gap > -5e-5 else f"overlapping {-gap * 1e3:.1f} mm"
    raise WorldError(f"the robot touches itself at q0 (the capsules of DH frames {f} and {g} {how}, "
                     f"serpentine_radius {robot.serpentine_radius:g} m, arm_radius {robot.arm_radius:g} "
                     f"m); every trial would end in collision", file=world.source, json_path=path)


def _inside_closed_meshes(world, origins: np.ndarray) -> list[tuple[int, float]]:
    """``(i, -inf)`` for each closed mesh ``world.obstacles[i]`` holding the robot, from the first and last of
    its DH frame origins ``origins`` (21, 3) [m, world].  Two points decide it: the robot's capsules make one
    connected body that touches no mesh (checked before), so it lies wholly in one side of each surface."""
    from navstack.sim.mesh_inside import points_inside

    points = origins[[0, -1]]
    return [(i, -math.inf) for i, o in enumerate(world.obstacles)
            if isinstance(o, Mesh) and bool(points_inside(o, points).any())]


def _save(out: Path | None, sim: _Simulation, reason: str, error: str | None, wall: float, render: bool):
    result = sim.result(reason, error, wall)
    if out is not None:
        sim.trajectory.save(out / "trajectory.npz")
        if render and reason != "error":
            from navstack.render import render_scene

            render_scene(sim, out / "scene.png", result)
        _write_json(out / "result.json", result.to_dict())
    sim.close()
    return result


class _Simulation:
    """The PyBullet side and the pipeline objects of one trial."""

    def __init__(self, world, controller: str, planner: str, seed: int, cfg: TrialConfig,
                 visuals: bool = False, built: tuple[Any, Any, Any] | None = None) -> None:
        """``visuals``: build the bodies with visual shapes (for ``render_scene``; nothing else reads them).
        ``built``: the ``(client, body, scene)`` of :func:`navstack.sim.probe.build_scene` for ``world`` and
        ``visuals``, made by the caller (who checked the start in it); None: built here."""
        from navstack.registry import CONTROLLERS, PLANNERS, PlannerContext, load
        from navstack.sim.probe import build_scene
        from navstack.sim.servo import JointServo

        self.world = world
        self.controller_name = controller
        self.planner_name = planner
        self.seed = seed
        cfg = cfg.for_robot(world.robot.serpentine_radius)  # the planners' and the sensor's tip: the world's robot
        self.cfg = cfg
        self.chain = jpl_serpentine()
        self.client, self.body, self.scene = built if built is not None else build_scene(world, visuals)
        robot = world.robot
        self.T0 = robot.base.transform()
        self.R0 = self.T0[:3, :3]
        self.p0 = self.T0[:3, 3]
        self.q0 = self.chain.check(robot.q0)
        for obstacle in self.scene.body_ids:  # contact is measured, not simulated (module docstring)
            for link in range(-1, self.client.getNumJoints(self.body.body_id)):
                self.client.setCollisionFilterPair(self.body.body_id, obstacle, link, -1, 0)
        self.servo = JointServo(self.body, cfg.servo)
        self.servo.hold(self.q0)
        self.dt = cfg.servo.control_dt
        self.controller = load(CONTROLLERS[controller].factory)(self.chain, self.q0, self.dt, cfg)
        self.goals = np.array([g.position for g in world.goals])
        self.tolerances = np.array([g.tolerance for g in world.goals])
        F = self.chain.frames(self.q0)
        tip0 = self._to_world(F[21, :3, 3])
        heading0 = self.R0 @ F[20, :3, 0]
        self.rng = np.random.default_rng(seed)
        from navstack.generate.geometry import segment_samples  # the arm's axis, sampled for the planner

        entry = PLANNERS[planner]
        arm_frames = np.array([self._to_world(F[i, :3, 3]) for i in range(1, 10)])
        context = PlannerContext(start=tip0, heading=heading0, goals=self.goals, tolerances=self.tolerances,
                                 dt=self.dt, config=cfg, arm=segment_samples(arm_frames[:-1], arm_frames[1:], 0.05),
                                 arm_radius=world.robot.arm_radius, flange=arm_frames[-1],
                                 **self._lathe())
        self.planner = load(entry.factory)(context)
        self.sensor = None
        self.estimator = None
        if entry.senses:
            from navstack.estimate import RangeEstimator
            from navstack.sim.rays import RaySensor

            self.sensor = RaySensor(self.client, cfg.sensor, self.body.body_id, self.rng)
            self.estimator = RangeEstimator(cfg.sensor)
        self.trajectory = Trajectory()
        self.goal_index = 0
        self.steps = 0
        self.tip_error_max = 0.0
        self.slither_dev_max = 0.0
        self.min_clearance = np.inf
        self._capsules_before = None  # the robot's capsules at the last measurement (the swept check)
        self.contacts = 0
        self.self_pairs = self_pairs(self.body.link_radii)  # the robot's own capsules (navstack.self_contact)
        self.self_contacts = 0
        self.self_clearance = (np.inf, -1)  # the least [m], and the pair of self_pairs where
        self.pinned_time = 0.0
        self.tip_des = tip0.copy()
        self.tip_des_reverse = False
        self.tip0 = tip0.copy()
        self.retracting = False
        self.retreat = None
        self.retracted = False
        self.retract_dev_max = 0.0  # m: the serpentine joint points' farthest from the recorded path, backing out
        self.closed = False

    # ---- frames ---------------------------------------------------------
    def _lathe(self) -> dict[str, Any]:
        """The lathe bed's unit axis in the world and how far it may still move along it from ``q0`` [m]
        (frame 1's origin at the joint's two limits; the planner's :class:`ArmShape` fields)."""
        a, b, p = lathe_travel(self.chain, self.T0, self.q0)
        axis = (b - a) / np.linalg.norm(b - a)
        return {"lathe_axis": axis, "lathe_travel": (min(float((a - p) @ axis), 0.0), max(float((b - p) @ axis), 0.0))}

    def _to_world(self, p_base: np.ndarray) -> np.ndarray:
        return self.R0 @ p_base + self.p0

    def _to_base(self, p_world: np.ndarray) -> np.ndarray:
        return self.R0.T @ (p_world - self.p0)

    # ---- the loop ---------------------------------------------------------
    def _measure(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Update metrics from the measured joints ``q``; return the measured tip (world) and the frames."""
        F = self.chain.frames(q)
        origins = F[1:22, :3, 3] @ self.R0.T + self.p0  # frames 1..21 in the world
        tip = self._to_world(F[21, :3, 3])
        boxes = self.body.link_boxes(origins)
        capsules = self.body.capsules(origins)
        record = min(self.min_clearance, self.cfg.clearance_horizon)  # exact below it: min_clearance is exact
        clearance = self.scene.clearance(self.body.body_id, self.cfg.clearance_horizon, boxes, record, capsules)
        if self.scene.movers and self.steps:  # and while they moved since the last control step
            t = self.steps * self.dt
            clearance = self.scene.swept_clearance(self.body.body_id, t - self.dt, t, clearance, boxes, capsules,
                                                   self._capsules_before)
        self._capsules_before = capsules
        self.min_clearance = min(self.min_clearance, clearance)
        if clearance <= 0.0:
            self.contacts += 1
        self._measure_self(capsules)
        path = self.controller.path
        points = F[BACKBONE_FRAMES[1:], :3, 3]
        many = getattr(path, "max_distance_to_path", None)  # PathMemory's: one compiled call for all six
        deviation = many(points) if many is not None else max(path.distance_to_path(p) for p in points)
        self.slither_dev_max = max(self.slither_dev_max, deviation)
        if self.retracting:
            self.retract_dev_max = max(self.retract_dev_max, deviation)
        return tip, F

    def _measure_self(self, capsules: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """Count a step whose robot touches itself (:mod:`navstack.self_contact`); keep the least distance."""
        gap, k = self_clearance(*capsules, self.self_pairs)
        if gap <= 0.0:
            self.self_contacts += 1
        if gap < self.self_clearance[0]:
            self.self_clearance = (gap, k)

    def _ended(self, reason: str) -> str:
        """``reason``, unless the robot touched an obstacle or itself on the way: then ``collision``."""
        return "collision" if self.contacts or self.self_contacts else reason

    def _advance_goals(self, tip: np.ndarray) -> None:
        while self.goal_index < len(self.goals) and (
            np.linalg.norm(tip - self.goals[self.goal_index]) <= self.tolerances[self.goal_index]
        ):
            self.goal_index += 1

    def run(self) -> str:
        """Run the trial to its outcome (``reason``); ``min_clearance`` then exact beyond the horizon too."""
        reason = self._loop()
        if self.min_clearance >= self.cfg.clearance_horizon:  # nothing ever came within it: measure again
            self.min_clearance = self._replayed_min_clearance()
        return reason

    def _replayed_min_clearance(self) -> float:
        """The recorded steps measured again without a horizon (:mod:`navstack.sim.far_clearance`)."""
        from navstack.sim.far_clearance import replay_min_clearance

        qs = np.asarray(self.trajectory.q, dtype=np.float64)
        origins = np.array([self.chain.frames(q)[1:22, :3, 3] @ self.R0.T + self.p0 for q in qs]).reshape(-1, 21, 3)
        return replay_min_clearance(self.scene, self.body, qs, origins, np.asarray(self.trajectory.t), self.dt)

    def _loop(self) -> str:
        self.client.performCollisionDetection()
        q, _ = self.body.joint_state()
        tip, F = self._measure(q)
        self._record(q, self.q0)
        limit_steps = steps_within(self.world.time_limit, self.dt)  # never beyond time_limit
        pinned_steps = int(np.ceil(self.cfg.joint_limit_time / self.dt))
        pinned = 0
        while True:
            self._advance_goals(tip)
            if self.goal_index >= len(self.goals) and (not self.world.retract or self._retracted(tip)):
                return self._ended("reached")
            if pinned >= pinned_steps:  # after the goals: one reached on this very sample still counts
                return self._ended("joint_limit")
            if self.steps >= limit_steps:
                return self._ended("timeout")
            cmd = self._plan(tip, F) if self.goal_index < len(self.goals) else self._retract()
            if cmd.stalled:
                return self._ended("stalled")
            x_d = np.asarray(cmd.position, dtype=np.float64)
            v_d = np.asarray(cmd.velocity, dtype=np.float64)
            if not (np.isfinite(x_d).all() and np.isfinite(v_d).all()):
                raise FloatingPointError(f"planner produced a non-finite tip command at step {self.steps}")
            # equation (4) is evaluated at time t: the command of the previous step x_d(t) with the rate
            # v_d over [t, t + dt]; it returns theta_d(t + dt), whose tip is the new command x_d(t + dt)
            # (passing the new command itself would make theta_d lead it by one period, v_d * dt); a
            # reverse x_d(t) (retracing the path) cuts the controller's path memory back to it
            reverse = {"reverse": True} if self.tip_des_reverse else {}
            theta_d = self.controller.step(self._to_base(self.tip_des), self.R0.T @ v_d, **reverse)
            self.tip_des = x_d
            self.tip_des_reverse = bool(cmd.reverse)
            self.servo.command(theta_d, self.controller.thetadot_d)
            self.servo.step()
            self.steps += 1
            if self.scene.update(self.steps * self.dt):  # moving obstacles, before rays and clearance
                self.client.performCollisionDetection()
            q, _ = self.body.joint_state()
            tip, F = self._measure(q)
            self.tip_error_max = max(self.tip_error_max, float(np.linalg.norm(tip - x_d)))
            self._record(q, theta_d)
            at_limit = np.any((theta_d <= self.chain.lower + 1e-6) | (theta_d >= self.chain.upper - 1e-6))
            pinned = pinned + 1 if at_limit and np.linalg.norm(tip - x_d) > self.cfg.joint_limit_lag else 0

    def _plan(self, tip: np.ndarray, F: np.ndarray):
        """The planner's command for the current goal (sensing first, for a sensing planner)."""
        reading = None
        if self.sensor is not None:
            raw = self.sensor.read(self.T0 @ F[21])
            reading = self.estimator.update(raw, self.dt)
        return self.planner.step(self.dt, tip, self.R0 @ F[20, :3, 0], reading, self.goal_index)

    def _retract(self):
        """After the last goal of a ``retract`` world: back along the controller's recorded path (world frame).

        The first call holds the last command for one period, so the controller records it and the retreat
        starts from rest exactly at the end of its path; then a :class:`~navstack.retreat.Retreat` to the
        arc length of the initial tip (the planner is no longer consulted).
        """
        from navstack.planner import TipCommand
        from navstack.retreat import Retreat

        if not self.retracting:
            self.retracting = True
            return TipCommand(position=self.tip_des.copy(), velocity=np.zeros(3), stalled=False, mode="retreat")
        if self.retreat is None:
            path = self.controller.path
            self.retreat = Retreat(path, path.start_arc_length, self.cfg.retract_speed, self.cfg.retract_accel)
        cmd = self.retreat.step(self.dt)
        return replace(cmd, position=self._to_world(cmd.position), velocity=self.R0 @ cmd.velocity)

    def _retracted(self, tip: np.ndarray) -> bool:
        """Whether the robot is back out: the retreat's command has come back along the whole recorded path, to
        within :data:`RETRACT_TOLERANCE` of its start, the actual tip is within it of where it was at t = 0, and
        no serpentine joint point has been farther than it from the recorded path since the retraction began.
        (The tip alone once ended a retraction halfway, where a way in that loops passed near its start: 0.14 m
        of 1.96 m backed out, every joint point still 0.3-1.8 m in; an audit.  And a body that does not follow
        its path, ``tip-only``'s, backed out 0.34 m off it in free space and was a success; a review, session 40:
        it backs out still, and runs on to ``timeout``, ``retracted: false``.)"""
        back = self.retreat is not None and self.retreat.remaining <= RETRACT_TOLERANCE
        on_path = self.retract_dev_max <= RETRACT_TOLERANCE
        self.retracted = self.retracting and back and on_path and float(np.linalg.norm(tip - self.tip0)) <= \
            RETRACT_TOLERANCE
        return self.retracted

    def _record(self, q: np.ndarray, q_des: np.ndarray) -> None:
        tr = self.trajectory
        tr.t.append(sim_time(self.steps, self.dt, self.world.time_limit))
        tr.q.append(np.array(q, dtype=np.float64))
        tr.q_des.append(np.array(q_des, dtype=np.float64))
        tr.tip_des.append(np.array(self.tip_des, dtype=np.float64))

    def finish_partial(self) -> None:
        """Make the recorded arrays consistent after an exception mid-step."""
        tr = self.trajectory
        n = min(len(tr.t), len(tr.q), len(tr.q_des), len(tr.tip_des))
        del tr.t[n:], tr.q[n:], tr.q_des[n:], tr.tip_des[n:]

    def result(self, reason: str, error: str | None, wall: float) -> TrialResult:
        return TrialResult(
            world=self.world.name,
            seed=self.seed,
            controller=self.controller_name,
            planner=self.planner_name,
            success=reason == "reached",
            reason=reason,
            goals_reached=int(self.goal_index),
            sim_time=sim_time(self.steps, self.dt, self.world.time_limit),
            steps=int(self.steps),
            wall_time=round(wall, 3),
            metrics={
                "tip_error_max": float(self.tip_error_max),
                "slither_deviation_max": float(self.slither_dev_max),
                "min_clearance": self._reported_clearance(reason),
                "contacts": int(self.contacts),
            },
            error=error,
            retracted=bool(self.retracted) if self.world.retract else None,
            self_contacts=int(self.self_contacts),
            self_clearance=self._self_clearance_text(),
        )

    def _self_clearance_text(self) -> str:
        """``TrialResult.self_clearance``: the robot's least distance to itself and between which capsules."""
        gap, k = self.self_clearance
        if k < 0:
            return ""
        a, b = pair_frames(self.body.link_radii, self.self_pairs, k)
        return f"{gap * 1e3:.1f} mm between the capsules of DH frames {a} and {b}"

    def _reported_clearance(self, reason: str) -> float | None:
        """``min_clearance`` [m] for ``result.json``: None when unknown (no obstacle; never measured; a trial
        that ended in ``error`` before anything came within the horizon, so it was not replayed)."""
        if not np.isfinite(self.min_clearance):
            return None
        if reason == "error" and self.min_clearance >= self.cfg.clearance_horizon:
            return None
        return float(self.min_clearance)

    def close(self) -> None:
        if not self.closed:
            self.client.disconnect()
            self.closed = True
