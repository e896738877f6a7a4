"""Tests of navstack.report: Wilson intervals, numbers in report.md against a recomputation, bad input."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest

from navstack import report
from navstack.report import ReportError, summarize, wilson_interval, write_report

Z = 1.959963984540054


# ---------------------------------------------------------------------------------------------- Wilson


@pytest.mark.parametrize(("k", "n", "lo", "hi"), [
    # published Wilson 95 % intervals (e.g. Newcombe 1998, Table I; Brown, Cai & DasGupta 2001)
    (0, 10, 0.0, 0.2775),
    (10, 10, 0.7225, 1.0),
    (5, 10, 0.2366, 0.7634),
    (1, 20, 0.0089, 0.2361),
    (81, 263, 0.2553, 0.3662),
])
def test_wilson_known_values(k, n, lo, hi):
    got = wilson_interval(k, n)
    assert got == pytest.approx((lo, hi), abs=1e-4)


def test_wilson_endpoints_are_the_score_test_roots():
    """Independent check: the bounds solve (phat - p)^2 = z^2 p (1 - p) / n (numpy.roots), for many k/n."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(1, 300))
        k = int(rng.integers(0, n + 1))
        ph = k / n
        # (1 + z^2/n) p^2 - (2 ph + z^2/n) p + ph^2 = 0
        roots = np.sort(np.roots([1 + Z * Z / n, -(2 * ph + Z * Z / n), ph * ph]).real)
        lo, hi = wilson_interval(k, n)
        assert (lo, hi) == pytest.approx(tuple(roots), abs=1e-9)
        assert 0.0 <= lo <= ph <= hi <= 1.0


@pytest.mark.parametrize(("k", "n"), [(0, 0), (3, 2), (-1, 5), (1.5, 4), (True, 3)])
def test_wilson_bad_counts(k, n):
    with pytest.raises(ValueError, match="wilson_interval"):
        wilson_interval(k, n)


# ---------------------------------------------------------------------------------------------- synthetic data

METHODS = [("slither", "field"), ("tip-only", "field")]
FAILS = ["collision", "timeout", "stalled", "joint_limit", "error"]


def synthetic_records(seed: int = 1) -> list[dict]:
    rng = np.random.default_rng(seed)
    recs = []
    i = 0
    for fam, p_fam in (("truss", 0.8), ("pipe-rack", 0.5), (None, 0.6)):
        for diff in ((0.2, 0.8) if fam else (None,)):
            for ctrl, planner in METHODS:
                p = p_fam * (1.0 if ctrl == "slither" else 0.5) * (1.2 - (diff or 0.5))
                for _ in range(int(rng.integers(3, 15))):
                    ok = bool(rng.random() < p)
                    reason = "reached" if ok else FAILS[int(rng.integers(len(FAILS)))]
                    err = reason == "error"
                    rec = {
                        "trial_id": f"t{i:04d}", "world": f"w{i}", "seed": i, "controller": ctrl,
                        "planner": planner, "success": ok, "reason": reason, "goals_reached": None if err else 1,
                        "sim_time": None if err else float(rng.uniform(5, 40)), "steps": None, "wall_time": 1.0,
                        "metrics": {"tip_error_max": None, "contacts": None,
                                    "slither_deviation_max": None if err else float(rng.uniform(0, 0.05)),
                                    "min_clearance": None if err else  # a success never penetrates
                                    abs(float(rng.uniform(-0.01, 0.1))) if ok else float(rng.uniform(-0.01, 0.1))},
                        "family": fam, "difficulty": diff,
                    }
                    if fam is None and rng.random() < 0.5:
                        del rec["family"], rec["difficulty"]  # hand-made lines may lack the sweep fields
                    recs.append(rec)
                    i += 1
    return recs


def write_jsonl(path: Path, recs: list[dict]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in recs))
    return path


def md_table(text: str, heading: str) -> list[list[str]]:
    """Rows (cells stripped) of the first Markdown table after ``heading``."""
    lines = text.splitlines()
    start = lines.index(heading)
    rows = []
    for line in lines[start + 1:]:
        if line.startswith("#"):
            break
        if line.startswith("|"):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    assert rows, f"no table under {heading!r}"
    return rows[2:]  # drop header and separator


def hand_wilson(k: int, n: int) -> tuple[float, float]:
    roots = np.sort(np.roots([1 + Z * Z / n, -(2 * k / n + Z * Z / n), (k / n) ** 2]).real)
    return max(0.0, roots[0]), min(1.0, roots[1])


