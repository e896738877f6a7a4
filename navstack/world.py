"""World files (``navstack-world/1``, JSON): load, validate, save.

A world is the robot's base placement and start posture, obstacles, static or moving
(known to the simulator only: the planner and controller never read them) and
tip goals.  The format is interfaces.md section 2.  Units: metres, radians,
seconds.

Keys (anything else is an error, except inside ``extra``), whether required, default and constraint:

* ``format``: required; exactly ``"navstack-world/1"`` (checked first).
* ``name``: required; non-empty string.
* ``description``: optional; ``""``.
* ``robot``: required; an object (may be ``{}``), with all keys optional:
  ``base`` (``{"position": [0,0,0], "rpy": [0,0,0]}``, each of the two optional; m and rad: roll about
  world X, pitch about world Y, yaw about world Z, in that order), ``q0`` (:data:`navstack.jpl.Q_DEFAULT`;
  20 numbers inside the joint limits), ``serpentine_radius`` (0.025 m), ``arm_radius`` (0.06 m).
* ``obstacles``: required; an array, may be empty (see below).
* ``goals``: required; an array of at least one ``{"position": [x,y,z], "tolerance": t}``, ``tolerance``
  optional (0.02 m).
* ``time_limit``: optional; 60.0 s.
* ``family``: optional; ``null`` or a non-empty string (reports group by it).
* ``retract``: optional; ``false``; a boolean: after the last goal the robot backs out along its own path
  (interfaces.md section 2a).  Written only when true.
* ``extra``: optional; ``{}``; any JSON object, checked only for being finite JSON.

Obstacles (``type`` is required and selects the kind):

* ``cylinder``: ``p0``, ``p1`` (m, required), ``radius`` (m, required), ``motion`` (optional, below).
  Flat-ended, its axis from ``p0`` to ``p1``.
* ``box``: ``center`` (m, required), ``half_extents`` (m, required), ``rpy`` (rad, default 0), ``motion``.
* ``sphere``: ``center`` (m, required), ``radius`` (m, required), ``motion``.
* ``mesh``: ``path`` (required; relative to the world file's folder; any format trimesh reads),
  ``position`` (m, default 0), ``rpy`` (rad, default 0), ``scale`` (default 1.0).  The file is loaded
  with trimesh when the world is loaded; it must exist and contain at least one triangle.  A mesh may not
  carry ``motion``.

Moving obstacles (interfaces.md section 2b): ``motion`` translates a cylinder, box or sphere (never rotates
it) by d(t), t the simulated time since the trial's start (s):

* ``{"type": "linear", "velocity": [vx, vy, vz], "start": 0.0, "stop": ...}``: d(t) = velocity *
  clamp(t - start, 0, stop - start); ``velocity`` m/s (required), ``start`` s (default 0), ``stop`` s
  (default: never; at least ``start``).
* ``{"type": "oscillate", "axis": [ax, ay, az], "amplitude": A, "period": T, "phase": 0.0}``: d(t) =
  A * unit(axis) * sin(2 pi t / T + phase); ``axis`` non-zero (required), ``amplitude`` m (required),
  ``period`` s (required), ``phase`` rad (default 0).

Bounds (so that no value can overflow the simulator's geometry and turn into a wrong result; every one is
a module constant):

* coordinates (``robot.base.position``, ``p0``, ``p1``, ``center``, mesh ``position``, goal ``position``,
  ``motion.axis``): each within +-:data:`MAX_COORDINATE` (1 km) of the world origin;
* obstacle sizes (``radius``, each of ``half_extents``, a cylinder's length ``|p1 - p0|``, an oscillation's
  ``amplitude``): in [:data:`MIN_LENGTH`, :data:`MAX_LENGTH`] = [0.1 mm, 1 km] (``amplitude`` may be 0);
  a mesh's ``scale`` in [:data:`MIN_MESH_SCALE`, :data:`MAX_MESH_SCALE`] = [1e-4, 1e4], and its scaled
  vertices within :data:`MAX_LENGTH` of the mesh's own origin;
* robot radii (``serpentine_radius``, ``arm_radius``): in [:data:`MIN_ROBOT_RADIUS`,
  :data:`MAX_ROBOT_RADIUS`] = [0.01, 0.5] m; goal ``tolerance`` in [:data:`MIN_TOLERANCE`,
  :data:`MAX_TOLERANCE`] = [0.1 mm, 1 m];
* angles (every ``rpy`` value, ``motion.phase``): within +-:data:`MAX_ANGLE` (2 pi rad; a larger value is
  most likely degrees);
* ``time_limit`` in (0, :data:`MAX_TIME_LIMIT`] = (0, 3600] s; ``motion.start``, ``stop`` in [0,
  :data:`MAX_MOTION_TIME`] s and ``period`` in [:data:`MIN_PERIOD`, :data:`MAX_MOTION_TIME`] = [1e-3, 1e6] s;
* moving obstacles are at most :data:`MAX_OBSTACLE_SPEED` (5 m/s) fast: ``|velocity|`` and the peak
  speed 2 pi ``amplitude`` / ``period`` of an oscillation.  At the default 30 Hz control rate that is up to
  167 mm per control step; a trial's contact check sweeps each mover over the step
  (:meth:`navstack.sim.scene.Scene.swept_clearance`), so one that grazes a link, or passes through it,
  between two control steps is seen;
* at most :data:`MAX_OBSTACLES` (10000) obstacles and :data:`MAX_GOALS` (1000) goals; ``extra`` nested at
  most :data:`MAX_EXTRA_DEPTH` (64) levels deep;
* a mesh: at most :data:`MAX_MESH_VERTICES` (131072) vertices and :data:`MAX_MESH_TRIANGLES` (174762)
  triangles (PyBullet's own limits for one shape), at least one triangle of non-zero area; at most
  :data:`MAX_TOTAL_TRIANGLES` (1000000) triangles over all the mesh obstacles of a world (each is its own
  body, so a file named twice counts twice);
* the file: a regular file (not a directory, FIFO or device) of at most :data:`MAX_WORLD_BYTES` (64 MiB;
  ``load_world(path, max_bytes=...)`` raises it), checked before it is parsed.

Mesh paths must stay inside the world file's folder tree (after resolving ``..`` and symbolic links):
absolute paths and paths that leave it are refused unless ``allow_mesh_outside=True`` (``navstack run``
/ ``check-world --allow-mesh-outside``), so a world file from someone else cannot make navstack read
files elsewhere.  World data built in code (``world_from_dict(data)`` without ``source``) names no folder:
its relative mesh paths are resolved against the current directory and are not restricted.

The start condition (the robot at ``q0`` clear of every obstacle at t = 0) needs the simulator and is
checked by :func:`navstack.trial.check_start` (``run_trial``, ``navstack run`` and ``check-world`` all
call it).

Numbers are JSON numbers: ``true``/``false`` are not numbers, and the ``NaN``/``Infinity`` literals
(which Python's :mod:`json` accepts) and overflowing values such as ``1e400`` are rejected.  Duplicate
keys in one object are rejected.  Joint values of ``q0`` may exceed the limits by at most 1e-9 rad
(rounding of values written in degrees); anything further out is an error.

Every problem raises :class:`WorldError` (a ``ValueError``) whose message names the file, the JSON path
of the bad field (e.g. ``obstacles[3].radius``, ``robot.q0[7]``) and what was expected.  The dataclasses
validate their own fields too (same checks, with the field name as the path), so a ``World`` built in
code is as trustworthy as one loaded from a file.

The dataclasses are frozen; their vectors are read-only float64 numpy arrays.  Equality compares
values (``source`` is ignored), so ``world_from_dict(w.to_dict()) == w``.
"""

from __future__ import annotations

import copy
import json
import math
import os
import stat
from dataclasses import dataclass, field, fields
from functools import lru_cache
from pathlib import Path
from typing import Any, ClassVar, Union

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from navstack import jpl

FORMAT = "navstack-world/1"
"""The value of the ``format`` key this module reads and writes."""

DEFAULT_TIME_LIMIT = 60.0
"""Seconds, when ``time_limit`` is absent."""
DEFAULT_TOLERANCE = 0.02
"""Metres, when a goal has no ``tolerance``."""
JOINT_LIMIT_SLACK = 1e-9
"""Radians (metres for the lathe bed) by which ``q0`` may exceed the joint limits (values written in degrees
and rounded); such a value is moved onto the limit."""

