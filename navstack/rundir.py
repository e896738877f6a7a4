"""A trial's output folder (``navstack run --out DIR``) read back: the world it ran, its trajectory, its result.

``run_trial(..., out_dir=DIR)`` writes ``DIR/world.json`` (:func:`write_run_world`) beside
``result.json`` and ``trajectory.npz``, so that ``navstack animate DIR`` and ``navstack view DIR`` need
nothing but the folder.  Mesh obstacles: their files are copied into ``DIR/meshes/`` and ``world.json``
names them there (``meshes/<index>-<file name>``, :func:`mesh_copy_name`), so the run folder is
self-contained: it can be moved or archived, and its mesh paths never leave its own folder tree.  A rerun
into the same folder first removes what the earlier run wrote (:data:`RUN_FILES`).

``trajectory.npz`` holds ``t`` (T,), ``q`` (T, 20), ``q_des`` (T, 20), ``tip_des`` (T, 3)
(interfaces.md section 3) and, optionally, ``sensed`` (T, K, 3): world points [m] the tip sensors hit
at each control step, NaN where a ray hit nothing.  navstack does not record ``sensed`` today; the
viewer draws it when a trajectory has it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from navstack.world import MAX_TIME_LIMIT, Mesh, World, WorldError, load_world, save_world

WORLD_FILE = "world.json"
TRAJECTORY_FILE = "trajectory.npz"
RESULT_FILE = "result.json"
MESH_DIR = "meshes"
SETTINGS_FILE = "settings.json"
"""Every setting of a trial run with settings other than the defaults (``run_trial(config=...)``, ``--settings``)."""
RUN_FILES = (RESULT_FILE, TRAJECTORY_FILE, WORLD_FILE, SETTINGS_FILE, "scene.png", "animation.mp4", "animation.gif")
"""What a run writes into its folder; a new run into the same folder removes them first (a run folder
holds one run: an old ``scene.png`` beside a new ``result.json`` would show another trial)."""
MAX_NAME_BYTES = 255
"""The longest file name most file systems take."""


def clear_run_files(out_dir: str | os.PathLike[str]) -> None:
    """Remove what an earlier run wrote into ``out_dir`` (:data:`RUN_FILES`), if it holds one (a ``result.json``
    or ``trajectory.npz``): a folder that never held a run keeps its files.  Its ``meshes/`` copies stay, as the
    folder may hold the user's own meshes there, and the new ``world.json`` names the ones it uses."""
    out = Path(out_dir)
    if not any((out / name).is_file() for name in (RESULT_FILE, TRAJECTORY_FILE)):
        return
    for name in RUN_FILES:
        if (out / name).is_file() or (out / name).is_symlink():
            (out / name).unlink()


def check_run_folder(world: World, out_dir: str | os.PathLike[str]) -> None:
    """Refuse (``ValueError`` naming it) an output folder a run would damage: one where a file the run writes
    is a folder, or whose ``world.json`` is the world file being run (the run would overwrite it)."""
    out = Path(out_dir)
    for name in RUN_FILES:
        if (out / name).is_dir():
            raise ValueError(f"{out / name} is a folder, where the run writes a file; choose another --out")
    if world.source is not None and (out / WORLD_FILE).resolve() == Path(world.source).resolve():
        raise ValueError(f"--out {out} would overwrite the world file {world.source} with the run's "
                         f"{WORLD_FILE}; choose another --out")


def mesh_copy_name(index: int, name: str) -> str:
    """The name of obstacle ``index``'s mesh file ``name`` in ``meshes/``: ``<index>-<name>``, or, when
    that is longer than :data:`MAX_NAME_BYTES`, ``<index>-<sha1 of name, 16 hex>`` and its extension
    (which tells trimesh the format)."""
    full = f"{index:03d}-{name}"
    if len(full.encode("utf-8", "surrogateescape")) <= MAX_NAME_BYTES:
        return full
    suffix = Path(name).suffix
    if len(suffix.encode("utf-8", "surrogateescape")) > 32:
        suffix = ""
    digest = hashlib.sha1(name.encode("utf-8", "surrogateescape")).hexdigest()[:16]
    return f"{index:03d}-{digest}{suffix}"