# ---------------------------------------------------------------------------------------------- report


def test_report_numbers_match_a_recomputation(tmp_path):
    recs = synthetic_records()
    write_jsonl(tmp_path / "results.jsonl", recs)
    path = write_report(tmp_path)
    assert path == tmp_path / "report.md"
    text = path.read_text()

    def fam(r):
        return r.get("family") or "(none)"

    # per family x difficulty x method
    rows = md_table(text, "## Success rate per family, difficulty and controller")
    cells = {}
    for r in recs:
        key = (fam(r), "-" if r.get("difficulty") is None else f"{r['difficulty']:g}", r["controller"], r["planner"])
        cells.setdefault(key, []).append(r["success"])
    assert len(rows) == len(cells)
    for f, d, c, p, n, k, rate, lo, hi in rows:
        got = cells[(f, d, c, p)]
        assert (int(n), int(k)) == (len(got), sum(got))
        assert float(rate) == pytest.approx(sum(got) / len(got), abs=5e-4)
        assert (float(lo), float(hi)) == pytest.approx(hand_wilson(sum(got), len(got)), abs=5e-4)

    # per method
    rows = md_table(text, "## Success rate per controller")
    assert [(r[0], r[1]) for r in rows] == sorted(METHODS)
    for c, p, n, k, rate, lo, hi in rows:
        got = [r["success"] for r in recs if (r["controller"], r["planner"]) == (c, p)]
        assert (int(n), int(k)) == (len(got), sum(got))
        assert float(rate) == pytest.approx(sum(got) / len(got), abs=5e-4)
        assert (float(lo), float(hi)) == pytest.approx(hand_wilson(sum(got), len(got)), abs=5e-4)

    # per family, controllers side by side: "rate (k/n) [lo, hi]"
    rows = md_table(text, "## Success rate per family (controllers side by side)")
    assert [r[0] for r in rows] == ["pipe-rack", "truss", "(none)"]
    for row in rows:
        for (c, p), cell in zip(sorted(METHODS), row[1:], strict=True):
            got = [r["success"] for r in recs if fam(r) == row[0] and (r["controller"], r["planner"]) == (c, p)]
            rate, frac, ci = cell.split(" ", 2)
            assert frac == f"({sum(got)}/{len(got)})"
            lo, hi = (float(x) for x in ci.strip("[]").split(","))
            assert (lo, hi) == pytest.approx(hand_wilson(sum(got), len(got)), abs=5e-4)

    # failure causes
    rows = md_table(text, "## Failure causes")
    for row in rows:
        for (c, p), cell in zip(sorted(METHODS), row[1:], strict=True):
            fails = [r for r in recs if (r["controller"], r["planner"]) == (c, p) and not r["success"]]
            want = len(fails) if row[0] == "all failures" else sum(r["reason"] == row[0] for r in fails)
            assert int(cell) == want
    assert {r[0] for r in rows} == {r["reason"] for r in recs if not r["success"]} | {"all failures"}

    # distributions: n and median
    for heading, values in (
        ("### Minimum clearance (m), all trials",
         lambda r: r["metrics"]["min_clearance"]),
        ("### Slithering deviation (m), all trials", lambda r: r["metrics"]["slither_deviation_max"]),
        ("### Time to goal (s, simulated), successful trials",
         lambda r: r["sim_time"] if r["success"] else None),
    ):
        for c, p, n, mn, p10, med, p90, mx, mean in md_table(text, heading):
            v = [values(r) for r in recs if (r["controller"], r["planner"]) == (c, p)]
            v = [x for x in v if x is not None]
            assert int(n) == len(v)
            for s, want in ((mn, min(v)), (p10, float(np.percentile(v, 10))), (med, float(np.median(v))),
                            (p90, float(np.percentile(v, 90))), (mx, max(v)), (mean, float(np.mean(v)))):
                assert float(s) == pytest.approx(want, rel=1e-3, abs=1e-6)

    n_err = sum(r["reason"] == "error" for r in recs)
    assert f"{n_err} here" in text
    for png in ("success_rate", "success_vs_difficulty", "failure_causes", "min_clearance",
                "slither_deviation", "time_to_goal"):
        f = tmp_path / "plots" / f"{png}.png"
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 5000
        assert f"(plots/{png}.png)" in text