MAX_COORDINATE = 1000.0
"""Metres: every coordinate of a position (and of ``motion.axis``) is within +-1 km."""
MIN_LENGTH = 1e-4
"""Metres: the smallest obstacle size (radius, half-extent, cylinder length)."""
MAX_LENGTH = 1000.0
"""Metres: the largest obstacle size (radius, half-extent, oscillation amplitude, scaled mesh extent)."""
MIN_CYLINDER_LENGTH = MIN_LENGTH
"""Metres: a cylinder's ``p0`` and ``p1`` must be at least this far apart (and at most :data:`MAX_LENGTH`)."""
MIN_ROBOT_RADIUS = jpl.MIN_ROBOT_RADIUS
"""Metres: the smallest ``serpentine_radius`` / ``arm_radius``."""
MAX_ROBOT_RADIUS = jpl.MAX_ROBOT_RADIUS
"""Metres: the largest ``serpentine_radius`` / ``arm_radius``."""
MIN_TOLERANCE = 1e-4
"""Metres: the smallest goal ``tolerance``."""
MAX_TOLERANCE = 1.0
"""Metres: the largest goal ``tolerance``."""
MAX_ANGLE = 2.0 * math.pi
"""Radians: the largest ``|rpy|`` value and ``|motion.phase|`` (plus 1e-9 for rounding)."""
MIN_MESH_SCALE = 1e-4
"""The smallest mesh ``scale``."""
MAX_MESH_SCALE = 1e4
"""The largest mesh ``scale``."""
MAX_MESH_VERTICES = 131_072
"""The most vertices of one mesh: PyBullet's ``createCollisionShape`` refuses more (measured, an audit)."""
MAX_MESH_TRIANGLES = 174_762
"""The most triangles of one mesh: PyBullet's 524,288 indices per shape, over 3 (measured, an audit)."""
MAX_TOTAL_TRIANGLES = 1_000_000
"""The most triangles over all the mesh obstacles of a world: PyBullet keeps a collision and a visual shape per
body, about 400 bytes per triangle (an audit: 100 copies of an 82,000-triangle file took 3.2 GB; 250, a crash)."""
MAX_TIME_LIMIT = 3600.0
"""Seconds: the largest ``time_limit`` (one simulated hour, about 10 minutes of wall clock)."""
MAX_MOTION_TIME = 1e6
"""Seconds: the largest ``motion.start``, ``motion.stop`` and ``motion.period``."""
MIN_PERIOD = 1e-3
"""Seconds: the shortest ``motion.period`` (a period of 5e-324 s made ``2 pi t / period`` infinite and the trial
crash mid-run)."""
MAX_OBSTACLE_SPEED = 5.0
"""m/s: the fastest a moving obstacle may be (linear speed, peak speed of an oscillation).  The contact check
sweeps a mover near the robot at most 1 mm of its motion apart, so the cost, not the result, grows with speed:
at this bound 167 distance queries per control step for each mover near the robot."""
MAX_OBSTACLES = 10_000
"""The most obstacles a world may have."""
MAX_GOALS = 1_000
"""The most goals a world may have."""
MAX_EXTRA_DEPTH = 64
"""How deeply ``extra`` may nest arrays and objects."""
MAX_WORLD_BYTES = 64 * 1024 * 1024
"""Bytes: the largest world file :func:`load_world` reads by default (64 MiB)."""

FloatArray = NDArray[np.float64]


# --------------------------------------------------------------------------- errors


class WorldError(ValueError):
    """A world file or world data is invalid.

    Attributes:
        file: the file as the caller named it (``None`` for data that did not come from a file).
        json_path: JSON path of the bad field, e.g. ``obstacles[3].radius``; ``""`` for the whole
            document (unreadable file, invalid JSON, top level not an object).
        detail: what was expected / what is wrong, without the file and path.
    """

    def __init__(self, detail: str, *, file: str | os.PathLike[str] | None = None, json_path: str = ""):
        self.file = None if file is None else os.fspath(file)
        self.json_path = json_path
        self.detail = detail
        where = self.file if self.file is not None else "world data"
        loc = json_path if json_path else "(top level)"
        super().__init__(f"{where}: {loc}: {detail}")


class _NonFinite:
    """Stands in for a ``NaN``/``Infinity`` literal so the validator can report where it was."""

    __slots__ = ("literal",)

    def __init__(self, literal: str):
        self.literal = literal


class _Obj(dict):
    """A JSON object that remembers keys that appeared more than once."""

    duplicates: tuple[str, ...] = ()


def _pairs_hook(pairs: list[tuple[str, Any]]) -> _Obj:
    out = _Obj()
    dups = []
    for k, v in pairs:
        if k in out:
            dups.append(k)
        out[k] = v
    if dups:
        out.duplicates = tuple(dups)
    return out


def _describe(v: Any) -> str:
    """A short JSON-ish description of a value for error messages."""
    if isinstance(v, _NonFinite):
        return v.literal
    if v is None:
        return "null"
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (float, np.floating)) and not math.isfinite(v):
        return f"{v!r} (a number too large for a float, or a non-finite value)"
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v)) if abs(v) < 10**100 else f"an integer of about {len(hex(int(v))) * 1.2:.0f} digits"
    if isinstance(v, str):
        s = json.dumps(v)
        return s if len(s) <= 60 else s[:57] + '..."'
    if isinstance(v, dict):
        return "an object"
    if isinstance(v, (list, tuple)):
        return f"an array of {len(v)} value{'' if len(v) == 1 else 's'}"
    if isinstance(v, np.ndarray):
        return f"an array of shape {v.shape}"
    return f"a {type(v).__name__}"


class _Ctx:
    """Where validation is happening: the file (for messages), the folder meshes are relative to, and
    whether mesh paths may leave that folder."""

    def __init__(self, file: str | os.PathLike[str] | None, base_dir: Path | None, *,
                 allow_mesh_outside: bool = False):
        self.file = file
        self.base_dir = base_dir
        self.allow_mesh_outside = allow_mesh_outside

    def error(self, path: str, detail: str) -> WorldError:
        return WorldError(detail, file=self.file, json_path=path)


_CODE = _Ctx(None, None)  # for dataclasses built in code


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


# --------------------------------------------------------------------------- value checks


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _expected(positive: bool, lo: float | None, hi: float | None, unit: str) -> str:
    """``a positive number``, ``a number in [-1000, 1000] m``, ``a positive number in (0, 3600] s``..."""
    if lo is None and hi is None:
        return "a positive number" if positive else "a finite number"
    left = "(0" if lo is None else f"[{lo:g}"
    right = "inf)" if hi is None else f"{hi:g}]"
    return f"a {'positive' if positive else 'finite'} number in {left}, {right}{unit}"


def _number(ctx: _Ctx, path: str, v: Any, *, positive: bool = False, lo: float | None = None,
            hi: float | None = None, unit: str = "") -> float:
    """A finite float (and > 0 if ``positive``, and within [``lo``, ``hi``] where given; ``unit`` such as
    ``" m"`` is only used in the message)."""
    what = _expected(positive, lo, hi, unit)
    if not _is_number(v):
        raise ctx.error(path, f"expected {what}, got {_describe(v)}")
    try:
        x = float(v)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise ctx.error(path, f"expected {what}, got {_describe(v)}")
    if (positive and not x > 0.0) or (lo is not None and x < lo) or (hi is not None and x > hi):
        raise ctx.error(path, f"expected {what}, got {_describe(v)}")
    return x


def _vector(ctx: _Ctx, path: str, v: Any, n: int, **bounds: Any) -> FloatArray:
    """A read-only float64 array of ``n`` finite numbers (each checked by :func:`_number` with ``bounds``)."""
    if isinstance(v, np.ndarray):
        if v.ndim != 1:
            raise ctx.error(path, f"expected an array of {n} numbers, got {_describe(v)}")
        v = v.tolist()
    if not isinstance(v, (list, tuple)):
        raise ctx.error(path, f"expected an array of {n} numbers, got {_describe(v)}")
    if len(v) != n:
        raise ctx.error(path, f"expected an array of {n} numbers, got {_describe(v)}")
    out = np.array([_number(ctx, f"{path}[{i}]", x, **bounds) for i, x in enumerate(v)], dtype=np.float64)
    out.setflags(write=False)
    return out


