"""Animations (navstack.animate, ``navstack animate``) and the run folder they read (navstack.rundir)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest

from navstack import animate
from navstack.animate import AnimationConfig, Replay, animate_run, choose_view, contacts_per_sample, frame_times
from navstack.cli import main
from navstack.jpl import jpl_serpentine
from navstack.render import CONTACT_RGBA
from navstack.rundir import MAX_SENSED, RunData, load_run, other_world, write_run_world
from navstack.trial import run_trial
from navstack.truss import PAPER_BASE_RPY
from navstack.world import Mesh, world_from_dict

SMALL = AnimationConfig(fps=10, width=320, height=192, hold=0.5)


def _tip(world_dict: dict, q: np.ndarray) -> np.ndarray:
    w = world_from_dict(world_dict)
    T0 = w.robot.base.transform()
    return T0[:3, :3] @ jpl_serpentine().frames(q)[21, :3, 3] + T0[:3, 3]


def straight_world(contact: bool = True) -> dict:
    """The lathe pushes the straight serpentine along +x between four members; with ``contact`` a sphere
    sits on the tip's way in the last part of the run."""
    chain = jpl_serpentine()
    base = {"robot": {"base": {"position": [0.0, 0.0, 0.3], "rpy": list(PAPER_BASE_RPY)}}}
    start = _tip({"format": "navstack-world/1", "name": "x", "obstacles": [],
                  "goals": [{"position": [0, 0, 0]}], **base}, chain.q_default)
    obstacles = [{"type": "cylinder", "p0": (start + [0.0, dy, dz]).tolist(), "p1": (start + [0.5, dy, dz]).tolist(),
                  "radius": 0.02} for dy in (-0.15, 0.15) for dz in (-0.15, 0.15)]
    if contact:
        obstacles.append({"type": "sphere", "center": (start + [0.36, 0.0, 0.0]).tolist(), "radius": 0.05})
    return {"format": "navstack-world/1", "name": "straight", "obstacles": obstacles,
            "goals": [{"position": (start + [0.2, 0, 0]).tolist()}, {"position": (start + [0.4, 0, 0]).tolist()}],
            "time_limit": 10.0, **base}


def synthetic_run(folder: Path, n: int = 31, contact: bool = True) -> Path:
    """A run folder as navstack run writes it, without simulating: the lathe moves 0.4 m in ``n`` samples."""
    wd = straight_world(contact)
    world = world_from_dict(wd)
    chain = jpl_serpentine()
    q = np.tile(chain.q_default, (n, 1))
    q[:, 0] = np.linspace(0.0, 0.4, n)
    tips = np.array([_tip(wd, qi) for qi in q])
    folder.mkdir(parents=True, exist_ok=True)
    write_run_world(world, folder)
    np.savez_compressed(folder / "trajectory.npz", t=np.arange(n) / 15.0, q=q, q_des=q, tip_des=tips)
    result = {"world": "straight", "seed": 0, "controller": "slither", "planner": "scripted", "success": False,
              "reason": "collision" if contact else "reached", "goals_reached": 2, "sim_time": (n - 1) / 15.0,
              "steps": n - 1, "wall_time": 0.1,
              "metrics": {"tip_error_max": 0.0, "slither_deviation_max": 0.0, "min_clearance": -0.01, "contacts": 5}}
    (folder / "result.json").write_text(json.dumps(result))
    return folder


def _red_pixels(rgb: np.ndarray) -> int:
    r, g, b = (rgb[..., k].astype(int) for k in range(3))
    return int(((r > 150) & (g < 70) & (b < 70)).sum())


@pytest.fixture(scope="module")
def contact_trial(tmp_path_factory):
    """A real closed-loop trial whose tip goes straight through a sphere (scripted planner, no sensing)."""
    out = tmp_path_factory.mktemp("contact")
    result = run_trial(straight_world(), controller="slither", planner="scripted", out_dir=out)
    assert result.reason == "collision" and result.metrics["contacts"] > 0
    return result, out


def test_run_folder_holds_the_world_and_reads_back(contact_trial):
    result, out = contact_trial
    run = load_run(out)
    assert run.world == world_from_dict(straight_world())
    assert run.result == json.loads((out / "result.json").read_text())
    assert len(run.t) == result.steps + 1 and run.q.shape == (len(run.t), 20)


