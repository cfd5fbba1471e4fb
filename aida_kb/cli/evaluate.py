"""`aida-kb evaluate`: a reconstruction against the ground truth of its scene."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
checks (aida_kb.interpret.evaluate), the first that fails is the cause:
  outcome         an object found where truth.json has one, nothing where it has none
  specialisation  the concepts truth.json asks for (the roof's kind, the wing's)
  parts           no true part missing, no part that is not in the truth
  normals         every paired part's normal within 0.5 degrees
  vertices        every true vertex within 2% of the object's size
  cameras         every view's camera within 0.1 degrees and 1% of its distance
also named (no check): the true parts no view shows, neither their face (200 px) nor half
of an edge (from the rendered depth maps, synthetic scenes only): no interpretation can
measure them, so they are right only where the knowledge guesses right.
exit status: 0 correct, 1 not correct, 2 unreadable input.

examples:
  aida-kb synth house -o out/house
  aida-kb reconstruct kb/buildings.kb out/house -o out/house-model
  aida-kb evaluate out/house-model out/house
  aida-kb evaluate out/house-model out/house --json
a scene of several objects (aida-kb synth street, kb/street.kb) is judged object by object:
each true house against the reconstructed one nearest it; missed, invented or twice fail.
"""


def register(subparsers: Any) -> None:
    """Add the `evaluate` command."""
    p = subparsers.add_parser(
        "evaluate",
        help="compare a reconstruction (OUT_DIR) with a scene's truth.json",
        description=(
            "Compare the interpretation.json of a reconstruction with the scene's truth.json: "
            "the outcome, the specialisations chosen, plane normals, vertices (as % of the "
            "object's size) and camera poses."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("output", metavar="OUT_DIR", help="what `aida-kb reconstruct` wrote")
    p.add_argument("scene", metavar="SCENE_DIR", help="the scene directory, with truth.json")
    p.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Evaluate and print; exit 0 when the result is correct."""
    import json
    from pathlib import Path

    from aida_kb.cli._kbfiles import EXIT_ERRORS, EXIT_OK
    from aida_kb.errors import FormatError
    from aida_kb.interpret.evaluate import evaluate, format_evaluation
    from aida_kb.interpret.result import read_interpretation
    from aida_kb.interpret.sight import unseen_parts
    from aida_kb.io.scene import read_scene

    file = Path(args.output) / "interpretation.json"
    if not file.is_file():
        raise FormatError(f"{file}: no interpretation.json (run `aida-kb reconstruct` first)")
    interp = read_interpretation(file)
    scene = read_scene(args.scene)
    truth = scene.truth
    if truth is None:
        raise FormatError(f"{args.scene}: the scene has no truth.json to compare with")
    hidden = unseen_parts(scene)
    if interp.objects:  # several objects per scene: every true one against its own
        return _evaluate_objects(interp, truth, hidden, as_json=args.json)
    result = evaluate(interp, truth, unmeasurable=hidden)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        for line in format_evaluation(result):
            print(line)
    return EXIT_OK if result.correct else EXIT_ERRORS


def _evaluate_objects(interp: Any, truth: Any, hidden: Any, *, as_json: bool) -> int:
    """Every true object of a scene of several against the reconstructed one paired with it
    (`aida_kb.interpret.scene.evaluate_scene`); correct when each is, none is missed,
    invented or taken twice."""
    import json

    from aida_kb.cli._kbfiles import EXIT_ERRORS, EXIT_OK
    from aida_kb.interpret.scene import evaluate_scene

    role = interp.objects[0].role.split("[", 1)[0]
    rows = evaluate_scene(interp, truth, role, hidden)
    correct = all(r["status"] == "found" and r.get("correct") for r in rows)
    if as_json:
        print(json.dumps({"correct": correct, "objects": rows}))
    else:
        word = "correct" if correct else "NOT correct"
        print(f"{word}: {len(interp.objects)} objects found, {len(rows)} rows")
        for r in rows:
            if r["status"] != "found":
                print(f"  {r.get('truth') or r.get('object')}: {r['status']}")
                continue
            cause = "correct" if r.get("correct") else f"NOT correct ({r.get('cause')})"
            print(
                f"  {r['truth']} as {r['object']}: {cause}, {r['outcome']}; normals "
                f"{r['max_normal_error_deg']} deg, vertices {r['max_vertex_error_pct']}%"
            )
            unseen = r.get("unmeasurable")
            if isinstance(unseen, list) and unseen:
                print(f"    shown by no view: {', '.join(str(u) for u in unseen)}")
    return EXIT_OK if correct else EXIT_ERRORS