_ANGLE_SLACK = 1e-9


def _coords(ctx: _Ctx, path: str, v: Any) -> FloatArray:
    """A position (m): 3 numbers within +-:data:`MAX_COORDINATE`."""
    return _vector(ctx, path, v, 3, lo=-MAX_COORDINATE, hi=MAX_COORDINATE, unit=" m")


def _angles(ctx: _Ctx, path: str, v: Any) -> FloatArray:
    """Roll, pitch, yaw (rad): 3 numbers within +-:data:`MAX_ANGLE`."""
    return _vector(ctx, path, v, 3, lo=-MAX_ANGLE - _ANGLE_SLACK, hi=MAX_ANGLE + _ANGLE_SLACK, unit=" rad")


def _size(ctx: _Ctx, path: str, v: Any) -> float:
    """An obstacle size (m) in [:data:`MIN_LENGTH`, :data:`MAX_LENGTH`]."""
    return _number(ctx, path, v, positive=True, lo=MIN_LENGTH, hi=MAX_LENGTH, unit=" m")


def _sizes(ctx: _Ctx, path: str, v: Any) -> FloatArray:
    """Three obstacle sizes (m), e.g. half-extents."""
    return _vector(ctx, path, v, 3, positive=True, lo=MIN_LENGTH, hi=MAX_LENGTH, unit=" m")


def _robot_radius(ctx: _Ctx, path: str, v: Any) -> float:
    return _number(ctx, path, v, positive=True, lo=MIN_ROBOT_RADIUS, hi=MAX_ROBOT_RADIUS, unit=" m")


def _tolerance(ctx: _Ctx, path: str, v: Any) -> float:
    return _number(ctx, path, v, positive=True, lo=MIN_TOLERANCE, hi=MAX_TOLERANCE, unit=" m")


def _time_limit(ctx: _Ctx, path: str, v: Any) -> float:
    return _number(ctx, path, v, positive=True, hi=MAX_TIME_LIMIT, unit=" s")


def _scale(ctx: _Ctx, path: str, v: Any) -> float:
    return _number(ctx, path, v, positive=True, lo=MIN_MESH_SCALE, hi=MAX_MESH_SCALE)


def _string(ctx: _Ctx, path: str, v: Any, *, nonempty: bool = False) -> str:
    if not isinstance(v, str) or (nonempty and not v.strip()):
        raise ctx.error(path, f"expected a {'non-empty ' if nonempty else ''}string, got {_describe(v)}")
    return _utf8(ctx, path, v)


def _utf8(ctx: _Ctx, path: str, v: str) -> str:
    """``v`` if UTF-8 can hold it: JSON's ``"\\ud800"`` decodes to a lone surrogate, which no file or
    terminal can take (it failed as an internal error when the run folder's world.json was written)."""
    try:
        v.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise ctx.error(path, f"expected text, got a string with a lone surrogate {v[exc.start]!r} at character "
                              f"{exc.start} (an unpaired \\ud800-\\udfff escape)") from None
    return v


def _object(ctx: _Ctx, path: str, v: Any, required: tuple[str, ...], optional: tuple[str, ...]) -> dict:
    """Check ``v`` is an object with all ``required`` keys and nothing outside required + optional."""
    if not isinstance(v, dict):
        raise ctx.error(path, f"expected an object, got {_describe(v)}")
    dups = getattr(v, "duplicates", ())
    if dups:
        raise ctx.error(_join(path, dups[0]), "duplicate key (a JSON object may name each key once)")
    allowed = required + optional
    for k in v:
        if not isinstance(k, str):
            raise ctx.error(path, f"object keys must be strings, got {_describe(k)}")
        if k not in allowed:
            raise ctx.error(_join(path, k), f"unknown key; expected one of: {', '.join(allowed)}")
    for k in required:
        if k not in v:
            raise ctx.error(_join(path, k), "missing required key")
    return v


def _json_value(ctx: _Ctx, path: str, v: Any, depth: int = 0) -> Any:
    """A deep copy of ``v`` as plain JSON (dict/list/str/finite number/bool/null), nested at most
    :data:`MAX_EXTRA_DEPTH` levels; errors name the path."""
    if v is None or isinstance(v, bool):
        return v
    if isinstance(v, str):
        return _utf8(ctx, path, v)
    if isinstance(v, _NonFinite):
        raise ctx.error(path, f"expected a finite number, got {v.literal} (not valid JSON)")
    if isinstance(v, np.bool_):
        return bool(v)
    if _is_number(v):
        x = _number(ctx, path, v)
        return int(v) if isinstance(v, (int, np.integer)) else x
    if isinstance(v, (dict, list, tuple)) and depth >= MAX_EXTRA_DEPTH:
        raise ctx.error(path, f"nested too deeply (at most {MAX_EXTRA_DEPTH} levels of arrays and objects)")
    if isinstance(v, dict):
        dups = getattr(v, "duplicates", ())
        if dups:
            raise ctx.error(_join(path, dups[0]), "duplicate key (a JSON object may name each key once)")
        out = {}
        for k, x in v.items():
            if not isinstance(k, str):
                raise ctx.error(path, f"object keys must be strings, got {_describe(k)}")
            out[_utf8(ctx, path, k)] = _json_value(ctx, _join(path, k), x, depth + 1)
        return out
    if isinstance(v, (list, tuple)):
        return [_json_value(ctx, f"{path}[{i}]", x, depth + 1) for i, x in enumerate(v)]
    raise ctx.error(path, f"expected a JSON value (object, array, string, finite number, bool, null), "
                          f"got {_describe(v)}")


def _rotation(rpy: FloatArray) -> NDArray[np.float64]:
    """3x3 rotation of roll about world X, then pitch about world Y, then yaw about world Z."""
    return Rotation.from_euler("xyz", rpy).as_matrix()


def _pose(position: FloatArray, rpy: FloatArray) -> FloatArray:
    T = np.eye(4)
    T[:3, :3] = _rotation(rpy)
    T[:3, 3] = position
    return T


class _ValueEq:
    """Value equality/hash over dataclass fields (numpy arrays compared elementwise)."""

    _ignore: ClassVar[tuple[str, ...]] = ()

    def _key(self) -> tuple:
        out = []
        for f in fields(self):  # type: ignore[arg-type]
            if f.name in self._ignore:
                continue
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                v = (v.shape, tuple(v.ravel().tolist()))
            elif isinstance(v, dict):
                v = json.dumps(v, sort_keys=True)
            elif isinstance(v, Path):
                v = str(v)
            out.append(v)
        return tuple(out)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._key() == other._key()  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        return hash((type(self).__name__, self._key()))