def test_summarize_is_pure_and_skips_missing_values():
    recs = synthetic_records(seed=5)
    a, b = summarize(recs), summarize(list(reversed(recs)))
    assert a == b
    m = ("slither", "field")
    times = a.values["time_to_goal"][m]
    assert len(times) == sum(1 for r in recs if r["success"] and r["controller"] == "slither")
    assert a.errors == sum(r["reason"] == "error" for r in recs)
    st = a.stats("min_clearance", m)
    assert st.n == sum(1 for r in recs if r["controller"] == "slither" and r["metrics"]["min_clearance"] is not None)


def test_the_unsuccessful_trials_are_listed_by_name_up_to_a_limit(tmp_path, monkeypatch):
    recs = synthetic_records()
    failed = sorted(r["trial_id"] for r in recs if not r["success"])
    assert len(failed) > 3
    write_jsonl(tmp_path / "results.jsonl", recs)
    rows = md_table(write_report(tmp_path, plots=False).read_text(), "### Unsuccessful trials")
    assert [r[0] for r in rows] == failed
    by_id = {r["trial_id"]: r for r in recs}
    for trial, world, method, reason, goals, _ in rows:
        rec = by_id[trial]
        assert (world, method, reason) == (rec["world"], f"{rec['controller']}/{rec['planner']}", rec["reason"])
        assert goals == ("-" if rec.get("goals_reached") is None else str(rec["goals_reached"]))
    monkeypatch.setattr(report, "MAX_FAILED_LISTED", 3)
    text = write_report(tmp_path, plots=False).read_text()
    assert [r[0] for r in md_table(text, "### Unsuccessful trials")] == failed[:3]
    assert f"the first 3 of {len(failed)}" in text


def test_truncated_last_line_is_ignored_with_a_note(tmp_path):
    recs = synthetic_records()[:6]
    write_jsonl(tmp_path / "results.jsonl", recs)
    with open(tmp_path / "results.jsonl", "a") as fh:
        fh.write('{"trial_id": "t9999", "contr')
    text = write_report(tmp_path, plots=False).read_text()
    assert "cut short" in text
    rows = md_table(text, "## Success rate per controller")
    assert sum(int(r[2]) for r in rows) == 6