def write_run_world(world: World, out_dir: str | os.PathLike[str]) -> Path:
    """Write ``world`` as ``out_dir/world.json``, its mesh files copied to ``out_dir/meshes/``.

    Returns the path of ``world.json``.  Raises ``OSError`` when the folder or a mesh copy cannot be
    written.
    """
    out = Path(out_dir)
    obstacles = list(world.obstacles)
    for i, o in enumerate(obstacles):
        if isinstance(o, Mesh):
            dest = out / MESH_DIR / mesh_copy_name(i, o.path.name)
            if dest.resolve() != o.path:
                dest.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(o.path, dest)
            obstacles[i] = dataclasses.replace(o, path=dest)
    if any(isinstance(o, Mesh) for o in obstacles):
        world = dataclasses.replace(world, obstacles=tuple(obstacles))
    path = out / WORLD_FILE
    tmp = path.with_name(path.name + ".tmp")
    save_world(world, tmp)
    os.replace(tmp, path)
    return path


def write_run_settings(config: Any, out_dir: str | os.PathLike[str]) -> Path:
    """Write every setting of ``config`` (a :class:`navstack.trial.TrialConfig`) as ``out_dir/settings.json``
    (the form ``navstack run --settings`` reads back); returns its path."""
    from navstack.settings import settings_to_dict

    path = Path(out_dir) / SETTINGS_FILE
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(settings_to_dict(config), indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)
    return path


@dataclass(frozen=True)
class RunData:
    """What a run folder holds, validated.

    Attributes:
        path: the run folder.
        world: the world the trial ran (``world.json``, or the file given to :func:`load_run`).
        t: control-step times [s], shape (T,).
        q: measured joints (T, 20) [m for joint 1, rad for the others].
        q_des: commanded joints (T, 20).
        tip_des: commanded tip positions in the world (T, 3) [m].
        result: ``result.json`` as a dict, or ``None`` when the folder has none (an interrupted run).
        sensed: optional (T, K, 3) sensed world points [m], NaN where nothing was sensed.
    """

    path: Path
    world: World
    t: NDArray[np.float64]
    q: NDArray[np.float64]
    q_des: NDArray[np.float64]
    tip_des: NDArray[np.float64]
    result: dict[str, Any] | None = None
    sensed: NDArray[np.float64] | None = None

    @property
    def duration(self) -> float:
        """Simulated time of the last sample [s]."""
        return float(self.t[-1]) if len(self.t) else 0.0


MAX_SAMPLES = 200_000
"""The most control steps a trajectory may hold (a trial of the longest ``time_limit``, 3600 s at 30 Hz, has
108,001); a header claiming more is refused before anything is read."""
MAX_SENSED = 1_000
"""The most sensed points per control step ``sensed`` may hold."""
_ARRAYS = {"t": (None,), "q": (None, 20), "q_des": (None, 20), "tip_des": (None, 3), "sensed": (None, None, 3)}


def _read_arrays(traj: Path) -> dict[str, np.ndarray]:
    """The arrays of ``trajectory.npz`` that a run folder uses, each header checked (shape, a real numeric
    dtype, size) before its data is read: a header may claim terabytes, and a member may be a zip bomb."""
    if not zipfile.is_zipfile(traj):
        raise ValueError(f"{traj}: not a .npz archive (numpy.savez writes a zip file)")
    out: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(traj) as z:
            names = {n[:-4]: n for n in z.namelist() if n.endswith(".npy")}
            for key, shape in _ARRAYS.items():
                if key in names:
                    with z.open(names[key]) as fh:
                        dims, dtype = _npy_header(fh)
                    _check_header(traj, key, dims, dtype, shape)
                    with z.open(names[key]) as fh:
                        out[key] = np.lib.format.read_array(fh, allow_pickle=False)
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as e:
        raise ValueError(f"{traj}: not a readable .npz archive ({e})") from e
    return out


