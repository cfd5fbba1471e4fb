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
from pathlib import Path

from aida_kb.errors import AidaError
from aida_kb.interpret.evaluate import evaluate
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.interpret.robustness import SceneOutcome, scene_rates
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


def _one(scene_dir: Path, out_dir: Path, cache: dict[str, KnowledgeBase]) -> SceneOutcome:
    """Reconstruct and evaluate one scene (its seed: the truth's, else 0)."""
    try:
        scene = read_scene(scene_dir)
    except AidaError as exc:
        return SceneOutcome.failed(0, "?", False, 0, type(exc).__name__, str(exc), 0.0)
    truth = scene.truth
    if truth is None:
        return SceneOutcome.failed(0, "?", False, 0, "FormatError", "no truth.json", 0.0)
    seed = int(float(truth.parameters.get("seed", 0)))
    kind = str(truth.parameters.get("kind", truth.object))
    labels = any(v.labels is not None for v in scene.views)
    kb = _knowledge(str(truth.parameters.get("knowledge", "buildings.kb")), cache)
    start = time.perf_counter()
    try:
        result = reconstruct_scene(kb, scene_dir, out_dir)
    except AidaError as exc:
        seconds = time.perf_counter() - start
        name = type(exc).__name__
        return SceneOutcome.failed(seed, kind, labels, len(scene.views), name, str(exc), seconds)
    judged = evaluate(result.interpretation, truth)
    return SceneOutcome.judged(
        seed, kind, labels, len(scene.views), judged, time.perf_counter() - start
    )


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
            verdict = "correct" if row.correct else f"WRONG {row.cause}"
            print(
                f"{scene_dir.name} {row.kind:<6} labels={int(row.labels)} views={row.views} "
                f"{row.outcome:<8} {verdict} ({row.seconds:.0f} s)"
            )
            print("   " + json.dumps(row.figures), file=sys.stderr)
    print(json.dumps({"benchmark": "independent", "root": str(root), **scene_rates(rows)}))


if __name__ == "__main__":
    main()