def test_replayed_contacts_match_the_trial_metric(contact_trial):
    """Contact recomputed per sample from the replayed joints agrees with the trial's own count."""
    result, out = contact_trial
    contacts = contacts_per_sample(load_run(out))
    assert sum(1 for c in contacts if c) == result.metrics["contacts"]
    assert all(k >= 8 for c in contacts for k in c)  # the serpentine's links (PyBullet link = DH frame - 1)


def test_mesh_obstacles_are_copied_into_the_run_folder(tmp_path):
    import trimesh

    src = tmp_path / "src"
    (src / "parts").mkdir(parents=True)
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(src / "parts" / "block.stl")
    wd = straight_world(contact=False)
    wd["obstacles"].append({"type": "mesh", "path": "parts/block.stl", "position": [0.0, 2.0, 0.5]})
    (src / "w.json").write_text(json.dumps(wd))
    run_dir = tmp_path / "run"
    run_trial(src / "w.json", planner="scripted", out_dir=run_dir, config=None)
    text = json.loads((run_dir / "world.json").read_text())
    assert text["obstacles"][-1]["path"] == "meshes/004-block.stl"
    assert (run_dir / "meshes" / "004-block.stl").read_bytes() == (src / "parts" / "block.stl").read_bytes()
    moved = tmp_path / "elsewhere"
    shutil.move(run_dir, moved)
    shutil.rmtree(src)  # the run folder no longer needs the original world's folder
    mesh = load_run(moved).world.obstacles[-1]
    assert isinstance(mesh, Mesh) and mesh.path == (moved / "meshes" / "004-block.stl").resolve()


def test_frame_times_cover_the_run_and_end_on_its_last_sample():
    t = frame_times(2.05, AnimationConfig(fps=10))
    assert t[0] == 0.0 and t[-1] == pytest.approx(2.05) and len(t) == 22
    np.testing.assert_allclose(np.diff(t[:-1]), 0.1)
    assert len(frame_times(2.0, AnimationConfig(fps=10, speed=2.0))) == 11


def test_replay_paints_touching_links_red(tmp_path):
    run = load_run(synthetic_run(tmp_path / "run"))
    replay = Replay(run, choose_view(run, SMALL), SMALL.width, SMALL.height)
    try:
        first, touching0 = replay.frame(run.q[0])
        last, touching1 = replay.frame(run.q[-1])
    finally:
        replay.close()
    assert not touching0 and touching1
    assert _red_pixels(first) == 0
    assert _red_pixels(last) > 20
    assert CONTACT_RGBA[0] > 0.8


def test_mp4_has_every_frame_and_shows_motion(tmp_path):
    run_dir = synthetic_run(tmp_path / "run")
    out = animate_run(run_dir, tmp_path / "a.mp4", SMALL)
    assert out == tmp_path / "a.mp4" and not list(tmp_path.glob("*.part*"))
    reader = imageio.get_reader(out)
    n = reader.count_frames()
    expected = len(frame_times(2.0, SMALL)) + round(SMALL.hold * SMALL.fps)
    assert n == expected
    assert reader.get_meta_data()["fps"] == pytest.approx(SMALL.fps)
    first, last = reader.get_data(0), reader.get_data(n - 1)
    assert first.shape == (SMALL.height, SMALL.width, 3)
    assert first.std() > 10  # not a blank picture
    assert np.abs(first.astype(int) - last.astype(int)).mean() > 1.0  # the robot moved, the caption changed
    reader.close()


def test_gif_fallback_without_ffmpeg(tmp_path, monkeypatch):
    from PIL import Image

    monkeypatch.setattr(animate, "_ffmpeg_available", lambda: False)
    run_dir = synthetic_run(tmp_path / "run", n=11)
    out = animate_run(run_dir, config=SMALL)
    assert out == run_dir / "animation.gif"
    n = len(frame_times(10 / 15.0, SMALL))
    with Image.open(out) as im:
        assert im.n_frames == n and im.size == (SMALL.width, SMALL.height)
        durations = []
        for k in range(n):
            im.seek(k)
            durations.append(im.info["duration"])
    assert durations == [100] * (n - 1) + [100 * (1 + round(SMALL.hold * SMALL.fps))]  # the last frame is held


