"""Robustness on randomised scenes (not a test). Prints a line per scene, then ONE line of JSON.

Each seed's scene (`aida_kb.synth.randomised.random_scene`: any building preset with random
sizes, an asymmetric gable, the turntable box, or no building at all; random cameras, 1-8
views, light, shadows, occluders, distortion, exposure, ground and labels) is rendered,
reconstructed with kb/buildings.kb exactly as `aida-kb reconstruct` does, and judged by
`aida_kb.interpret.evaluate.evaluate`: correct = the right outcome (nothing where there is no
house), the right specialisations, normals within 0.5 deg, vertices within 2 % of the size,
every camera within 0.1 deg and 1 % of its distance.

Scenes with labels.png and without are reported apart. The seeds reported by default
(10000 ...) were never looked at while the code was developed (development used seeds below
3000). Figures: correct_rate, wrong_accepted_rate (verified but not correct), doubtful_rate,
nothing_rate (nothing found), error_rate, the correct rate per kind, nothing found in the
scenes without a house, and the count of each failure cause.

Run: ``.venv/bin/python benchmarks/robustness.py [--count 100] [--start 10000] [--jobs 1]``
(about half a minute per scene on one core). ``--keep DIR`` keeps every scene and result in
DIR; ``--rejudge DIR`` judges the kept results again with the current verdict (no rendering,
no reconstruction: seconds each) and reports the seeds of the range found there.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from aida_kb.interpret.robustness import SceneOutcome, rejudge_scene, run_random_scene
from aida_kb.kb import compile_path
from aida_kb.kb.model import KnowledgeBase

KB = Path(__file__).resolve().parents[1] / "kb" / "buildings.kb"


def _knowledge() -> KnowledgeBase:
    """kb/buildings.kb compiled; a clear one-line message (and exit 1) when it does not
    compile (edited while a long run goes on)."""
    result = compile_path(KB)
    if result.kb is None:
        first = next((str(d) for d in result.diagnostics), "no diagnostics")
        raise SystemExit(f"{KB}: does not compile: {first}")
    return result.kb


def _one(args: tuple[int, int, int, str]) -> SceneOutcome:
    seed, max_views, max_width, keep = args
    kb = _knowledge()
    if keep:
        return run_random_scene(kb, seed, keep, max_views=max_views, max_width=max_width)
    with tempfile.TemporaryDirectory(prefix="aida-robust-") as tmp:
        return run_random_scene(kb, seed, tmp, max_views=max_views, max_width=max_width)


def _rejudged(folder: str, seeds: range) -> list[SceneOutcome]:
    kb = _knowledge()
    rows = [rejudge_scene(kb, s, folder) for s in seeds]
    return [r for r in rows if r is not None]


def _line(r: SceneOutcome) -> str:
    return (
        f"seed {r.seed} {r.kind:<17} labels={int(r.labels)} views={r.views} "
        f"{r.outcome:<8} {'correct' if r.correct else 'WRONG ' + r.cause} "
        f"({r.seconds:.0f} s) {json.dumps(r.figures)}"
    )


def _rates(rows: list[SceneOutcome]) -> dict[str, object]:
    n = len(rows)
    if n == 0:
        return {"scenes": 0}

    def rate(k: int) -> float:
        return round(k / n, 3)

    by_kind: dict[str, list[bool]] = defaultdict(list)
    for r in rows:
        by_kind[r.kind].append(r.correct)
    empty = [r for r in rows if not r.figures.get("expected_object", True)]
    return {
        "scenes": n,
        "correct_rate": rate(sum(r.correct for r in rows)),
        "wrong_accepted_rate": rate(sum(r.wrong_accepted for r in rows)),
        "doubtful_rate": rate(sum(r.outcome == "doubtful" for r in rows)),
        "nothing_rate": rate(sum(r.outcome == "nothing" for r in rows)),
        "error_rate": rate(sum(r.outcome == "error" for r in rows)),
        "no_object_nothing_found": f"{sum(r.outcome == 'nothing' for r in empty)}/{len(empty)}",
        "correct_by_kind": {
            k: f"{sum(v)}/{len(v)}" for k, v in sorted(by_kind.items(), key=lambda kv: kv[0])
        },
        "causes": dict(Counter(r.cause for r in rows if not r.correct).most_common()),
    }


def main() -> None:
    """Run the scenes, print one line each (stderr) and the JSON summary (stdout)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=100, help="number of scenes (default 100)")
    ap.add_argument("--start", type=int, default=10000, help="first seed (default 10000)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--max-views", type=int, default=8, help="cap on the views (default 8)")
    ap.add_argument("--max-width", type=int, default=800, help="cap on image width (800)")
    ap.add_argument("--keep", default="", help="keep scenes and results in this folder")
    ap.add_argument("--rejudge", default="", help="judge the results kept in this folder again")
    args = ap.parse_args()
    rows: list[SceneOutcome] = []
    if args.rejudge:
        rows = _rejudged(args.rejudge, range(args.start, args.start + args.count))
        for r in rows:
            print(_line(r), file=sys.stderr, flush=True)
    else:
        if args.keep:
            Path(args.keep).mkdir(parents=True, exist_ok=True)
        seeds = [
            (s, args.max_views, args.max_width, args.keep)
            for s in range(args.start, args.start + args.count)
        ]
        with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            for r in pool.map(_one, seeds):
                rows.append(r)
                print(_line(r), file=sys.stderr, flush=True)
    summary = {
        "benchmark": "robustness",
        "seeds": f"{args.start}..{args.start + args.count - 1}",
        "rejudged": bool(args.rejudge),
        "max_views": args.max_views,
        "max_width": args.max_width,
        "all": _rates(rows),
        "with_labels": _rates([r for r in rows if r.labels]),
        "without_labels": _rates([r for r in rows if not r.labels]),
        "median_seconds": sorted(r.seconds for r in rows)[len(rows) // 2] if rows else None,
    }
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
