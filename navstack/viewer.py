"""``navstack view RUN_DIR``: a run folder in a 3D viewer in the browser (optional extra ``navstack[viewer]``).

Built on viser (https://viser.studio): a Python web server that ships its prebuilt three.js client in the
wheel, so nothing is fetched at run time, and gives GUI widgets (buttons, sliders, text) and scene nodes
whose poses are updated from Python.  meshcat (the other candidate) has had no release since 2021 and
needs a ZeroMQ server process beside the web server; viser is one process, maintained, and has the
play/pause/slider widgets built in.

What it shows (world frame, metres): the obstacles (one merged mesh), the robot's capsules (interfaces.md
section 1) at the measured joints of the chosen time, links touching an obstacle in red (recomputed with
PyBullet, as the animations do), the commanded tip path, the goals (radius = tolerance; gold, green once
reached), the sensed points of that control step when ``trajectory.npz`` recorded ``sensed``, and a
caption with the time, the goal count and the outcome.  A Play/Pause button and a time slider drive the
replay (``speed`` x real time).
"""

from __future__ import annotations

import contextlib
import io
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from navstack.jpl import jpl_serpentine
from navstack.render import CONTACT_RGB, GOAL_RGB, PATH_RGB, REACHED_RGB, outcome_line
from navstack.rundir import RunData, load_run

OBSTACLE_RGB = (140, 158, 191)
ARM_RGB = (217, 140, 38)
SERPENTINE_RGB = (51, 153, 64)
SENSED_RGB = (30, 110, 255)
TICK = 1.0 / 30.0
"""Seconds between replay updates while playing."""
PICTURE_WINDOW = (-1.0, 0.4)
"""Horizontal part of a 16:10 browser window the first view frames the run in (the control panel is on
the right)."""


def _wxyz(R: NDArray[np.float64]) -> NDArray[np.float64]:
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


def obstacle_mesh(world):
    """All obstacles of ``world`` as one trimesh (world frame, m)."""
    import trimesh

    from navstack.world import Box, Cylinder, Mesh, Sphere

    parts = []
    for o in world.obstacles:
        if isinstance(o, Cylinder):
            parts.append(trimesh.creation.cylinder(radius=o.radius, segment=[o.p0, o.p1], sections=16))
        elif isinstance(o, Sphere):
            parts.append(trimesh.creation.icosphere(subdivisions=2, radius=o.radius).apply_translation(o.center))
        elif isinstance(o, Box):
            T = np.eye(4)
            T[:3, :3] = Rotation.from_euler("xyz", o.rpy).as_matrix()
            T[:3, 3] = o.center
            parts.append(trimesh.creation.box(extents=2 * o.half_extents, transform=T))
        elif isinstance(o, Mesh):
            v, f = o.triangles()
            R = Rotation.from_euler("xyz", o.rpy).as_matrix()
            parts.append(trimesh.Trimesh(vertices=v @ R.T + o.position, faces=f, process=False))
    return trimesh.util.concatenate(parts) if parts else None


def link_capsules(world) -> list[tuple[int, Any, tuple[int, int, int]]]:
    """(DH frame k, capsule trimesh in frame k's coordinates, colour) for every robot link with a segment."""
    import trimesh

    chain = jpl_serpentine()
    F = chain.frames(np.zeros(chain.n))
    out = []
    for k in range(1, len(chain.alpha)):
        seg = (np.linalg.inv(F[k]) @ F[k + 1])[:3, 3]
        length = float(np.linalg.norm(seg))
        if length < 1e-9:
            continue
        serp = k >= 9
        r = world.robot.serpentine_radius if serp else world.robot.arm_radius
        cap = trimesh.creation.capsule(height=length, radius=r, count=[12, 12])
        T = np.eye(4)
        T[:3, :3] = Rotation.align_vectors([seg / length], [[0.0, 0.0, 1.0]])[0].as_matrix()
        T[:3, 3] = seg / 2.0
        out.append((k, cap.apply_transform(T), SERPENTINE_RGB if serp else ARM_RGB))
    return out


