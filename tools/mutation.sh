#!/usr/bin/env bash
# Mutation testing with cosmic-ray, one navstack module at a time (configurations in mutation/*.toml).
#
#   tools/mutation.sh MODULE [OUT_DIR]      MODULE: the name of a configuration mutation/MODULE.toml
#                                           (ls mutation/: estimate, trial, scene, mover_sweep, ...)
#
# Works on a scratch copy of the working tree (tracked and untracked, not ignored, files), so the mutants
# cosmic-ray writes to disk never touch your checkout; the numba cache is shared with the test suite's
# (tests/conftest.py keys it by a hash of the sources compiled code sees, so a mutated kernel is always
# recompiled and an unchanged one reused). Writes OUT_DIR (default runs/mutation/MODULE) /session.sqlite,
# report.txt (every surviving mutant with its diff) and summary.txt (kill rate, survivors; a configuration's
# confirm-command re-tests the survivors with more tests first); rerunning resumes an unfinished session.
# Needs the test and mutation extras (pip install -e '.[test,mutation]');
# PYTHON selects the interpreter (default .venv/bin/python); SAMPLE=N [SEED=S] tests a seeded random sample of
# N mutants instead of all (for slow modules; the kill rate is then an estimate); EXCLUDE="S1 S2" with it leaves out
# the mutants earlier sessions S1, S2 of the module tested (SAMPLE=100000 EXCLUDE=... runs all the rest).
set -euo pipefail
module=${1:?usage: tools/mutation.sh MODULE [OUT_DIR]}
repo=$(cd "$(dirname "$0")/.." && pwd)
cfg=$repo/mutation/$module.toml
[ -f "$cfg" ] || { echo "no configuration $cfg" >&2; exit 2; }
out=$(mkdir -p "${2:-$repo/runs/mutation/$module}" && cd "${2:-$repo/runs/mutation/$module}" && pwd)
py=${PYTHON:-$repo/.venv/bin/python}
bin=$(dirname "$py")
export PATH="$bin:$PATH" NAVSTACK_NUMBA_CACHE_ROOT=${NAVSTACK_NUMBA_CACHE_ROOT:-$repo/.pytest_cache/numba}
work=$out/tree
rm -rf "$work" && mkdir -p "$work"
(cd "$repo" && git ls-files -z --cached --others --exclude-standard | xargs -0 -I{} cp --parents {} "$work")
export PYTHONPATH=$work
cd "$work"
"$py" -c "import navstack, sys; assert navstack.__file__.startswith('$work'), navstack.__file__"
session=$out/session.sqlite
if [ ! -f "$session" ]; then
    "$bin/cosmic-ray" init "$cfg" "$session"
    "$bin/cr-filter-operators" "$session" "$cfg"
    "$bin/cr-filter-pragma" "$session"
    # shellcheck disable=SC2086  # EXCLUDE: space-separated session files
    if [ -n "${SAMPLE:-}" ]; then "$py" "$repo/tools/mutation_sample.py" "$session" "$SAMPLE" --seed "${SEED:-0}" \
        ${EXCLUDE:+--exclude $EXCLUDE}; fi
    "$bin/cosmic-ray" baseline "$cfg"
fi
"$bin/cosmic-ray" exec "$cfg" "$session"
"$bin/cr-report" "$session" --surviving-only --show-diff > "$out/report.txt" || true
confirm=()
if grep -q '^confirm-command' "$cfg"; then confirm=(--confirm "$cfg" --tree "$work"); fi
"$py" "$repo/tools/mutation_summary.py" "$session" "${confirm[@]}" | tee "$out/summary.txt"
