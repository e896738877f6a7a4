"""Tests of navstack.compare: intervals and tests against published or independently computed values, pairing,
method matching, the Markdown and the command line."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest

from navstack import compare
from navstack.compare import fisher_exact_p, mcnemar_exact, newcombe_paired, newcombe_unpaired

Z = 1.959963984540054


@pytest.mark.parametrize(("k_a", "n_a", "k_b", "n_b", "lo", "hi"), [
    # Newcombe (1998), Stat. Med. 17:873, Table II, method 10 (difference B - A = first - second there);
    # statsmodels 0.15 confint_proportions_2indep(method="newcomb") gives the same to 1e-12
    (48, 80, 56, 70, 0.0524, 0.3339),
    (3, 10, 9, 10, 0.1705, 0.8090),
    (2, 7, 6, 7, 0.0582, 0.8062),
    (0, 29, 5, 56, -0.0381, 0.1926),
    (0, 20, 0, 10, -0.1611, 0.2775),
    (0, 20, 10, 10, 0.6791, 1.0000),
])
def test_newcombe_unpaired_published_values(k_a, n_a, k_b, n_b, lo, hi):
    assert newcombe_unpaired(k_a, n_a, k_b, n_b) == pytest.approx((lo, hi), abs=1e-4)


def hand_wilson(k: int, n: int) -> tuple[float, float]:
    roots = np.sort(np.roots([1 + Z * Z / n, -(2 * k / n + Z * Z / n), (k / n) ** 2]).real)
    return max(0.0, roots[0]), min(1.0, roots[1])


def hand_paired(a: int, b: int, c: int, d: int) -> tuple[float, float]:
    """Newcombe (1998), Stat. Med. 17:2635, method 10, written out from the paper for p_A - p_B with
    p_A = (a + b) / n, p_B = (a + c) / n; returned as the interval of p_B - p_A."""
    n = a + b + c + d
    p1, p2 = (a + b) / n, (a + c) / n
    l1, u1 = hand_wilson(a + b, n)
    l2, u2 = hand_wilson(a + c, n)
    num = a * d - b * c
    if num > n / 2:
        num -= n / 2
    elif num >= 0:
        num = 0
    den = math.sqrt((a + b) * (c + d) * (a + c) * (b + d))
    phi = num / den if den else 0.0
    lo = (p1 - p2) - math.sqrt((p1 - l1) ** 2 - 2 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2) ** 2)
    hi = (p1 - p2) + math.sqrt((p2 - l2) ** 2 - 2 * phi * (p2 - l2) * (u1 - p1) + (u1 - p1) ** 2)
    return -hi, -lo


@pytest.mark.parametrize("table", [(14, 5, 0, 22), (36, 12, 2, 0), (10, 3, 8, 4), (0, 0, 0, 7), (5, 0, 0, 5),
                                   (1, 1, 7, 12), (20, 2, 9, 1)])
def test_newcombe_paired_matches_the_paper_formula(table):
    lo, hi = newcombe_paired(*table)
    assert (lo, hi) == pytest.approx(hand_paired(*table), abs=1e-9)
    a, b, c, d = table
    n = sum(table)
    assert lo <= (c - b) / n <= hi
    assert newcombe_paired(a, c, b, d) == pytest.approx((-hi, -lo), abs=1e-12)  # swapping A and B mirrors it


def test_newcombe_paired_without_correlation_is_the_unpaired_interval():
    # a d - b c = 0: phi = 0, the square-and-add of the two Wilson intervals at the same n
    assert newcombe_paired(2, 2, 2, 2) == pytest.approx(newcombe_unpaired(4, 8, 4, 8), abs=1e-12)
    assert newcombe_paired(6, 2, 3, 1) == pytest.approx(newcombe_unpaired(8, 12, 9, 12), abs=1e-12)


@pytest.mark.parametrize(("b", "c"), [(0, 5), (5, 0), (3, 3), (2, 9), (0, 0), (1, 12)])
def test_mcnemar_exact_is_the_binomial_tail(b, c):
    m = b + c
    if m == 0:
        want = 1.0
    else:
        tail = sum(math.comb(m, i) for i in range(min(b, c) + 1)) / 2 ** m
        want = min(1.0, 2 * tail)
    assert mcnemar_exact(b, c) == pytest.approx(want, rel=1e-12)


def test_fisher_exact_known_value():
    # R's fisher.test(matrix(c(3, 1, 1, 3), 2)) (the tea-tasting example): p = 0.4857
    assert fisher_exact_p(3, 4, 1, 4) == pytest.approx(0.4857, abs=1e-4)
    assert fisher_exact_p(4, 8, 4, 8) == pytest.approx(1.0)


# ---------------------------------------------------------------------------------------------- sweeps


def sweep_records(outcomes: dict[tuple[str, int], bool], controller="slither", planner="field") -> list[dict]:
    """Records of a sweep: ``outcomes[(family, index)] = success``."""
    recs = []
    for (fam, i), ok in outcomes.items():
        recs.append({"trial_id": f"{fam}__{i}__{controller}__{planner}", "world": f"{fam}-{i}", "seed": 100 + i,
                     "controller": controller, "planner": planner, "success": ok,
                     "reason": "reached" if ok else "collision", "family": fam, "difficulty": 0.5,
                     "world_id": f"{fam}__d0.5__{i:04d}", "world_seed": 1000 + i})
    return recs


def test_same_trials_are_paired_and_counted():
    a = {("truss", i): i % 2 == 0 for i in range(10)} | {("pipe-rack", i): True for i in range(6)}
    b = {("truss", i): i % 3 != 0 for i in range(10)} | {("pipe-rack", i): i != 4 for i in range(6)}
    rows = compare.compare(sweep_records(a), sweep_records(b))
    assert [(r.family, r.paired) for r in rows] == [("pipe-rack", True), ("truss", True), ("(all)", True)]
    truss = rows[1]
    a_only = sum(a[("truss", i)] and not b[("truss", i)] for i in range(10))
    b_only = sum(b[("truss", i)] and not a[("truss", i)] for i in range(10))
    assert (truss.a_only, truss.b_only) == (a_only, b_only) == (2, 3)
    assert (truss.k_a, truss.n_a, truss.k_b, truss.n_b) == (5, 10, 6, 10)
    assert truss.diff == pytest.approx(0.1)
    assert truss.p_value == pytest.approx(mcnemar_exact(2, 3))
    both = sum(a[("truss", i)] and b[("truss", i)] for i in range(10))
    assert (truss.ci_low, truss.ci_high) == pytest.approx(hand_paired(both, 2, 3, 10 - both - 5))
    pooled = rows[2]
    assert (pooled.n_a, pooled.k_a, pooled.k_b) == (16, 11, 11) and pooled.test == "McNemar exact"
    # the truss table (3, 2, 3, 2) mirrors another ((2, 2, 3, 3) gives the same interval): the pooled one does not
    both = sum(a[k] and b[k] for k in a)
    assert (both, pooled.a_only, pooled.b_only) == (8, 3, 3)
    assert (pooled.ci_low, pooled.ci_high) == pytest.approx(hand_paired(8, 3, 3, 2))
    assert (pooled.ci_low, pooled.ci_high) != pytest.approx(hand_paired(3, 3, 3, 7))


def test_different_trials_are_unpaired():
    a = sweep_records({("truss", i): i < 7 for i in range(10)})
    b = sweep_records({("truss", i): i < 3 for i in range(12)})  # two more worlds: not the same trials
    (row, pooled) = compare.compare(a, b)
    assert not row.paired and row.test == "Fisher exact"
    assert row.p_value == pytest.approx(fisher_exact_p(7, 10, 3, 12))
    assert (row.ci_low, row.ci_high) == pytest.approx(newcombe_unpaired(7, 10, 3, 12))
    for r in b:  # same worlds, other noise seeds: not paired either
        r["seed"] += 1
    assert not compare.compare(a, b[:10])[0].paired


def test_records_that_cannot_be_told_apart_are_not_paired():
    """Ten trials a sweep with neither world nor seed: every record has the same key, so no trial of A can be
    matched to one of B; pairing them by key would compare one record with itself (p = 1)."""
    from scipy.stats import fisher_exact

    def anonymous(successes):
        return [{"controller": "slither", "planner": "field", "success": i < successes,
                 "reason": "reached" if i < successes else "collision", "family": "truss"} for i in range(10)]

    rows = compare.compare(anonymous(2), anonymous(8))
    assert all(not r.paired for r in rows)
    assert rows[0].test == "Fisher exact"
    assert rows[0].p_value == pytest.approx(fisher_exact([[2, 8], [8, 2]]).pvalue, rel=1e-9)
    assert rows[0].p_value == pytest.approx(0.023, abs=5e-4)
    assert (rows[0].ci_low, rows[0].ci_high) == pytest.approx(newcombe_unpaired(2, 10, 8, 10))


def test_a_partial_overlap_is_unpaired_and_named_with_mcnemar_on_the_shared_trials():
    """20 trials in A, 19 of them in B (a review: Fisher's p over all of them read 0.0083 where McNemar's on the
    shared 19 reads 0.0156): the row stays unpaired, as the spec asks, and the Markdown names the overlap."""
    a = sweep_records({("truss", i): i < 14 for i in range(20)})
    b = sweep_records({("truss", i): i < 5 for i in range(19)})
    row = compare.compare(a, b)[0]
    assert not row.paired and row.shared == (19, 9, 0)
    assert row.p_value == pytest.approx(fisher_exact_p(14, 20, 5, 19))
    md = compare.render_markdown(compare.compare(a, b), "A", "B", a, b)
    assert "19 of the trials (A 20, B 19) were run by both" in md
    assert f"A only 9, B only 0, McNemar exact p = {compare._fmt_p(mcnemar_exact(9, 0))}" in md
    assert compare.compare(a, a)[0].shared == (0, 0, 0)  # paired: no note
    assert "were run by both" not in compare.render_markdown(compare.compare(a, a), "A", "B", a, a)
    other = sweep_records({("truss", i): i < 5 for i in range(20, 39)})  # no trial in common: no note
    assert compare.compare(a, other)[0].shared == (0, 0, 0)


def test_methods_matched_by_name_or_single_against_single():
    a = sweep_records({("truss", i): True for i in range(4)}, planner="field")
    b = sweep_records({("truss", i): i < 2 for i in range(4)}, planner="scripted")
    rows = compare.compare(a, b)
    assert [r.label for r in rows] == ["slither/field vs slither/scripted"] * 2
    assert rows[0].paired and (rows[0].a_only, rows[0].b_only) == (2, 0)
    two = a + sweep_records({("truss", i): False for i in range(4)}, controller="tip-only")
    assert compare.compare(two, b) == []  # nothing in common and no single-method pair
    rows = compare.compare(two, a)
    assert {r.method_a for r in rows} == {("slither", "field")}
    text = compare.render_markdown(rows, "A", "B", two, a)
    assert "Only in A (not compared): tip-only/field" in text


def _write(folder: Path, recs: list[dict]) -> Path:
    folder.mkdir(parents=True)
    (folder / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    return folder


def _args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    compare.add_arguments(parser)
    return parser.parse_args(argv)


def test_command_line_markdown_plot_and_bad_input(tmp_path, capsys):
    a = _write(tmp_path / "a", sweep_records({("truss", i): i % 2 == 0 for i in range(8)}))
    b = _write(tmp_path / "b", sweep_records({("truss", i): i != 3 for i in range(8)}))
    out = tmp_path / "cmp"
    assert compare.run_from_args(_args([str(a), str(b), "--out", str(out)])) == 0
    printed = capsys.readouterr().out
    assert printed == (out / "compare.md").read_text()
    row = next(line for line in printed.splitlines() if line.startswith("| slither/field | truss"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[2:7] == ["4/8", "7/8", "0.500", "0.875", "+0.375"]
    assert cells[8:] == [f"{mcnemar_exact(0, 3):.3g}", "McNemar exact", "0", "3"]
    assert (out / "compare.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and "(compare.png)" in printed

    assert compare.run_from_args(_args([str(a), str(tmp_path / "nowhere")])) == 2
    assert "nowhere: not a directory" in capsys.readouterr().err
    c = _write(tmp_path / "c", sweep_records({("truss", 0): True}, controller="tip-only") +
               sweep_records({("truss", 1): True}, planner="scripted"))
    assert compare.run_from_args(_args([str(a), str(c)])) == 2
    assert "no controller/planner in common" in capsys.readouterr().err
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "results.jsonl").write_text('{"controller": "slither"}\n')
    assert compare.run_from_args(_args([str(a), str(tmp_path / "d")])) == 2
    assert "line 1: field 'planner'" in capsys.readouterr().err


# ---- gaps a mutation sample of compare.py found (tools/mutation.sh compare) ------------------------------


def test_each_method_is_compared_with_its_own_trials_and_named_in_order():
    a = sweep_records({("truss", i): True for i in range(4)}, planner="scripted")
    a += sweep_records({("truss", i): i < 1 for i in range(6)}, planner="field")
    b = sweep_records({("truss", i): i < 2 for i in range(4)}, planner="scripted")
    b += sweep_records({("truss", i): i < 3 for i in range(6)}, planner="field")
    rows = [r for r in compare.compare(a, b) if r.family == "truss"]
    assert [(r.label, r.n_a, r.k_a, r.n_b, r.k_b) for r in rows] == [
        ("slither/field", 6, 1, 6, 3), ("slither/scripted", 4, 4, 4, 2)]
    single = compare.compare(sweep_records({("truss", 0): True}, planner="scripted"),
                             sweep_records({("truss", 0): True}, planner="field"))
    assert single[0].label == "slither/scripted vs slither/field"  # A's method first, whichever sorts first


def test_trials_without_a_family_come_after_the_named_families():
    a = sweep_records({("truss", i): True for i in range(3)})
    loose = sweep_records({("x", i): True for i in range(3)})
    for r in loose:
        del r["family"]
    rows = compare.compare(a + loose, a + loose)
    assert [r.family for r in rows] == ["truss", "(none)", "(all)"]


def test_the_header_names_each_sweeps_versions_and_flags_a_mix():
    def stamped(recs, version, commit):
        return [dict(r, provenance={"navstack": version, "commit": commit}) for r in recs]

    recs = sweep_records({("truss", i): True for i in range(2)})
    one = stamped(recs, "0.4.0", "abcdef1234567890")
    mixed = one[:1] + stamped(recs[1:], "0.5.0", None)
    text = compare.render_markdown(compare.compare(one, mixed), "A", "B", one, mixed)
    assert "- A: `A`, 2 trials (navstack 0.4.0 @ abcdef123456)\n" in text
    assert "- B: `B`, 2 trials (navstack 0.4.0 @ abcdef123456, navstack 0.5.0 **(mixed versions)**)\n" in text


def test_the_header_counts_the_trials_that_ended_in_error():
    recs = sweep_records({("truss", i): i < 3 for i in range(5)})
    broken = [dict(r, reason="error") if i in (3, 4) else r for i, r in enumerate(recs)]
    text = compare.render_markdown(compare.compare(recs, broken), "A", "B", recs, broken)
    assert "- A: `A`, 5 trials (no provenance)\n" in text
    assert "- B: `B`, 5 trials (no provenance); 2 ended in `error` (the trial crashed, exceeded its wall-clock " \
           "limit, or its world file was refused as bad input), counted as failures\n" in text


def test_the_plot_draws_every_row_once_with_its_own_interval(tmp_path, monkeypatch):
    from matplotlib.axes import Axes

    drawn = []
    original = Axes.errorbar

    def spy(self, x, y, xerr=None, fmt="", **kw):
        drawn.append((fmt, list(x), list(y), np.asarray(xerr).tolist()))
        return original(self, x, y, xerr=xerr, fmt=fmt, **kw)

    monkeypatch.setattr(Axes, "errorbar", spy)
    paired = compare.compare(sweep_records({("truss", i): i % 2 == 0 for i in range(8)}),
                             sweep_records({("truss", i): i != 3 for i in range(8)}))
    unpaired = compare.compare(sweep_records({("rack", i): i < 5 for i in range(9)}),
                               sweep_records({("rack", i): i < 2 for i in range(7)}))
    rows = paired + unpaired
    path = compare.write_plot(rows, tmp_path / "new" / "folder" / "compare.png")  # folders made as needed
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [d[0] for d in drawn] == ["o", "s"]  # paired rows as circles, unpaired as squares
    y = {3: 0, 2: 1, 1: 2, 0: 3}  # the first row at the top
    for fmt, xs, ys, err in drawn:
        for k, (x, yy) in enumerate(zip(xs, ys, strict=True)):
            r = rows[y[yy]]
            assert r.paired == (fmt == "o") and x == r.diff
            assert [err[0][k], err[1][k]] == pytest.approx([r.diff - r.ci_low, r.ci_high - r.diff])
    assert sorted(yy for d in drawn for yy in d[2]) == [0, 1, 2, 3]  # each row once


def test_the_command_line_says_what_it_wrote_and_only_then(tmp_path, capsys):
    a = _write(tmp_path / "a", sweep_records({("truss", i): i % 2 == 0 for i in range(4)}))
    assert compare.run_from_args(_args([str(a), str(a)])) == 0
    assert capsys.readouterr().err == ""
    out = tmp_path / "cmp"
    assert compare.run_from_args(_args([str(a), str(a), "--out", str(out)])) == 0
    assert capsys.readouterr().err == f"wrote {out / 'compare.md'} and {out / 'compare.png'}\n"
    assert compare.run_from_args(_args([str(a), str(a), "--out", str(out), "--no-plots"])) == 0
    assert capsys.readouterr().err == f"wrote {out / 'compare.md'}\n"


@pytest.mark.parametrize(("change", "needle"), [
    ({"world_id": [1]}, "field 'world_id' must be a string or null, got [1]"),  # once: unhashable, TypeError
    ({"provenance": {"navstack": [1], "commit": None}}, "field 'provenance.navstack' must be a string or null"),
    ({"difficulty": int("1" + "0" * 400)}, "field 'difficulty' must be a number in [-1e9, 1e9] or null"),
])
def test_mistyped_fields_are_bad_input_naming_the_line(tmp_path, capsys, change, needle):
    recs = sweep_records({("truss", i): i % 2 == 0 for i in range(4)})
    a = _write(tmp_path / "a", recs)
    recs[2] = {**recs[2], **change}
    b = _write(tmp_path / "b", recs)
    assert compare.run_from_args(_args([str(a), str(b)])) == 2
    assert f"{b / 'results.jsonl'}, line 3: {needle}" in capsys.readouterr().err


def test_a_family_named_all_is_not_the_pooled_row():
    a = {("(all)", i): True for i in range(4)} | {("truss", i): False for i in range(4)}
    rows = compare.compare(sweep_records(a), sweep_records(a))
    assert [(r.family, r.n_a, r.k_a) for r in rows] == [('"(all)"', 4, 4), ("truss", 4, 0), ("(all)", 8, 4)]


def test_a_family_only_one_sweep_ran_is_named_under_the_table():
    """It has no row (nothing to compare it with) but is counted in the pooled row: the report said neither
    (an independent review's finding)."""
    a = sweep_records({("truss", i): True for i in range(4)} | {("sphere-field", i): False for i in range(3)})
    b = sweep_records({("truss", i): i > 0 for i in range(4)} | {("pipe-rack", i): True for i in range(2)})
    rows = compare.compare(a, b)
    assert [(r.family, r.n_a, r.n_b) for r in rows] == [("truss", 4, 4), ("(all)", 7, 6)]
    text = compare.render_markdown(rows, "A", "B", a, b)
    assert ("Families only in A for slither/field (no row of their own; counted in (all)): sphere-field\n"
            in text)
    assert "Families only in B for slither/field (no row of their own; counted in (all)): pipe-rack\n" in text
    same = compare.render_markdown(compare.compare(a, a), "A", "A", a, a)
    assert "Families only in" not in same


def test_a_family_named_with_a_pipe_or_a_line_break_stays_in_its_cell():
    """As in the report: ``|`` or a line break in a family broke the comparison table's rows (a review)."""
    a = sweep_records({("pipes|racks", 0): True, ("two\nlines", 1): False})
    text = compare.render_markdown(compare.compare(a, a), "A", "B", a, a)
    rows = [line for line in text.splitlines() if line.startswith("| ")]
    assert len(rows) == 1 + 3  # header, two families, (all)
    assert all(r.replace("\\|", "").count("|") == 13 for r in rows), rows
    assert "| slither/field | pipes\\|racks |" in text and "| slither/field | two lines |" in text


def test_an_out_folder_that_cannot_be_made_is_named(tmp_path):
    """An audit's case: ``--out /proc/nope`` printed a bare ``[Errno 2] ...``."""
    from navstack.report import ReportError

    recs = sweep_records({("truss", i): i < 3 for i in range(5)})
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    (tmp_path / "file").write_text("x")
    with pytest.raises(ReportError, match=r"--out: cannot create .*file.sub"):
        compare.run_compare(tmp_path / "a", tmp_path / "b", out=tmp_path / "file" / "sub", plots=False)


def test_a_cut_off_last_line_is_said_not_dropped_silently(tmp_path):
    """An audit's case: ``compare`` dropped a truncated last line without a word (``report`` says it)."""
    recs = sweep_records({("truss", i): i < 3 for i in range(5)})
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    with open(tmp_path / "b" / "results.jsonl", "a") as fh:
        fh.write(json.dumps(recs[0])[:30])
    text = compare.run_compare(tmp_path / "a", tmp_path / "b", plots=False)
    assert "Note: the last line of B's results file was cut short (a killed sweep) and is ignored." in text
    assert "of A's results" not in text


def test_the_plot_of_very_many_families_draws_the_pooled_row_and_at_most_plot_rows(tmp_path, monkeypatch):
    """An audit (session 33) found a report of 1,500 families drawing figures thousands of inches large; the
    comparison's plot grew 0.4 inch per row the same way.  It draws every method's pooled row and the first
    family rows, at most PLOT_ROWS, and says so; the table keeps every row."""
    from matplotlib.axes import Axes

    drawn, titles = [], []
    original_errorbar, original_title = Axes.errorbar, Axes.set_title
    monkeypatch.setattr(Axes, "errorbar", lambda self, x, y, **kw: drawn.extend(y) or original_errorbar(
        self, x, y, **kw))
    monkeypatch.setattr(Axes, "set_title", lambda self, t, **kw: titles.append(t) or original_title(self, t, **kw))
    ticks, original_yticks = [], Axes.set_yticks
    monkeypatch.setattr(Axes, "set_yticks", lambda self, y, labels, **kw: ticks.extend(labels) or original_yticks(
        self, y, labels, **kw))
    rows = compare.compare(sweep_records({(f"f{k:03d}", i): (i + k) % 2 == 0 for k in range(200) for i in range(2)}),
                           sweep_records({(f"f{k:03d}", i): i == 0 for k in range(200) for i in range(2)}))
    assert len(rows) == 201 and rows[-1].family == compare.ALL_FAMILIES
    compare.write_plot(rows, tmp_path / "compare.png")
    assert len(drawn) == compare.PLOT_ROWS and sorted(drawn) == list(range(compare.PLOT_ROWS))
    assert titles == [f"{compare.PLOT_ROWS} of the 201 rows (the table has every one)"]
    assert ticks[-1].endswith(f"| {compare.ALL_FAMILIES}") and ticks[:-1] == [f"{r.label} | {r.family}" for r in
                                                                             rows[:compare.PLOT_ROWS - 1]]
    titles.clear()
    compare.write_plot(rows[-3:], tmp_path / "few.png")
    assert titles == []


def outcome_runner(world, *, controller, planner, seed, out_dir=None):
    """A sweep's runner that runs nothing: the world file says whether its trial succeeds."""
    data = json.loads(Path(world).read_text())
    ok = data["extra"]["ok"]
    return {"world": data["name"], "seed": seed, "controller": controller, "planner": planner, "success": ok,
            "reason": "reached" if ok else "collision", "goals_reached": int(ok), "sim_time": 1.0, "steps": 1,
            "wall_time": 0.0, "metrics": {}}


def _world_folder(folder: Path, names: list[str], ok: list[bool]) -> Path:
    folder.mkdir(parents=True)
    for i, (name, good) in enumerate(zip(names, ok, strict=True)):
        doc = {"format": "navstack-world/1", "name": name, "family": "truss", "extra": {"ok": good}}
        (folder / f"w{i}.json").write_text(json.dumps(doc))
    return folder


def test_two_folders_of_other_worlds_under_the_same_file_names_are_not_paired(tmp_path):
    """An audit (session 33): two sweeps of folders holding 'w0.json'... with other worlds in them were paired
    (the world id is the file's stem, and the seed is derived from it) and tested with McNemar's test.  The
    world's name, and the world file's SHA-256 that each sweep stores, are part of what makes a trial the same."""
    from navstack.sweep import SweepConfig, build_specs, run_sweep

    ok = [i % 2 == 0 for i in range(6)]
    names = [f"w{i}" for i in range(6)]
    cases = {"same worlds": (names, ok, True),
             "other names": ([f"other{i}" for i in range(6)], [not x for x in ok], False),
             "one edited": (names, [not x for x in ok[:3]] + [x for x in ok[3:]], False)}
    base = _world_folder(tmp_path / "base", names, ok)
    dir_a = tmp_path / "A"
    run_sweep(build_specs(SweepConfig(worlds_dir=str(base))), dir_a, jobs=1, runner=outcome_runner, progress=False)
    for case, (names_b, ok_b, paired) in cases.items():
        folder = _world_folder(tmp_path / case / "worlds", names_b, ok_b)
        dir_b = tmp_path / case / "B"
        run_sweep(build_specs(SweepConfig(worlds_dir=str(folder))), dir_b, jobs=1, runner=outcome_runner,
                  progress=False)
        text = compare.run_compare(dir_a, dir_b)
        assert ("| McNemar exact |" in text, "| Fisher exact |" in text) == (paired, not paired), case
        if case == "one edited":  # without the stored hashes the names alone pair them
            (dir_b / "sweep.json").unlink()
            assert "| McNemar exact |" in compare.run_compare(dir_a, dir_b)
