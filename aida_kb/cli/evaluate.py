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
exit status: 0 correct, 1 not correct, 2 unreadable input.

examples:
  aida-kb synth house -o out/house
  aida-kb reconstruct kb/buildings.kb out/house -o out/house-model
  aida-kb evaluate out/house-model out/house
  aida-kb evaluate out/house-model out/house --json
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
    from aida_kb.io.scene import read_scene

    file = Path(args.output) / "interpretation.json"
    if not file.is_file():
        raise FormatError(f"{file}: no interpretation.json (run `aida-kb reconstruct` first)")
    interp = read_interpretation(file)
    truth = read_scene(args.scene).truth
    if truth is None:
        raise FormatError(f"{args.scene}: the scene has no truth.json to compare with")
    result = evaluate(interp, truth)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        for line in format_evaluation(result):
            print(line)
    return EXIT_OK if result.correct else EXIT_ERRORS
