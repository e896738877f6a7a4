"""Closed-loop trials with the PyBullet servo in the loop, and the `navstack run` outputs.

The paper's demo takes about 2 s of wall time per controller here, so the
whole manoeuvre is tested, not a shortened one.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from navstack.cli import main
from navstack.jpl import jpl_serpentine
from navstack.trial import TrialConfig, run_trial
from navstack.truss import paper_truss_world
from navstack.world import load_world, world_from_dict

WORLDS = Path(__file__).resolve().parents[1] / "worlds"
RESULT_KEYS = {
    "world",
    "seed",
    "controller",
    "planner",
    "success",
    "reason",
    "goals_reached",
    "sim_time",
    "steps",
    "wall_time",
    "metrics",
}
METRIC_KEYS = {"tip_error_max", "slither_deviation_max", "min_clearance", "contacts"}


def test_paper_truss_file_is_the_generator_output():
    assert load_world(WORLDS / "paper_truss.json") == world_from_dict(paper_truss_world())


@pytest.fixture(scope="module")
def demo_runs(tmp_path_factory):
    world = load_world(WORLDS / "paper_truss.json")
    out = {}
    for controller in ("slither", "tip-only"):
        d = tmp_path_factory.mktemp(controller)
        out[controller] = (run_trial(world, controller=controller, planner="scripted", out_dir=d), d)
    return out


def test_slither_demo_meets_the_paper_requirements(demo_runs):
    r, _ = demo_runs["slither"]
    m = r.metrics
    print(f"slither/scripted: {r.reason}, goals {r.goals_reached}, sim {r.sim_time:.2f} s, metrics {m}")
    assert r.success and r.reason == "reached" and r.goals_reached == 4
    assert m["contacts"] == 0 and m["min_clearance"] > 0.0
    assert m["slither_deviation_max"] <= 0.001
    assert m["tip_error_max"] <= 0.005


def test_the_demo_runs_at_cruise_speed(demo_runs):
    """The accuracy above is met at the scripted planner's cruise speed, not by creeping: the commanded tip
    cruises at ``scripted_speed`` and the measured tip (forward kinematics of the measured joints) keeps up."""
    r, d = demo_runs["slither"]
    npz = np.load(d / "trajectory.npz")
    dt = TrialConfig().servo.control_dt
    commanded = np.linalg.norm(np.diff(npz["tip_des"], axis=0), axis=1) / dt
    chain = jpl_serpentine()
    measured = np.linalg.norm(np.diff([chain.frames(q)[21, :3, 3] for q in npz["q"]], axis=0), axis=1) / dt
    cruise = TrialConfig().scripted_speed
    print(f"cruise {cruise} m/s: commanded median {np.median(commanded):.4f} max {commanded.max():.4f}, "
          f"measured median {np.median(measured):.4f} m/s")
    assert commanded.max() <= cruise * (1 + 1e-6)
    assert np.median(commanded) == pytest.approx(cruise, rel=1e-6)  # most of the way at cruise speed
    assert np.median(measured) == pytest.approx(cruise, rel=0.05)
    world = load_world(WORLDS / "paper_truss.json")
    goals = np.array([g.position for g in world.goals])
    straight = np.linalg.norm(np.diff(np.vstack([npz["tip_des"][0], goals]), axis=0), axis=1).sum()
    # the whole way through every goal (it ends within the last goal's tolerance), not a part of it
    assert np.sum(commanded) * dt >= straight - world.goals[-1].tolerance


def test_tip_only_baseline_cuts_through_members(demo_runs):
    r, _ = demo_runs["tip-only"]
    print(f"tip-only/scripted: {r.reason}, metrics {r.metrics}")
    assert not r.success and r.reason == "collision"
    assert r.metrics["contacts"] > 0 and r.metrics["min_clearance"] < 0.0
    assert r.metrics["slither_deviation_max"] > 0.05


def test_outputs_follow_the_spec(demo_runs):
    r, d = demo_runs["slither"]
    data = json.loads((d / "result.json").read_text())
    assert set(data) == RESULT_KEYS and set(data["metrics"]) == METRIC_KEYS
    assert data == r.to_dict()
    assert isinstance(data["success"], bool) and isinstance(data["steps"], int)
    npz = np.load(d / "trajectory.npz")
    T = data["steps"] + 1  # the initial state plus one sample per control step
    assert set(npz.files) == {"t", "q", "q_des", "tip_des"}
    assert npz["t"].shape == (T,) and npz["q"].shape == (T, 20)
    assert npz["q_des"].shape == (T, 20) and npz["tip_des"].shape == (T, 3)
    assert np.all(np.diff(npz["t"]) > 0) and npz["t"][-1] == pytest.approx(data["sim_time"])
    # measured joints track the commanded ones closely
    assert np.abs(npz["q"] - npz["q_des"]).max() < 0.01


def test_same_seed_same_result(demo_runs, tmp_path):
    r, d = demo_runs["slither"]
    again = run_trial(load_world(WORLDS / "paper_truss.json"), planner="scripted", out_dir=tmp_path)
    a, b = r.to_dict(), again.to_dict()
    a.pop("wall_time"), b.pop("wall_time")
    assert a == b
    np.testing.assert_array_equal(np.load(d / "trajectory.npz")["q"], np.load(tmp_path / "trajectory.npz")["q"])


def test_timeout_is_reported(tmp_path):
    data = paper_truss_world()
    data["time_limit"] = 3.0
    r = run_trial(world_from_dict(data), planner="scripted")
    assert r.reason == "timeout" and not r.success and r.sim_time == pytest.approx(3.0, abs=0.02)


def test_a_trial_checks_its_start_and_runs_in_one_client(monkeypatch):
    """One PyBullet client per trial: the start check is made in the client the trial then simulates in."""
    import navstack.sim._bullet

    made = []
    real = navstack.sim._bullet.direct_client
    monkeypatch.setattr(navstack.sim._bullet, "direct_client", lambda: made.append(1) or real())
    data = paper_truss_world()
    data["time_limit"] = 0.5
    r = run_trial(world_from_dict(data), planner="scripted")
    assert r.reason == "timeout" and len(made) == 1


def test_cli_run_writes_outputs_and_exit_codes(tmp_path, capsys):
    world = WORLDS / "paper_truss.json"
    assert main(["run", str(world), "--out", str(tmp_path / "a"), "--planner", "scripted"]) == 0
    assert (tmp_path / "a" / "result.json").exists() and (tmp_path / "a" / "trajectory.npz").exists()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**json.loads(world.read_text()), "goal": []}))
    assert main(["run", str(bad), "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "bad.json" in err and "goal" in err
    assert main(["run", str(tmp_path / "missing.json"), "--out", str(tmp_path / "c")]) == 2


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"controller": "snake"}, "controller"),
        ({"planner": "magic"}, "planner"),
        ({"seed": -1}, "seed"),
        ({"config": {}}, "config must be a TrialConfig"),  # was silently the defaults
        ({"config": {"scripted_speed": 5}}, "config must be a TrialConfig"),  # was an AttributeError
        ({"render": "no"}, "render must be true or false"),  # 'no' rendered
        ({"out_dir": ""}, "out_dir must be a folder path"),  # meant the current folder
        ({"out_dir": 3}, "out_dir must be a folder path"),  # was a TypeError
    ],
)
def test_bad_trial_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        run_trial(world_from_dict(paper_truss_world()), **kwargs)


def test_goal_out_of_reach_is_bad_input(tmp_path, capsys):
    data = paper_truss_world()
    data["goals"][2]["position"] = [9.0, 0.1, 1.2]
    with pytest.raises(ValueError, match=r"goals\[2\]\.position: .* beyond the robot's reach"):
        run_trial(world_from_dict(data), planner="scripted")
    path = tmp_path / "far.json"
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "far.json" in capsys.readouterr().err
    assert main(["check-world", str(path)]) == 2
    assert "beyond the robot's reach" in capsys.readouterr().err


def test_joint_limit_is_reported():
    """A goal within the reach bound but past the lathe bed's travel along its axis: the lathe pins at its
    limit while the tip lags its command, and the trial ends with reason joint_limit."""
    data = paper_truss_world()
    data["obstacles"] = []
    tip = np.array(data["goals"][0]["position"])
    data["goals"] = [{"position": (tip + [2.3, 0.0, 0.0]).tolist(), "tolerance": 0.02}]
    data["time_limit"] = 120.0
    r = run_trial(world_from_dict(data), planner="scripted")
    print(f"far goal: {r.reason} after {r.sim_time:.1f} s, goals {r.goals_reached}")
    assert r.reason == "joint_limit" and not r.success and r.sim_time < 110.0


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(p.stem for p in WORLDS.glob("*.json")))
def test_field_planner_reaches_every_goal_of_every_example_world(name):
    """Closed loop with the sensor-based planner (no script) on every world shipped in ``worlds/``, the ones the
    README points a new user to: each reached without a contact (``bend_clutter.json`` once timed out after a
    planner change that the generated families' sweeps did not show)."""
    world = load_world(WORLDS / f"{name}.json")
    r = run_trial(world, planner="field")
    m = r.metrics
    print(f"{name} slither/field: {r.reason}, goals {r.goals_reached}/{len(world.goals)}, sim {r.sim_time:.1f} s, "
          f"min clearance {m['min_clearance'] * 1e3:.1f} mm, "
          f"slither deviation {m['slither_deviation_max'] * 1e3:.2f} mm")
    assert r.success and r.reason == "reached" and r.goals_reached == len(world.goals)
    assert r.retracted is not False  # a retract world backs out too
    assert m["contacts"] == 0 and m["min_clearance"] > 0.0
    assert m["slither_deviation_max"] <= 0.001 and m["tip_error_max"] <= 0.005


def test_no_success_after_the_time_limit(demo_runs):
    """The edge is taken from the demo run itself: with the time limit at the moment it reached its last goal
    the trial succeeds; half a control period less, it must end in timeout, not after the limit."""
    done, _ = demo_runs["slither"]
    dt = TrialConfig().servo.control_dt
    assert done.reason == "reached" and done.steps > 10
    assert done.sim_time == pytest.approx(done.steps * dt, abs=1e-9)
    data = paper_truss_world()
    data["time_limit"] = done.steps * dt
    at = run_trial(world_from_dict(data), planner="scripted")
    assert at.reason == "reached" and at.success and at.steps == done.steps
    data["time_limit"] = done.sim_time - 0.5 * dt
    short = run_trial(world_from_dict(data), planner="scripted")
    assert short.reason == "timeout" and not short.success
    assert short.steps == done.steps - 1 and short.sim_time <= data["time_limit"]
    assert short.goals_reached == done.goals_reached - 1


def test_check_world_reports_every_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "navstack-world/1"}')
    good = WORLDS / "u_trap.json"
    assert main(["check-world", str(bad), str(good), str(tmp_path / "missing.json")]) == 2
    captured = capsys.readouterr()
    assert "u_trap.json: ok" in captured.out
    assert "bad.json" in captured.err and "missing.json" in captured.err


