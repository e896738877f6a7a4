#!/usr/bin/env bash
# Issue 11's 200-trial sweep timed on two revisions of navstack in one session, alternating, with the
# outcomes compared line by line (apart from wall_time and provenance).
#
#   bash tools/sweep_ab.sh [REV_A [REV_B [ROUNDS]]]     defaults: a2c3154 (before issue 11) HEAD 1
#
# Each revision is exported (git archive) into a scratch folder and imported through PYTHONPATH from a
# neutral working folder: started from the checkout, `python -m` would import the checkout's navstack
# whatever PYTHONPATH says. Each tree runs one warm-up trial first (numba compiles into its own cache).
# Needs the checkout's venv active (numpy, pybullet, ...: the dependencies both revisions share).
# Prints each run's wall time, the ratio A / B, and how many lines differ in outcome or step count.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
A=${1:-a2c3154}
B=${2:-HEAD}
ROUNDS=${3:-1}
work=$(mktemp -d /tmp/sweep_ab.XXXXXX)
cd "$work"
export NAVSTACK_NUMBA_CACHE_ROOT="$work/numba"  # revisions keying numba's cache (navstack/numba_cache.py) keep it here
SWEEP=(trials --generate truss cluttered-truss pipe-rack sphere-field --count 25 --seed 2026
       --controller slither --controller tip-only --jobs 2)

navstack_at() {  # navstack_at TREE ARGS...: the CLI of the revision exported into TREE
    local tree=$1
    shift
    PYTHONPATH="$tree" python -c 'import sys; from navstack.cli import main; sys.exit(main(sys.argv[1:]))' "$@"
}

for side in A B; do
    rev=${!side}
    mkdir -p "tree_$side"
    git -C "$repo" archive "$rev" navstack | tar -x -C "tree_$side"
    where=$(PYTHONPATH="tree_$side" python -c 'import navstack; print(navstack.__file__)')
    case "$where" in "$work/tree_$side/"*) ;; *) echo "sweep_ab: tree_$side imports $where" >&2; exit 1 ;; esac
    navstack_at "tree_$side" trials --generate truss --count 1 --seed 7 --jobs 1 --out "warm_$side" >/dev/null 2>&1
    echo "$side = $rev ($(git -C "$repo" rev-parse --short "$rev"))"
done

for ((i = 1; i <= ROUNDS; i++)); do
    for side in A B; do
        t0=$(date +%s.%N)
        navstack_at "tree_$side" "${SWEEP[@]}" --out "run_${side}_$i" >/dev/null 2>"run_${side}_$i.err"
        t1=$(date +%s.%N)
        echo "$side round $i: $(python -c "print(f'{$t1 - $t0:.1f}')") s" | tee -a times.txt
    done
done

python - "$ROUNDS" <<'EOF'
import collections
import json
import re
import statistics
import sys

rounds = int(sys.argv[1])
times = {"A": [], "B": []}
for line in open("times.txt"):
    m = re.match(r"(\w) round \d+: ([\d.]+) s", line)
    times[m[1]].append(float(m[2]))
a, b = statistics.median(times["A"]), statistics.median(times["B"])
print(f"median wall: A {a:.1f} s, B {b:.1f} s: A / B = {a / b:.2f}x")


def lines(folder):
    out = {}
    for text in open(f"{folder}/results.jsonl"):
        r = json.loads(text)
        out[(r["world"], r["seed"], r["controller"], r["planner"])] = r
    return out


A, B = lines("run_A_1"), lines("run_B_1")
keys = sorted(set(A) | set(B))
strip = ("wall_time", "provenance")
same = sum(1 for k in keys if k in A and k in B
           and {x: v for x, v in A[k].items() if x not in strip} == {x: v for x, v in B[k].items() if x not in strip})
outcome = sum(1 for k in keys if k in A and k in B and A[k]["success"] == B[k]["success"]
              and A[k]["reason"] == B[k]["reason"] and A[k]["goals_reached"] == B[k]["goals_reached"])
steps = sum(1 for k in keys if k in A and k in B and A[k]["steps"] == B[k]["steps"])
print(f"{len(keys)} trials ({len(A)} in A, {len(B)} in B): {outcome} with the same outcome, {steps} with the "
      f"same steps, {same} identical apart from wall_time and provenance; successes A {sum(r['success'] for r in A.values())}, "
      f"B {sum(r['success'] for r in B.values())}")
fields = collections.Counter()
for k in keys:
    if k in A and k in B:
        a, b = A[k], B[k]
        fields.update(x for x in set(a) | set(b) if x not in strip + ("metrics",) and a.get(x) != b.get(x))
        ma, mb = a.get("metrics") or {}, b.get("metrics") or {}
        fields.update(f"metrics.{m}" for m in set(ma) | set(mb) if ma.get(m) != mb.get(m))
print("fields that differ (trials):", ", ".join(f"{f} {n}" for f, n in sorted(fields.items())) or "none")
for k in keys:
    if k in A and k in B and (A[k]["success"], A[k]["reason"]) != (B[k]["success"], B[k]["reason"]):
        print(f"  differs: {k}: A {A[k]['reason']} ({A[k]['steps']} steps), B {B[k]['reason']} ({B[k]['steps']} steps)")
EOF
echo "sweep_ab: folders in $work"
