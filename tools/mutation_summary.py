"""Summarise a cosmic-ray session of tools/mutation.sh; optionally re-test its survivors with more tests.

    python tools/mutation_summary.py SESSION [--confirm CONFIG --tree DIR]

Prints the kill rate (killed / tested; operators left out by the configuration's filter are not counted)
and every surviving mutant as ``line: operator: the changed line``. With ``--confirm`` each survivor is
applied again to the scratch tree ``DIR`` and run against the configuration's ``confirm-command`` (a larger
test selection than the per-mutant ``test-command``, e.g. whole closed-loop trials); a survivor that fails
there counts as killed. The results are kept in ``SESSION.confirm.json`` so a rerun does not redo them.
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path


def _records(session: Path) -> list[tuple[dict, dict]]:
    out = subprocess.run([str(Path(sys.executable).parent / "cosmic-ray"), "dump", str(session)],
                         capture_output=True, text=True, check=True).stdout
    return [tuple(json.loads(line)) for line in out.splitlines() if line.strip()]


def _changed_line(diff: str) -> str:
    plus = [ln[1:].strip() for ln in diff.splitlines() if ln.startswith("+") and not ln.startswith("+++")]
    return plus[0] if plus else "?"


def _confirm(survivors, cfg_path: Path, tree: Path, cache: Path) -> dict[str, bool]:
    import tomllib

    cfg = tomllib.loads(cfg_path.read_text())["cosmic-ray"]
    command = cfg.get("confirm-command")
    if not command:
        raise SystemExit(f"{cfg_path} has no confirm-command")
    done: dict[str, bool] = json.loads(cache.read_text()) if cache.exists() else {}
    cr = str(Path(sys.executable).parent / "cosmic-ray")
    for item, _ in survivors:
        job = item["job_id"]
        if job in done:
            continue
        (m,) = item["mutations"]
        path = tree / m["module_path"]
        backup = path.with_name(path.name + ".orig")
        shutil.copy2(path, backup)
        try:
            subprocess.run([cr, "apply", m["module_path"], m["operator_name"], str(m["occurrence"])],
                           cwd=tree, check=True, capture_output=True)
            run = subprocess.run(shlex.split(command), cwd=tree, capture_output=True, text=True,
                                 timeout=float(cfg.get("timeout", 3600)) * 4)
            done[job] = run.returncode != 0
        except subprocess.TimeoutExpired:
            done[job] = True
        finally:
            shutil.move(backup, path)
        cache.write_text(json.dumps(done, indent=1))
        print(f"confirm {m['start_pos'][0]}: {m['operator_name']}: {'killed' if done[job] else 'survived'}",
              flush=True)
    return done


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("session", type=Path)
    ap.add_argument("--confirm", type=Path, help="the module's configuration (mutation/MODULE.toml)")
    ap.add_argument("--tree", type=Path, help="the scratch tree tools/mutation.sh made (OUT_DIR/tree)")
    args = ap.parse_args(argv)
    records = _records(args.session)
    tested = [(i, r) for i, r in records if r and r.get("worker_outcome") == "normal"]
    pending = sum(1 for _, r in records if not r)
    survivors = [(i, r) for i, r in tested if r["test_outcome"] == "survived"]
    confirmed: dict[str, bool] = {}
    if args.confirm is not None:
        if args.tree is None:
            raise SystemExit("--confirm needs --tree")
        confirmed = _confirm(survivors, args.confirm, args.tree.resolve(),
                             args.session.with_name(args.session.name + ".confirm.json"))
    left = [(i, r) for i, r in survivors if not confirmed.get(i["job_id"], False)]
    killed = len(tested) - len(left)
    module = records[0][0]["mutations"][0]["module_path"] if records else "?"
    print(f"{module}: {killed}/{len(tested)} mutants killed ({100.0 * killed / max(len(tested), 1):.1f} %), "
          f"{len(left)} survived" + (f" ({len(survivors) - len(left)} more killed by the confirm-command)"
                                     if confirmed else "") + (f"; {pending} not run yet" if pending else ""))
    for item, result in sorted(left, key=lambda ir: ir[0]["mutations"][0]["start_pos"]):
        m = item["mutations"][0]
        print(f"  {m['start_pos'][0]:4d} {m.get('definition_name') or ''}: {m['operator_name'].split('/')[-1]}: "
              f"{_changed_line(result.get('diff') or '')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