@pytest.mark.parametrize(("content", "needle"), [
    ("", "empty"),
    ("\n\n", "empty"),
    ('{"a": 1}\n', "line 1: field 'controller'"),
    ("GOOD\nGOOD\n{not json}\nGOOD\n", "line 3: malformed"),
    ('GOOD\n{"controller": "slither", "planner": "field", "success": "yes", "reason": "reached"}\n',
     "line 2: field 'success'"),
    ('GOOD\n{"controller": "slither", "planner": "field", "success": false, "reason": "crashed"}\n',
     "line 2: field 'reason' is 'crashed'"),
    ('GOOD\n{"controller": "slither", "planner": "field", "success": true, "reason": "timeout"}\n',
     "line 2: field 'reason' is 'timeout' but 'success' is true"),
    ('GOOD\n{"controller": "slither", "planner": "field", "success": true, "reason": "collision"}\n',
     "line 2: field 'reason' is 'collision' but 'success' is true"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "difficulty": "hard"}\n',
     "line 2: field 'difficulty' must be a number in [-1e9, 1e9] or null, got 'hard'"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "sim_time": NaN}\n',
     "line 2: malformed result line (NaN is not valid JSON)"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "sim_time": 1e400}\n',
     "line 2: field 'sim_time' must be a number in [0, 1e9] or null, got inf"),
    # numbers too large for a float (OverflowError) or for the statistics and plots
    (f'GOOD\n{{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "sim_time": 1{"0" * 400}}}\n',
     "line 2: field 'sim_time' must be a number in [0, 1e9] or null, got 1000000000000000000000000000000000000000... "
     "(401 characters)"),
    (f'GOOD\n{{"controller": "s", "planner": "f", "success": false, "reason": "timeout", '
     f'"difficulty": -1{"0" * 400}}}\n',
     "line 2: field 'difficulty' must be a number in [-1e9, 1e9] or null"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "difficulty": 1e308}\n',
     "line 2: field 'difficulty' must be a number in [-1e9, 1e9] or null, got 1e+308"),
    (f'GOOD\n{{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "metrics": '
     f'{{"min_clearance": 1{"0" * 400}}}}}\n', "line 2: field 'metrics.min_clearance' must be a number in [-1e9, 1e9]"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "sim_time": -1}\n',
     "line 2: field 'sim_time' must be a number in [0, 1e9] or null, got -1"),
    # deeply nested: a RecursionError in the parser
    ("GOOD\n" + "[" * 100000 + "\nGOOD\n", "line 2: malformed result line (nested too deeply)"),
    # a line cut inside a string, not the last: its own end is not read as part of the string (a review's case)
    ('GOOD\n{"controller": "sli\nGOOD\n', "line 2: malformed result line (Unterminated string starting at"),
    # types (they once went into sets and dict keys: TypeError)
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", '
     '"provenance": {"navstack": [1], "commit": null}}\n',
     "line 2: field 'provenance.navstack' must be a string or null, got [1]"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "world_id": [1]}\n',
     "line 2: field 'world_id' must be a string or null, got [1]"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "world_seed": "7"}\n',
     "line 2: field 'world_seed' must be an integer >= 0 or null, got '7'"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "metrics": '
     '{"contacts": "x"}}\n', "line 2: field 'metrics.contacts' must be an integer >= 0 or null, got 'x'"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "metrics": '
     '{"contacts": 1.5}}\n', "line 2: field 'metrics.contacts' must be an integer >= 0 or null, got 1.5"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "goals_reached": "y"}\n',
     "line 2: field 'goals_reached' must be an integer >= 0 or null, got 'y'"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "steps": true}\n',
     "line 2: field 'steps' must be an integer >= 0 or null, got True"),
    # a success that contradicts itself is refused, never counted
    ('GOOD\n{"controller": "s", "planner": "f", "success": true, "reason": "reached", "metrics": {"contacts": 5}}\n',
     "line 2: 'success' is true but 'metrics.contacts' is 5 (a success has no contact)"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": true, "reason": "reached", "metrics": {"contacts": 1}}\n',
     "line 2: 'success' is true but 'metrics.contacts' is 1 (a success has no contact)"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": true, "reason": "reached", "metrics": '
     '{"min_clearance": -0.001}}\n', "line 2: 'success' is true but 'metrics.min_clearance' is -0.001"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": true, "reason": "reached", "goals_reached": 0}\n',
     "line 2: 'success' is true but 'goals_reached' is 0"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": true, "reason": "reached", "retracted": false}\n',
     "line 2: 'success' is true but 'retracted' is false"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "reached"}\n',
     "line 2: field 'reason' is 'reached' but 'success' is false"),
    ('GOOD\n{"controller": "s", "planner": "f", "success": false, "reason": "timeout", "metrics": '
     '{"min_clearance": "far"}}\n', "line 2: field 'metrics.min_clearance'"),
    ('GOOD\n{"trial_id": "t0000", "controller": "s", "planner": "f", "success": false, "reason": "timeout"}\n',
     "line 2: trial_id 't0000' already on line 1"),
])
def test_bad_results_name_file_and_line(tmp_path, content, needle):
    good = json.dumps(synthetic_records()[0])
    (tmp_path / "results.jsonl").write_text(content.replace("GOOD", good, 1).replace("GOOD", json.dumps(
        {**synthetic_records()[1], "trial_id": "t0001b"})).replace("GOOD", json.dumps(
            {**synthetic_records()[2], "trial_id": "t0002b"})))
    with pytest.raises(ReportError) as info:
        write_report(tmp_path)
    msg = str(info.value)
    assert str(tmp_path / "results.jsonl") in msg
    assert needle in msg
    assert not (tmp_path / "report.md").exists()


def test_missing_results_and_cli_exit_status(tmp_path, capsys):
    with pytest.raises(ReportError, match="no such results file"):
        write_report(tmp_path)
    parser = argparse.ArgumentParser()
    report.add_arguments(parser)
    assert report.run_from_args(parser.parse_args([str(tmp_path)])) == 2
    assert "results.jsonl" in capsys.readouterr().err
    write_jsonl(tmp_path / "results.jsonl", synthetic_records()[:4])
    assert report.run_from_args(parser.parse_args([str(tmp_path), "--no-plots"])) == 0
    assert (tmp_path / "report.md").exists() and not (tmp_path / "plots").exists()


def test_a_results_path_that_is_a_directory_is_named_as_such(tmp_path, capsys):
    (tmp_path / "results.jsonl").mkdir()
    with pytest.raises(ReportError, match="not a results file .a directory"):
        write_report(tmp_path)
    parser = argparse.ArgumentParser()
    report.add_arguments(parser)
    assert report.run_from_args(parser.parse_args([str(tmp_path)])) == 2
    assert "not a results file" in capsys.readouterr().err
    assert not (tmp_path / "report.md").exists()


def test_reasons_match_the_trial_module():
    from navstack import trial

    assert set(report.REASONS) == set(trial.REASONS)
    assert math.isclose(report.Z95, 1.959963984540054)