def test_cli_animate_and_its_errors(tmp_path, capsys):
    run_dir = synthetic_run(tmp_path / "run", n=11)
    assert main(["animate", str(run_dir), "--fps", "5", "--size", "320x192", "--view", "side"]) == 0
    out = capsys.readouterr().out
    assert "animation.mp4" in out and "animated in" in out and (run_dir / "animation.mp4").is_file()
    assert main(["animate", str(run_dir), "--eye", "3", "-2", "1", "--target", "0", "0", "0.5", "--size", "320x192",
                 "--out", str(tmp_path / "e.gif")]) == 0
    assert (tmp_path / "e.gif").is_file()
    capsys.readouterr()
    for argv, words in [
        (["animate", str(tmp_path / "nope")], "not a folder"),
        (["animate", str(run_dir), "--size", "300x200"], "multiple of 16"),
        (["animate", str(run_dir), "--size", "big"], "WIDTHxHEIGHT"),
        (["animate", str(run_dir), "--fps", "0"], "fps"),
        (["animate", str(run_dir), "--out", str(tmp_path / "a.avi")], ".mp4 or .gif"),
        (["animate", str(run_dir), "--eye", "1", "2", "3"], "eye and target go together"),
        (["animate", str(run_dir), "--eye", "0", "0", "5", "--target", "0", "0", "0"], "straight down"),
    ]:
        assert main(argv) == 2, argv
        assert words in capsys.readouterr().err, argv


def _mesh_world(folder: Path, mesh_path: str, block: Path) -> Path:
    """``straight_world`` without contact plus one mesh obstacle at ``mesh_path`` (``block`` written there)."""
    import trimesh

    block.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(block)
    wd = straight_world(contact=False)
    wd["obstacles"].append({"type": "mesh", "path": mesh_path, "position": [0.0, 2.0, 0.5]})
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "w.json").write_text(json.dumps(wd))
    return folder / "w.json"


def test_a_given_world_that_is_not_the_runs_is_named(tmp_path):
    """--world drew whatever world it was given without a word, though world.json and result.json say
    which world the trial ran; a copy of the same world (its mesh elsewhere, the same bytes) is no warning."""
    from navstack.world import load_world

    run_dir = synthetic_run(tmp_path / "run", n=5, contact=True)
    ran = load_run(run_dir).world
    assert other_world(run_dir, ran) is None
    without_contact = world_from_dict(straight_world(contact=False))  # the same name, one sphere fewer
    assert "is not the world given" in other_world(run_dir, without_contact)
    (run_dir / "world.json").unlink()  # an older folder: only result.json names the world
    assert other_world(run_dir, without_contact) is None
    renamed = world_from_dict({**straight_world(contact=True), "name": "other"})
    assert "says the trial ran the world 'straight', not the world given ('other')" in other_world(run_dir, renamed)
    assert other_world(tmp_path / "nope", renamed) is None  # load_run names the missing folder

    wfile = _mesh_world(tmp_path / "src", "parts/block.stl", tmp_path / "src" / "parts" / "block.stl")
    mesh_run = tmp_path / "mesh_run"
    write_run_world(load_world(wfile), mesh_run)
    assert other_world(mesh_run, load_world(wfile)) is None  # the copy in meshes/ has the same bytes
    (tmp_path / "src" / "parts" / "block.stl").write_bytes(b"solid x\nendsolid x\n")
    assert other_world(mesh_run, load_world(mesh_run / "world.json")) is None
    moved = _mesh_world(tmp_path / "src2", "parts/block.stl", tmp_path / "src2" / "parts" / "block.stl")
    import trimesh

    trimesh.creation.box(extents=[0.2, 0.1, 0.1]).export(tmp_path / "src2" / "parts" / "block.stl")
    assert "is not the world given" in other_world(mesh_run, load_world(moved))


def test_animate_and_view_take_the_world_options_and_warn_of_another_world(tmp_path, capsys):
    """The mesh-path refusal told animate and view users to pass --allow-mesh-outside, which they lacked."""
    run_dir = synthetic_run(tmp_path / "run", n=3, contact=False)
    wfile = _mesh_world(tmp_path / "w", "../outside/block.stl", tmp_path / "outside" / "block.stl")
    for command in ("animate", "view"):
        assert main([command, str(run_dir), "--world", str(wfile)]) == 2
        assert "pass --allow-mesh-outside" in capsys.readouterr().err
        assert main([command, str(run_dir), "--world", str(wfile), "--max-world-mb", "1e-4"]) == 2
        assert "bytes, more than the 104 bytes a world file may have" in capsys.readouterr().err
    assert main(["animate", str(run_dir), "--world", str(wfile), "--allow-mesh-outside", "--size", "320x192",
                 "--fps", "5", "--out", str(tmp_path / "a.gif")]) == 0
    err = capsys.readouterr().err
    assert "navstack animate: warning: " in err and "is not the world given ('straight')" in err