@dataclass
class Viewer:
    """A running viewer of one run: ``url`` to open, :meth:`seek` / :meth:`play` / :meth:`pause` drive it."""

    run: RunData
    server: Any
    contacts: list[frozenset[int]]
    reached: NDArray[np.int64]
    links: dict[int, Any] = field(default_factory=dict)
    goals: list[Any] = field(default_factory=list)
    speed: float = 1.0
    playing: bool = False
    clock: float = 0.0
    """The replay clock [s]; ``index`` is the last sample at or before it."""
    index: int = 0
    obstacles: Any = None
    button: Any = None
    slider: Any = None
    caption: Any = None
    _from_slider: bool = False
    _lock: threading.RLock = field(default_factory=threading.RLock)
    _stop: threading.Event = field(default_factory=threading.Event)

    @property
    def url(self) -> str:
        host = self.server.get_host()
        host = "127.0.0.1" if host in ("0.0.0.0", "") else host
        return f"http://{host}:{self.server.get_port()}"

    def seek(self, t: float) -> None:
        """Show the last control step at or before ``t`` [s] (clipped to the run)."""
        run = self.run
        t = float(np.clip(t, run.t[0], run.t[-1]))
        i = int(np.clip(np.searchsorted(run.t, t + 1e-9, side="right") - 1, 0, len(run.t) - 1))
        with self._lock:
            self.clock, self.index = t, i
            T0 = run.world.robot.base.transform()
            F = T0 @ jpl_serpentine().frames(run.q[i])
            touching = self.contacts[i]
            with self.server.atomic():
                for k, handle in self.links.items():
                    handle.position = F[k, :3, 3]
                    handle.wxyz = _wxyz(F[k, :3, :3])
                    handle.color = CONTACT_RGB if (k - 1) in touching else handle_colour(k)
                for g, handle in enumerate(self.goals):
                    handle.color = REACHED_RGB if g < self.reached[i] else GOAL_RGB
                if run.sensed is not None:
                    pts = run.sensed[i][np.isfinite(run.sensed[i]).all(axis=1)]
                    self.server.scene.add_point_cloud("/sensed", points=pts.reshape(-1, 3), colors=SENSED_RGB,
                                                      point_size=0.01)
                self.caption.content = self._caption(i, touching)
            if abs(self.slider.value - float(run.t[i])) > 1e-9 and not self._from_slider:
                self.slider.value = float(run.t[i])

    def _caption(self, i: int, touching: frozenset[int]) -> str:
        run = self.run
        text = f"**t = {run.t[i]:.2f} s**, goals {self.reached[i]}/{len(run.world.goals)}"
        if touching:
            text += f", **contact: {len(touching)} link{'s' if len(touching) > 1 else ''}**"
        return text

    def play(self) -> None:
        if self.index >= len(self.run.t) - 1:
            self.seek(0.0)
        self.playing = True
        self.button.label = "Pause"

    def pause(self) -> None:
        self.playing = False
        self.button.label = "Play"

    def _loop(self) -> None:
        last = time.monotonic()
        while not self._stop.wait(TICK):
            now = time.monotonic()
            if self.playing:  # the replay clock runs on between samples (slow speeds too)
                self.seek(self.clock + (now - last) * self.speed)
                if self.index >= len(self.run.t) - 1:
                    self.pause()
            last = now

    def stop(self) -> None:
        """Stop the replay thread and the web server."""
        self._stop.set()
        self.server.stop()


def handle_colour(k: int) -> tuple[int, int, int]:
    """The own colour of the link carrying DH frame ``k``."""
    return SERPENTINE_RGB if k >= 9 else ARM_RGB


def start_viewer(run: RunData | str, host: str = "127.0.0.1", port: int = 8080, speed: float = 1.0) -> Viewer:
    """Start the viewer of ``run`` (a :class:`RunData` or a run folder) on ``host:port`` (the next free port
    if taken; 0 for any) and return it, paused at t = 0.  Raises ``ImportError`` without viser."""
    import viser

    from navstack.animate import contacts_per_sample, goals_reached_per_sample

    run = run if isinstance(run, RunData) else load_run(run)
    contacts = contacts_per_sample(run)
    with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner with the address; serve() prints it
        server = viser.ViserServer(host=host, port=port, label="navstack", verbose=False)
    app = Viewer(run=run, server=server, contacts=contacts, reached=goals_reached_per_sample(run), speed=speed)
    _build_scene(app)
    _build_gui(app)
    app.seek(0.0)
    threading.Thread(target=app._loop, name="navstack-viewer", daemon=True).start()
    return app


