"""Compare the success rates of two sweeps (``navstack compare DIR_A DIR_B``, interfaces.md section 4).

For each method (controller/planner) and world family, and for each method over all families, the two
success rates, their difference ``B - A`` with a 95 % confidence interval, and a two-sided p-value:

* **paired**, when both sweeps ran exactly the same trials of that row (the same worlds, identified by
  ``world_id`` (else ``world``), ``world_seed``, ``difficulty``, and the same noise ``seed``): McNemar's exact
  test (a binomial test of the discordant pairs, ``scipy.stats.binomtest``) and Newcombe's interval for paired
  data (method 10 of Newcombe 1998, Stat. Med. 17:2635, from the two Wilson intervals and the phi
  correlation of the 2x2 table);
* **unpaired** otherwise: Fisher's exact test (``scipy.stats.fisher_exact``) and Newcombe's hybrid score
  interval (method 10 of Newcombe 1998, Stat. Med. 17:873).

A row whose sweeps share only some of their trials is unpaired (the spec pairs identical trial sets); as
Fisher's test then takes the shared trials for independent samples, a line under the table gives McNemar's
exact test on the shared trials alone.

Methods are matched by name; when each sweep holds a single method and the names differ (a sweep of planner
``field`` against one of ``scripted``), those two are compared. The Wilson intervals are scipy's
(``binomtest(k, n).proportion_ci(method="wilson")``).

Output: Markdown (printed; with ``--out DIR`` also ``DIR/compare.md``) and ``DIR/compare.png``, the
differences with their intervals.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navstack.report import (
    NO_FAMILY,
    POOLED,
    ReportError,
    family_label,
    load_results,
    md_cell,
    method_label,
    plain,
    sweep_notes,
)

ALL_FAMILIES = POOLED
CONFIDENCE = 0.95
Method = tuple[str, str]


# --------------------------------------------------------------------------------------------------------
# Intervals and tests
# --------------------------------------------------------------------------------------------------------


def wilson(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson score interval of ``k`` successes in ``n`` trials (scipy)."""
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def newcombe_unpaired(k_a: int, n_a: int, k_b: int, n_b: int,
                      confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Newcombe's hybrid score interval for ``k_b/n_b - k_a/n_a`` (independent samples)."""
    pa, pb = k_a / n_a, k_b / n_b
    la, ua = wilson(k_a, n_a, confidence)
    lb, ub = wilson(k_b, n_b, confidence)
    d = pb - pa
    return d - math.hypot(pb - lb, ua - pa), d + math.hypot(ub - pb, pa - la)


def newcombe_paired(both: int, a_only: int, b_only: int, neither: int,
                    confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Newcombe's interval (method 10) for ``p_B - p_A`` from a paired 2x2 table.

    ``both``: pairs where A and B succeeded; ``a_only`` / ``b_only``: only A / only B succeeded;
    ``neither``. phi is the table's correlation with Newcombe's continuity correction of the numerator.
    """
    n = both + a_only + b_only + neither
    pa, pb = (both + a_only) / n, (both + b_only) / n
    la, ua = wilson(both + a_only, n, confidence)
    lb, ub = wilson(both + b_only, n, confidence)
    num = both * neither - a_only * b_only
    num = num - n / 2 if num > n / 2 else (num if num < 0 else 0.0)
    den = math.sqrt(float((both + a_only) * (b_only + neither) * (both + b_only) * (a_only + neither)))
    phi = num / den if den > 0 else 0.0
    # Newcombe's Delta = p_A - p_B has limits Delta - delta, Delta + eps; B - A is the mirror image
    delta = math.sqrt(max(0.0, (pa - la) ** 2 - 2 * phi * (pa - la) * (ub - pb) + (ub - pb) ** 2))
    eps = math.sqrt(max(0.0, (ua - pa) ** 2 - 2 * phi * (ua - pa) * (pb - lb) + (pb - lb) ** 2))
    d = pa - pb
    return -(d + eps), -(d - delta)


def mcnemar_exact(a_only: int, b_only: int) -> float:
    """Two-sided p-value of McNemar's exact test (binomial test of the discordant pairs at 1/2)."""
    from scipy.stats import binomtest

    m = a_only + b_only
    return 1.0 if m == 0 else float(binomtest(b_only, m, 0.5).pvalue)


def fisher_exact_p(k_a: int, n_a: int, k_b: int, n_b: int) -> float:
    """Two-sided p-value of Fisher's exact test of ``k_a/n_a`` against ``k_b/n_b``."""
    from scipy.stats import fisher_exact

    return float(fisher_exact([[k_a, n_a - k_a], [k_b, n_b - k_b]]).pvalue)


# --------------------------------------------------------------------------------------------------------
# Rows
# --------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Row:
    """One comparison: method in A and in B, family (or :data:`ALL_FAMILIES`), counts, ``diff = rate_b - rate_a``
    with its interval, the p-value and the test; for paired rows the discordant counts."""

    method_a: Method
    method_b: Method
    family: str
    n_a: int
    k_a: int
    n_b: int
    k_b: int
    paired: bool
    a_only: int
    b_only: int
    diff: float
    ci_low: float
    ci_high: float
    p_value: float
    shared: tuple[int, int, int] = (0, 0, 0)
    """An unpaired row's trials run by both sweeps (a partial overlap): how many, and how many of them only A,
    only B succeeded in; (0, 0, 0) for paired rows and for sweeps with no trial in common."""

    @property
    def test(self) -> str:
        return "McNemar exact" if self.paired else "Fisher exact"

    @property
    def label(self) -> str:
        m = method_label(self.method_a)
        return m if self.method_a == self.method_b else f"{m} vs {method_label(self.method_b)}"


WORLD_HASH = "_world_sha256"
"""The key :func:`run_compare` adds to each record read from a sweep folder: the SHA-256 of its world file as
that sweep's ``sweep.json`` stored it (when both sweeps store them), so an edited world is another world."""


def trial_key(rec: Mapping[str, Any]) -> tuple[Any, ...]:
    """What makes two records the same trial apart from the method: the world (its id, its name and, when
    known, its file's SHA-256: two folders of world files may use the same file names for other worlds) and the
    noise seed."""
    return (rec.get("world_id", rec.get("world")), rec.get("world"), rec.get(WORLD_HASH), rec.get("world_seed"),
            rec.get("difficulty"), rec.get("seed"))


def _with_world_hashes(records: Sequence[Mapping[str, Any]], hashes: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Copies of ``records``, each with :data:`WORLD_HASH`: its ``world_file``'s stored hash (None: none)."""
    return [{**r, WORLD_HASH: hashes.get(r["world_file"]) if isinstance(r.get("world_file"), str) else None}
            for r in records]


def compare_rows(recs_a: Sequence[Mapping[str, Any]], recs_b: Sequence[Mapping[str, Any]], method_a: Method,
                 method_b: Method, family: str) -> Row:
    """The :class:`Row` of two non-empty record lists (paired when they hold the same trials)."""
    n_a, n_b = len(recs_a), len(recs_b)
    k_a = sum(r["success"] is True for r in recs_a)
    k_b = sum(r["success"] is True for r in recs_b)
    by_a = {trial_key(r): r for r in recs_a}
    by_b = {trial_key(r): r for r in recs_b}
    paired = len(by_a) == n_a and len(by_b) == n_b and by_a.keys() == by_b.keys()
    a_only = b_only = 0
    if paired:
        a_only = sum(by_a[k]["success"] is True and by_b[k]["success"] is not True for k in by_a)
        b_only = sum(by_b[k]["success"] is True and by_a[k]["success"] is not True for k in by_a)
        both = sum(by_a[k]["success"] is True and by_b[k]["success"] is True for k in by_a)
        lo, hi = newcombe_paired(both, a_only, b_only, n_a - both - a_only - b_only)
        p = mcnemar_exact(a_only, b_only)
    else:
        lo, hi = newcombe_unpaired(k_a, n_a, k_b, n_b)
        p = fisher_exact_p(k_a, n_a, k_b, n_b)
    common = by_a.keys() & by_b.keys() if not paired else set()
    shared = (len(common), sum(by_a[k]["success"] is True and by_b[k]["success"] is not True for k in common),
              sum(by_b[k]["success"] is True and by_a[k]["success"] is not True for k in common))
    return Row(method_a, method_b, family, n_a, k_a, n_b, k_b, paired, a_only, b_only, k_b / n_b - k_a / n_a,
               lo, hi, p, shared)


def _method(r: Mapping[str, Any]) -> Method:
    return (r["controller"], r["planner"])


def match_methods(a: Sequence[Method], b: Sequence[Method]) -> list[tuple[Method, Method]]:
    """Methods compared: those in both sweeps; or the single method of each when they differ."""
    common = [m for m in a if m in b]
    if common:
        return [(m, m) for m in common]
    if len(a) == 1 and len(b) == 1:
        return [(a[0], b[0])]
    return []


def compare(records_a: Sequence[Mapping[str, Any]], records_b: Sequence[Mapping[str, Any]]) -> list[Row]:
    """Every row: per matched method, one per family present in both sweeps, then all families pooled."""
    methods_a = sorted({_method(r) for r in records_a})
    methods_b = sorted({_method(r) for r in records_b})
    rows = []
    for ma, mb in match_methods(methods_a, methods_b):
        ra = [r for r in records_a if _method(r) == ma]
        rb = [r for r in records_b if _method(r) == mb]
        fams_a = {family_label(r) for r in ra}
        fams_b = {family_label(r) for r in rb}
        for fam in sorted(fams_a & fams_b, key=lambda f: (f == NO_FAMILY, f)):
            rows.append(compare_rows([r for r in ra if family_label(r) == fam],
                                     [r for r in rb if family_label(r) == fam], ma, mb, fam))
        rows.append(compare_rows(ra, rb, ma, mb, ALL_FAMILIES))
    return rows


# --------------------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------------------


def _fmt_p(p: float) -> str:
    return f"{p:.3g}" if p >= 1e-4 else f"{p:.1e}"


def _identities(records: Sequence[Mapping[str, Any]]) -> str:
    from navstack.provenance import version_key

    keys = sorted({version_key(r.get("provenance")) for r in records}, key=repr)
    names = ["no provenance" if k is None else f"navstack {k[0]}" + (f" @ {str(k[1])[:12]}" if k[1] else "")
             for k in keys]
    return ", ".join(names) + (" **(mixed versions)**" if len(keys) > 1 else "")


def _errors(records: Sequence[Mapping[str, Any]]) -> str:
    """How many trials ended in ``error`` (as ``navstack report`` counts them: failures, but of the run, not of
    the method), or nothing when none did."""
    n = sum(1 for r in records if r.get("reason") == "error")
    return f"; {n} ended in `error` (the trial crashed, exceeded its wall-clock limit, or its world file was " \
        "refused as bad input), counted as failures" \
        if n else ""


def render_markdown(rows: Sequence[Row], dir_a: str, dir_b: str, records_a: Sequence[Mapping[str, Any]],
                    records_b: Sequence[Mapping[str, Any]], plot: str | None = None,
                    notes: Sequence[str] = ()) -> str:
    """The comparison as Markdown; ``plot`` is the PNG's path relative to the Markdown file; ``notes``: lines
    said under the two sweeps (:func:`navstack.report.sweep_notes`)."""
    lines = ["# navstack sweep comparison", "",
             f"- A: `{dir_a}`, {len(records_a)} trials ({_identities(records_a)}){_errors(records_a)}",
             f"- B: `{dir_b}`, {len(records_b)} trials ({_identities(records_b)}){_errors(records_b)}", "",
             *(line for note in notes for line in (note, "")),
             "Difference = success rate of B minus A, with a 95 % confidence interval and a two-sided p-value. "
             "Paired rows (both sweeps ran the same worlds, by id, name and, where both sweeps store them, world "
             "file contents, with the same seeds): Newcombe's interval for paired "
             "data and McNemar's exact test; `A only` / `B only` count the trials only A / only B succeeded "
             "in. Unpaired rows: Newcombe's hybrid score interval and Fisher's exact test.", ""]
    header = ["method", "family", "A", "B", "rate A", "rate B", "B - A", "95 % CI", "p", "test", "A only",
              "B only"]
    lines += ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        cells = [r.label, r.family, f"{r.k_a}/{r.n_a}", f"{r.k_b}/{r.n_b}", f"{r.k_a / r.n_a:.3f}",
                 f"{r.k_b / r.n_b:.3f}", f"{r.diff:+.3f}", f"[{r.ci_low:+.3f}, {r.ci_high:+.3f}]",
                 _fmt_p(r.p_value), r.test, str(r.a_only) if r.paired else "-", str(r.b_only) if r.paired else "-"]
        lines.append("| " + " | ".join(md_cell(c) for c in cells) + " |")
    methods_a = {_method(r) for r in records_a}
    methods_b = {_method(r) for r in records_b}
    used_a, used_b = {r.method_a for r in rows}, {r.method_b for r in rows}
    for name, left in (("A", sorted(methods_a - used_a)), ("B", sorted(methods_b - used_b))):
        if left:
            lines += ["", f"Only in {name} (not compared): " + ", ".join(method_label(m) for m in left)]
    lines += _partly_shared(rows)
    lines += _one_sided_families(rows, records_a, records_b)
    if plot:
        lines += ["", f"![Differences B - A with 95 % intervals]({plot})"]
    return "\n".join(lines) + "\n"


def _partly_shared(rows: Sequence[Row]) -> list[str]:
    """Lines naming the unpaired rows whose sweeps share some trials (only identical trial sets are paired): Fisher's
    test takes the shared trials as independent samples, which they are not, so its p-value can mislead either
    way; McNemar's exact test on the shared trials alone is given beside it."""
    out = []
    for r in rows:
        n, a_only, b_only = r.shared
        if n:
            out.append(f"- {md_cell(r.label)}, {md_cell(r.family)}: {n} of the trials (A {r.n_a}, B {r.n_b}) were run "
                       f"by both; on those alone, A only {a_only}, B only {b_only}, McNemar exact "
                       f"p = {_fmt_p(mcnemar_exact(a_only, b_only))}")
    if out:
        out = ["", "Unpaired rows whose sweeps share some trials (a row is paired only when both ran the same "
                   "trials; Fisher's test takes the shared ones as independent, which they are not):"] + out
    return out


def _one_sided_families(rows: Sequence[Row], records_a: Sequence[Mapping[str, Any]],
                        records_b: Sequence[Mapping[str, Any]]) -> list[str]:
    """Lines naming, per compared method, the families only one sweep ran: they have no row of their own but
    are counted in the method's pooled row."""
    lines = []
    for ma, mb in dict.fromkeys((r.method_a, r.method_b) for r in rows):
        fa = {family_label(r) for r in records_a if _method(r) == ma}
        fb = {family_label(r) for r in records_b if _method(r) == mb}
        for name, only in (("A", sorted(fa - fb)), ("B", sorted(fb - fa))):
            if only:
                lines += ["", f"Families only in {name} for {method_label(ma)} (no row of their own; counted in "
                              f"{ALL_FAMILIES}): " + ", ".join(only)]
    return lines


PLOT_ROWS = 60
"""The most rows the plot draws: every method's pooled row, then family rows in the table's order (the table
has every one; 1,500 families made a figure 600 inches tall)."""


def write_plot(rows: Sequence[Row], path: Path) -> Path:
    """A horizontal error-bar plot of the rows' differences and intervals (at most :data:`PLOT_ROWS`)."""
    from matplotlib.figure import Figure

    every = rows
    if len(rows) > PLOT_ROWS:
        pooled = [r for r in rows if r.family == ALL_FAMILIES][:PLOT_ROWS]
        rest = [r for r in rows if r.family != ALL_FAMILIES][:PLOT_ROWS - len(pooled)]
        keep = {id(r) for r in pooled + rest}
        rows = [r for r in rows if id(r) in keep]  # in the table's order
    fig = Figure(figsize=(7.5, 1.0 + 0.4 * len(rows)), layout="constrained")
    ax = fig.add_subplot()
    if len(rows) < len(every):
        ax.set_title(f"{len(rows)} of the {len(every)} rows (the table has every one)", fontsize="small")
    y = np.arange(len(rows))[::-1]
    for paired, marker, label in ((True, "o", "paired (McNemar)"), (False, "s", "unpaired (Fisher)")):
        idx = [i for i, r in enumerate(rows) if r.paired == paired]
        if idx:
            d = np.array([rows[i].diff for i in idx])
            err = np.array([[rows[i].diff - rows[i].ci_low, rows[i].ci_high - rows[i].diff] for i in idx]).T
            ax.errorbar(d, y[idx], xerr=err, fmt=marker, capsize=3, label=label)
    ax.axvline(0.0, color="grey", lw=0.8, ls="--")
    ax.set_yticks(y, [plain(f"{r.label} | {r.family}") for r in rows])
    ax.set_xlim(-1.05, 1.05)
    ax.set_xlabel("success rate B - A (95 % CI)")
    ax.legend(fontsize="small")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def run_compare(dir_a: str | Path, dir_b: str | Path, out: str | Path | None = None,
                plots: bool = True) -> str:
    """Compare the sweeps in ``dir_a`` and ``dir_b``; returns the Markdown (also written to ``out`` if given).

    Raises :class:`navstack.report.ReportError` for unusable results or nothing to compare."""
    recs, notes, hashes = [], [], []
    for name, d in (("A", dir_a), ("B", dir_b)):
        if not Path(d).is_dir():
            raise ReportError(f"{d}: not a directory")
        loaded = load_results(Path(d) / "results.jsonl")
        recs.append(loaded.records)
        hashes.append(loaded.world_files)
        notes += sweep_notes(len(loaded.records), loaded.planned, loaded.truncated_tail, name,
                             f"{name}'s results file")
    if hashes[0] is not None and hashes[1] is not None:
        recs = [_with_world_hashes(r, h) for r, h in zip(recs, hashes, strict=True)]
    rows = compare(*recs)
    if not rows:
        raise ReportError(f"{dir_a} and {dir_b} have no controller/planner in common "
                          f"(A: {sorted({method_label(_method(r)) for r in recs[0]})}, "
                          f"B: {sorted({method_label(_method(r)) for r in recs[1]})})")
    plot = None
    if out is not None:
        out = Path(out)
        if out.exists() and not out.is_dir():
            raise ReportError(f"--out: {out} exists and is not a directory")
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ReportError(f"--out: cannot create {out}: {exc.strerror or exc}") from None
        if plots:
            plot = write_plot(rows, out / "compare.png").name
    text = render_markdown(rows, str(dir_a), str(dir_b), recs[0], recs[1], plot, notes)
    if out is not None:
        (Path(out) / "compare.md").write_text(text, encoding="utf-8")
    return text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``navstack compare`` arguments to ``parser``."""
    parser.add_argument("dir_a", metavar="DIR_A", help="sweep directory (the baseline, 'before')")
    parser.add_argument("dir_b", metavar="DIR_B", help="sweep directory compared with it ('after')")
    parser.add_argument("--out", metavar="DIR", default=None,
                        help="also write DIR/compare.md and the plot DIR/compare.png")
    parser.add_argument("--no-plots", action="store_true", help="with --out: write compare.md only")


def run_from_args(args: argparse.Namespace) -> int:
    """Run ``navstack compare``: Markdown on stdout; exit status 0, or 2 for unusable input."""
    try:
        out = Path(args.out) if args.out else None
        text = run_compare(args.dir_a, args.dir_b, out, plots=not args.no_plots)
    except (ReportError, OSError) as exc:
        print(f"navstack compare: error: {exc}", file=sys.stderr)
        return 2
    print(text, end="")
    if out is not None:
        print(f"wrote {out / 'compare.md'}" + ("" if args.no_plots else f" and {out / 'compare.png'}"),
              file=sys.stderr)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m navstack.compare DIR_A DIR_B``."""
    parser = argparse.ArgumentParser(prog="navstack compare", description=__doc__.split("\n")[0])
    add_arguments(parser)
    return run_from_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
