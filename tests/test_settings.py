"""Trial settings from a file (``navstack settings``, ``run --settings``, ``trials --settings``).

The file names only what it changes; every key must be a setting and every value of its type, and the
dataclasses' own checks still apply.  A run with settings writes them (``settings.json``) and behaves by them;
a sweep with settings stores them, marks every results line with their digest and refuses to be resumed with
others.  Distances in metres, times in seconds.
"""

from __future__ import annotations

import dataclasses
import json

import pytest
from _worlds import world_data

from navstack.cli import main
from navstack.settings import SettingsError, load_settings, settings_digest, settings_from_dict, settings_to_dict
from navstack.trial import TrialConfig


def _leaves(d: dict, path: str = ""):
    for k, v in d.items():
        at = f"{path}.{k}" if path else k
        if isinstance(v, dict):
            yield from _leaves(v, at)
        else:
            yield at, v


def _nested(path: str, value) -> dict:
    out: dict = value
    for key in reversed(path.split(".")):
        out = {key: out}
    return out


def test_every_setting_round_trips_through_its_json_form():
    defaults = settings_to_dict(TrialConfig())
    assert settings_from_dict(defaults) == TrialConfig()
    leaves = dict(_leaves(defaults))
    assert len(leaves) > 150  # every setting of every nested dataclass is reachable
    for path, value in leaves.items():  # each alone, set to its own default: nothing changes
        assert settings_from_dict(_nested(path, value)) == TrialConfig(), path


def test_overrides_change_only_what_they_name():
    cfg = settings_from_dict({"sensor": {"max_range": 0.5}, "field_planner": {"repulsion": {"margin": 0.02},
                                                                             "tight_margin": None},
                              "scripted_speed": 1})
    assert cfg.sensor.max_range == 0.5 and cfg.field_planner.repulsion.margin == 0.02
    assert cfg.field_planner.tight_margin is None
    assert cfg.scripted_speed == 1.0 and isinstance(cfg.scripted_speed, float)
    changed = {p for p, v in _leaves(settings_to_dict(cfg)) if v != dict(_leaves(settings_to_dict(TrialConfig())))[p]}
    assert changed == {"sensor.max_range", "field_planner.repulsion.margin", "field_planner.tight_margin",
                       "scripted_speed"}
    assert settings_digest(cfg) != settings_digest(TrialConfig())
    assert settings_digest(cfg) == settings_digest(dataclasses.replace(cfg))


@pytest.mark.parametrize(("data", "needle"), [
    ({"sensor": {"max_rnge": 0.5}}, "sensor.max_rnge: unknown setting; expected one of"),
    ({"sensr": {}}, "sensr: unknown setting"),
    ({"sensor": 0.5}, "sensor: expected an object of settings, got the number 0.5"),
    ({"sensor": {"max_range": "far"}}, "sensor.max_range: expected a finite number, got the string 'far'"),
    ({"sensor": {"max_range": True}}, "sensor.max_range: expected a finite number, got true"),
    ({"sensor": {"max_range": None}}, "sensor.max_range: null is not allowed here"),
    ({"sensor": {"max_range": -1}}, "sensor: SensorConfig.max_range must be"),
    ({"sensor": {"cone_rings": 2.5}}, "sensor.cone_rings: expected an integer, got the number 2.5"),
    ({"sensor": {"include_axis": 1}}, "sensor.include_axis: expected true or false, got the number 1"),
    ({"slither_mode": "fast"}, "slither_mode must be 'projected' or 'full'"),
    ({"slither_mode": 5}, "slither_mode: expected a string, got the number 5"),
    ({"scripted_speed": {"x": 1}}, "scripted_speed: expected a finite number, got an object"),
    ({"field_planner": {"map": {"shadow_depths": [0.01, "x"]}}}, "field_planner.map.shadow_depths: expected a list"),
    ([1, 2], "expected a JSON object of settings, got an array"),
    ({"sensor": {"body_radius": 0.01}}, "sensor.body_radius: not a setting: every trial takes it from its world"),
    ({"field_planner": {"repulsion": {"body_radius": 0.05}}}, "field_planner.repulsion.body_radius: not a setting"),
    ({"field_planner": {"search": {"max_expansions": 10**24}}}, "max_expansions: 1000000000000000000000000 is out"),
    ({"servo": {"solver_iterations": 2**31}}, "servo.solver_iterations: 2147483648 is out of range"),
])
def test_bad_settings_name_the_setting(data, needle):
    with pytest.raises(SettingsError, match=None) as info:
        settings_from_dict(data, "s.json")
    assert str(info.value).startswith("s.json: ") and needle in str(info.value), str(info.value)


def test_bad_files_are_refused_with_their_name(tmp_path):
    for text, needle in (("{", "invalid JSON"), ('{"scripted_speed": NaN}', "NaN is not a number"),
                         (b"\xff\xfe", "cannot read")):
        f = tmp_path / "s.json"
        f.write_bytes(text if isinstance(text, bytes) else text.encode())
        with pytest.raises(SettingsError, match=needle):
            load_settings(f)
    with pytest.raises(SettingsError, match="cannot read"):
        load_settings(tmp_path / "missing.json")
    with pytest.raises(SettingsError, match="not a folder"):
        load_settings(tmp_path)
    f = tmp_path / "s.json"
    f.write_text('{"sensor": {"max_range": 0.5, "max_range": 0.6}}')
    with pytest.raises(SettingsError, match="the key 'max_range' is given twice"):
        load_settings(f)