def test_load_run_names_what_is_wrong(tmp_path):
    run_dir = synthetic_run(tmp_path / "run", n=5)
    (run_dir / "world.json").rename(tmp_path / "w.json")
    with pytest.raises(ValueError, match="no world.json.*--world"):
        load_run(run_dir)
    assert load_run(run_dir, tmp_path / "w.json").world.name == "straight"
    good = dict(np.load(run_dir / "trajectory.npz"))
    for change, words in [
        ({"q": good["q"][:, :19]}, r"'q' has shape \(5, 19\)"),
        ({"tip_des": good["tip_des"][:4]}, "tip_des has 4 samples but t has 5"),
        ({"t": good["t"][::-1].copy()}, "t must increase"),
        ({"q_des": np.full((5, 20), np.nan)}, "'q_des' holds NaN"),
    ]:
        np.savez(run_dir / "trajectory.npz", **{**good, **change})
        with pytest.raises(ValueError, match=words):
            load_run(run_dir, tmp_path / "w.json")
    (run_dir / "trajectory.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a .npz archive"):
        load_run(run_dir, tmp_path / "w.json")


def test_load_run_checks_every_sample_count_and_time(tmp_path):
    """No samples at all, a longer array than t, two samples out of order, only the last time too late."""
    run_dir = synthetic_run(tmp_path / "run", n=5)
    world = run_dir / "world.json"
    good = dict(np.load(run_dir / "trajectory.npz"))
    traj = run_dir / "trajectory.npz"
    late = good["t"].copy()
    late[-1] = 4000.0
    for change, words in [({k: v[:0] for k, v in good.items()}, "holds no samples"),
                          ({"q": np.vstack([good["q"], good["q"][-1:]])}, "q has 6 samples but t has 5"),
                          ({k: v[:2] for k, v in {**good, "t": np.array([0.1, 0.0])}.items()}, "t must increase"),
                          ({"t": late}, r"t runs from 0 to 4000 s, expected times within 0 \.\. 3600 s")]:
        np.savez(traj, **{**good, **change})
        with pytest.raises(ValueError, match=words):
            load_run(run_dir, world)
    edge = good["tip_des"].copy()
    edge[0, 0] = 1.0e4  # the bound itself is taken (a world within 1 km)
    np.savez(traj, **{**good, "tip_des": edge})
    assert load_run(run_dir, world).tip_des[0, 0] == 1.0e4
    assert RunData(path=run_dir, world=load_run(run_dir, world).world, t=np.empty(0), q=np.empty((0, 20)),
                   q_des=np.empty((0, 20)), tip_des=np.empty((0, 3))).duration == 0.0


def _npz_with_header(path, key: str, shape: tuple, arrays: dict) -> None:
    """An .npz whose member ``key`` has a header claiming ``shape`` (and a few bytes of data)."""
    import io
    import zipfile

    with zipfile.ZipFile(path, "w") as z:
        for name, a in arrays.items():
            buf = io.BytesIO()
            np.lib.format.write_array(buf, a)
            z.writestr(f"{name}.npy", buf.getvalue())
        buf = io.BytesIO()
        np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
        z.writestr(f"{key}.npy", buf.getvalue() + b"\0" * 64)


