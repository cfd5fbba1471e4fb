"""Reconstructions of scenes aida-kb did not render, judged against their truth (not a test).

The scenes come from elsewhere: `benchmarks/blender/render_houses.py` renders houses with
Blender's path tracer and writes them in the scene format of docs/formats.md without
importing aida_kb; any other renderer that writes scene.yaml, calib.yaml, the images and
truth.json will do. Each scene is reconstructed as ``aida-kb reconstruct`` does, with the
knowledge its truth names (parameter ``knowledge``, a file under ``kb/``; buildings.kb
otherwise), and evaluated as ``aida-kb evaluate`` does (`aida_kb.interpret.evaluate`):
correct means the right specialisation, every plane normal within 0.5 deg, every vertex
within 2 % of the object's size and every registered camera within 0.1 deg and 1 % of its
distance. A result reported as verified that is not correct is a wrong acceptance — the
figure that must stay 0.

    .venv/bin/python benchmarks/independent.py /tmp/blender [--keep OUT]

Prints a line per scene, then ONE line of JSON: scenes, correct_rate, wrong_accepted_rate,
doubtful_rate, nothing_rate, error_rate, correct_by_kind and the failure causes.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

from aida_kb.errors import AidaError
from aida_kb.interpret.evaluate import evaluate
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.io.scene import read_scene
from aida_kb.kb import compile_path
from aida_kb.kb.model import KnowledgeBase

KB_DIR = Path(__file__).resolve().parent.parent / "kb"


def _knowledge(name: str, cache: dict[str, KnowledgeBase]) -> KnowledgeBase:
    """kb/NAME compiled once; exits with a one-line message when it does not compile."""
    if name not in cache:
        path = KB_DIR / Path(name).name
        result = compile_path(path)
        if result.kb is None:
            first = next((str(d) for d in result.diagnostics), "no diagnostics")
            raise SystemExit(f"{path}: does not compile: {first}")
        cache[name] = result.kb
    return cache[name]


def _one(scene_dir: Path, out_dir: Path, cache: dict[str, KnowledgeBase]) -> dict[str, object]:
    """Reconstruct and evaluate one scene: its row of the report."""
    try:
        scene = read_scene(scene_dir)
    except AidaError as exc:
        return {"scene": scene_dir.name, "outcome": "error", "correct": False, "cause": str(exc)}
    truth = scene.truth
    if truth is None:
        return {"scene": scene_dir.name, "outcome": "error", "correct": False, "cause": "no truth"}
    kind = str(truth.parameters.get("kind", truth.object))
    kb = _knowledge(str(truth.parameters.get("knowledge", "buildings.kb")), cache)
    start = time.perf_counter()
    try:
        result = reconstruct_scene(kb, scene_dir, out_dir)
    except AidaError as exc:
        return {
            "scene": scene_dir.name,
            "kind": kind,
            "outcome": "error",
            "correct": False,
            "cause": f"error: {type(exc).__name__}: {exc}",
        }
    judged = evaluate(result.interpretation, truth)
    return {
        "scene": scene_dir.name,
        "kind": kind,
        "outcome": judged.outcome,
        "correct": judged.correct,
        "cause": judged.cause,
        "seconds": round(time.perf_counter() - start, 1),
        **judged.summary(),
    }


def _rates(rows: list[dict[str, object]]) -> dict[str, object]:
    n = len(rows)
    if n == 0:
        return {"scenes": 0}

    def rate(k: int) -> float:
        return round(k / n, 3)

    by_kind: dict[str, list[bool]] = defaultdict(list)
    for r in rows:
        by_kind[str(r.get("kind", "?"))].append(bool(r["correct"]))
    return {
        "scenes": n,
        "correct_rate": rate(sum(bool(r["correct"]) for r in rows)),
        "wrong_accepted_rate": rate(
            sum(r["outcome"] == "verified" and not r["correct"] for r in rows)
        ),
        "doubtful_rate": rate(sum(r["outcome"] == "doubtful" for r in rows)),
        "nothing_rate": rate(sum(r["outcome"] == "nothing" for r in rows)),
        "error_rate": rate(sum(r["outcome"] == "error" for r in rows)),
        "correct_by_kind": {k: f"{sum(v)}/{len(v)}" for k, v in sorted(by_kind.items())},
        "causes": dict(Counter(str(r["cause"]) for r in rows if not r["correct"]).most_common()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "root",
        nargs="?",
        help="folder of scene folders (each with scene.yaml, truth.json); none: nothing to judge",
    )
    parser.add_argument(
        "--keep", help="write each reconstruction to KEEP/<scene> (else a temp dir)"
    )
    args = parser.parse_args()
    if args.root is None:  # `make bench` runs every script bare: say what is missing
        reason = "no scenes given: render them with benchmarks/blender/render_houses.py first"
        print(json.dumps({"benchmark": "independent", "scenes": 0, "reason": reason}))
        return
    root = Path(args.root)
    scenes = sorted(p.parent for p in root.glob("*/scene.yaml"))
    if not scenes:
        raise SystemExit(f"{root}: no scene folders (NAME/scene.yaml) in it")
    cache: dict[str, KnowledgeBase] = {}
    rows = []
    with tempfile.TemporaryDirectory(prefix="aida-independent-") as tmp:
        out_root = Path(args.keep) if args.keep else Path(tmp)
        for scene_dir in scenes:
            row = _one(scene_dir, out_root / scene_dir.name, cache)
            rows.append(row)
            verdict = "correct" if row["correct"] else f"WRONG {row['cause']}"
            print(f"{row['scene']} {row.get('kind', '?'):<6} {row['outcome']:<8} {verdict}")
            print("   " + json.dumps(row), file=sys.stderr)
    print(json.dumps({"benchmark": "independent", "root": str(root), **_rates(rows)}))


if __name__ == "__main__":
    main()
