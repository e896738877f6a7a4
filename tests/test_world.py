"""World files (navstack-world/1): loading, validation errors, round trip."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import trimesh

from navstack import jpl
from navstack.world import (
    FORMAT,
    Base,
    Box,
    Cylinder,
    Goal,
    Mesh,
    RobotSpec,
    Sphere,
    World,
    WorldError,
    load_world,
    save_world,
    world_from_dict,
)

# interfaces.md section 2's example with its placeholders filled in
SPEC_EXAMPLE = """{
  "format": "navstack-world/1",
  "name": "paper-truss",
  "description": "free text",
  "robot": {
    "base": {"position": [0, 0, 0], "rpy": [0, 0, 0]},
    "q0": [0.0, 0.0, 0.0, -1.5707963267948966, 1.0471975511965976, 0.0, 0.5235987755982988,
           0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    "serpentine_radius": 0.025,
    "arm_radius": 0.06
  },
  "obstacles": [
    {"type": "cylinder", "p0": [1.2, -0.5, 1.0], "p1": [1.2, 0.5, 1.0], "radius": 0.02},
    {"type": "box", "center": [1.5, 0, 0.5], "half_extents": [0.1, 0.2, 0.3], "rpy": [0, 0, 0.5]},
    {"type": "sphere", "center": [0.5, 0.5, 2.0], "radius": 0.1},
    {"type": "mesh", "path": "parts/node.stl", "position": [2, 0, 1], "rpy": [0.1, 0.2, 0.3], "scale": 1.0}
  ],
  "goals": [
    {"position": [0.9, -0.1, 2.0], "tolerance": 0.02}
  ],
  "time_limit": 60.0
}
"""


def write_stl(path: Path, extents=(0.2, 0.2, 0.2)) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=extents).export(path)
    return path


@pytest.fixture
def spec_file(tmp_path) -> Path:
    write_stl(tmp_path / "parts" / "node.stl")
    f = tmp_path / "bad_world.json"
    f.write_text(SPEC_EXAMPLE)
    return f


@pytest.fixture
def valid(spec_file) -> dict:
    return json.loads(spec_file.read_text())


def test_spec_example_loads(spec_file, tmp_path):
    w = load_world(spec_file)
    assert w.name == "paper-truss" and w.description == "free text"
    assert [type(o) for o in w.obstacles] == [Cylinder, Box, Sphere, Mesh]
    assert w.obstacles[3].path == (tmp_path / "parts" / "node.stl").resolve()
    assert w.obstacles[3].path.is_absolute()
    np.testing.assert_array_equal(w.obstacles[0].p1, [1.2, 0.5, 1.0])
    assert w.obstacles[1].rpy[2] == 0.5
    assert w.goals[0].tolerance == 0.02 and w.time_limit == 60.0
    np.testing.assert_allclose(w.robot.q0, jpl.Q_DEFAULT, atol=1e-15)
    assert w.source == spec_file.resolve()
    assert w.family is None and w.extra == {}
    for arr in (w.robot.q0, w.goals[0].position, w.obstacles[0].p0):
        assert arr.dtype == np.float64 and not arr.flags.writeable


def test_defaults_of_optional_keys(tmp_path):
    f = tmp_path / "min.json"
    f.write_text(json.dumps({"format": FORMAT, "name": "m", "robot": {}, "obstacles": [],
                             "goals": [{"position": [1, 2, 3]}]}))
    w = load_world(f)
    np.testing.assert_array_equal(w.robot.q0, jpl.Q_DEFAULT)
    np.testing.assert_array_equal(w.robot.base.position, [0, 0, 0])
    np.testing.assert_array_equal(w.robot.base.rpy, [0, 0, 0])
    assert (w.robot.serpentine_radius, w.robot.arm_radius) == (0.025, 0.06)
    assert w.goals[0].tolerance == 0.02
    assert w.time_limit == 60.0 and w.description == "" and w.obstacles == ()
    # box rpy and mesh position/rpy/scale are optional too
    write_stl(tmp_path / "m.stl")
    d = json.loads(f.read_text())
    d["obstacles"] = [{"type": "box", "center": [0, 0, 0], "half_extents": [1, 1, 1]},
                      {"type": "mesh", "path": "m.stl"}]
    w = world_from_dict(d, source=f)
    np.testing.assert_array_equal(w.obstacles[0].rpy, [0, 0, 0])
    assert w.obstacles[1].scale == 1.0
    np.testing.assert_array_equal(w.obstacles[1].position, [0, 0, 0])


def test_round_trip(spec_file, tmp_path):
    d = json.loads(spec_file.read_text())
    d["family"] = "truss"
    d["extra"] = {"seed": 7, "notes": ["a", {"b": None, "c": True}], "x": 1.5}
    d["robot"]["base"] = {"position": [0.1, -0.2, 0.3], "rpy": [0.01, -0.02, 3.0]}
    d["goals"].append({"position": [1.0, 0.0, 2.5], "tolerance": 0.05})
    w = world_from_dict(d, source=spec_file)
    # dict round trip (mesh paths absolute, so no source needed)
    out = w.to_dict()
    assert out["format"] == FORMAT
    assert json.loads(json.dumps(out, allow_nan=False)) == out  # JSON-ready
    assert world_from_dict(out) == w
    assert world_from_dict(out).to_dict() == out
    # file round trip into another folder: mesh path written relative to the new file
    dest = tmp_path / "elsewhere" / "copy.json"
    dest.parent.mkdir()
    save_world(w, dest)
    saved = json.loads(dest.read_text())
    assert saved["obstacles"][3]["path"] == "../parts/node.stl"
    w2 = load_world(dest)
    assert w2 == w and w2.source == dest.resolve()
    assert w2.extra == d["extra"] and w2.family == "truss"
    # saving next to the mesh folder writes the same relative path the spec uses
    save_world(w, tmp_path / "same.json")
    assert json.loads((tmp_path / "same.json").read_text())["obstacles"][3]["path"] == "parts/node.stl"
    # a changed value is not equal
    d["obstacles"][2]["radius"] = 0.1000001
    assert world_from_dict(d, source=spec_file) != w


def test_mesh_world_loads_relative_to_file_not_cwd(tmp_path, monkeypatch):
    write_stl(tmp_path / "w" / "meshes" / "cube.stl", extents=(1.0, 2.0, 3.0))
    f = tmp_path / "w" / "mesh_world.json"
    f.write_text(json.dumps({"format": FORMAT, "name": "mesh", "robot": {}, "goals": [{"position": [0, 0, 3]}],
                             "obstacles": [{"type": "mesh", "path": "meshes/cube.stl", "scale": 0.5}]}))
    monkeypatch.chdir(tmp_path)  # not the world's folder
    w = load_world(f)
    m = w.obstacles[0]
    assert m.path == (tmp_path / "w" / "meshes" / "cube.stl").resolve()
    v, faces = m.triangles()
    assert faces.shape == (12, 3)
    np.testing.assert_allclose(v.max(axis=0) - v.min(axis=0), [0.5, 1.0, 1.5])  # scale applied


def test_base_transform_matches_pybullet():
    rpy = np.array([0.3, -0.7, 1.9])
    T = Base(position=[1.0, 2.0, 3.0], rpy=rpy).transform()
    R_pb = np.reshape(p.getMatrixFromQuaternion(p.getQuaternionFromEuler(rpy.tolist())), (3, 3))
    np.testing.assert_allclose(T[:3, :3], R_pb, atol=1e-12)
    np.testing.assert_array_equal(T[:3, 3], [1, 2, 3])
    np.testing.assert_array_equal(T[3], [0, 0, 0, 1])
    # roll about world X first, then pitch about world Y: a body x axis ends up yawed but not rolled
    Rz = Base(rpy=[0, 0, np.pi / 2]).transform()[:3, :3]
    np.testing.assert_allclose(Rz @ [1, 0, 0], [0, 1, 0], atol=1e-15)


def test_joint_limit_boundary_accepted(valid, spec_file):
    valid["robot"]["q0"][8] = 1.3089969389957472  # 75 deg written in decimal
    valid["robot"]["q0"][0] = -1.0
    w = world_from_dict(valid, source=spec_file)
    assert w.robot.q0[8] == pytest.approx(75 * np.pi / 180)


# ---------------------------------------------------------------------------- errors

def _set(path: str, value):
    """A mutation that sets a dotted/indexed path (e.g. 'obstacles[0].radius') in the document."""
    def f(d):
        obj, key = _walk(d, path)
        obj[key] = value
    return f


def _del(path: str):
    def f(d):
        obj, key = _walk(d, path)
        del obj[key]
    return f


def _walk(d, path):
    tokens = []
    for part in path.split("."):
        name, *idx = part.replace("]", "").split("[")
        tokens.append(name)
        tokens.extend(int(i) for i in idx)
    for t in tokens[:-1]:
        d = d[t]
    return d, tokens[-1]


NUMBER_PLACEHOLDER = 424242.0


ERROR_CASES = [
    # (id, mutation, json_path, message fragment)
    ("format-wrong", _set("format", "navstack-world/2"), "format", "navstack-world/1"),
    ("format-missing", _del("format"), "format", "missing"),
    ("name-missing", _del("name"), "name", "missing required key"),
    ("robot-missing", _del("robot"), "robot", "missing required key"),
    ("obstacles-missing", _del("obstacles"), "obstacles", "missing required key"),
    ("goals-missing", _del("goals"), "goals", "missing required key"),
    ("radius-missing", _del("obstacles[0].radius"), "obstacles[0].radius", "missing required key"),
    ("goal-position-missing", _del("goals[0].position"), "goals[0].position", "missing required key"),
    ("unknown-top", _set("nmae", "x"), "nmae", "unknown key"),
    ("unknown-robot", _set("robot.bse", {}), "robot.bse", "unknown key"),
    ("unknown-base", _set("robot.base.yaw", 0), "robot.base.yaw", "unknown key"),
    ("unknown-obstacle", _set("obstacles[1].colour", "red"), "obstacles[1].colour", "unknown key"),
    ("unknown-goal", _set("goals[0].tol", 0.1), "goals[0].tol", "unknown key"),
    ("name-type", _set("name", 3), "name", "string"),
    ("name-empty", _set("name", ""), "name", "non-empty string"),
    ("description-null", _set("description", None), "description", "string"),
    ("family-type", _set("family", 3), "family", "string"),
    ("extra-type", _set("extra", [1]), "extra", "object"),
    ("robot-type", _set("robot", []), "robot", "object"),
    ("bool-radius", _set("obstacles[0].radius", True), "obstacles[0].radius", "positive number"),
    ("bool-q0", _set("robot.q0[7]", False), "robot.q0[7]", "finite number"),
    ("string-q0", _set("robot.q0[7]", "0"), "robot.q0[7]", "finite number"),
    ("bool-time-limit", _set("time_limit", False), "time_limit", "positive number"),
    ("obstacles-type", _set("obstacles", {}), "obstacles", "array"),
    ("goals-type", _set("goals", "x"), "goals", "array"),
    ("position-type", _set("robot.base.position", 5), "robot.base.position", "array of 3"),
    ("obstacle-not-object", _set("obstacles[2]", [1, 2]), "obstacles[2]", "object"),
    ("vector-short", _set("obstacles[0].p0", [1, 2]), "obstacles[0].p0", "array of 3 numbers"),
    ("vector-long", _set("goals[0].position", [1, 2, 3, 4]), "goals[0].position", "array of 3 numbers"),
    ("q0-short", _set("robot.q0", [0.0] * 19), "robot.q0", "array of 20 numbers"),
    ("radius-zero", _set("obstacles[0].radius", 0), "obstacles[0].radius", "positive"),
    ("radius-negative", _set("obstacles[2].radius", -0.1), "obstacles[2].radius", "positive"),
    ("half-extent-zero", _set("obstacles[1].half_extents[1]", 0.0), "obstacles[1].half_extents[1]", "positive"),
    ("scale-zero", _set("obstacles[3].scale", 0), "obstacles[3].scale", "positive"),
    ("tolerance-zero", _set("goals[0].tolerance", 0.0), "goals[0].tolerance", "positive"),
    ("time-limit-negative", _set("time_limit", -5), "time_limit", "positive"),
    ("serp-radius-zero", _set("robot.serpentine_radius", 0), "robot.serpentine_radius", "positive"),
    ("cylinder-degenerate", _set("obstacles[0].p1", [1.2, -0.5, 1.0]), "obstacles[0].p1", "different from p0"),
    ("q0-serpentine-limit", _set("robot.q0[8]", 2.0), "robot.q0[8]", "limits of joint 9"),
    ("q0-lathe-limit", _set("robot.q0[0]", 2.5), "robot.q0[0]", "limits of joint 1"),
    ("goals-empty", _set("goals", []), "goals", "at least one goal"),
    ("type-unknown", _set("obstacles[1].type", "cone"), "obstacles[1].type", '"cylinder"'),
    ("type-missing", _del("obstacles[2].type"), "obstacles[2].type", "missing"),
    ("mesh-missing-file", _set("obstacles[3].path", "parts/nope.stl"), "obstacles[3].path", "nope.stl"),
    ("mesh-unsupported", _set("obstacles[3].path", "parts/notes.txt"), "obstacles[3].path", "trimesh"),
    ("mesh-garbage", _set("obstacles[3].path", "parts/garbage.stl"), "obstacles[3].path", "triangle"),
    ("mesh-path-type", _set("obstacles[3].path", 3), "obstacles[3].path", "string"),
    ("nan-radius", _set("obstacles[0].radius", float("nan")), "obstacles[0].radius", "NaN"),
    ("inf-goal", _set("goals[0].position[2]", float("inf")), "goals[0].position[2]", "Infinity"),
    ("neg-inf-q0", _set("robot.q0[3]", float("-inf")), "robot.q0[3]", "-Infinity"),
    ("overflow-1e400", _set("obstacles[1].center[0]", NUMBER_PLACEHOLDER), "obstacles[1].center[0]", "inf"),
    ("nan-in-extra", _set("extra", {"a": [1, float("nan")]}), "extra.a[1]", "NaN"),
]


@pytest.mark.parametrize(("mutate", "json_path", "fragment"), [c[1:] for c in ERROR_CASES],
                         ids=[c[0] for c in ERROR_CASES])
def test_error_names_file_and_path(valid, spec_file, mutate, json_path, fragment):
    (spec_file.parent / "parts" / "notes.txt").write_text("not a mesh")
    (spec_file.parent / "parts" / "garbage.stl").write_bytes(b"solid? no " * 20)
    d = copy.deepcopy(valid)
    mutate(d)
    text = json.dumps(d, indent=2)  # NaN/Infinity literals, as python's json writes them
    text = text.replace(repr(NUMBER_PLACEHOLDER), "1e400")
    spec_file.write_text(text)
    with pytest.raises(WorldError) as ei:
        load_world(spec_file)
    err = ei.value
    msg = str(err)
    assert isinstance(err, ValueError)
    assert "bad_world.json" in msg
    assert err.file == str(spec_file)
    assert err.json_path == json_path, msg
    assert f": {json_path}: " in msg
    assert fragment in msg, msg


def test_unknown_keys_inside_extra_are_fine(valid, spec_file):
    valid["extra"] = {"anything": {"nested": [1, 2, {"deep": "ok"}]}, "typo_welcome": True}
    w = world_from_dict(valid, source=spec_file)
    assert w.extra["anything"]["nested"][2]["deep"] == "ok"


@pytest.mark.parametrize(("text", "fragment"), [
    ('{"format": "navstack-world/1",\n  "name" "x"}', "line 2, column 10"),
    ("", "line 1, column 1"),
    ('[1, 2]', "top level"),
])
def test_invalid_json(tmp_path, text, fragment):
    f = tmp_path / "broken.json"
    f.write_text(text)
    with pytest.raises(WorldError) as ei:
        load_world(f)
    assert "broken.json" in str(ei.value) and fragment in str(ei.value)
    assert ei.value.json_path == ""


def test_duplicate_key(tmp_path):
    f = tmp_path / "dup.json"
    f.write_text('{"format": "navstack-world/1", "name": "a", "name": "b", "robot": {}, "obstacles": [],'
                 ' "goals": [{"position": [0, 0, 1]}]}')
    with pytest.raises(WorldError, match=r"dup\.json: name: duplicate key"):
        load_world(f)


def test_unreadable_files(tmp_path):
    with pytest.raises(WorldError, match=r"missing\.json: \(top level\): cannot read"):
        load_world(tmp_path / "missing.json")
    with pytest.raises(WorldError, match="cannot read"):
        load_world(tmp_path)  # a directory
    f = tmp_path / "latin1.json"
    f.write_bytes(b'{"name": "caf\xe9"}')
    with pytest.raises(WorldError, match=r"latin1\.json: .*UTF-8"):
        load_world(f)


def test_dict_errors_without_file(valid, spec_file):
    valid["obstacles"][0]["radius"] = -1
    with pytest.raises(WorldError) as ei:
        world_from_dict(valid)
    assert ei.value.file is None and ei.value.json_path == "obstacles[0].radius"
    with pytest.raises(WorldError, match="top level"):
        world_from_dict([1, 2, 3], source="x.json")


def test_dataclasses_validate_too(tmp_path):
    with pytest.raises(WorldError, match=r"Cylinder\.radius"):
        Cylinder(p0=[0, 0, 0], p1=[0, 0, 1], radius=-1.0)
    with pytest.raises(WorldError, match=r"Cylinder\.p1"):
        Cylinder(p0=[0, 0, 0], p1=[0, 0, 0], radius=1.0)
    with pytest.raises(WorldError, match=r"Box\.half_extents\[2\]"):
        Box(center=[0, 0, 0], half_extents=[1, 1, 0])
    with pytest.raises(WorldError, match=r"RobotSpec\.q0\[12\]"):
        RobotSpec(q0=np.r_[jpl.Q_DEFAULT[:12], 3.0, jpl.Q_DEFAULT[13:]])
    with pytest.raises(WorldError, match=r"Goal\.position\[1\]"):
        Goal(position=[0.0, np.nan, 0.0])
    with pytest.raises(WorldError, match=r"World\.goals"):
        World(name="w", robot=RobotSpec(), obstacles=(), goals=())
    with pytest.raises(WorldError, match=r"Mesh\.path"):
        Mesh(path=tmp_path / "none.stl").triangles()
    s = Sphere(center=[1, 2, 3], radius=0.5)
    with pytest.raises(AttributeError):
        s.radius = 1.0  # frozen
    with pytest.raises(ValueError):
        s.center[0] = 5.0  # read-only array
    assert s == Sphere(center=np.array([1.0, 2.0, 3.0]), radius=0.5)
    assert hash(s) == hash(Sphere(center=(1, 2, 3), radius=0.5))