def test_run_into_a_file_is_bad_input(tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("")
    assert main(["run", str(WORLDS / "u_trap.json"), "--out", str(target), "--planner", "scripted"]) == 2
    assert "taken" in capsys.readouterr().err


def test_an_opening_far_range_beyond_the_sensors_reach_is_refused():
    """``OpeningConfig.far_range`` above the sensor's range would silently turn seen openings off (no ray goes that
    far): refused naming both fields; equal to the range, or with openings off, accepted."""
    from navstack.planner.field import FieldPlannerConfig
    from navstack.planner.opening import OpeningConfig
    from navstack.sensing import SensorConfig

    def config(far: float, enabled: bool = True, max_range: float = 0.4) -> TrialConfig:
        return TrialConfig(sensor=SensorConfig(max_range=max_range),
                           field_planner=FieldPlannerConfig(opening=OpeningConfig(enabled=enabled, far_range=far)))

    with pytest.raises(ValueError, match=r"field_planner\.opening\.far_range \(0\.5 m\) exceeds "
                                         r"TrialConfig\.sensor\.max_range \(0\.4 m\)"):
        config(0.5)
    assert config(0.4).field_planner.opening.far_range == 0.4
    assert not config(0.5, enabled=False).field_planner.opening.enabled
    assert config(0.5, max_range=0.6).sensor.max_range == 0.6