# ---------------------------------------------------------------------------------------------- provenance


def _prov(**kw) -> dict:
    base = {"navstack": "0.1.0", "commit": "a" * 40, "python": "3.11.7", "pybullet": "3.2.7", "numpy": "2.1.0",
            "host": "h1", "backend": "local"}
    return {**base, **kw}


def test_provenance_listed_and_mixed_versions_warned(tmp_path, capsys):
    recs = synthetic_records()[:9]
    for i, r in enumerate(recs):
        r["provenance"] = _prov(host=f"h{i % 2}", backend="ray" if i % 3 == 0 else "local")
    write_jsonl(tmp_path / "results.jsonl", recs)
    text = write_report(tmp_path, plots=False).read_text()
    assert "mixes software versions" not in text  # other hosts and backends are the same software
    rows = md_table(text, "## Provenance")
    assert rows == [["0.1.0", f"`{'a' * 40}`", "3.11.7", "3.2.7", "2.1.0", "local, ray", "h0, h1", "9"]]

    recs[4]["provenance"] = _prov(numpy="2.2.0")
    del recs[7]["provenance"]  # a line written before provenance existed
    write_jsonl(tmp_path / "results.jsonl", recs)
    parser = argparse.ArgumentParser()
    report.add_arguments(parser)
    assert report.run_from_args(parser.parse_args([str(tmp_path), "--no-plots"])) == 0
    assert "mixes software versions" in capsys.readouterr().err
    text = (tmp_path / "report.md").read_text()
    assert "**Warning: this sweep mixes software versions** (3 different" in text
    rows = md_table(text, "## Provenance")
    assert [(r[4], r[-1]) for r in rows] == [("2.1.0", "7"), ("2.2.0", "1"), ("-", "1")]
    assert rows[-1][0] == "(not recorded)"


def test_retraction_column_counts_only_records_that_carry_the_key(tmp_path):
    recs = synthetic_records()
    flags = {}
    for i, r in enumerate(recs):
        if r.get("family") == "truss":  # the truss worlds ask for retraction
            r["retracted"] = bool(r["success"] or i % 2 == 0)  # a success has retracted
            flags[r["trial_id"]] = r["retracted"]
    write_jsonl(tmp_path / "results.jsonl", recs)
    text = write_report(tmp_path, plots=False).read_text()
    rows = md_table(text, "## Success rate per controller")
    for c, p, *_rate, ret in rows:
        mine = [r for r in recs if (r["controller"], r["planner"]) == (c, p) and "retracted" in r]
        assert ret == f"{sum(r['retracted'] for r in mine)}/{len(mine)}"
    rows = md_table(text, "## Success rate per family, difficulty and controller")
    for f, d, c, p, *_rate, ret in rows:
        mine = [r for r in recs if r.get("family") == f and f"{r['difficulty']:g}" == d
                and (r["controller"], r["planner"]) == (c, p) and "retracted" in r]
        assert ret == (f"{sum(r['retracted'] for r in mine)}/{len(mine)}" if mine else "-")
    assert {r[0] for r in rows if r[-1] != "-"} == {"truss"}
    assert "its time to goal is that of the whole trial, backing out included" in text
    recs[0]["retracted"] = "yes"
    write_jsonl(tmp_path / "results.jsonl", recs)
    with pytest.raises(ReportError, match="line 1: field 'retracted' must be true or false"):
        write_report(tmp_path, plots=False)


