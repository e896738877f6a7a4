"""A run folder holds one run: a rerun replaces what an earlier one wrote, a run that fails before it starts
leaves the folder as it was, and a mesh with the longest legal file name is copied in (an adversarial review
found each of these broken)."""

from __future__ import annotations

import json

import pytest
import trimesh
from _worlds import TIP, world_data

import navstack.trial
from navstack.rundir import MAX_NAME_BYTES, RUN_FILES, check_run_folder, load_run, mesh_copy_name
from navstack.trial import run_trial
from navstack.world import load_world, world_from_dict


def _short(name: str) -> dict:
    data = world_data(time_limit=0.3)
    data["name"] = name
    return data


def test_a_rerun_replaces_every_file_of_the_earlier_run(tmp_path):
    out = tmp_path / "out"
    run_trial(world_from_dict(_short("first")), planner="scripted", out_dir=out, render=True)
    (out / "animation.mp4").write_bytes(b"an earlier run's animation")
    assert (out / "scene.png").exists()
    run_trial(world_from_dict(_short("second")), planner="scripted", out_dir=out)  # no pictures this time
    assert not (out / "scene.png").exists() and not (out / "animation.mp4").exists()
    assert json.loads((out / "result.json").read_text())["world"] == "second"
    assert load_run(out).world.name == "second"
    assert set(RUN_FILES) >= {"result.json", "trajectory.npz", "world.json", "scene.png", "animation.mp4"}


def test_a_run_that_fails_before_it_starts_leaves_the_folder_as_it_was(tmp_path, monkeypatch):
    out = tmp_path / "out"
    run_trial(world_from_dict(_short("first")), planner="scripted", out_dir=out)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}

    def broken(*args, **kwargs):
        raise ValueError("the controller refused its start")

    monkeypatch.setattr(navstack.trial, "_Simulation", broken)
    with pytest.raises(ValueError, match="refused"):
        run_trial(world_from_dict(_short("second")), planner="scripted", out_dir=out)
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before  # world.json too


def test_a_mesh_with_a_255_byte_file_name_is_copied_into_the_run_folder(tmp_path):
    name = "p" * 251 + ".obj"
    folder = tmp_path / "w"
    folder.mkdir()
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(folder / name)
    data = world_data(time_limit=0.3)
    data["obstacles"].append({"type": "mesh", "path": name, "position": (TIP + [0.0, 0.0, 1.0]).tolist()})
    (folder / "world.json").write_text(json.dumps(data))
    out = tmp_path / "out"
    run_trial(load_world(folder / "world.json"), planner="scripted", out_dir=out)
    copied = load_run(out).world.obstacles[-1].path
    assert copied.parent == (out / "meshes").resolve() and copied.name.endswith(".obj")
    assert len(copied.name.encode()) <= MAX_NAME_BYTES
    assert copied.read_bytes() == (folder / name).read_bytes()
    assert mesh_copy_name(3, "node.stl") == "003-node.stl"  # short names as before


def test_mesh_copy_names_at_the_file_name_limit_and_with_a_long_extension():
    assert MAX_NAME_BYTES == 255
    whole = "q" * 247 + ".stl"  # 251 bytes: with "003-", exactly 255
    assert mesh_copy_name(3, whole) == "003-" + whole
    longer = "q" + whole  # 256: hashed, the extension kept
    name = mesh_copy_name(3, longer)
    assert name.startswith("003-") and name.endswith(".stl") and len(name) == 4 + 16 + 4 and name != "003-" + longer
    ext32, ext33 = "." + "e" * 31, "." + "e" * 32  # extensions of 32 and 33 bytes
    assert mesh_copy_name(0, "m" * 260 + ext32).endswith(ext32)
    assert len(mesh_copy_name(0, "m" * 260 + ext33)) == 4 + 16  # too long to be an extension: dropped


def test_a_folder_that_never_held_a_run_keeps_its_files(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "scene.png").write_bytes(b"the user's own picture")
    run_trial(world_from_dict(_short("first")), planner="scripted", out_dir=out)
    assert (out / "scene.png").read_bytes() == b"the user's own picture"


def test_an_output_folder_the_run_would_damage_is_bad_input(tmp_path, capsys):
    """A folder named scene.png where the picture goes (it became an internal error), and --out the world
    file's own folder when the file is world.json (the run overwrote the user's world)."""
    from navstack.cli import main

    out = tmp_path / "out"
    (out / "scene.png").mkdir(parents=True)
    with pytest.raises(navstack.trial.TrialInputError, match="scene.png is a folder"):
        run_trial(world_from_dict(_short("first")), planner="scripted", out_dir=out)
    folder = tmp_path / "w"
    folder.mkdir()
    (folder / "world.json").write_text(json.dumps(_short("mine")))
    before = (folder / "world.json").read_bytes()
    assert main(["run", str(folder / "world.json"), "--out", str(folder), "--planner", "scripted"]) == 2
    assert "would overwrite the world file" in capsys.readouterr().err
    assert (folder / "world.json").read_bytes() == before and not (folder / "result.json").exists()
    # a world.json elsewhere is no obstacle, whichever way the two paths sort
    for other in (tmp_path / "a" / "world.json", tmp_path / "z" / "world.json"):
        other.parent.mkdir()
        other.write_text(json.dumps(_short("elsewhere")))
        check_run_folder(load_world(other), tmp_path / "m")