def _npy_header(fh: Any) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype from a ``.npy`` member's header, its data unread (``OSError`` if it is not one)."""
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            dims, _, dtype = np.lib.format.read_array_header_1_0(fh)
        elif version == (2, 0):
            dims, _, dtype = np.lib.format.read_array_header_2_0(fh)
        else:
            raise OSError(f"an .npy format version {version} header")
    except ValueError as e:
        raise OSError(f"a bad .npy header: {e}") from e
    return tuple(int(x) for x in dims), np.dtype(dtype)


def _check_header(traj: Path, key: str, dims: tuple[int, ...], dtype: np.dtype,
                  shape: tuple[int | None, ...]) -> None:
    want = "(" + ", ".join(str(s) if s is not None else ("K" if i else "T") for i, s in enumerate(shape)) + ")"
    if len(dims) != len(shape) or any(s is not None and s != n for s, n in zip(shape, dims, strict=True)):
        raise ValueError(f"{traj}: array {key!r} has shape {dims}, expected {want}")
    if dtype.kind not in "fiu":
        raise ValueError(f"{traj}: array {key!r} holds {dtype} values, expected real numbers")
    if dims[0] > MAX_SAMPLES or (key == "sensed" and dims[1] > MAX_SENSED):
        raise ValueError(f"{traj}: array {key!r} claims shape {dims}: more than {MAX_SAMPLES:,} control steps"
                         + (f" or {MAX_SENSED:,} points per step" if key == "sensed" else ""))


def _array(data: dict[str, np.ndarray], key: str, file: Path, *, finite: bool = True,
           bound: float = 1.0e4) -> np.ndarray:
    """``data[key]`` as float64, its values finite (``finite``; else NaN allowed) and within +-``bound``."""
    if key not in data:
        raise ValueError(f"{file}: has no array {key!r} (expected t, q, q_des, tip_des as navstack run writes)")
    a = np.asarray(data[key], dtype=np.float64)
    if finite and not np.isfinite(a).all():
        raise ValueError(f"{file}: array {key!r} holds NaN or infinite values")
    if not np.all(np.isnan(a) | (np.abs(a) <= bound)):
        raise ValueError(f"{file}: array {key!r} holds values beyond +-{bound:g} (or infinite ones): not a trajectory "
                         f"of this robot in a world within 1 km")
    return a