def _set(obj: object, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


# --------------------------------------------------------------------------- dataclasses


@dataclass(frozen=True, eq=False)
class Base(_ValueEq):
    """Pose of DH frame 0 in the world.

    Attributes:
        position: (3,) metres.
        rpy: (3,) radians: roll about world X, pitch about world Y, yaw about world Z, applied in that
            order (pybullet's ``getQuaternionFromEuler``; scipy ``Rotation.from_euler("xyz", rpy)``).
    """

    position: FloatArray = field(default_factory=lambda: np.zeros(3))
    rpy: FloatArray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        _set(self, "position", _coords(_CODE, "Base.position", self.position))
        _set(self, "rpy", _angles(_CODE, "Base.rpy", self.rpy))

    def transform(self) -> FloatArray:
        """(4, 4) homogeneous transform world <- DH frame 0 (metres)."""
        return _pose(self.position, self.rpy)

    def to_dict(self) -> dict[str, Any]:
        return {"position": self.position.tolist(), "rpy": self.rpy.tolist()}


@dataclass(frozen=True, eq=False)
class RobotSpec(_ValueEq):
    """The robot's placement, start posture and collision radii.

    Attributes:
        base: pose of DH frame 0 in the world.
        q0: (20,) start joint vector (q[0] in metres, the rest radians), inside the joint limits.
        serpentine_radius: capsule radius of the serpentine links (m).
        arm_radius: capsule radius of the arm links (m).
    """

    base: Base = field(default_factory=Base)
    q0: FloatArray = field(default_factory=lambda: jpl.Q_DEFAULT.copy())
    serpentine_radius: float = jpl.SERPENTINE_RADIUS
    arm_radius: float = jpl.ARM_RADIUS

    def __post_init__(self) -> None:
        if not isinstance(self.base, Base):
            raise _CODE.error("RobotSpec.base", f"expected a Base, got {_describe(self.base)}")
        _set(self, "q0", _q0(_CODE, "RobotSpec.q0", self.q0))
        _set(self, "serpentine_radius", _robot_radius(_CODE, "RobotSpec.serpentine_radius", self.serpentine_radius))
        _set(self, "arm_radius", _robot_radius(_CODE, "RobotSpec.arm_radius", self.arm_radius))

    def to_dict(self) -> dict[str, Any]:
        return {
            "base": self.base.to_dict(),
            "q0": self.q0.tolist(),
            "serpentine_radius": self.serpentine_radius,
            "arm_radius": self.arm_radius,
        }


def _q0(ctx: _Ctx, path: str, v: Any) -> FloatArray:
    q = _vector(ctx, path, v, jpl.N_JOINTS)
    for i, x in enumerate(q):
        lo, hi = jpl.LOWER[i], jpl.UPPER[i]
        if x < lo - JOINT_LIMIT_SLACK or x > hi + JOINT_LIMIT_SLACK:
            unit = "m" if jpl.PRISMATIC[i] else "rad"
            raise ctx.error(f"{path}[{i}]", f"expected a value in [{lo:.10g}, {hi:.10g}] {unit} "
                                            f"(limits of joint {i + 1}), got {_describe(x)}")
    q = np.clip(q, jpl.LOWER, jpl.UPPER)  # within the slack: onto the limit (the controller refuses beyond it)
    q.setflags(write=False)
    return q


@dataclass(frozen=True, eq=False)
class LinearMotion(_ValueEq):
    """Translation at constant ``velocity`` (m/s) from time ``start`` to ``stop`` (s; ``inf``: never stops).

    d(t) = velocity * clamp(t - start, 0, stop - start), t the simulated time since the trial's start.
    """

    velocity: FloatArray
    start: float = 0.0
    stop: float = math.inf
    type: ClassVar[str] = "linear"

    def __post_init__(self) -> None:
        _set(self, "velocity", _velocity(_CODE, "LinearMotion.velocity", self.velocity))
        _set(self, "start", _number(_CODE, "LinearMotion.start", self.start, lo=0.0, hi=MAX_MOTION_TIME, unit=" s"))
        if not (isinstance(self.stop, (int, float)) and self.stop == math.inf):
            _set(self, "stop", _number(_CODE, "LinearMotion.stop", self.stop, lo=self.start, hi=MAX_MOTION_TIME,
                                       unit=" s (at least start; omit it for no stop)"))
        else:
            _set(self, "stop", math.inf)

    @property
    def peak_speed(self) -> float:
        """Largest speed (m/s): ``|velocity|``."""
        return float(np.linalg.norm(self.velocity))

    def displacement(self, t: float) -> FloatArray:
        """Translation (m) at simulated time ``t`` (s)."""
        return self.velocity * min(max(float(t) - self.start, 0.0), self.stop - self.start)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"type": self.type, "velocity": self.velocity.tolist(), "start": self.start}
        if math.isfinite(self.stop):
            d["stop"] = self.stop
        return d


@dataclass(frozen=True, eq=False)
class OscillateMotion(_ValueEq):
    """Oscillation along ``axis`` (any length, not zero): d(t) = amplitude (m) * unit(axis) *
    sin(2 pi t / period + phase), ``period`` in s, ``phase`` in rad."""

    axis: FloatArray
    amplitude: float
    period: float
    phase: float = 0.0
    type: ClassVar[str] = "oscillate"

    def __post_init__(self) -> None:
        _set(self, "axis", _direction(_CODE, "OscillateMotion.axis", self.axis))
        _set(self, "amplitude", _number(_CODE, "OscillateMotion.amplitude", self.amplitude, lo=0.0, hi=MAX_LENGTH,
                                        unit=" m"))
        _set(self, "period", _number(_CODE, "OscillateMotion.period", self.period, lo=MIN_PERIOD,
                                     hi=MAX_MOTION_TIME, unit=" s"))
        _set(self, "phase", _number(_CODE, "OscillateMotion.phase", self.phase, lo=-MAX_ANGLE - _ANGLE_SLACK,
                                    hi=MAX_ANGLE + _ANGLE_SLACK, unit=" rad"))
        _check_speed(_CODE, "OscillateMotion.period", self.peak_speed, "peak speed 2 pi amplitude / period")

    @property
    def peak_speed(self) -> float:
        """Largest speed (m/s) over a period: 2 pi amplitude / period."""
        return 2.0 * math.pi * self.amplitude / self.period

    def displacement(self, t: float) -> FloatArray:
        """Translation (m) at simulated time ``t`` (s)."""
        u = self.axis / np.linalg.norm(self.axis)
        return self.amplitude * u * math.sin(2.0 * math.pi * float(t) / self.period + self.phase)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type, "axis": self.axis.tolist(), "amplitude": self.amplitude,
                "period": self.period, "phase": self.phase}


Motion = Union[LinearMotion, OscillateMotion]  # noqa: UP007 - a runtime alias usable in isinstance
"""Any motion of an obstacle (interfaces.md section 2b)."""

MOTION_TYPES: dict[str, type] = {"linear": LinearMotion, "oscillate": OscillateMotion}


def _velocity(ctx: _Ctx, path: str, v: Any) -> FloatArray:
    """A velocity (m/s) of at most :data:`MAX_OBSTACLE_SPEED`."""
    vel = _vector(ctx, path, v, 3, lo=-MAX_OBSTACLE_SPEED, hi=MAX_OBSTACLE_SPEED, unit=" m/s")
    _check_speed(ctx, path, float(np.linalg.norm(vel)), "|velocity|")
    return vel


def _direction(ctx: _Ctx, path: str, v: Any) -> FloatArray:
    a = _coords(ctx, path, v)
    if not float(np.linalg.norm(a)) >= 1e-9:
        raise ctx.error(path, f"expected a non-zero direction, got {a.tolist()}")
    return a


def _check_speed(ctx: _Ctx, path: str, speed: float, what: str) -> None:
    if not speed <= MAX_OBSTACLE_SPEED:
        raise ctx.error(path, f"expected a moving obstacle at most {MAX_OBSTACLE_SPEED:g} m/s fast, got {what} "
                              f"= {speed:.6g} m/s")


def _check_motion(ctx: _Ctx, path: str, motion: Any) -> Motion | None:
    if motion is not None and not isinstance(motion, (LinearMotion, OscillateMotion)):
        raise ctx.error(path, f"expected a LinearMotion, an OscillateMotion or None, got {_describe(motion)}")
    return motion


def _with_motion(d: dict[str, Any], motion: Motion | None) -> dict[str, Any]:
    if motion is not None:
        d["motion"] = motion.to_dict()
    return d


@dataclass(frozen=True, eq=False)
class Cylinder(_ValueEq):
    """Flat-ended cylinder (as PyBullet's) with its axis from ``p0`` to ``p1`` (m); ``radius`` in m;
    ``motion`` translates it over time (``None``: static)."""

    p0: FloatArray
    p1: FloatArray
    radius: float
    motion: Motion | None = None
    type: ClassVar[str] = "cylinder"

    def __post_init__(self) -> None:
        _set(self, "p0", _coords(_CODE, "Cylinder.p0", self.p0))
        _set(self, "p1", _coords(_CODE, "Cylinder.p1", self.p1))
        _set(self, "radius", _size(_CODE, "Cylinder.radius", self.radius))
        _check_length(_CODE, "Cylinder.p1", self.p0, self.p1)
        _check_motion(_CODE, "Cylinder.motion", self.motion)

    @property
    def length(self) -> float:
        """Axis length |p1 - p0| (m)."""
        return float(np.linalg.norm(self.p1 - self.p0))

    def to_dict(self, relative_to: Path | None = None) -> dict[str, Any]:
        return _with_motion({"type": self.type, "p0": self.p0.tolist(), "p1": self.p1.tolist(),
                             "radius": self.radius}, self.motion)