def _build_scene(app: Viewer) -> None:
    from navstack.animate import robot_points
    from navstack.render import auto_view, framing_points

    run, scene = app.run, app.server.scene
    scene.set_up_direction("+z")
    mesh = obstacle_mesh(run.world)
    if mesh is not None:
        app.obstacles = scene.add_mesh_simple("/world/obstacles", vertices=mesh.vertices, faces=mesh.faces,
                                              color=OBSTACLE_RGB)
    T0 = run.world.robot.base.transform()
    chain = jpl_serpentine()  # the lathe bed: a rail along z0 over the prismatic joint's travel, as in PyBullet
    lo, hi = float(chain.lower[0]), float(chain.upper[0])
    scene.add_box("/world/lathe_bed", color=(77, 77, 89), dimensions=(0.1, 0.24, hi - lo + 0.2),
                  position=(T0 @ np.array([-0.1, 0.0, (lo + hi) / 2, 1.0]))[:3], wxyz=_wxyz(T0[:3, :3]))
    for k, cap, colour in link_capsules(run.world):
        app.links[k] = scene.add_mesh_simple(f"/robot/link{k}", vertices=cap.vertices, faces=cap.faces,
                                             color=colour)
    scene.add_spline_catmull_rom("/path/tip_des", points=run.tip_des[:: max(1, len(run.tip_des) // 400)],
                                 color=PATH_RGB, thickness=2.0, thickness_units="screen")
    for g, goal in enumerate(run.world.goals):
        app.goals.append(scene.add_icosphere(f"/goals/{g}", radius=goal.tolerance, color=GOAL_RGB,
                                             position=goal.position))
    view = auto_view(framing_points(run.world, robot_points(run, chain, T0)), width=16, height=10,
                     toward=T0[:3, 3], window=PICTURE_WINDOW)
    cam = app.server.initial_camera
    cam.position, cam.look_at, cam.up = np.array(view.eye), np.array(view.target), np.array([0.0, 0.0, 1.0])
    cam.fov = math.radians(view.fov)


def _build_gui(app: Viewer) -> None:
    run, gui = app.run, app.server.gui
    res = run.result or {}
    gui.add_markdown(f"**{run.world.name}**: {res.get('controller', '?')} / {res.get('planner', '?')}  \n"
                     + outcome_line(run.result, len(run.world.goals))[0])
    app.button = gui.add_button("Play")
    app.slider = gui.add_slider("time [s]", min=0.0, max=max(run.duration, 1e-3),
                                step=float(np.min(np.diff(run.t))) if len(run.t) > 1 else 0.01, initial_value=0.0)
    speed = gui.add_slider("speed", min=0.1, max=4.0, step=0.1, initial_value=app.speed)
    app.caption = gui.add_markdown("")

    @app.button.on_click
    def _(_event) -> None:
        app.pause() if app.playing else app.play()

    @app.slider.on_update
    def _(_event) -> None:
        if abs(app.slider.value - float(run.t[app.index])) > 1e-9:
            app._from_slider = True
            try:
                app.seek(app.slider.value)
            finally:
                app._from_slider = False

    @speed.on_update
    def _(_event) -> None:
        app.speed = float(speed.value)


def serve(run_dir: str, host: str = "127.0.0.1", port: int = 8080, world=None) -> int:
    """``navstack view``: start the viewer, print its address, serve until Ctrl-C; return the exit status."""
    try:
        import viser  # noqa: F401
    except ImportError as e:
        raise ImportError("navstack view needs the viewer extra: pip install 'navstack[viewer]' (viser)") from e
    run = load_run(run_dir, world)
    print(f"navstack view: replaying {run.path} ({run.world.name}, {run.duration:.1f} s); computing contacts ...")
    app = start_viewer(run, host=host, port=port)
    print(f"navstack view: open {app.url} in a browser (Ctrl-C to stop)", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        print("navstack view: stopped")
    finally:
        app.stop()
    return 0
