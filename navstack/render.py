"""Pictures of a trial: PyBullet's TinyRenderer plus the tip path drawn on top.

The camera uses explicit view and projection matrices (OpenGL convention,
column-major as PyBullet returns them); the commanded tip path and the goals
are projected with the same matrices and drawn with matplotlib, since the
TinyRenderer does not draw debug lines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from navstack.sim._bullet import pybullet


def _project(view, proj, pts: np.ndarray, width: int, height: int) -> np.ndarray:
    V = np.asarray(view, dtype=float).reshape(4, 4).T
    P = np.asarray(proj, dtype=float).reshape(4, 4).T
    h = np.c_[pts, np.ones(len(pts))] @ (P @ V).T
    ndc = h[:, :3] / h[:, 3:4]
    return np.c_[(ndc[:, 0] + 1) / 2 * width, (1 - ndc[:, 1]) / 2 * height]


def camera(target: np.ndarray, eye: np.ndarray, width: int, height: int, fov: float = 45.0):
    """View and projection matrices looking from ``eye`` at ``target`` (world, m), z up."""
    view = pybullet.computeViewMatrix(list(eye), list(target), [0, 0, 1])
    proj = pybullet.computeProjectionMatrixFOV(fov, width / height, 0.05, 20.0)
    return view, proj


def render_scene(sim, path: Path, width: int = 960, height: int = 720) -> Path:
    """Render the robot in its world at the end of the trial ``sim`` with the tip path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tip_path = np.asarray(sim.trajectory.tip_des)
    goals = sim.goals
    base = sim.p0
    target = 0.4 * base + 0.6 * goals.mean(axis=0)
    span = np.linalg.norm(goals.mean(axis=0) - base) + 0.6
    eye = target + span * np.array([-0.3, -1.0, 0.45])
    view, proj = camera(target, eye, width, height)
    img = sim.client.getCameraImage(
        width,
        height,
        viewMatrix=view,
        projectionMatrix=proj,
        renderer=pybullet.ER_TINY_RENDERER,
        lightDirection=[1.0, -2.0, 3.0],
        shadow=0,
    )[2]
    rgb = np.reshape(np.asarray(img, dtype=np.uint8), (height, width, 4))[:, :, :3]
    fig = plt.figure(figsize=(width / 100, height / 100), dpi=100)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.imshow(rgb)
    if len(tip_path):
        uv = _project(view, proj, tip_path, width, height)
        ax.plot(uv[:, 0], uv[:, 1], "-", color="crimson", lw=1.8, label="commanded tip path")
    g = _project(view, proj, goals, width, height)
    ax.plot(g[:, 0], g[:, 1], "o", ms=7, mfc="none", mec="gold", mew=2, label="goals")
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)
    ax.axis("off")
    ax.legend(loc="lower right", fontsize=9)
    ax.text(
        10,
        24,
        f"{sim.world.name}: {sim.controller_name} / {sim.planner_name}, t = {sim.steps * sim.dt:.1f} s",
        color="black",
        fontsize=11,
    )
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path