def test_a_hostile_or_damaged_run_folder_is_refused_naming_the_file(tmp_path):
    """An adversarial review's cases: each was an internal error, a memory blow-up or a wrong picture."""
    run_dir = synthetic_run(tmp_path / "run", n=5)
    world = run_dir / "world.json"
    good = dict(np.load(run_dir / "trajectory.npz"))
    traj = run_dir / "trajectory.npz"
    rest = {k: v for k, v in good.items() if k != "t"}
    _npz_with_header(traj, "t", (2**40,), rest)  # 8 TiB claimed: refused from the header
    with pytest.raises(ValueError, match=r"'t' claims shape \(1099511627776,\)"):
        load_run(run_dir, world)
    _npz_with_header(traj, "sensed", (5, 10**7, 3), good)
    with pytest.raises(ValueError, match=r"'sensed' claims shape .* or 1,000 points per step$"):
        load_run(run_dir, world)
    _npz_with_header(traj, "t", (2**40,), rest)
    with pytest.raises(ValueError, match=r"control steps$"):  # no word of points for another array
        load_run(run_dir, world)
    assert MAX_SENSED == 1000
    for k, ok in ((MAX_SENSED, True), (MAX_SENSED + 1, False)):  # the limit itself is taken
        np.savez(traj, **good, sensed=np.zeros((5, k, 3)))
        if ok:
            assert load_run(run_dir, world).sensed.shape == (5, k, 3)
        else:
            with pytest.raises(ValueError, match="'sensed' claims shape"):
                load_run(run_dir, world)
    np.save(tmp_path / "plain.npy", good["t"])  # a .npy saved under the .npz name
    traj.write_bytes((tmp_path / "plain.npy").read_bytes())
    with pytest.raises(ValueError, match="not a .npz archive"):
        load_run(run_dir, world)
    for change, words in [({"t": good["t"] - 100.0}, r"t runs from -100 to -99\.7333 s"),
                          ({"t": good["t"] + 5000.0}, "expected times within 0 .. 3600 s"),
                          ({"t": good["t"] * 1e12}, "'t' holds values beyond"),
                          ({"q": good["q"] * 1e300}, "'q' holds values beyond"),
                          ({"tip_des": good["tip_des"] + 1e6}, "'tip_des' holds values beyond"),
                          ({"q": good["q"] + 0j}, "'q' holds complex128 values, expected real numbers"),
                          ({"q_des": good["q_des"] > 0}, "'q_des' holds bool values")]:
        np.savez(traj, **{**good, **change})
        with pytest.raises(ValueError, match=words):
            load_run(run_dir, world)
    np.savez(traj, **good, extra=np.zeros(10))  # an array it does not use is never read
    assert load_run(run_dir, world).t.shape == (5,)
    result = run_dir / "result.json"
    for text, words in [('{"success": "false", "reason": "collision"}', "'success' is 'false'"),
                        ('{"success": true, "reason": "collision"}', "'success' is true but 'reason'"),
                        ('{"metrics": "x"}', "'metrics' is 'x'"), ('{"goals_reached": "x"}', "'goals_reached'"),
                        ("[" * 100000, "nested too deeply")]:
        result.write_text(text)
        with pytest.raises(ValueError, match=words):
            load_run(run_dir, world)


def test_animation_config_checks_its_fields():
    for kw, words in [({"width": 100}, "width"), ({"speed": -1}, "speed"), ({"view": "under"}, "view"),
                      ({"fps": float("nan")}, "fps"), ({"target": (0, 0, 0)}, "together")]:
        with pytest.raises(ValueError, match=words):
            AnimationConfig(**kw)


def test_cli_run_animate(tmp_path, capsys):
    world = tmp_path / "straight.json"
    world.write_text(json.dumps(straight_world(contact=False)))
    out = tmp_path / "run"
    assert main(["run", str(world), "--out", str(out), "--planner", "scripted", "--animate", "--render"]) == 0
    printed = capsys.readouterr().out
    assert "world.json, scene.png" in printed and "animation.mp4" in printed
    reader = imageio.get_reader(out / "animation.mp4")
    run = load_run(out)
    assert reader.count_frames() == len(frame_times(run.duration, AnimationConfig())) + 22  # 1.5 s held at 15 fps
    reader.close()


def test_robot_rectangle_render_equals_the_full_render(contact_trial):
    """The per-frame shortcut (render only the robot's pixel rectangle) gives the same picture as
    rendering the whole frame."""
    _, out = contact_trial
    run = load_run(out)
    cfg = AnimationConfig(width=480, height=272)
    replay = Replay(run, choose_view(run, cfg), cfg.width, cfg.height)
    try:
        for i in np.linspace(0, len(run.t) - 1, 5).astype(int):
            fast, touching = replay.frame(run.q[i])
            full, touching_full = replay.frame(run.q[i], full=True)
            assert touching == touching_full
            box = replay.robot_box(run.q[i])
            assert box is not None and (box[2] - box[0]) * (box[3] - box[1]) < 0.8 * cfg.width * cfg.height
            differ = np.abs(fast.astype(int) - full.astype(int)).max(axis=-1) > 2
            assert differ.sum() <= 5, (i, differ.sum())
    finally:
        replay.close()


def test_an_animation_into_a_folder_is_refused_before_drawing(tmp_path, monkeypatch):
    import navstack.animate as animate

    run_dir = synthetic_run(tmp_path / "run", n=5)
    (tmp_path / "out.gif").mkdir()
    monkeypatch.setattr(animate, "write_animation", lambda *a, **k: (_ for _ in ()).throw(AssertionError("drew")))
    with pytest.raises(ValueError, match="out.gif is a folder"):
        animate.animate_stats(run_dir, tmp_path / "out.gif")