def _check_length(ctx: _Ctx, path: str, p0: FloatArray, p1: FloatArray) -> None:
    length = float(np.linalg.norm(p1 - p0))
    if not length >= MIN_CYLINDER_LENGTH:
        raise ctx.error(path, f"expected a point different from p0 (a cylinder needs a length of at least "
                              f"{MIN_CYLINDER_LENGTH:g} m), got {p1.tolist()}")
    if not length <= MAX_LENGTH:
        raise ctx.error(path, f"expected a point within {MAX_LENGTH:g} m of p0 (the longest cylinder), got "
                              f"{p1.tolist()}, {length:.6g} m away")


@dataclass(frozen=True, eq=False)
class Box(_ValueEq):
    """Box centred at ``center`` (m) with ``half_extents`` (m) and orientation ``rpy`` (rad); ``motion``
    translates it over time (``None``: static)."""

    center: FloatArray
    half_extents: FloatArray
    rpy: FloatArray = field(default_factory=lambda: np.zeros(3))
    motion: Motion | None = None
    type: ClassVar[str] = "box"

    def __post_init__(self) -> None:
        _set(self, "center", _coords(_CODE, "Box.center", self.center))
        _set(self, "half_extents", _sizes(_CODE, "Box.half_extents", self.half_extents))
        _set(self, "rpy", _angles(_CODE, "Box.rpy", self.rpy))
        _check_motion(_CODE, "Box.motion", self.motion)

    def to_dict(self, relative_to: Path | None = None) -> dict[str, Any]:
        return _with_motion({"type": self.type, "center": self.center.tolist(),
                             "half_extents": self.half_extents.tolist(), "rpy": self.rpy.tolist()}, self.motion)


@dataclass(frozen=True, eq=False)
class Sphere(_ValueEq):
    """Sphere at ``center`` (m) with ``radius`` (m); ``motion`` translates it over time (``None``: static)."""

    center: FloatArray
    radius: float
    motion: Motion | None = None
    type: ClassVar[str] = "sphere"

    def __post_init__(self) -> None:
        _set(self, "center", _coords(_CODE, "Sphere.center", self.center))
        _set(self, "radius", _size(_CODE, "Sphere.radius", self.radius))
        _check_motion(_CODE, "Sphere.motion", self.motion)

    def to_dict(self, relative_to: Path | None = None) -> dict[str, Any]:
        return _with_motion({"type": self.type, "center": self.center.tolist(), "radius": self.radius},
                            self.motion)


@dataclass(frozen=True, eq=False)
class Mesh(_ValueEq):
    """A triangle mesh file placed at ``position`` (m) with ``rpy`` (rad), vertices scaled by ``scale``.

    ``path`` is stored resolved and absolute.  The simulator treats the mesh as a static concave triangle
    mesh (its surface; there is no notion of inside).
    """

    path: Path
    position: FloatArray = field(default_factory=lambda: np.zeros(3))
    rpy: FloatArray = field(default_factory=lambda: np.zeros(3))
    scale: float = 1.0
    type: ClassVar[str] = "mesh"

    def __post_init__(self) -> None:
        if not isinstance(self.path, (str, os.PathLike)):
            raise _CODE.error("Mesh.path", f"expected a path, got {_describe(self.path)}")
        try:
            _set(self, "path", Path(self.path).expanduser().resolve())
        except (RuntimeError, ValueError, OSError) as exc:  # ~nosuchuser, a NUL character, a loop
            raise _CODE.error("Mesh.path", f"expected a file path, got {str(self.path)!r} ({exc})") from None
        _set(self, "position", _coords(_CODE, "Mesh.position", self.position))
        _set(self, "rpy", _angles(_CODE, "Mesh.rpy", self.rpy))
        _set(self, "scale", _scale(_CODE, "Mesh.scale", self.scale))

    def triangles(self) -> tuple[FloatArray, NDArray[np.int32]]:
        """Vertices (V, 3) in metres, already multiplied by ``scale``, in the mesh's own frame (before
        ``position``/``rpy``), and faces (F, 3) of vertex indices.  Read-only arrays.

        Raises:
            WorldError: the file is missing, unreadable by trimesh, or has no triangles; or the scaled mesh
                reaches farther than :data:`MAX_LENGTH` from its origin.
        """
        v, f = _mesh_triangles(_CODE, "Mesh.path", self.path)
        _check_mesh_extent(_CODE, "Mesh.scale", v, self.scale)
        if self.scale != 1.0:
            v = v * self.scale
            v.setflags(write=False)
        return v, f

    def to_dict(self, relative_to: Path | None = None) -> dict[str, Any]:
        return {"type": self.type, "path": _mesh_path_str(self.path, relative_to),
                "position": self.position.tolist(), "rpy": self.rpy.tolist(), "scale": self.scale}


def _check_mesh_extent(ctx: _Ctx, path: str, vertices: FloatArray, scale: float) -> None:
    reach = float(np.abs(vertices).max()) * scale
    if not reach <= MAX_LENGTH:
        raise ctx.error(path, f"expected a scale that keeps the mesh within {MAX_LENGTH:g} m of its origin, "
                              f"got {scale:g} (a vertex {reach:.6g} m away)")


def _mesh_path_str(path: Path, relative_to: Path | None) -> str:
    if relative_to is None:
        return path.as_posix()
    try:
        return Path(os.path.relpath(path, Path(relative_to).resolve())).as_posix()
    except ValueError:  # e.g. another drive on Windows
        return path.as_posix()


@lru_cache(maxsize=64)
def _load_triangles_cached(path: str, mtime_ns: int, size: int) -> tuple[FloatArray, NDArray[np.int32]]:
    from navstack.mesh_file import load_triangles  # trimesh, with what it misreads put right

    vertices, faces = load_triangles(path)
    v = np.ascontiguousarray(vertices)
    f = np.ascontiguousarray(faces)
    v.setflags(write=False)
    f.setflags(write=False)
    return v, f


@lru_cache(maxsize=4096)
def _mesh_facts(path: str, mtime_ns: int, size: int) -> tuple[int, int, bool, bool]:
    """``(vertices, triangles, all vertices finite, some triangle of non-zero area)`` of a mesh file, computed
    once per file version (the checks of every load and the world's triangle count ask for them)."""
    v, f = _load_triangles_cached(path, mtime_ns, size)
    finite = bool(np.all(np.isfinite(v)))
    area = False
    if len(f) and finite:
        area = bool(np.abs(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])).max() > 0.0)
    return len(v), len(f), finite, area


def _mesh_triangles(ctx: _Ctx, path: str, file: Path) -> tuple[FloatArray, NDArray[np.int32]]:
    try:
        st = file.stat()
    except OSError as e:
        raise ctx.error(path, f"expected an existing mesh file, cannot access {file}: {e.strerror}") from e
    if not file.is_file():
        raise ctx.error(path, f"expected a mesh file, {file} is not a regular file")
    try:
        v, f = _load_triangles_cached(str(file), st.st_mtime_ns, st.st_size)
        n_v, n_f, finite, area = _mesh_facts(str(file), st.st_mtime_ns, st.st_size)
    except Exception as e:  # trimesh raises many kinds (ValueError, NotImplementedError, KeyError, ...)
        raise ctx.error(path, f"expected a mesh file trimesh can read, {file}: "
                              f"{type(e).__name__}: {e}") from e
    if n_f == 0 or n_v == 0:
        raise ctx.error(path, f"expected a mesh with at least one triangle, {file} has none "
                              f"(empty or unreadable by trimesh)")
    if not finite:
        raise ctx.error(path, f"expected finite vertex coordinates, {file} has NaN/inf vertices")
    if n_v > MAX_MESH_VERTICES or n_f > MAX_MESH_TRIANGLES:
        raise ctx.error(path, f"expected at most {MAX_MESH_VERTICES} vertices and {MAX_MESH_TRIANGLES} triangles "
                              f"(PyBullet's limits for one shape), {file} has {n_v} and {n_f}")
    if not area:
        raise ctx.error(path, f"expected a mesh with a triangle of non-zero area, every triangle of {file} is "
                              f"degenerate (no surface to collide with)")
    return v, f