def test_the_plots_draw_the_numbers_of_the_tables(tmp_path, monkeypatch):
    """The success-rate bars and the per-family curves carry each rate and its Wilson interval, every method
    of every family once (a mutation sample of report.py found plots the tables did not check)."""
    from matplotlib.axes import Axes

    bars, curves, stacked = [], [], []
    real_bar, real_errorbar = Axes.bar, Axes.errorbar

    def bar(self, x, height, *args, **kw):
        if "yerr" in kw:  # the success-rate chart
            bars.append((np.asarray(x).tolist(), np.asarray(height).tolist(), np.asarray(kw["yerr"]).tolist()))
        else:  # the failure causes, stacked: one bar per reason
            stacked.append((kw["label"], np.asarray(height).tolist(), np.asarray(kw["bottom"]).tolist()))
        return real_bar(self, x, height, *args, **kw)

    def errorbar(self, x, y, *args, **kw):
        if kw.get("label") != "_nolegend_":  # not the bars' own error bars
            curves.append((self, kw["label"], np.asarray(x).tolist(), np.asarray(y).tolist(),
                           np.asarray(kw["yerr"]).tolist()))
        return real_errorbar(self, x, y, *args, **kw)

    monkeypatch.setattr(Axes, "bar", bar)
    monkeypatch.setattr(Axes, "errorbar", errorbar)
    recs = synthetic_records()
    s = summarize(recs)
    report.write_plots(s, tmp_path / "a" / "plots")  # folders made as needed
    groups = [*s.families, "all"]
    assert len(bars) == len(s.methods)
    for (xs, heights, err), m in zip(bars, s.methods, strict=True):
        rates = [s.by_family.get((f, m)) for f in s.families] + [s.by_method[m]]
        assert len(xs) == len(groups) and np.all(np.diff(xs) > 0)
        for k, r in enumerate(rates):
            if r is not None:
                assert heights[k] == r.rate and [err[0][k], err[1][k]] == pytest.approx(
                    [r.rate - r.ci_low, r.ci_high - r.rate])
    assert sorted(x for xs, _, _ in bars for x in xs) == sorted(  # the methods side by side in each group
        g + (j - (len(s.methods) - 1) / 2) * 0.8 / len(s.methods) for g in range(len(groups))
        for j in range(len(s.methods)))
    labels = {report.method_label(m): m for m in s.methods}
    seen = set()
    for ax, label, xs, ys, err in curves:
        fam, m = ax.get_title(), labels[label]  # the title is set once the curves are drawn
        seen.add((fam, m))
        cells = [(d, s.by_cell[(fam, d, m)]) for d in s.difficulties if (fam, d, m) in s.by_cell]
        assert xs == pytest.approx([d for d, _ in cells], abs=0.01) and ys == [r.rate for _, r in cells]
        want = [[r.rate - r.ci_low for _, r in cells], [r.ci_high - r.rate for _, r in cells]]
        np.testing.assert_allclose(err, want, rtol=1e-12)
    assert seen == {(f, m) for (f, d, m) in s.by_cell if d is not None}
    bottom = np.zeros(len(s.methods))
    for reason, heights, below in stacked:
        want = [sum(r["reason"] == reason for r in recs if (r["controller"], r["planner"]) == m) for m in s.methods]
        assert heights == want and below == bottom.tolist()
        bottom += heights
    assert [r for r, _, _ in stacked] == [r for r in report.REASONS if r != "reached" and any(
        x["reason"] == r for x in recs)]
    assert report.Stats.of([]).n == 0


