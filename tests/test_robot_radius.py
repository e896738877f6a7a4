"""The world's ``robot.serpentine_radius`` is the tip's radius for the planners and the sensor
(:meth:`navstack.trial.TrialConfig.for_robot`): a thicker or thinner robot than the default 0.025 m is planned
and sensed as what it is, with the configured clearances beyond its surface.  And a robot whose radii (or q0)
make it touch itself at the start is bad input (:func:`navstack.trial.check_start`)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from _worlds import world_data

from navstack.cli import main
from navstack.planner.field import FieldPlanner
from navstack.planner.reactive import PotentialFieldPlanner
from navstack.sim.rays import RaySensor
from navstack.trial import TrialConfig, check_start, run_trial
from navstack.world import WorldError, world_from_dict


@pytest.mark.parametrize("r", [0.01, 0.04, 0.5])  # the world format's least and largest radii, and one between
def test_every_tip_radius_follows_the_robot_and_what_lies_beyond_the_surface_stays(r):
    base = TrialConfig(scripted_speed=0.05)
    fit = base.for_robot(r)
    rep0, rep = base.field_planner.repulsion, fit.field_planner.repulsion
    assert rep.body_radius == fit.sensor.body_radius == fit.reactive_planner.body_radius == r
    assert rep.r_block - r == pytest.approx(rep0.r_block - rep0.body_radius, abs=1e-15)  # the margin
    assert rep.influence - r == pytest.approx(rep0.influence - rep0.body_radius, abs=1e-15)
    assert rep.unseen_radius - r == pytest.approx(rep0.unseen_radius - rep0.body_radius, abs=1e-15)
    assert fit.sensor.max_range - r == pytest.approx(base.sensor.max_range - base.sensor.body_radius, abs=1e-15)
    # nothing else changes
    assert dataclasses.replace(fit, sensor=base.sensor, field_planner=base.field_planner,
                               reactive_planner=base.reactive_planner) == base
    assert dataclasses.replace(rep, body_radius=rep0.body_radius, influence=rep0.influence,
                               unseen_radius=rep0.unseen_radius) == rep0
    assert dataclasses.replace(fit.sensor, body_radius=base.sensor.body_radius,
                               max_range=base.sensor.max_range) == base.sensor
    assert fit.for_robot(r) is fit


@pytest.mark.parametrize(("r", "split"), [(0.0249, 2), (0.013, 2), (0.0125, 2), (0.012, 3), (0.01, 3),
                                          (0.025, 1), (0.04, 1), (0.5, 1)])
def test_a_thinner_tip_gets_a_finer_seen_free_grid(r, split):
    # the seen-free cells (the navigation function's grid) at most 0.8 of the tip's radius, as 0.02 m is of the
    # default 0.025 m, and a whole fraction of the configured cell (worlds/hard12/thin_slot: 4/13 -> 12/13)
    base = TrialConfig()
    fit = base.for_robot(r)
    m0, m = base.field_planner.map, fit.field_planner.map
    assert m.free_cell == m0.free_cell / split
    assert m.free_cell <= 0.8 * r + 1e-12 or split == 1
    assert m.free_cell_fallback == (None if split == 1 else m0.free_cell)
    assert dataclasses.replace(m, free_cell=m0.free_cell, free_cell_fallback=None) == m0  # nothing else changes


@pytest.mark.parametrize(("extent", "margin", "cell"), [((0.2, 0.1, 0.1), 0.3, 0.02 / 3), ((0.2, 0.1, 0.1), 0.7, 0.01),
                                                       ((0.5, 0.3, 0.3), 0.7, 0.01), ((2.0, 1.0, 1.0), 0.7, 0.02)])
def test_a_wide_world_keeps_coarser_cells_for_a_thin_robot(extent, margin, cell):
    # the box of start and goals, grown by the margin, in the finest whole fraction of 2 cm that needs at most
    # FINE_CELLS cells, down to the 2 cm grid itself (a review's case: a thin robot's goals 1.6 m apart ran into
    # the 40 M cell cap and the trial ended as an internal error)
    from navstack.planner.map import FINE_CELLS, MapConfig, MapTooLarge, SensedMap

    cfg = dataclasses.replace(TrialConfig().for_robot(0.011).field_planner.map, margin=margin)
    assert (cfg.free_cell, cfg.free_cell_fallback) == (0.02 / 3, 0.02)
    smap = SensedMap([0.0, 0.0, 0.0], extent, cfg)
    assert smap.config.free_cell == pytest.approx(cell, rel=1e-12)
    assert int(smap.free_dims.prod()) <= FINE_CELLS or cell == 0.02
    finer = cell / 2 if cell != 0.02 / 3 else None  # the next finer grid would not have fitted
    if finer is not None:
        side = 0.02 / (round(0.02 / cell) + 1)
        span = np.asarray(extent) + 2 * margin + 0.01
        assert np.prod(np.ceil(span / side) + 1) > FINE_CELLS
    plain = MapConfig(free_cell=0.02 / 3, margin=margin)  # no fallback: the cells as configured, or refused
    if cell == 0.02:
        with pytest.raises(MapTooLarge, match="more than 40,000,000"):
            SensedMap([0.0, 0.0, 0.0], extent, plain)
    else:
        assert SensedMap([0.0, 0.0, 0.0], extent, plain).config.free_cell == 0.02 / 3


def test_cells_too_small_for_the_world_are_bad_input_not_a_crash(tmp_path, capsys):
    (tmp_path / "w.json").write_text(json.dumps(world_data(time_limit=1.0)))
    (tmp_path / "s.json").write_text('{"field_planner": {"map": {"free_cell": 0.001}}}')
    assert main(["run", str(tmp_path / "w.json"), "--out", str(tmp_path / "o"), "--settings",
                 str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err
    assert "the field planner's map cannot cover this world" in err and "more than 40,000,000" in err


def test_the_default_robot_keeps_the_configuration_itself():
    cfg = TrialConfig()
    assert cfg.for_robot(0.025) is cfg


@pytest.mark.parametrize("planner, cls", [("field", FieldPlanner), ("reactive", PotentialFieldPlanner)])
@pytest.mark.parametrize("r", [0.015, 0.04])
def test_a_trial_plans_and_senses_with_the_worlds_serpentine_radius(monkeypatch, planner, cls, r):
    """The configurations the trial hands its planner and its sensor, for a world whose robot is thinner or
    thicker than the default."""
    seen = {}
    for name, klass in (("planner", cls), ("sensor", RaySensor)):
        init = klass.__init__

        def spy(self, *args, _init=init, _name=name, **kwargs):
            seen[_name] = args, kwargs
            _init(self, *args, **kwargs)

        monkeypatch.setattr(klass, "__init__", spy)
    data = world_data(time_limit=0.1)
    data["robot"] = dict(data["robot"], serpentine_radius=r)
    run_trial(world_from_dict(data), planner=planner, seed=0)
    args, kwargs = seen["planner"]
    config = next(a for a in (*args, *kwargs.values()) if hasattr(a, "body_radius") or hasattr(a, "repulsion"))
    assert (config.repulsion.body_radius if planner == "field" else config.body_radius) == r
    args, kwargs = seen["sensor"]
    sensor = next(a for a in (*args, *kwargs.values()) if hasattr(a, "max_range"))
    assert sensor.body_radius == r


def _robot(serpentine_radius: float = 0.025, arm_radius: float = 0.06, q0=None) -> dict:
    data = world_data(time_limit=0.1)
    data["robot"] = dict(data["robot"], serpentine_radius=serpentine_radius, arm_radius=arm_radius)
    if q0 is not None:
        data["robot"]["q0"] = q0
    return data


@pytest.mark.parametrize("r", [0.099, 0.1, 0.3])
def test_a_straight_serpentine_too_thick_for_itself_is_refused_by_its_radius(tmp_path, capsys, r):
    """The straight serpentine at q0: two links with one between them have collinear axes 0.2 m apart end to
    end, so their capsules' gap is 0.2 - 2 r (closed form): clear at 0.099 m, touching from 0.1 m.  Such a
    robot ends every trial in ``collision`` (it touches itself); check-world and run refuse it as bad input,
    naming the radius."""
    path = tmp_path / "thick.json"
    path.write_text(json.dumps(_robot(serpentine_radius=r)))
    status = main(["check-world", str(path)])
    err = capsys.readouterr().err
    if 0.2 - 2 * r > 0.0:
        assert status == 0 and "touches itself" not in err
        return
    assert status == 2
    assert f"{path}: robot.serpentine_radius: the robot touches itself at q0" in err and "Traceback" not in err
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "robot.serpentine_radius: the robot touches itself" in capsys.readouterr().err
    with pytest.raises(WorldError, match="touches itself"):
        run_trial(world_from_dict(_robot(serpentine_radius=r)))


def test_an_arm_too_thick_for_the_serpentine_or_a_coiled_start_is_refused_by_what_makes_it():
    """arm_radius 0.3 m: the arm's capsules reach the serpentine's at q0 (clear at the default 0.06 m); a q0
    with every serpentine joint at 60 deg coils the serpentine back into the arm at the default radii."""
    with pytest.raises(WorldError, match=r"robot\.arm_radius: the robot touches itself at q0"):
        check_start(world_from_dict(_robot(arm_radius=0.3)))
    q0 = list(world_from_dict(_robot()).robot.q0)
    q0[8:20:2] = [math.radians(60.0)] * 6
    with pytest.raises(WorldError, match=r"robot\.q0: the robot touches itself at q0"):
        check_start(world_from_dict(_robot(q0=q0)))
    check_start(world_from_dict(_robot(arm_radius=0.1)))  # clear: no error