def test_a_settings_file_of_more_than_a_mebibyte_is_refused_before_parsing(tmp_path):
    from navstack.settings import MAX_SETTINGS_BYTES

    assert MAX_SETTINGS_BYTES == 1 << 20
    body = '{"scripted_speed": 0.1}'
    f = tmp_path / "s.json"
    f.write_text(body + " " * (MAX_SETTINGS_BYTES - len(body)))  # exactly the limit: read
    assert load_settings(f).scripted_speed == 0.1
    f.write_text(body + " " * (MAX_SETTINGS_BYTES + 1 - len(body)))  # one byte more: refused
    with pytest.raises(SettingsError, match="larger than 1048576 bytes"):
        load_settings(f)


def test_settings_command_prints_what_run_reads_back(tmp_path, capsys):
    assert main(["settings"]) == 0
    assert json.loads(capsys.readouterr().out) == settings_to_dict(TrialConfig())
    f = tmp_path / "s.json"
    f.write_text('{"servo": {"position_gain": 0.5}}')
    assert main(["settings", str(f)]) == 0
    printed = tmp_path / "printed.json"
    printed.write_text(capsys.readouterr().out)
    assert load_settings(printed) == load_settings(f) and load_settings(f).servo.position_gain == 0.5
    f.write_text('{"servo": {"position_gian": 0.5}}')
    assert main(["settings", str(f)]) == 2
    assert "servo.position_gian: unknown setting" in capsys.readouterr().err


def test_run_uses_and_records_its_settings(tmp_path, capsys):
    world = tmp_path / "w.json"
    world.write_text(json.dumps(world_data(time_limit=20.0)))
    slow, fast = tmp_path / "slow", tmp_path / "fast"
    assert main(["run", str(world), "--planner", "scripted", "--out", str(slow)]) == 0
    assert not (slow / "settings.json").exists()  # the defaults: nothing to record
    s = tmp_path / "s.json"
    s.write_text('{"scripted_speed": 0.12}')
    assert main(["run", str(world), "--planner", "scripted", "--out", str(fast), "--settings", str(s)]) == 0
    a, b = (json.loads((d / "result.json").read_text()) for d in (slow, fast))
    assert a["success"] and b["success"]
    assert b["sim_time"] < 0.7 * a["sim_time"], (a["sim_time"], b["sim_time"])  # twice the cruise speed
    assert load_settings(fast / "settings.json") == load_settings(s)
    # a rerun into the same folder with the defaults leaves no stale settings.json behind
    assert main(["run", str(world), "--planner", "scripted", "--out", str(fast)]) == 0
    assert not (fast / "settings.json").exists()
    s.write_text('{"scripted_sped": 0.12}')
    capsys.readouterr()
    assert main(["run", str(world), "--planner", "scripted", "--out", str(tmp_path / "x"), "--settings", str(s)]) == 2
    err = capsys.readouterr().err
    assert "s.json: scripted_sped: unknown setting" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_a_sweep_runs_with_its_settings_and_is_not_resumed_with_others(tmp_path, capsys):
    worlds = tmp_path / "worlds"
    worlds.mkdir()
    (worlds / "w.json").write_text(json.dumps(world_data(time_limit=20.0)))
    s = tmp_path / "s.json"
    s.write_text('{"scripted_speed": 0.12}')
    base = ["trials", "--worlds", str(worlds), "--planner", "scripted", "--jobs", "1", "--no-progress"]
    assert main([*base, "--out", str(tmp_path / "plain")]) == 0
    assert main([*base, "--out", str(tmp_path / "fast"), "--settings", str(s)]) == 0
    plain = json.loads((tmp_path / "plain" / "results.jsonl").read_text())
    fast = json.loads((tmp_path / "fast" / "results.jsonl").read_text())
    assert "settings" not in plain and fast["settings"] == settings_digest(load_settings(s))
    assert fast["success"] and fast["sim_time"] < 0.7 * plain["sim_time"]
    stored = json.loads((tmp_path / "fast" / "sweep.json").read_text())
    assert settings_from_dict(stored["config"]["trial_settings"]) == load_settings(s)
    # the same folder with other settings (or none) is another sweep: refused, naming the field
    capsys.readouterr()
    assert main([*base, "--out", str(tmp_path / "fast")]) == 2
    assert "settings" in capsys.readouterr().err
    # settings that leave every value at its default are no settings: the plain sweep resumes with them
    s.write_text('{"scripted_speed": 0.06}')
    assert main([*base, "--out", str(tmp_path / "plain"), "--settings", str(s)]) == 0
    assert len((tmp_path / "plain" / "results.jsonl").read_text().splitlines()) == 1
    s.write_text('{"scripted_speed": "x"}')
    assert main([*base, "--out", str(tmp_path / "bad"), "--settings", str(s)]) == 2
    assert "--settings: " in capsys.readouterr().err and not (tmp_path / "bad").exists()
    # the reports say which settings ran
    assert main(["report", str(tmp_path / "plain")]) == 0 and main(["report", str(tmp_path / "fast")]) == 0
    plain_md = (tmp_path / "plain" / "report.md").read_text()
    fast_md = (tmp_path / "fast" / "report.md").read_text()
    assert "Trial settings: the defaults (" in plain_md
    assert f"Trial settings: `{fast['settings'][:12]}` (the SHA-256" in fast_md