def _check_total_triangles(ctx: _Ctx, path: str, obstacles: tuple[Any, ...]) -> None:
    """At most :data:`MAX_TOTAL_TRIANGLES` over the mesh obstacles (each counted, a file named twice twice).  A mesh
    that cannot be read is not counted: its own error comes where it is read (a file parsed has been read)."""
    total = 0
    for o in obstacles:
        if isinstance(o, Mesh):
            try:
                if not o.path.is_file():
                    continue  # (a FIFO would block the read)
                st = o.path.stat()
                total += _mesh_facts(str(o.path), st.st_mtime_ns, st.st_size)[1]
            except Exception:  # noqa: BLE001 - unreadable: its own error comes where it is read
                continue
            if total > MAX_TOTAL_TRIANGLES:
                break
    if total > MAX_TOTAL_TRIANGLES:
        raise ctx.error(path, f"expected at most {MAX_TOTAL_TRIANGLES} mesh triangles in all (each mesh obstacle "
                              f"is its own body), got at least {total}")


Obstacle = Union[Cylinder, Box, Sphere, Mesh]  # noqa: UP007 - a runtime alias usable in isinstance
"""Any obstacle kind."""

OBSTACLE_TYPES: dict[str, type] = {"cylinder": Cylinder, "box": Box, "sphere": Sphere, "mesh": Mesh}


@dataclass(frozen=True, eq=False)
class Goal(_ValueEq):
    """A tip waypoint at ``position`` (m), reached when the tip passes within ``tolerance`` (m)."""

    position: FloatArray
    tolerance: float = DEFAULT_TOLERANCE

    def __post_init__(self) -> None:
        _set(self, "position", _coords(_CODE, "Goal.position", self.position))
        _set(self, "tolerance", _tolerance(_CODE, "Goal.tolerance", self.tolerance))

    def to_dict(self) -> dict[str, Any]:
        return {"position": self.position.tolist(), "tolerance": self.tolerance}


@dataclass(frozen=True, eq=False)
class World(_ValueEq):
    """One world: robot placement, obstacles (static or moving), tip goals (reached in order) and a time
    limit (s).

    ``source`` is the file it was loaded from (absolute), if any; it does not take part in equality.
    """

    name: str
    robot: RobotSpec
    obstacles: tuple[Obstacle, ...]
    goals: tuple[Goal, ...]
    time_limit: float = DEFAULT_TIME_LIMIT
    description: str = ""
    family: str | None = None
    retract: bool = False
    """After the last goal, back out along the path until the tip is within 0.02 m of its start."""
    extra: dict[str, Any] = field(default_factory=dict)
    source: Path | None = None

    _ignore: ClassVar[tuple[str, ...]] = ("source",)

    def __post_init__(self) -> None:
        c = _CODE
        _string(c, "World.name", self.name, nonempty=True)
        if not isinstance(self.robot, RobotSpec):
            raise c.error("World.robot", f"expected a RobotSpec, got {_describe(self.robot)}")
        obstacles = tuple(self.obstacles)
        _check_count(c, "World.obstacles", len(obstacles), MAX_OBSTACLES, "obstacles")
        for i, o in enumerate(obstacles):
            if not isinstance(o, (Cylinder, Box, Sphere, Mesh)):
                raise c.error(f"World.obstacles[{i}]", f"expected a Cylinder, Box, Sphere or Mesh, "
                                                       f"got {_describe(o)}")
        _check_total_triangles(c, "World.obstacles", obstacles)
        goals = tuple(self.goals)
        if not goals:
            raise c.error("World.goals", "expected at least one goal, got none")
        _check_count(c, "World.goals", len(goals), MAX_GOALS, "goals")
        for i, g in enumerate(goals):
            if not isinstance(g, Goal):
                raise c.error(f"World.goals[{i}]", f"expected a Goal, got {_describe(g)}")
        _set(self, "obstacles", obstacles)
        _set(self, "goals", goals)
        _set(self, "time_limit", _time_limit(c, "World.time_limit", self.time_limit))
        _string(c, "World.description", self.description)
        if self.family is not None:
            _string(c, "World.family", self.family, nonempty=True)
        if not isinstance(self.retract, (bool, np.bool_)):
            raise c.error("World.retract", f"expected true or false, got {_describe(self.retract)}")
        _set(self, "retract", bool(self.retract))
        if not isinstance(self.extra, dict):
            raise c.error("World.extra", f"expected a dict, got {_describe(self.extra)}")
        _set(self, "extra", _json_value(c, "World.extra", self.extra))
        if self.source is not None:
            _set(self, "source", Path(self.source).resolve())

    def to_dict(self, relative_to: str | os.PathLike[str] | None = None) -> dict[str, Any]:
        """The world as JSON-ready data in the ``navstack-world/1`` format (inverse of
        :func:`world_from_dict`).  Mesh paths are absolute, or relative to the folder ``relative_to``
        when given (what :func:`save_world` writes)."""
        rel = None if relative_to is None else Path(relative_to)
        d: dict[str, Any] = {
            "format": FORMAT,
            "name": self.name,
            "description": self.description,
        }
        if self.family is not None:
            d["family"] = self.family
        if self.retract:
            d["retract"] = True
        d["robot"] = self.robot.to_dict()
        d["obstacles"] = [o.to_dict(rel) for o in self.obstacles]
        d["goals"] = [g.to_dict() for g in self.goals]
        d["time_limit"] = self.time_limit
        if self.extra:
            d["extra"] = copy.deepcopy(self.extra)
        return d

    @property
    def goal_positions(self) -> FloatArray:
        """(G, 3) goal positions in order (m)."""
        return np.array([g.position for g in self.goals])


# --------------------------------------------------------------------------- parsing


def _check_count(ctx: _Ctx, path: str, n: int, most: int, what: str) -> None:
    if n > most:
        raise ctx.error(path, f"expected at most {most} {what}, got {n}")


def _parse_base(ctx: _Ctx, path: str, v: Any) -> Base:
    o = _object(ctx, path, v, (), ("position", "rpy"))
    pos = _coords(ctx, _join(path, "position"), o["position"]) if "position" in o else np.zeros(3)
    rpy = _angles(ctx, _join(path, "rpy"), o["rpy"]) if "rpy" in o else np.zeros(3)
    return Base(position=pos, rpy=rpy)


def _parse_robot(ctx: _Ctx, path: str, v: Any) -> RobotSpec:
    o = _object(ctx, path, v, (), ("base", "q0", "serpentine_radius", "arm_radius"))
    base = _parse_base(ctx, _join(path, "base"), o["base"]) if "base" in o else Base()
    q0 = _q0(ctx, _join(path, "q0"), o["q0"]) if "q0" in o else jpl.Q_DEFAULT.copy()
    sr = (_robot_radius(ctx, _join(path, "serpentine_radius"), o["serpentine_radius"])
          if "serpentine_radius" in o else jpl.SERPENTINE_RADIUS)
    ar = _robot_radius(ctx, _join(path, "arm_radius"), o["arm_radius"]) if "arm_radius" in o else jpl.ARM_RADIUS
    return RobotSpec(base=base, q0=q0, serpentine_radius=sr, arm_radius=ar)


