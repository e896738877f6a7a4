"""Success-rate reports of a trial sweep (``navstack report DIR``, interfaces.md section 4).

Reads ``DIR/results.jsonl`` (written by :mod:`navstack.sweep` or by hand: one ``result.json`` object per line,
optionally with ``trial_id``, ``family`` and ``difficulty``) and writes ``DIR/report.md`` with PNG plots in
``DIR/plots/``:

* success rate with a 95 % Wilson score interval per method (controller and planner), per family with the
  methods side by side, and per family x difficulty x method;
* failure causes: counts of ``reason`` among unsuccessful trials, per method;
* distributions (n, min, p10, median, p90, max, mean) of ``metrics.min_clearance`` (m) and
  ``metrics.slither_deviation_max`` (m) over all trials that report them, and of time to goal
  (``sim_time``, s) over successful trials;
* retraction: when some records carry ``retracted`` (trials of ``retract`` worlds, interfaces.md section 2a),
  the success tables get a column ``retracted`` = retracted / trials that carry the key;
* provenance: every distinct software identity (navstack version, commit, Python, PyBullet, numpy) found in
  the lines' ``provenance``, with its backends, hosts and trial count, and a warning at the top when a sweep
  mixes versions (or mixes lines with and without provenance).

Conventions: a trial counts as a success only if ``success`` is ``true``; trials with ``reason: "error"``
(the trial itself crashed or hung) count as failures and the report says how many there were. A record
without ``family`` is grouped under ``(none)``; one without ``difficulty`` under ``-``. A final line cut
short by a killed sweep (no newline, not JSON) is ignored with a note in the report, as
:func:`navstack.sweep.read_results` does; any other malformed line, an unknown ``reason``, a missing or
mistyped field, or a repeated ``trial_id`` is a :class:`ReportError` naming the file and line. Types:
``difficulty``, ``sim_time``, ``wall_time`` and the float metrics are null or numbers within
+-:data:`MAX_VALUE` (1e9; times and the metrics other than ``min_clearance`` not negative),
``goals_reached``, ``steps``, ``seed``, ``world_seed`` and ``metrics.contacts`` null or integers >= 0,
``world``, ``world_id`` and the ``provenance`` fields null or strings. A line that contradicts itself is
refused, never counted: ``success`` must be true exactly when ``reason`` is ``reached``, and a success must
not have ``metrics.contacts`` > 0, a negative ``metrics.min_clearance``, ``goals_reached`` 0 or
``retracted`` false.

The plots use matplotlib's object API (:class:`matplotlib.figure.Figure` rendered by Agg), so no global
backend is changed.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

Z95 = 1.959963984540054
"""Two-sided 95 % standard-normal quantile."""

REASONS: tuple[str, ...] = ("reached", "collision", "timeout", "stalled", "joint_limit", "error")
NO_FAMILY = "(none)"
POOLED = "(all)"
"""The label of ``navstack compare``'s row over every family."""


def family_label(record: Mapping[str, Any]) -> str:
    """The family a record is grouped and shown under: its ``family``, :data:`NO_FAMILY` when it has none, and
    a family that is literally spelled like one of those labels in quotes (a world may call its family
    ``(none)``; it must not be merged with the records that have none)."""
    f = record.get("family")
    if not f:
        return NO_FAMILY
    return f'"{f}"' if f in (NO_FAMILY, POOLED) else str(f)
METRICS: tuple[tuple[str, str, str], ...] = (
    ("min_clearance", "Minimum clearance (m), all trials", "min_clearance.png"),
    ("slither_deviation_max", "Slithering deviation (m), all trials", "slither_deviation.png"),
    ("time_to_goal", "Time to goal (s, simulated), successful trials", "time_to_goal.png"),
)
PLOTS_DIR = "plots"