def test_numbers_at_the_bound_make_every_plot_without_a_warning(tmp_path):
    """Difficulties of +-1e308 once left no report.md ('arange: cannot compute length', overflow warnings):
    such numbers are refused (test_bad_results_name_file_and_line); up to +-1e9 every plot is drawn."""
    import warnings

    recs = []
    for i, d in enumerate([1e9, -1e9, 1e9, -1e9, 0.5]):
        ok = i % 2 == 0
        recs.append({"trial_id": f"t{i}", "controller": "slither", "planner": "field", "success": ok,
                     "reason": "reached" if ok else "timeout", "family": "truss", "difficulty": d, "sim_time": 1e9,
                     "metrics": {"min_clearance": abs(d) if ok else d, "slither_deviation_max": 1e9}})
    write_jsonl(tmp_path / "results.jsonl", recs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        text = write_report(tmp_path).read_text()
    assert "(plots/success_vs_difficulty.png)" in text and "(plots/min_clearance.png)" in text


def test_a_family_spelled_like_a_label_is_not_merged_with_records_without_one():
    """A world may call its family "(none)": its trials were counted with the trials that have no family."""
    recs = [r for r in synthetic_records() if r.get("family") is None]
    named = [dict(r, trial_id=f"n{r['trial_id']}", family="(none)", success=True, reason="reached",
                  goals_reached=1, metrics={**r["metrics"], "min_clearance": 0.02}) for r in recs]
    s = summarize(recs + named)
    assert s.families == ('"(none)"', "(none)")
    method = recs[0]["controller"], recs[0]["planner"]
    n_none = sum(1 for r in recs if (r["controller"], r["planner"]) == method)
    assert s.by_family[("(none)", method)].n == n_none and s.by_family[('"(none)"', method)].successes == n_none


def test_a_family_named_with_a_pipe_or_a_line_break_stays_in_its_cell(tmp_path):
    """A world file's ``family`` may be any non-empty string; ``|`` and line breaks in it split or ended the
    report's table rows (a review: ``"pipes|racks"`` gave a row of three cells under a header of two)."""
    base = synthetic_records()[0]
    recs = [dict(base, trial_id=f"t{i}", family=fam) for i, fam in enumerate(("pipes|racks", "two\nlines", "plain"))]
    write_jsonl(tmp_path / "results.jsonl", recs)
    text = write_report(tmp_path, plots=False).read_text()
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("|---"):  # every row of every table has the header's number of cells
            n = line.count("|")
            for row in lines[i + 1:]:
                if not row.startswith("|"):
                    break
                assert row.replace("\\|", "").count("|") == n, row
    assert "\n| pipes\\|racks | " in text and "\n| two lines | " in text


def test_a_line_of_another_sweep_configuration_is_refused_beside_its_sweep_json(tmp_path):
    """A results line whose trial_id is the sweep's but whose seed or method is another's (a line of the same
    worlds run with another --seed, an edited line) was reported as a trial of the sweep (a review)."""
    from navstack import compare
    from navstack.sweep import SWEEP_FORMAT, SweepConfig, build_specs

    worlds = tmp_path / "worlds"
    worlds.mkdir()
    for i in range(2):
        (worlds / f"w{i}.json").write_text(json.dumps({"name": f"w{i}", "family": "truss"}))
    specs = build_specs(SweepConfig(worlds_dir=str(worlds), seed=0))
    other = build_specs(SweepConfig(worlds_dir=str(worlds), seed=1))

    def line(spec, **change):
        rec = {"trial_id": spec.trial_id, "world": spec.world_id, "seed": spec.seed, "controller": spec.controller,
               "planner": spec.planner, "success": True, "reason": "reached", "family": spec.family,
               "difficulty": spec.difficulty, "index": spec.index, "world_id": spec.world_id,
               "world_file": spec.world_file, "world_seed": spec.world_seed}
        return rec | change

    def sweep_dir(name, recs):
        d = tmp_path / name
        d.mkdir()
        (d / "sweep.json").write_text(json.dumps({"format": SWEEP_FORMAT, "trials": [s.to_dict() for s in specs]}))
        write_jsonl(d / "results.jsonl", recs)
        return d

    good = sweep_dir("good", [line(s) for s in specs])
    assert "unfinished" not in write_report(good, plots=False).read_text()
    part = sweep_dir("part", [line(specs[0])])  # an interrupted sweep: the report says so (an audit, session 29)
    assert f"**Note: the sweep is unfinished**: 1 of the {len(specs)} trials its `sweep.json` lists" in \
        write_report(part, plots=False).read_text()
    assert f"**Note: B is unfinished**: 1 of the {len(specs)} trials its `sweep.json` lists" in \
        compare.run_compare(good, part, plots=False)  # compare says it too (an audit, session 32)
    for name, recs, needle in (
            ("seed", [line(specs[0]), line(other[1])], r"line 2: not a line of the sweep in .*'seed' is"),
            ("edited", [line(specs[0], controller="tip-only")], r"line 1: .*'controller' is 'tip-only'"),
            ("foreign", [line(specs[0]), line(specs[1], trial_id="x__000__slither__field")],
             r"line 2: .*trial_id 'x__000__slither__field' is not a trial of")):
        bad = sweep_dir(name, recs)
        with pytest.raises(ReportError, match=needle):
            write_report(bad, plots=False)
        with pytest.raises(ReportError, match=needle):
            compare.run_compare(good, bad)
    # without a sweep.json (hand-made results) the lines are reported as they are
    loose = tmp_path / "loose"
    loose.mkdir()
    write_jsonl(loose / "results.jsonl", [line(specs[0]), line(other[1])])
    write_report(loose, plots=False)


def test_a_results_file_of_one_cut_off_line_is_not_called_empty(tmp_path):
    """An audit's case: a killed sweep's only line, cut short, was reported as "(it is empty)"."""
    (tmp_path / "results.jsonl").write_text(json.dumps(synthetic_records()[0])[:40])
    with pytest.raises(ReportError, match=r"only line was cut short \(a killed sweep"):
        write_report(tmp_path)
    (tmp_path / "results.jsonl").write_text("")
    with pytest.raises(ReportError, match=r"\(it is empty\)"):
        write_report(tmp_path)


def test_the_failures_table_gives_sim_time_to_a_tenth_of_a_second(tmp_path):
    recs = [dict(r, success=False, reason="timeout", sim_time=22.266666667) for r in synthetic_records()[:2]]
    write_jsonl(tmp_path / "results.jsonl", recs)
    text = write_report(tmp_path, plots=False).read_text()
    assert "| 22.3 |" in text and "22.266666667" not in text


def test_the_intro_counts_difficulty_levels_and_not_a_missing_difficulty(tmp_path):
    """An audit (session 32): a sweep of world files without a difficulty said '1 difficulty level(s)'."""
    recs = synthetic_records()  # difficulties 0.2 and 0.8, and lines without one
    write_jsonl(tmp_path / "results.jsonl", recs)
    intro = write_report(tmp_path, plots=False).read_text().splitlines()[2]
    assert "2 difficulty level(s) (and trials whose world gives none)" in intro
    write_jsonl(tmp_path / "results.jsonl", [r for r in recs if r.get("difficulty") is None])
    intro = write_report(tmp_path, plots=False).read_text().splitlines()[2]
    assert "0 difficulty level(s) (and trials whose world gives none)" in intro
    write_jsonl(tmp_path / "results.jsonl", [r for r in recs if r.get("difficulty") is not None])
    intro = write_report(tmp_path, plots=False).read_text().splitlines()[2]
    assert "2 difficulty level(s). A success" in intro
    text = write_report(tmp_path, plots=False).read_text()
    assert "an `error` trial reports none, so it is in no table below" in text  # the distributions' n
    assert "backing out included" not in text  # no line of a retraction world


def test_a_results_file_of_very_many_families_is_plotted_in_bounded_figures(tmp_path, monkeypatch):
    """An audit (session 33): 1,500 families asked for figures 1,000-6,000 inches wide and the report ran 22
    minutes into 4.9 GB before it was stopped.  The plots draw the first PLOT_FAMILIES families and say so (the
    tables keep every one); no figure is larger than MAX_FIGURE_INCHES."""
    from matplotlib.figure import Figure

    sizes, titles = [], []
    real_savefig = Figure.savefig

    def savefig(self, path, *args, **kw):
        sizes.append(tuple(self.get_size_inches()))
        titles.extend(t for ax in self.axes for t in [ax.get_title()] if t)
        if self._suptitle is not None:
            titles.append(self._suptitle.get_text())
        return real_savefig(self, path, *args, **kw)

    monkeypatch.setattr(Figure, "savefig", savefig)
    recs = [{"trial_id": f"t{i}", "controller": "slither", "planner": f"p{i % 2}", "success": i % 3 == 0,
             "reason": "reached" if i % 3 == 0 else "timeout", "sim_time": 10.0, "family": f"fam{i // 3:04d}",
             "difficulty": float(i % 3), "metrics": {"min_clearance": 0.01, "slither_deviation_max": 0.001}}
            for i in range(3 * 300)]
    write_jsonl(tmp_path / "results.jsonl", recs)
    text = write_report(tmp_path).read_text()
    assert len(md_table(text, "## Success rate per family (controllers side by side)")) == 300
    assert sizes and max(max(w, h) for w, h in sizes) <= report.MAX_FIGURE_INCHES
    left_out = f"the first {report.PLOT_FAMILIES} of 300 families (the tables list every one)"
    assert titles.count(left_out) == 2  # the success-rate bars and the curves per difficulty
    assert (tmp_path / "plots" / "success_vs_difficulty.png").exists()


def test_names_with_dollar_signs_are_drawn_literally_not_as_mathtext(tmp_path):
    """An audit (session 33): a world family 'price $\\le$ $\\euro 5$' (a legal name) stopped `report` and
    `compare --out` with matplotlib's mathtext parse error and no report.md; '$\\Delta p$' was silently typeset."""
    from navstack import compare

    bad, typeset = r"price $\le$ $\euro 5$", r"$\Delta p$"
    recs = [{"trial_id": f"t{i}", "controller": "slither", "planner": "f$i$eld" if i % 2 else "field",
             "success": i % 3 == 0, "reason": "reached" if i % 3 == 0 else "timeout", "sim_time": 5.0,
             "family": (bad, typeset)[i % 2], "difficulty": float(i % 2), "seed": i, "world": f"w{i}",
             "metrics": {"min_clearance": 0.01}} for i in range(8)]
    write_jsonl(tmp_path / "results.jsonl", recs)
    assert bad in write_report(tmp_path).read_text()
    assert (tmp_path / "plots" / "success_rate.png").stat().st_size > 0
    assert report.plain(bad) == r"price \$\le\$ \$\euro 5\$"
    text = compare.run_compare(tmp_path, tmp_path, out=tmp_path / "cmp")
    assert bad in text and (tmp_path / "cmp" / "compare.png").stat().st_size > 0