def _parse_motion(ctx: _Ctx, path: str, v: Any) -> Motion:
    if not isinstance(v, dict):
        raise ctx.error(path, f"expected a motion object, got {_describe(v)}")
    if "type" not in v:
        raise ctx.error(_join(path, "type"), f"missing required key (one of: {', '.join(MOTION_TYPES)})")
    kind = v["type"]
    if not isinstance(kind, str) or kind not in MOTION_TYPES:
        names = ", ".join(map(json.dumps, MOTION_TYPES))
        raise ctx.error(_join(path, "type"), f"expected one of {names}, got {_describe(kind)}")
    times = {"lo": 0.0, "hi": MAX_MOTION_TIME, "unit": " s"}
    if kind == "linear":
        _object(ctx, path, v, ("type", "velocity"), ("start", "stop"))
        velocity = _velocity(ctx, _join(path, "velocity"), v["velocity"])
        start = _number(ctx, _join(path, "start"), v["start"], **times) if "start" in v else 0.0
        stop = math.inf
        if "stop" in v:
            stop = _number(ctx, _join(path, "stop"), v["stop"], lo=start, hi=MAX_MOTION_TIME,
                           unit=" s (at least start; omit stop for a motion that never stops)")
        return LinearMotion(velocity=velocity, start=start, stop=stop)
    _object(ctx, path, v, ("type", "axis", "amplitude", "period"), ("phase",))
    axis = _direction(ctx, _join(path, "axis"), v["axis"])
    amplitude = _number(ctx, _join(path, "amplitude"), v["amplitude"], lo=0.0, hi=MAX_LENGTH, unit=" m")
    period = _number(ctx, _join(path, "period"), v["period"], lo=MIN_PERIOD, hi=MAX_MOTION_TIME, unit=" s")
    phase = 0.0
    if "phase" in v:
        phase = _number(ctx, _join(path, "phase"), v["phase"], lo=-MAX_ANGLE - _ANGLE_SLACK,
                        hi=MAX_ANGLE + _ANGLE_SLACK, unit=" rad")
    _check_speed(ctx, _join(path, "period"), 2.0 * math.pi * amplitude / period,
                 "peak speed 2 pi amplitude / period")
    return OscillateMotion(axis=axis, amplitude=amplitude, period=period, phase=phase)


def _resolved_mesh(file: Path, base_dir: Path | None) -> Path:
    """A mesh path (``~`` already expanded) as the loader reads it: relative to ``base_dir`` (else the working
    folder), resolved."""
    return ((base_dir or Path.cwd()) / file).resolve()  # (an absolute ``file`` stays itself)


def named_mesh_files(text: bytes | str | None, world_file: str | os.PathLike[str]) -> list[Path]:
    """The mesh files that the obstacles of a world file's text name, resolved as :func:`load_world` resolves them
    (nothing is checked or read; none if the text is not a world's JSON).  For callers that must know which
    files a world depends on without loading it (a sweep's change detection)."""
    try:
        obstacles = json.loads(text)["obstacles"] if text is not None else []
    except (ValueError, TypeError, KeyError, RecursionError):
        return []
    out = []
    for o in obstacles if isinstance(obstacles, list) else ():
        if isinstance(o, dict) and o.get("type") == "mesh" and isinstance(o.get("path"), str):
            try:
                out.append(_resolved_mesh(Path(o["path"]).expanduser(), Path(world_file).parent))
            except (OSError, RuntimeError, ValueError):
                continue
    return out


def _mesh_file(ctx: _Ctx, path: str, p: str) -> Path:
    """The resolved mesh file named by ``p``, refused if it leaves the world file's folder tree (unless
    ``ctx.allow_mesh_outside``, or the data has no file).  A leading ``~`` is the user's home folder (so a
    path outside the world file's folder)."""
    if "\x00" in p:
        raise ctx.error(path, f"expected a file path, got {json.dumps(p)} (it holds a NUL character)")
    try:
        file = Path(p).expanduser()
    except RuntimeError as exc:  # ~nosuchuser
        raise ctx.error(path, f"expected a file path, got {json.dumps(p)} ({exc})") from None
    restrict = ctx.base_dir is not None and ctx.file is not None and not ctx.allow_mesh_outside
    if restrict and file.is_absolute():
        raise ctx.error(path, f"expected a path relative to the world file's folder, got the "
                              f"{'home' if p.startswith('~') else 'absolute'} path "
                              f"{json.dumps(p)} (to use meshes outside it, pass --allow-mesh-outside / "
                              f"allow_mesh_outside=True)")
    file = _resolved_mesh(file, ctx.base_dir)
    if restrict and not file.is_relative_to(ctx.base_dir):
        raise ctx.error(path, f"expected a mesh inside the world file's folder {ctx.base_dir}, but "
                              f"{json.dumps(p)} leads to {file} (to use meshes outside it, pass "
                              f"--allow-mesh-outside / allow_mesh_outside=True)")
    return file


def _parse_obstacle(ctx: _Ctx, path: str, v: Any) -> Obstacle:
    if not isinstance(v, dict):
        raise ctx.error(path, f"expected an obstacle object, got {_describe(v)}")
    if "type" not in v:
        raise ctx.error(_join(path, "type"), f"missing required key (one of: {', '.join(OBSTACLE_TYPES)})")
    kind = v["type"]
    if not isinstance(kind, str) or kind not in OBSTACLE_TYPES:
        names = ", ".join(map(json.dumps, OBSTACLE_TYPES))
        raise ctx.error(_join(path, "type"), f"expected one of {names}, got {_describe(kind)}")

    def motion() -> Motion | None:
        return _parse_motion(ctx, _join(path, "motion"), v["motion"]) if "motion" in v else None

    if kind == "cylinder":
        _object(ctx, path, v, ("type", "p0", "p1", "radius"), ("motion",))
        p0, p1 = _coords(ctx, _join(path, "p0"), v["p0"]), _coords(ctx, _join(path, "p1"), v["p1"])
        _check_length(ctx, _join(path, "p1"), p0, p1)
        return Cylinder(p0=p0, p1=p1, radius=_size(ctx, _join(path, "radius"), v["radius"]), motion=motion())
    if kind == "box":
        _object(ctx, path, v, ("type", "center", "half_extents"), ("rpy", "motion"))
        rpy = _angles(ctx, _join(path, "rpy"), v["rpy"]) if "rpy" in v else np.zeros(3)
        return Box(center=_coords(ctx, _join(path, "center"), v["center"]),
                   half_extents=_sizes(ctx, _join(path, "half_extents"), v["half_extents"]), rpy=rpy,
                   motion=motion())
    if kind == "sphere":
        _object(ctx, path, v, ("type", "center", "radius"), ("motion",))
        return Sphere(center=_coords(ctx, _join(path, "center"), v["center"]),
                      radius=_size(ctx, _join(path, "radius"), v["radius"]), motion=motion())
    # mesh
    if "motion" in v:
        raise ctx.error(_join(path, "motion"), "a mesh cannot move: motion is allowed on a cylinder, box or "
                                               "sphere only")
    _object(ctx, path, v, ("type", "path"), ("position", "rpy", "scale"))
    file = _mesh_file(ctx, _join(path, "path"), _string(ctx, _join(path, "path"), v["path"], nonempty=True))
    position = _coords(ctx, _join(path, "position"), v["position"]) if "position" in v else np.zeros(3)
    rpy = _angles(ctx, _join(path, "rpy"), v["rpy"]) if "rpy" in v else np.zeros(3)
    scale = _scale(ctx, _join(path, "scale"), v["scale"]) if "scale" in v else 1.0
    vertices, _ = _mesh_triangles(ctx, _join(path, "path"), file)
    _check_mesh_extent(ctx, _join(path, "scale"), vertices, scale)
    return Mesh(path=file, position=position, rpy=rpy, scale=scale)


def _parse_goal(ctx: _Ctx, path: str, v: Any) -> Goal:
    o = _object(ctx, path, v, ("position",), ("tolerance",))
    tol = _tolerance(ctx, _join(path, "tolerance"), o["tolerance"]) if "tolerance" in o else DEFAULT_TOLERANCE
    return Goal(position=_coords(ctx, _join(path, "position"), o["position"]), tolerance=tol)


def _array(ctx: _Ctx, path: str, v: Any, most: int, what: str) -> list | tuple:
    if not isinstance(v, (list, tuple)):
        raise ctx.error(path, f"expected an array, got {_describe(v)}")
    _check_count(ctx, path, len(v), most, what)
    return v


_TOP_REQUIRED = ("format", "name", "robot", "obstacles", "goals")
_TOP_OPTIONAL = ("description", "time_limit", "family", "retract", "extra")