def _read_result(rfile: Path) -> dict[str, Any] | None:
    """``result.json``, its fields checked against interfaces.md section 3 where present (an edited file must
    not make a failed trial read as a success in the pictures); None when the folder has none."""
    if not rfile.exists():
        return None
    try:
        result = json.loads(rfile.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as e:
        why = "nested too deeply" if isinstance(e, RecursionError) else e
        raise ValueError(f"{rfile}: not readable JSON ({why})") from e
    if not isinstance(result, dict):
        raise ValueError(f"{rfile}: expected a JSON object")
    checks = {"success": lambda v: isinstance(v, bool), "reason": lambda v: v in _REASONS,
              "goals_reached": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0,
              "metrics": lambda v: isinstance(v, dict)}
    for key, ok in checks.items():
        if key in result and not ok(result[key]):
            raise ValueError(f"{rfile}: field {key!r} is {result[key]!r:.80}, not what navstack run writes "
                             f"(interfaces.md section 3)")
    if result.get("success") is True and result.get("reason", "reached") != "reached":
        raise ValueError(f"{rfile}: 'success' is true but 'reason' is {result['reason']!r}")
    return result


_REASONS = ("reached", "collision", "timeout", "stalled", "joint_limit", "error")


def load_run(run_dir: str | os.PathLike[str], world: str | os.PathLike[str] | World | None = None) -> RunData:
    """Read and check the run folder ``run_dir``.

    ``world`` overrides ``run_dir/world.json`` (a path or a :class:`World`), for folders written before
    navstack wrote it.  Raises ``ValueError`` (``WorldError`` for the world) naming the file and what is
    wrong: a missing folder or file, an array of the wrong shape or with non-finite values, samples of
    different lengths, times that do not increase.
    """
    run = Path(run_dir)
    if not run.is_dir():
        raise ValueError(f"{run}: not a folder (expected a run folder written by navstack run --out)")
    traj = run / TRAJECTORY_FILE
    if not traj.is_file():
        raise ValueError(f"{run}: has no {TRAJECTORY_FILE} (expected a run folder written by navstack run --out)")
    if world is None:
        wfile = run / WORLD_FILE
        if not wfile.is_file():
            raise ValueError(f"{run}: has no {WORLD_FILE} (written by navstack run since version 0.1 with "
                             f"animations); pass the world file the trial ran with --world")
        world = load_world(wfile)
    elif not isinstance(world, World):
        world = load_world(world)
    data = _read_arrays(traj)
    t = _array(data, "t", traj)
    q = _array(data, "q", traj, bound=1.0e3)
    q_des = _array(data, "q_des", traj, bound=1.0e3)
    tip_des = _array(data, "tip_des", traj)
    sensed = _array(data, "sensed", traj, finite=False) if "sensed" in data else None
    n = len(t)
    if n == 0:
        raise ValueError(f"{traj}: holds no samples (the trial recorded no control step)")
    lengths = {"q": len(q), "q_des": len(q_des), "tip_des": len(tip_des)}
    if sensed is not None:
        lengths["sensed"] = len(sensed)
    for key, m in lengths.items():
        if m != n:
            raise ValueError(f"{traj}: {key} has {m} samples but t has {n}")
    if n > 1 and not (np.diff(t) > 0).all():
        raise ValueError(f"{traj}: t must increase from sample to sample")
    if not (t[0] >= 0.0 and t[-1] <= MAX_TIME_LIMIT + 1.0):
        raise ValueError(f"{traj}: t runs from {t[0]:g} to {t[-1]:g} s, expected times within 0 .. "
                         f"{MAX_TIME_LIMIT:g} s (the longest time_limit)")
    result = _read_result(run / RESULT_FILE)
    return RunData(path=run, world=world, t=t, q=q, q_des=q_des, tip_des=tip_des, result=result, sensed=sensed)


def _content(world: World) -> dict[str, Any]:
    """``world`` as data with each mesh named by its file's SHA-256 instead of its path (a copy in a run
    folder and the original compare equal)."""
    d = world.to_dict()
    for o, od in zip(world.obstacles, d["obstacles"], strict=True):
        if isinstance(o, Mesh):
            try:
                od["path"] = hashlib.sha256(o.path.read_bytes()).hexdigest()
            except OSError:
                pass  # unreadable: compared by path
    return d


def other_world(run_dir: str | os.PathLike[str], world: World) -> str | None:
    """Why ``world`` (given for the run folder ``run_dir``) may not be the world its trial ran: the
    folder's ``world.json`` holds a different world, or its ``result.json`` names another one.  None when
    neither says so (or neither can be read: :func:`load_run` reports that)."""
    run = Path(run_dir)
    wfile = run / WORLD_FILE
    if wfile.is_file():
        try:
            ran = load_world(wfile)
        except (WorldError, OSError):
            ran = None
        if ran is not None and _content(ran) != _content(world):
            return (f"{wfile} (the world the trial ran) is not the world given ({world.name!r}); the "
                    f"given world is drawn")
    try:
        result = _read_result(run / RESULT_FILE)
    except (ValueError, OSError):
        result = None
    name = result.get("world") if result else None
    if isinstance(name, str) and name != world.name:
        return f"{run / RESULT_FILE} says the trial ran the world {name!r}, not the world given ({world.name!r})"
    return None


__all__ = ["RunData", "WorldError", "load_run", "other_world", "write_run_world"]
