"""``retract`` worlds (interfaces.md section 2a): the key in world files, and the closed loop backing out
along its own path in PyBullet."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from navstack import jpl_serpentine
from navstack.jpl import BACKBONE_FRAMES
from navstack.path import PathMemory
from navstack.trial import RETRACT_TOLERANCE, run_trial
from navstack.truss import paper_truss_world
from navstack.world import WorldError, load_world, world_from_dict

WORLDS = Path(__file__).resolve().parents[1] / "worlds"
CHAIN = jpl_serpentine()


# ---------------------------------------------------------------- the world key
def test_retract_key_parses_round_trips_and_defaults_to_false(tmp_path):
    assert world_from_dict(paper_truss_world()).retract is False
    w = world_from_dict(paper_truss_world(retract=True))
    assert w.retract is True and w.to_dict()["retract"] is True
    assert world_from_dict(w.to_dict()) == w
    assert "retract" not in world_from_dict(paper_truss_world()).to_dict()
    data = paper_truss_world()
    data["retract"] = False
    assert world_from_dict(data).retract is False
    for bad in (1, "yes", None):
        data["retract"] = bad
        with pytest.raises(WorldError, match="retract: expected true or false"):
            world_from_dict(data)


def test_the_retract_world_file_is_the_generator_output():
    expected = world_from_dict(paper_truss_world(name="paper-truss-retract", retract=True, time_limit=90.0))
    assert load_world(WORLDS / "paper_truss_retract.json") == expected


# ---------------------------------------------------------------- closed loop
def _backbone_world(world, q: np.ndarray) -> np.ndarray:
    T0 = world.robot.base.transform()
    return CHAIN.frames(q)[BACKBONE_FRAMES, :3, 3] @ T0[:3, :3].T + T0[:3, 3]


def _deviation_both_ways(world, out_dir: Path) -> tuple[float, float]:
    """Largest distance [m] of the measured joint points J1..J6 from the path recorded on the way in,
    before and after the retraction starts (recomputed from trajectory.npz, independently of the trial)."""
    tr = np.load(out_dir / "trajectory.npz")
    tip_des, q = tr["tip_des"], tr["q"]
    path = PathMemory(_backbone_world(world, q[0]))
    # the retraction starts, once the last goal is reached, with one period holding the last command
    tips = np.array([_backbone_world(world, qk)[0] for qk in q])
    last = world.goals[-1]
    k_goal = int(np.flatnonzero(np.linalg.norm(tips - last.position, axis=1) <= last.tolerance)[0])
    repeated = np.flatnonzero(np.all(tip_des[1:] == tip_des[:-1], axis=1)) + 1
    k_turn = int(repeated[repeated >= k_goal][0])
    for x in tip_des[1:k_turn + 1]:
        path.record(x)

    def worst(qs: np.ndarray) -> float:
        return max(path.distance_to_path(p) for qk in qs for p in _backbone_world(world, qk)[1:])

    return worst(q[: k_turn + 1]), worst(q[k_turn + 1 :])


@pytest.mark.slow
def test_paper_truss_in_up_out_and_back_out_of_the_entry(tmp_path):
    world = load_world(WORLDS / "paper_truss_retract.json")
    r = run_trial(world, controller="slither", planner="field", out_dir=tmp_path)
    m = r.metrics
    dev_in, dev_out = _deviation_both_ways(world, tmp_path)
    print(f"retract slither/field: {r.reason}, retracted {r.retracted}, sim {r.sim_time:.1f} s, metrics {m}, "
          f"deviation in {dev_in * 1e3:.3f} mm, out {dev_out * 1e3:.3f} mm")
    assert r.success and r.reason == "reached" and r.retracted is True and r.goals_reached == 4
    assert m["contacts"] == 0 and m["min_clearance"] > 0.0
    # the issue asks below 1 mm both ways; measured 0.042 mm in and 0.078 mm out (servo with gravity feed-forward,
    # backing out at 0.1 m/s): bound at 0.25 mm, so losing the feed-forward (0.83 mm) fails here too
    assert m["slither_deviation_max"] < 2.5e-4 and dev_in < 2.5e-4 and dev_out < 2.5e-4
    data = json.loads((tmp_path / "result.json").read_text())
    assert data["retracted"] is True
    q_end = np.load(tmp_path / "trajectory.npz")["q"][-1]
    tip0 = _backbone_world(world, world.robot.q0)[0]
    assert np.linalg.norm(_backbone_world(world, q_end)[0] - tip0) <= RETRACT_TOLERANCE


@pytest.mark.slow
def test_the_tip_only_baseline_backs_out_too_but_its_body_cuts_the_truss():
    r = run_trial(load_world(WORLDS / "paper_truss_retract.json"), controller="tip-only", planner="scripted")
    print(f"retract tip-only/scripted: {r.reason}, retracted {r.retracted}, metrics {r.metrics}")
    assert r.retracted is False and r.reason == "collision" and not r.success  # off its path too (below)
    assert r.metrics["contacts"] > 0


FREE = [(2.1, 0.1079, 1.1668), (2.35, 0.35, 1.35), (2.3, 0.6, 1.6)]
"""Goals [m] of a way in through free space that turns (a review's world, session 40)."""


@pytest.mark.slow
@pytest.mark.parametrize("controller", ["slither", "tip-only"])
def test_a_retraction_whose_body_leaves_the_path_is_not_one(tmp_path, controller):
    """Spec 2a: backing out, "every serpentine joint point stays on" the recorded path.  ``tip-only``'s body does
    not follow its path: in free space it backed out 0.34 m off it, and the trial was a success with
    ``retracted: true`` (only the tip was checked).  Now it runs on to its time limit, ``retracted: false``; the
    slithering body retraces the path (deviations recomputed from trajectory.npz)."""
    from navstack.generate.base import robot_dict

    data = {"format": "navstack-world/1", "name": "free-retract", "robot": robot_dict(), "obstacles": [],
            "goals": [{"position": list(g), "tolerance": 0.02} for g in FREE], "time_limit": 40.0, "retract": True}
    world = world_from_dict(data)
    r = run_trial(world, controller=controller, planner="scripted", out_dir=tmp_path)
    _, dev_out = _deviation_both_ways(world, tmp_path)
    tip_end = _backbone_world(world, np.load(tmp_path / "trajectory.npz")["q"][-1])[0]
    back = np.linalg.norm(tip_end - _backbone_world(world, world.robot.q0)[0])
    print(f"retract {controller}/scripted in free space: {r.reason}, retracted {r.retracted}, sim {r.sim_time} s, "
          f"deviation out {dev_out * 1e3:.2f} mm, tip {back * 1e3:.1f} mm from its start")
    assert r.goals_reached == 3 and r.metrics["contacts"] == 0 and back <= RETRACT_TOLERANCE  # the tip got back
    if controller == "slither":
        assert r.success and r.retracted is True and dev_out < 1e-3
    else:
        assert dev_out > 0.2 and not r.success and r.reason == "timeout" and r.retracted is False
        assert r.sim_time == pytest.approx(40.0)


@pytest.mark.slow
def test_running_out_of_time_while_retracting_is_a_timeout(tmp_path):
    data = paper_truss_world(retract=True, time_limit=26.0)  # the way in takes about 22 s
    r = run_trial(world_from_dict(data), planner="scripted", out_dir=tmp_path)
    assert r.goals_reached == 4 and r.reason == "timeout" and not r.success and r.retracted is False
    assert json.loads((tmp_path / "result.json").read_text())["retracted"] is False


LOOP = [(2.2, 1.1668), (2.45, 1.4168), (2.2, 1.6668), (1.95, 1.4168), (1.82, 1.1968), (1.9, 1.0168)]
"""Goals (x, z) [m] at y = 0.1079 of a way in that loops back past the tip's start (an audit, session 29)."""


@pytest.mark.slow
@pytest.mark.parametrize(("time_limit", "retracted"), [(40.0, False), (90.0, True)])
def test_a_way_in_that_passes_near_the_start_is_backed_out_of_whole(tmp_path, time_limit, retracted):
    """The tip backing out along a looped way in passes within 0.02 m of its start after 0.14 m of 1.96 m: that
    once ended the retraction (``retracted: true``, a success) with every joint point still 0.3-1.8 m in.  The
    whole path must be backed out of: 40 s is too short for that (a timeout; the way in takes about 32 s, the
    way out 18 s), 90 s is enough, and then every joint point is back where it started (recomputed from the
    measured joints)."""
    from navstack.generate.base import robot_dict

    data = {"format": "navstack-world/1", "name": "loop-retract", "robot": robot_dict(), "obstacles": [],
            "goals": [{"position": [x, 0.1079, z], "tolerance": 0.02} for x, z in LOOP],
            "time_limit": time_limit, "retract": True}
    world = world_from_dict(data)
    r = run_trial(world, planner="scripted", out_dir=tmp_path)
    assert r.goals_reached == len(LOOP) and r.retracted is retracted
    # the scripted loop takes the tip link into the arm (test_self_contact.py): a collision with itself either
    # way (since session 37; it read as a success before), with no obstacle touched
    assert r.reason == "collision" and not r.success and r.self_contacts > 0 and r.metrics["contacts"] == 0
    q = np.load(tmp_path / "trajectory.npz")["q"]
    deepest = max(np.linalg.norm(_backbone_world(world, qk) - _backbone_world(world, q[0]), axis=1).max()
                  for qk in q)
    moved = np.linalg.norm(_backbone_world(world, q[-1]) - _backbone_world(world, q[0]), axis=1)
    assert deepest > 1.0  # the way in went deep
    if retracted:
        assert moved.max() < 0.03  # every joint point (and the tip) back where it started
    else:
        assert moved.max() > 0.3  # still in when time ran out


def test_worlds_without_retract_write_no_retracted_field(tmp_path):
    data = paper_truss_world(time_limit=2.0)
    r = run_trial(world_from_dict(data), planner="scripted", out_dir=tmp_path)
    assert r.retracted is None and "retracted" not in json.loads((tmp_path / "result.json").read_text())