def world_from_dict(data: Any, source: str | os.PathLike[str] | None = None, *,
                    allow_mesh_outside: bool = False) -> World:
    """Validate parsed ``navstack-world/1`` data and build a :class:`World`.

    Args:
        data: the parsed JSON document (a dict).
        source: the file it came from: named in error messages, the folder relative mesh paths are
            resolved against (the current directory when ``None``), and stored as ``World.source``.
        allow_mesh_outside: accept mesh paths that are absolute or leave ``source``'s folder tree (only
            checked when ``source`` is given).

    Raises:
        WorldError: the first invalid field, with its JSON path.
    """
    base_dir = Path(source).resolve().parent if source is not None else None
    ctx = _Ctx(source, base_dir, allow_mesh_outside=allow_mesh_outside)
    if not isinstance(data, dict):
        raise ctx.error("", f"expected a JSON object at the top level, got {_describe(data)}")
    if "format" not in data:
        raise ctx.error("format", f'missing required key (expected "format": "{FORMAT}")')
    if data["format"] != FORMAT:
        raise ctx.error("format", f'expected "{FORMAT}", got {_describe(data["format"])}')
    d = _object(ctx, "", data, _TOP_REQUIRED, _TOP_OPTIONAL)
    name = _string(ctx, "name", d["name"], nonempty=True)
    description = _string(ctx, "description", d["description"]) if "description" in d else ""
    family = None
    if d.get("family") is not None:
        family = _string(ctx, "family", d["family"], nonempty=True)
    retract = d.get("retract", False)
    if not isinstance(retract, bool):
        raise ctx.error("retract", f"expected true or false, got {_describe(retract)}")
    robot = _parse_robot(ctx, "robot", d["robot"])
    obstacles = tuple(_parse_obstacle(ctx, f"obstacles[{i}]", o)
                      for i, o in enumerate(_array(ctx, "obstacles", d["obstacles"], MAX_OBSTACLES, "obstacles")))
    _check_total_triangles(ctx, "obstacles", obstacles)
    goals_raw = _array(ctx, "goals", d["goals"], MAX_GOALS, "goals")
    if len(goals_raw) == 0:
        raise ctx.error("goals", "expected at least one goal, got an empty array")
    goals = tuple(_parse_goal(ctx, f"goals[{i}]", g) for i, g in enumerate(goals_raw))
    time_limit = _time_limit(ctx, "time_limit", d["time_limit"]) if "time_limit" in d else DEFAULT_TIME_LIMIT
    extra: dict[str, Any] = {}
    if "extra" in d:
        if not isinstance(d["extra"], dict):
            raise ctx.error("extra", f"expected an object, got {_describe(d['extra'])}")
        extra = _json_value(ctx, "extra", d["extra"])
    return World(name=name, robot=robot, obstacles=obstacles, goals=goals, time_limit=time_limit,
                 description=description, family=family, extra=extra, retract=retract,
                 source=None if source is None else Path(source).resolve())


def _read_text(ctx: _Ctx, path: str | os.PathLike[str], max_bytes: int) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes`` bytes (checked before reading it)."""
    try:
        # O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as e:
        raise ctx.error("", f"cannot read the file: {e.strerror or e}") from e
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ctx.error("", f"expected a regular file, got {_file_kind(st.st_mode)}")
        if st.st_size > max_bytes:
            raise ctx.error("", f"the file is {_mib(st.st_size)}, more than the {_mib(max_bytes)} a world file "
                                f"may have (raise the limit with --max-world-mb / max_bytes)")
        with os.fdopen(os.dup(fd), "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise ctx.error("", f"cannot read the file: {e.strerror or e}") from e
    finally:
        os.close(fd)
    if len(raw) > max_bytes:  # it grew after fstat
        raise ctx.error("", f"the file is larger than the {_mib(max_bytes)} a world file may have")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ctx.error("", f"expected UTF-8 JSON text, cannot decode byte {e.start}: {e.reason}") from e


def _file_kind(mode: int) -> str:
    kinds = [(stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")]
    return next((name for test, name in kinds if test(mode)), "not a regular file")


def _mib(n: int) -> str:
    """``n`` bytes for a message: in MiB to 3 significant digits, and in bytes below 1 MiB (a 1.5 kB file
    read '0.0 MiB')."""
    return f"{n / 2**20:.3g} MiB" if n >= 2**20 else f"{n:,} bytes"


def load_world(path: str | os.PathLike[str], *, allow_mesh_outside: bool = False,
               max_bytes: int = MAX_WORLD_BYTES) -> World:
    """Read, validate and return the world file at ``path`` (JSON, ``navstack-world/1``).

    Mesh files are loaded with trimesh here, so a world that loads can be simulated.

    Args:
        path: the world file; a regular file of at most ``max_bytes`` bytes.
        allow_mesh_outside: accept mesh paths that are absolute or lead outside the world file's folder
            tree (refused by default: a world file from someone else must not read files elsewhere).
        max_bytes: the largest file accepted (default :data:`MAX_WORLD_BYTES`, 64 MiB), checked before
            parsing.

    Raises:
        WorldError: unreadable file, not a regular file, too large, invalid JSON (with line/column), or the
            first invalid field (with its JSON path); the message always names the file.
    """
    if not isinstance(path, (str, os.PathLike)) or "\x00" in os.fspath(path):
        raise TypeError(f"load_world: path must be a file path (str or os.PathLike, no NUL), got {path!r:.80}")
    ctx = _Ctx(path, None)
    if isinstance(max_bytes, bool) or not isinstance(max_bytes, int) or max_bytes < 1:
        raise ValueError(f"load_world: max_bytes must be a positive integer, got {max_bytes!r}")
    text = _read_text(ctx, path, max_bytes)
    try:
        data = json.loads(text, parse_constant=_NonFinite, object_pairs_hook=_pairs_hook)
    except json.JSONDecodeError as e:
        raise ctx.error("", f"invalid JSON: {e.msg} (line {e.lineno}, column {e.colno})") from e
    except RecursionError as e:
        raise ctx.error("", "invalid JSON: nested too deeply") from e
    except ValueError as e:  # e.g. an integer of more than 4300 digits (sys.get_int_max_str_digits)
        raise ctx.error("", f"invalid JSON: {e}") from e
    return world_from_dict(data, source=path, allow_mesh_outside=allow_mesh_outside)


def _dumps(obj: Any, indent: int = 0, width: int = 110) -> str:
    """Pretty JSON: containers that fit on one line stay on one line."""
    one = json.dumps(obj, allow_nan=False, separators=(", ", ": "), ensure_ascii=False)
    if not isinstance(obj, (dict, list)) or (indent > 0 and indent + len(one) <= width) or not obj:
        return one
    pad = " " * (indent + 2)
    if isinstance(obj, list) and not any(isinstance(v, (dict, list)) for v in obj):
        # a long array of scalars (q0): several values per line
        lines, line = [], ""
        for s in (json.dumps(v, allow_nan=False, ensure_ascii=False) for v in obj):
            if line and len(pad) + len(line) + len(s) + 2 > width:
                lines.append(line.rstrip())
                line = ""
            line += s + ", "
        lines.append(line[:-2])
        return "[\n" + ",\n".join(pad + ln.rstrip(",") for ln in lines) + "\n" + " " * indent + "]"
    if isinstance(obj, dict):
        items = [f"{pad}{json.dumps(k, ensure_ascii=False)}: {_dumps(v, indent + 2, width)}"
                 for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + " " * indent + "}"
    items = [pad + _dumps(v, indent + 2, width) for v in obj]
    return "[\n" + ",\n".join(items) + "\n" + " " * indent + "]"


def save_world(world: World, path: str | os.PathLike[str]) -> None:
    """Write ``world`` to ``path`` as pretty JSON (UTF-8, trailing newline).

    Mesh paths are written relative to the output file's folder (absolute only where no relative path
    exists, e.g. another drive on Windows), so the world folder can be moved as a whole.
    """
    out = Path(path)
    text = _dumps(world.to_dict(relative_to=out.resolve().parent)) + "\n"
    out.write_text(text, encoding="utf-8")


__all__ = [
    "FORMAT",
    "MAX_COORDINATE",
    "MAX_TIME_LIMIT",
    "MAX_WORLD_BYTES",
    "MOTION_TYPES",
    "Base",
    "Box",
    "Cylinder",
    "Goal",
    "LinearMotion",
    "Mesh",
    "Motion",
    "OBSTACLE_TYPES",
    "Obstacle",
    "OscillateMotion",
    "RobotSpec",
    "Sphere",
    "World",
    "WorldError",
    "load_world",
    "named_mesh_files",
    "save_world",
    "world_from_dict",
]