class ReportError(ValueError):
    """Unusable results (message names the file and line, or the record index)."""


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval for ``successes`` out of ``n`` Bernoulli trials (default 95 %).

    ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)`` with ``p = successes / n`` (scipy's
    ``binomtest(...).proportion_ci(method="wilson")`` at the level of ``z``); unlike the normal approximation it
    stays inside [0, 1] and is not degenerate at 0/n or n/n.
    Raises ValueError unless ``0 <= successes <= n`` and ``n >= 1``.
    """
    from scipy.stats import binomtest, norm

    if isinstance(successes, bool) or isinstance(n, bool) or int(successes) != successes or int(n) != n:
        raise ValueError(f"wilson_interval: integer counts expected, got successes={successes!r}, n={n!r}")
    if n < 1 or not 0 <= successes <= n:
        raise ValueError(f"wilson_interval: need n >= 1 and 0 <= successes <= n, got {successes}/{n}")
    ci = binomtest(int(successes), int(n)).proportion_ci(confidence_level=2 * norm.cdf(z) - 1, method="wilson")
    # exact at the ends (rounding would otherwise leave 1e-17 off 0 or 1)
    return (0.0 if successes == 0 else float(ci.low), 1.0 if successes == n else float(ci.high))


@dataclass(frozen=True)
class Rate:
    """``successes`` of ``n`` trials, their ratio and 95 % Wilson interval."""

    n: int
    successes: int
    rate: float
    ci_low: float
    ci_high: float

    @classmethod
    def of(cls, successes: int, n: int) -> Rate:
        lo, hi = wilson_interval(successes, n)
        return cls(n=n, successes=successes, rate=successes / n, ci_low=lo, ci_high=hi)


@dataclass(frozen=True)
class Stats:
    """Order statistics of one metric (same unit as the metric); NaN fields when ``n == 0``."""

    n: int
    min: float
    p10: float
    median: float
    p90: float
    max: float
    mean: float

    @classmethod
    def of(cls, values: Sequence[float]) -> Stats:
        if not values:
            nan = float("nan")
            return cls(0, nan, nan, nan, nan, nan, nan)
        a = np.asarray(values, dtype=float)
        p10, med, p90 = np.percentile(a, [10, 50, 90])
        return cls(len(a), float(a.min()), float(p10), float(med), float(p90), float(a.max()), float(a.mean()))


@dataclass(frozen=True)
class Provenance:
    """One software identity found in a sweep (``key`` = :data:`navstack.provenance.VERSION_KEYS` values, or
    ``None`` for lines without ``provenance``), the backends and hosts that ran it and its trial count."""

    key: tuple[Any, ...] | None
    backends: tuple[str, ...]
    hosts: tuple[str, ...]
    trials: int


def _provenances(records: Sequence[Mapping[str, Any]]) -> tuple[Provenance, ...]:
    from navstack.provenance import version_key

    groups: dict[Any, list[Mapping[str, Any]]] = {}
    for r in records:
        groups.setdefault(version_key(r.get("provenance")), []).append(r)

    def names(recs: list[Mapping[str, Any]], key: str) -> tuple[str, ...]:
        return tuple(sorted({str((r.get("provenance") or {}).get(key)) for r in recs
                             if isinstance(r.get("provenance"), Mapping) and (r["provenance"].get(key) is not None)}))

    return tuple(Provenance(key=k, backends=names(v, "backend"), hosts=names(v, "host"), trials=len(v))
                 for k, v in sorted(groups.items(), key=lambda kv: (kv[0] is None, repr(kv[0]))))


@dataclass(frozen=True)
class Summary:
    """Everything the report shows; keys are plain strings / floats so it is easy to test.

    ``methods`` are ``(controller, planner)`` pairs; ``by_cell`` is keyed by ``(family, difficulty, method)``;
    ``reasons[method][reason]`` counts unsuccessful trials; ``values[metric][method]`` are the sorted metric
    values (``metric`` in ``min_clearance``, ``slither_deviation_max``, ``time_to_goal``).
    """

    n_trials: int
    methods: tuple[tuple[str, str], ...]
    families: tuple[str, ...]
    difficulties: tuple[float | None, ...]
    by_method: dict[tuple[str, str], Rate]
    by_family: dict[tuple[str, tuple[str, str]], Rate]
    by_cell: dict[tuple[str, float | None, tuple[str, str]], Rate]
    reasons: dict[tuple[str, str], dict[str, int]]
    values: dict[str, dict[tuple[str, str], tuple[float, ...]]]
    errors: int
    retracted_by_method: dict[tuple[str, str], tuple[int, int]] = field(default_factory=dict)
    retracted_by_cell: dict[tuple[str, float | None, tuple[str, str]], tuple[int, int]] = field(default_factory=dict)
    provenance: tuple[Provenance, ...] = ()
    settings: tuple[str, ...] = ()
    """The distinct trial settings of the lines: each line's ``settings`` (the SHA-256 of ``trials --settings``),
    ``""`` for lines run with the defaults."""
    animations: tuple[tuple[str, str, str], ...] = ()
    """(trial_id, reason, animation file relative to the sweep folder) of failed trials kept with
    ``--animate-failures``."""
    failed: tuple[tuple[str, str, str, str, str, str], ...] = ()
    """(trial_id, world, method, reason, goals reached, sim_time) of every unsuccessful trial, sorted (``-`` where
    a line lacks the field)."""

    @property
    def mixed_versions(self) -> bool:
        """More than one software identity among the lines (lines without provenance count as one)."""
        return len(self.provenance) > 1

    def stats(self, metric: str, method: tuple[str, str]) -> Stats:
        """:class:`Stats` of ``metric`` for ``method``."""
        return Stats.of(self.values[metric].get(method, ()))


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


MAX_VALUE = 1e9
"""The largest magnitude of a number the report reads (``difficulty``, times, metrics): far beyond any real
value (worlds are at most 1 km across, trials at most an hour long, the generator's difficulty is in [0, 1]),
and small enough that sums, percentiles and plot axes cannot overflow."""


def _show(v: Any) -> str:
    """``repr(v)``, shortened (a line may hold a 400-digit integer)."""
    text = repr(v)
    return text if len(text) <= 60 else f"{text[:40]}... ({len(text)} characters)"


def _number_problem(v: Any, *, nonneg: bool = False) -> str | None:
    """Why ``v`` is not null or a number in [-:data:`MAX_VALUE`, :data:`MAX_VALUE`] ([0, ...] if ``nonneg``)."""
    if v is None:
        return None
    expected = "a number in [0, 1e9]" if nonneg else "a number in [-1e9, 1e9]"
    if not _is_number(v) or not (-MAX_VALUE <= v <= MAX_VALUE) or (nonneg and v < 0):  # NaN fails too
        return f"must be {expected} or null, got {_show(v)}"
    return None


def _count_problem(v: Any) -> str | None:
    """Why ``v`` is not an integer >= 0 or null, or None."""
    if v is None or (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
        return None
    return f"must be an integer >= 0 or null, got {_show(v)}"


PROVENANCE_KEYS = ("navstack", "commit", "python", "pybullet", "numpy", "host", "backend")
"""The ``provenance`` fields of interfaces.md section 4: each a string or null."""


def check_record(rec: Any) -> str | None:
    """Why ``rec`` cannot be summarised (a malformed or self-contradicting results line), or None."""
    if not isinstance(rec, Mapping):
        return f"expected a JSON object, got {type(rec).__name__}"
    for key in ("controller", "planner", "reason"):
        if not isinstance(rec.get(key), str) or not rec.get(key):
            return f"field '{key}' must be a non-empty string, got {_show(rec.get(key))}"
    if not isinstance(rec.get("success"), bool):
        return f"field 'success' must be true or false, got {_show(rec.get('success'))}"
    if rec["reason"] not in REASONS:
        return f"field 'reason' is {_show(rec['reason'])}, expected one of {list(REASONS)}"
    if rec["success"] and rec["reason"] != "reached":
        return f"field 'reason' is {rec['reason']!r} but 'success' is true"
    if not rec["success"] and rec["reason"] == "reached":
        return "field 'reason' is 'reached' but 'success' is false"
    fam = rec.get("family")
    if fam is not None and not isinstance(fam, str):
        return f"field 'family' must be a string or null, got {_show(fam)}"
    for key in ("world", "world_id"):
        if rec.get(key) is not None and not isinstance(rec[key], str):
            return f"field '{key}' must be a string or null, got {_show(rec[key])}"
    for key, why in (("difficulty", _number_problem(rec.get("difficulty"))),
                     ("sim_time", _number_problem(rec.get("sim_time"), nonneg=True)),
                     ("wall_time", _number_problem(rec.get("wall_time"), nonneg=True)),
                     ("goals_reached", _count_problem(rec.get("goals_reached"))),
                     ("steps", _count_problem(rec.get("steps"))),
                     ("seed", _count_problem(rec.get("seed"))),
                     ("world_seed", _count_problem(rec.get("world_seed")))):
        if why is not None:
            return f"field '{key}' {why}"
    metrics = rec.get("metrics")
    if metrics is not None:
        if not isinstance(metrics, Mapping):
            return f"field 'metrics' must be an object, got {_show(metrics)}"
        for key, why in (("min_clearance", _number_problem(metrics.get("min_clearance"))),
                         ("slither_deviation_max", _number_problem(metrics.get("slither_deviation_max"),
                                                                   nonneg=True)),
                         ("tip_error_max", _number_problem(metrics.get("tip_error_max"), nonneg=True)),
                         ("contacts", _count_problem(metrics.get("contacts")))):
            if why is not None:
                return f"field 'metrics.{key}' {why}"
    tid = rec.get("trial_id")
    if tid is not None and not isinstance(tid, str):
        return f"field 'trial_id' must be a string, got {_show(tid)}"
    if "retracted" in rec and not isinstance(rec["retracted"], bool):
        return f"field 'retracted' must be true or false, got {_show(rec['retracted'])}"
    prov = rec.get("provenance")
    if prov is not None:
        if not isinstance(prov, Mapping):
            return f"field 'provenance' must be an object, got {_show(prov)}"
        for key in PROVENANCE_KEYS:
            if prov.get(key) is not None and not isinstance(prov[key], str):
                return f"field 'provenance.{key}' must be a string or null, got {_show(prov[key])}"
    if rec["success"]:  # a success must not contradict itself: a wrong success is the worst error a report can make
        met = metrics or {}
        if met.get("contacts"):
            return f"'success' is true but 'metrics.contacts' is {met['contacts']} (a success has no contact)"
        if met.get("min_clearance") is not None and met["min_clearance"] < 0:
            return (f"'success' is true but 'metrics.min_clearance' is {met['min_clearance']!r} "
                    "(negative: the robot penetrated an obstacle)")
        if rec.get("goals_reached") == 0:
            return "'success' is true but 'goals_reached' is 0 (a world has at least one goal)"
        if rec.get("retracted") is False:
            return "'success' is true but 'retracted' is false (a retraction world needs the robot back out)"
    return None


def _diff_key(d: float | None) -> tuple[bool, float]:
    return (d is None, 0.0 if d is None else d)


def _fam_key(f: str) -> tuple[bool, str]:
    return (f == NO_FAMILY, f)


def _check_records(records: Sequence[Mapping[str, Any]], where, short=None) -> None:
    """Raise :class:`ReportError` at the first malformed record or repeated ``trial_id``; ``where(i)`` names
    record ``i`` in the message (``short(i)`` when it is named a second time)."""
    short = short or where
    seen: dict[str, int] = {}
    for i, rec in enumerate(records):
        why = check_record(rec)
        if why is not None:
            raise ReportError(f"{where(i)}: {why}")
        tid = rec.get("trial_id")
        if tid is not None:
            if tid in seen:
                raise ReportError(f"{where(i)}: trial_id {tid!r} already on {short(seen[tid])}")
            seen[tid] = i


def _tally(records: Sequence[Mapping[str, Any]], keyf: Any) -> dict[Any, Rate]:
    """The success :class:`Rate` of the records grouped by ``keyf(record)``."""
    counts: dict[Any, list[int]] = {}
    for r in records:
        c = counts.setdefault(keyf(r), [0, 0])
        c[0] += r["success"] is True
        c[1] += 1
    return {k: Rate.of(s, n) for k, (s, n) in counts.items()}


def _tally_retracted(records: Sequence[Mapping[str, Any]], keyf: Any) -> dict[Any, tuple[int, int]]:
    """(retracted, asked to) of the records of worlds that ask for retraction, grouped by ``keyf(record)``."""
    counts: dict[Any, list[int]] = {}
    for r in records:
        if "retracted" in r:
            c = counts.setdefault(keyf(r), [0, 0])
            c[0] += r["retracted"] is True
            c[1] += 1
    return {k: (a, b) for k, (a, b) in counts.items()}


def summarize(records: Iterable[Mapping[str, Any]], *, checked: bool = False) -> Summary:
    """Success rates, failure causes and metric distributions of result records (pure; see module doc).

    Raises :class:`ReportError` naming the record index (0-based) for an invalid record or a repeated
    ``trial_id``, and for no records at all.
    """
    records = list(records)
    if not records:
        raise ReportError("no trial results to summarise")
    if not checked:
        _check_records(records, lambda i: f"record {i}")

    def method(r: Mapping[str, Any]) -> tuple[str, str]:
        return (r["controller"], r["planner"])

    family = family_label

    methods = tuple(sorted({method(r) for r in records}))
    families = tuple(sorted({family(r) for r in records}, key=_fam_key))
    difficulties = tuple(sorted({r.get("difficulty") for r in records}, key=_diff_key))

    by_method = _tally(records, method)
    by_family = _tally(records, lambda r: (family(r), method(r)))
    by_cell = _tally(records, lambda r: (family(r), r.get("difficulty"), method(r)))
    reasons: dict[tuple[str, str], dict[str, int]] = {m: {} for m in methods}
    for r in records:
        if not r["success"]:
            d = reasons[method(r)]
            d[r["reason"]] = d.get(r["reason"], 0) + 1
    values: dict[str, dict[tuple[str, str], list[float]]] = {m[0]: {} for m in METRICS}
    for r in records:
        met = r.get("metrics") or {}
        for key in ("min_clearance", "slither_deviation_max"):
            if met.get(key) is not None:
                values[key].setdefault(method(r), []).append(float(met[key]))
        if r["success"] and r.get("sim_time") is not None:
            values["time_to_goal"].setdefault(method(r), []).append(float(r["sim_time"]))
    animations = tuple((str(r["trial_id"]), str(r["reason"]), str(r["animation"])) for r in records
                       if not r["success"] and isinstance(r.get("animation"), str) and "trial_id" in r)
    return Summary(
        animations=animations,
        failed=tuple(sorted(_failed_row(r) for r in records if r["success"] is not True)),
        n_trials=len(records), methods=methods, families=families, difficulties=difficulties,
        by_method=by_method, by_family=by_family,
        by_cell={k: by_cell[k] for k in sorted(by_cell, key=lambda k: (_fam_key(k[0]), _diff_key(k[1]), k[2]))},
        reasons=reasons,
        values={k: {m: tuple(sorted(v)) for m, v in d.items()} for k, d in values.items()},
        errors=sum(1 for r in records if r["reason"] == "error"),
        retracted_by_method=_tally_retracted(records, method),
        retracted_by_cell=_tally_retracted(records, lambda r: (family(r), r.get("difficulty"), method(r))),
        provenance=_provenances(records),
        settings=tuple(sorted({str(r["settings"]) if isinstance(r.get("settings"), str) else "" for r in records})),
    )


# --------------------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Loaded:
    """Records of a results file, their 1-based line numbers, whether a cut-off last line was ignored, and from the
    ``sweep.json`` beside it how many trials it lists and its world files' SHA-256 by path (None: no readable
    one, or no hashes stored)."""

    path: Path
    records: list[dict[str, Any]]
    line_numbers: list[int]
    truncated_tail: bool
    planned: int | None = None
    world_files: dict[str, Any] | None = None


def load_results(path: str | Path) -> Loaded:
    """Read and check ``results.jsonl``; :class:`ReportError` names the file and line of the first problem."""
    from navstack.sweep import SweepError, read_results

    path = Path(path)
    if not path.exists():
        raise ReportError(f"{path}: no such results file (run `navstack trials ... --out DIR` first)")
    if not path.is_file():
        raise ReportError(f"{path}: not a results file (a directory or other non-regular file; `navstack trials` "
                          f"writes results.jsonl as a file)")
    try:
        rf = read_results(path)
    except SweepError as exc:
        raise ReportError(str(exc)) from exc
    if not rf.records:
        why = "its only line was cut short (a killed sweep: rerun its command)" if rf.truncated_tail else "it is empty"
        raise ReportError(f"{path}: no trial results in the file ({why})")
    lines = rf.line_numbers
    _check_records(rf.records, lambda i: f"{path}, line {lines[i]}", lambda i: f"line {lines[i]}")
    planned, world_files = _check_against_sweep(path, rf.records, lines)
    return Loaded(path, rf.records, rf.line_numbers, rf.truncated_tail, planned, world_files)


def _check_against_sweep(path: Path, records: Sequence[Mapping[str, Any]],
                         lines: Sequence[int]) -> tuple[int | None, dict[str, Any] | None]:
    """When ``results.jsonl`` lies beside the ``sweep.json`` of the sweep that wrote it, refuse a line that is not
    one of its trials: a ``trial_id`` it does not list, or one whose seed, world or method is another's
    (:data:`navstack.sweep.SPEC_KEYS`; a line of the same worlds run with another ``--seed`` has the same
    ``trial_id``). A ``sweep.json`` that cannot be read as one is left alone: the lines are reported as they are.
    Returns how many trials the sweep lists and the world files' hashes it stored (each None without a readable
    ``sweep.json``; the hashes None also when it stored none)."""
    from navstack.sweep import SWEEP_NAME, SweepError, TrialSpec, read_sweep_file, spec_mismatch

    sweep_path = path.parent / SWEEP_NAME
    if not sweep_path.exists():
        return None, None
    try:
        stored = read_sweep_file(sweep_path)
        specs = {spec.trial_id: spec for spec in map(TrialSpec.from_dict, stored["trials"])}
    except (SweepError, KeyError, TypeError, AttributeError, ValueError):
        return None, None
    for rec, line in zip(records, lines, strict=True):
        tid = rec.get("trial_id")
        if tid is None:
            continue
        spec = specs.get(tid)
        why = f"trial_id {tid!r} is not a trial of" if spec is None else spec_mismatch(dict(rec), spec)
        if why is not None:
            raise ReportError(f"{path}, line {line}: not a line of the sweep in {sweep_path}: {why}"
                              + (f" {sweep_path}" if spec is None else "")
                              + " (a line of another sweep configuration, or edited)")
    hashes = stored.get("world_files")
    return len(specs), (hashes if isinstance(hashes, dict) else None)


# --------------------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------------------


def method_label(m: tuple[str, str]) -> str:
    """``"controller/planner"``."""
    return f"{m[0]}/{m[1]}"


def _fmt_diff(d: float | None) -> str:
    return "-" if d is None else f"{d:g}"


def _fmt(x: float, digits: int = 4) -> str:
    return "-" if math.isnan(x) else f"{x:.{digits}g}"


def md_cell(value: Any) -> str:
    """``value`` as the text of one Markdown table cell: a ``|`` escaped and line breaks made spaces, so a family
    or method named with them (a world file's ``family`` may be any non-empty string) stays in its cell."""
    return " ".join(str(value).replace("|", "\\|").splitlines())


def _table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> list[str]:
    out = ["| " + " | ".join(md_cell(c) for c in header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(md_cell(c) for c in row) + " |" for row in rows]
    return out


def _rate_cells(r: Rate) -> list[str]:
    return [str(r.n), str(r.successes), f"{r.rate:.3f}", f"{r.ci_low:.3f}", f"{r.ci_high:.3f}"]


RATE_HEADER = ["trials", "successes", "success rate", "95 % CI low", "95 % CI high"]


def render_markdown(s: Summary, *, source: str = "results.jsonl", plots: Sequence[str] = (),
                    truncated_tail: bool = False, planned: int | None = None) -> str:
    """The report as Markdown; ``plots`` are the PNG paths (relative to the report) to embed; ``planned``: the
    number of trials of the sweep (its ``sweep.json``), to say so when fewer are recorded."""
    plot_of = {Path(p).name: p for p in plots}
    lines = _intro_section(s, source, truncated_tail, planned)
    lines += _rate_sections(s, plot_of)
    lines += _failure_section(s, plot_of)
    lines += _distribution_section(s, plot_of)
    lines += _provenance_section(s)
    return "\n".join(lines) + "\n"


def sweep_notes(n_trials: int, planned: int | None, truncated_tail: bool, subject: str = "the sweep",
                results: str = "the results file") -> list[str]:
    """What a report or a comparison says of a results file: its sweep unfinished (``n_trials`` of the
    ``planned`` its ``sweep.json`` lists), or its cut-off last line ignored."""
    notes = []
    if planned is not None and planned > n_trials:
        notes.append(f"**Note: {subject} is unfinished**: {n_trials} of the {planned} trials its `sweep.json` "
                     "lists are recorded; the rates below cover those only. Rerun the sweep's command to finish it.")
    if truncated_tail:
        notes.append(f"Note: the last line of {results} was cut short (a killed sweep) and is ignored. Resume the "
                     "sweep to rerun that trial.")
    return notes


def _intro_section(s: Summary, source: str, truncated_tail: bool, planned: int | None = None) -> list[str]:
    lines = ["# navstack trial report", ""]
    levels = sum(d is not None for d in s.difficulties)
    unrated = " (and trials whose world gives none)" if levels < len(s.difficulties) else ""
    lines.append(
        f"Source: `{source}`, {s.n_trials} trials; {len(s.methods)} method(s) (controller/planner), "
        f"{len(s.families)} world famil{'y' if len(s.families) == 1 else 'ies'}, {levels} difficulty "
        f"level(s){unrated}. A success is every goal reached in order, with no contact, within the world's time limit. "
        "Intervals are 95 % Wilson score intervals. Trials ending in `error` (the trial crashed, exceeded its "
        f"wall-clock limit, or its world file was refused as bad input: {s.errors} here) count as failures.")
    for note in sweep_notes(s.n_trials, planned, truncated_tail):
        lines += ["", note]
    if s.mixed_versions:
        lines += ["", f"**Warning: this sweep mixes software versions** ({len(s.provenance)} different "
                  "navstack / commit / Python / PyBullet / numpy combinations, see Provenance below); its "
                  "trials may not be comparable."]
    return lines


def _rate_sections(s: Summary, plot_of: Mapping[str, str]) -> list[str]:
    """Success rates per method, per family and per family x difficulty x method (with the retraction counts
    when the sweep has worlds that ask for it)."""
    retraction = bool(s.retracted_by_method)
    retract_header = ["retracted"] if retraction else []

    def retracted(counts: tuple[int, int] | None) -> list[str]:
        if not retraction:
            return []
        return ["-" if counts is None else f"{counts[0]}/{counts[1]}"]

    lines = ["", "## Success rate per controller", ""]
    if retraction:
        lines += ["`retracted`: trials that backed out completely / trials of worlds that ask for it.", ""]
    lines += _table(["controller", "planner", *RATE_HEADER, *retract_header],
                    ([m[0], m[1], *_rate_cells(s.by_method[m]), *retracted(s.retracted_by_method.get(m))]
                     for m in s.methods))

    lines += ["", "## Success rate per family (controllers side by side)", "",
              "Each cell: success rate (successes/trials) [95 % CI].", ""]
    rows = []
    for fam in s.families:
        row = [fam]
        for m in s.methods:
            r = s.by_family.get((fam, m))
            row.append("-" if r is None else
                       f"{r.rate:.3f} ({r.successes}/{r.n}) [{r.ci_low:.3f}, {r.ci_high:.3f}]")
        rows.append(row)
    lines += _table(["family", *(method_label(m) for m in s.methods)], rows)
    for name, alt in (("success_rate.png", "Success rate per family"),
                      ("success_vs_difficulty.png", "Success rate against difficulty")):
        if name in plot_of:
            lines += ["", f"![{alt}]({plot_of[name]})"]

    lines += ["", "## Success rate per family, difficulty and controller", ""]
    lines += _table(["family", "difficulty", "controller", "planner", *RATE_HEADER, *retract_header],
                    ([f, _fmt_diff(d), m[0], m[1], *_rate_cells(r), *retracted(s.retracted_by_cell.get((f, d, m)))]
                     for (f, d, m), r in s.by_cell.items()))
    return lines


def _failed_row(r: Mapping[str, Any]) -> tuple[str, str, str, str, str, str]:
    def text(key: str) -> str:
        return "-" if r.get(key) is None else str(r[key])

    sim_time = "-" if r.get("sim_time") is None else f"{float(r['sim_time']):.1f}"
    return (text("trial_id"), text("world"), method_label((r["controller"], r["planner"])), str(r["reason"]),
            text("goals_reached"), sim_time)


MAX_FAILED_LISTED = 100
"""The report lists at most this many unsuccessful trials by name (the rest: in results.jsonl)."""


def _failure_section(s: Summary, plot_of: Mapping[str, str]) -> list[str]:
    lines = ["", "## Failure causes", "", "Counts of `reason` among unsuccessful trials.", ""]
    seen = sorted({k for d in s.reasons.values() for k in d}, key=REASONS.index)
    rows = [[reason, *(s.reasons[m].get(reason, 0) for m in s.methods)] for reason in seen]
    rows.append(["all failures", *(sum(s.reasons[m].values()) for m in s.methods)])
    lines += _table(["reason", *(method_label(m) for m in s.methods)], rows)
    if "failure_causes.png" in plot_of:
        lines += ["", f"![Failure causes]({plot_of['failure_causes.png']})"]
    if s.animations:
        lines += ["", "Animations of the failed trials (kept with `--animate-failures`):", ""]
        lines += [f"- [{tid}]({path}) ({reason})" for tid, reason, path in s.animations]
    if s.failed:
        shown = s.failed[:MAX_FAILED_LISTED]
        more = len(s.failed) - len(shown)
        lines += ["", "### Unsuccessful trials", "",
                  f"By trial{f'; the first {len(shown)} of {len(s.failed)}' if more else ''} "
                  "(rerun one with `navstack run WORLD --seed SEED --controller C --planner P`, the world and seed "
                  "as on its line).", ""]
        lines += _table(["trial", "world", "method", "reason", "goals reached", "sim time [s]"], shown)
    return lines


def _distribution_section(s: Summary, plot_of: Mapping[str, str]) -> list[str]:
    lines = ["", "## Distributions", "", "Each over the trials that report the metric (`n`): an `error` trial reports "
             "none, so it is in no table below."]
    if s.retracted_by_method:
        lines[-1] += (" A trial of a world that asks for retraction succeeds when it is back out: its time to goal "
                      "is that of the whole trial, backing out included.")
    for metric, title, png in METRICS:
        lines += ["", f"### {title}", ""]
        lines += _table(["controller", "planner", "n", "min", "p10", "median", "p90", "max", "mean"],
                        ([m[0], m[1], st.n, *(_fmt(x) for x in (st.min, st.p10, st.median, st.p90, st.max,
                                                                 st.mean))]
                         for m in s.methods for st in [s.stats(metric, m)]))
        if png in plot_of:
            lines += ["", f"![{title}]({plot_of[png]})"]
    return lines


def _provenance_section(s: Summary) -> list[str]:
    lines = ["", "## Provenance", "", "What produced the lines (`provenance` on each line of results.jsonl).", ""]
    rows = []
    for p in s.provenance:
        cells = ["(not recorded)", "-", "-", "-", "-"] if p.key is None else \
            ["-" if v is None else f"`{v}`" if i == 1 else str(v) for i, v in enumerate(p.key)]
        rows.append([*cells, ", ".join(p.backends) or "-", ", ".join(p.hosts) or "-", p.trials])
    lines += _table(["navstack", "commit", "python", "pybullet", "numpy", "backends", "hosts", "trials"], rows)
    named = [f"`{d[:12]}`" for d in s.settings if d]
    if not named:
        return lines + ["", "Trial settings: the defaults (`navstack settings` prints them)."]
    return lines + ["", "Trial settings: " + ("the defaults and " if "" in s.settings else "") + ", ".join(named)
                    + " (the SHA-256 of `trials --settings`; every setting is in sweep.json, `config.trial_settings`)."]


# --------------------------------------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------------------------------------


PLOT_FAMILIES = 24
"""The most families a plot draws (the first in the tables' order; the tables list every one): an audit's
results file of 1,500 families asked for a figure 6,000 inches wide and ran out of memory."""
MAX_FIGURE_INCHES = 40.0
"""The largest width or height of a plot [in] (so many methods cannot make a figure too large to draw)."""


def plain(text: str) -> str:
    """``text`` as matplotlib draws it literally: each ``$`` escaped, so a family or planner name is never read
    as mathtext (an audit: the family ``price $\\le$ 5`` stopped the report with matplotlib's parse error)."""
    return text.replace("$", r"\$")


def _figure(width: float = 7.0, height: float = 4.0) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(min(width, MAX_FIGURE_INCHES), min(height, MAX_FIGURE_INCHES)), layout="constrained")


def _left_out(families: Sequence[str]) -> str | None:
    """What a plot of the first :data:`PLOT_FAMILIES` of ``families`` says it leaves out, or None."""
    if len(families) <= PLOT_FAMILIES:
        return None
    return f"the first {PLOT_FAMILIES} of {len(families)} families (the tables list every one)"


def write_plots(s: Summary, folder: Path) -> list[Path]:
    """Write the PNG plots of ``s`` into ``folder``; returns their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    labels = [plain(method_label(m)) for m in s.methods]
    paths = [_plot_success_rate(s, labels, folder / "success_rate.png")]
    by_difficulty = _plot_success_vs_difficulty(s, labels, folder / "success_vs_difficulty.png")
    if by_difficulty is not None:
        paths.append(by_difficulty)
    paths.append(_plot_failure_causes(s, labels, folder / "failure_causes.png"))
    for metric, title, png in METRICS:
        paths.append(_plot_metric(s, labels, metric, title, folder / png))
    return paths


def _plot_success_rate(s: Summary, labels: Sequence[str], path: Path) -> Path:
    """Bars of each method's success rate per family and over all, with their intervals."""
    k = len(s.methods)
    width = 0.8 / max(k, 1)
    shown = list(s.families[:PLOT_FAMILIES])
    fig = _figure(max(6.0, 1.2 * (len(shown) + 1) * max(k, 1) * 0.6 + 3))
    ax = fig.add_subplot()
    if _left_out(s.families):
        ax.set_title(_left_out(s.families), fontsize="small")
    groups = [*shown, "all"]
    for j, m in enumerate(s.methods):
        rates = [s.by_family[(f, m)] if (f, m) in s.by_family else None for f in shown] + [s.by_method[m]]
        x = np.arange(len(groups)) + (j - (k - 1) / 2) * width
        y = np.array([r.rate if r else np.nan for r in rates])
        err = np.array([[r.rate - r.ci_low, r.ci_high - r.rate] if r else [0, 0] for r in rates]).T
        ax.bar(x, y, width, yerr=err, capsize=3, label=labels[j])
    ax.set_xticks(np.arange(len(groups)), [plain(g) for g in groups])
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success rate (95 % Wilson CI)")
    ax.legend(fontsize="small")
    fig.savefig(path, dpi=110)
    return path


def _plot_success_vs_difficulty(s: Summary, labels: Sequence[str], path: Path) -> Path | None:
    """Each family's success rate against difficulty (None: fewer than two difficulties)."""
    k = len(s.methods)
    diffs = [d for d in s.difficulties if d is not None]
    fams = [f for f in s.families if any((f, d, m) in s.by_cell for d in diffs for m in s.methods)]
    if len(diffs) <= 1 or not fams:
        return None
    shown = fams[:PLOT_FAMILIES]
    cols = min(len(shown), 6)
    rows = -(-len(shown) // cols)
    fig = _figure(4.0 * cols, 3.5 * rows)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    if _left_out(fams):
        fig.suptitle(_left_out(fams), fontsize="small")
    for ax in axes[len(shown):]:
        ax.set_visible(False)
    for ax, fam in zip(axes, shown, strict=False):
        for j, m in enumerate(s.methods):
            pts = [(d, s.by_cell[(fam, d, m)]) for d in diffs if (fam, d, m) in s.by_cell]
            if not pts:
                continue
            x = np.array([d for d, _ in pts])
            y = np.array([r.rate for _, r in pts])
            err = np.array([[r.rate - r.ci_low, r.ci_high - r.rate] for _, r in pts]).T
            ax.errorbar(x + (j - (k - 1) / 2) * 0.005, y, yerr=err, marker="o", capsize=3, label=labels[j])
        ax.set_title(plain(fam))
        ax.set_xlabel("difficulty")
        ax.set_ylim(-0.02, 1.05)
    axes[0].set_ylabel("success rate")
    axes[0].legend(fontsize="small")
    fig.savefig(path, dpi=110)
    return path


def _plot_failure_causes(s: Summary, labels: Sequence[str], path: Path) -> Path:
    """Each method's unsuccessful trials, stacked by reason."""
    k = len(s.methods)
    fig = _figure(max(5.0, 1.5 * k + 2))
    ax = fig.add_subplot()
    bottom = np.zeros(k)
    for reason in REASONS:
        counts = np.array([s.reasons[m].get(reason, 0) for m in s.methods], dtype=float)
        if counts.any():
            ax.bar(np.arange(k), counts, 0.6, bottom=bottom, label=reason)
            bottom += counts
    ax.set_xticks(np.arange(k), labels)
    ax.set_ylabel("unsuccessful trials")
    if bottom.any():
        ax.legend(fontsize="small")
    else:
        ax.text(0.5, 0.5, "no failures", ha="center", va="center", transform=ax.transAxes)
    fig.savefig(path, dpi=110)
    return path


def _plot_metric(s: Summary, labels: Sequence[str], metric: str, title: str, path: Path) -> Path:
    """Box plots of one metric's values per method."""
    k = len(s.methods)
    fig = _figure(max(5.0, 1.5 * k + 2))
    ax = fig.add_subplot()
    data = [(i, s.values[metric].get(m, ())) for i, m in enumerate(s.methods)]
    data = [(i, v) for i, v in data if v]
    if data:
        ax.boxplot([list(v) for _, v in data], positions=[i for i, _ in data], widths=0.5)
    else:
        ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
    if metric == "min_clearance":
        ax.axhline(0.0, color="red", lw=0.8, ls="--")
    ax.set_xticks(np.arange(k), labels)
    ax.set_xlim(-0.6, k - 0.4)
    ax.set_title(title)
    fig.savefig(path, dpi=110)
    return path


def write_report(directory: str | Path, *, plots: bool = True) -> Path:
    """Summarise ``directory/results.jsonl`` into ``directory/report.md`` (+ ``directory/plots/*.png``).

    Returns the path of ``report.md``. Raises :class:`ReportError` (file and line) for unusable results.
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise ReportError(f"{directory}: not a directory")
    loaded = load_results(directory / "results.jsonl")
    summary = summarize(loaded.records, checked=True)  # load_results has checked every line
    pngs = write_plots(summary, directory / PLOTS_DIR) if plots else []
    text = render_markdown(summary, plots=[f"{PLOTS_DIR}/{p.name}" for p in pngs],
                           truncated_tail=loaded.truncated_tail, planned=loaded.planned)
    out = directory / "report.md"
    out.write_text(text, encoding="utf-8")
    return out


# --------------------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``navstack report`` arguments to ``parser``."""
    parser.add_argument("dir", metavar="DIR", help="sweep directory holding results.jsonl")
    parser.add_argument("--no-plots", action="store_true", help="write report.md only")


def run_from_args(args: argparse.Namespace) -> int:
    """Run ``navstack report``; exit status 0, or 2 for unusable input (message on stderr)."""
    try:
        path = write_report(args.dir, plots=not args.no_plots)
    except ReportError as exc:
        print(f"navstack report: error: {exc}", file=sys.stderr)
        return 2
    if "**Warning: this sweep mixes software versions**" in path.read_text(encoding="utf-8"):
        print(f"navstack report: warning: {args.dir} mixes software versions (see Provenance in {path})",
              file=sys.stderr)
    print(path)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m navstack.report DIR``."""
    parser = argparse.ArgumentParser(prog="navstack report", description=__doc__.split("\n")[0])
    add_arguments(parser)
    return run_from_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
