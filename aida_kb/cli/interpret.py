"""`aida-kb interpret`: hypothesis-verification interpretation of an evidence file."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aida_kb.interpret.result import Interpretation

EXAMPLE = """\
what it does:
  establishes the goal hypothesis (a scene concept; by default the knowledge base's only
  one), expands it along con-of, part-of and is-a, matches the world parts to the evidence
  regions, inserts the parts no view can see, adjusts every alternative by weighted least
  squares and rejects those whose constraints cost too much. Prints the accepted instances
  as a tree.
  The verdict (aida_kb.interpret.verdict) then checks the accepted interpretation against
  the constraints' thresholds, the evidence and the knowledge's measured attributes.
  exit status: 0 verified, 3 doubtful (reasons in the summary line), 4 nothing found
  (a scene without the goal object; interpretation.json is still written), 1 an error.
  With -o FILE.json, the result is also written as instances of the knowledge base,
  FILE.kb (docs/formats.md); check it with
  aida-kb lint FILE.kb --import-path KB_FOLDER.

examples:
  aida-kb synth house -o out/house
  aida-kb evidence out/house -o out/house/evidence.json --debug out/house/debug
  aida-kb interpret kb/buildings.kb out/house/evidence.json
  aida-kb interpret kb/buildings.kb out/house/evidence.json --explain
  aida-kb interpret kb/buildings.kb out/house/evidence.json -o out/interpretation.json
"""


def register(subparsers: Any) -> None:
    """Add the `interpret` command."""
    p = subparsers.add_parser(
        "interpret",
        help="interpret an evidence file against a knowledge base (hypothesis-verification)",
        description=(
            "Interpret evidence.json against a knowledge base: instances of the goal concept, "
            "the reconstructed model, every constraint's residual and the hypothesis trace."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("kb", metavar="KB", help="knowledge base (.kb file)")
    p.add_argument("evidence", metavar="EVIDENCE", help="evidence.json (aida-kb evidence)")
    p.add_argument(
        "--goal",
        default=None,
        help="goal concept (default: the knowledge base's only scene concept)",
    )
    p.add_argument("--explain", action="store_true", help="say why each rejected hypothesis fell")
    p.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        default=None,
        help="write interpretation.json here, and the result as instances (.kb) beside it",
    )
    p.set_defaults(run=run)


def load_kb(path: str) -> tuple[Any, dict[str, str]]:
    """Compile a knowledge base; print its diagnostics and raise KbError when it has errors.

    Returns the compiled knowledge base and the source text of each of its files (for the
    source lines under a constraint's location).
    """
    from aida_kb.diagnostics.render import render_summary, render_text
    from aida_kb.errors import FormatError, KbError
    from aida_kb.kb import compile_path

    if not Path(path).is_file():
        raise FormatError(f"{path}: no such file")
    result = compile_path(path)
    if result.kb is None:
        print(render_text(result.diagnostics, result.sources), file=sys.stderr)
        print(render_summary(result.diagnostics, len(result.sources)), file=sys.stderr)
        raise KbError(f"{path}: the knowledge base has errors; nothing interpreted")
    return result.kb, dict(result.sources)


def constraint_notes(interp: Interpretation, *, explain: bool) -> list[Any]:
    """The interpretation's notes at the knowledge base's lines: ``KB401`` for the accepted
    interpretation's constraint closest to its threshold and, with ``explain``, ``KB400`` for
    each constraint that rejected a hypothesis (those with a ``.kb`` line)."""
    from aida_kb.diagnostics import codes
    from aida_kb.diagnostics.core import Diagnostic

    notes: list[Diagnostic] = []
    if interp.accepted and interp.residuals:
        worst = max(interp.residuals, key=lambda r: r.normalised_cost / r.threshold)
        if worst.span is not None:
            notes.append(
                Diagnostic(
                    codes.CLOSEST_TO_THRESHOLD.code,
                    codes.CLOSEST_TO_THRESHOLD.severity,
                    f"'{worst.label}' ({', '.join(worst.parts)}) is the closest to its "
                    f"threshold: normalised cost {worst.normalised_cost:.3g} of "
                    f"{worst.threshold:.3g}",
                    worst.span,
                )
            )
    if explain:
        for h in interp.rejected():
            if h.span is None or h.constraint is None or h.cost is None:
                continue
            notes.append(
                Diagnostic(
                    codes.REJECTED_BY.code,
                    codes.REJECTED_BY.severity,
                    f"'{h.constraint}' rejected {h.concept} as {h.role or 'the goal'} "
                    f"(hypothesis #{h.id}): normalised cost {h.cost:.3g}",
                    h.span,
                )
            )
    return notes


def print_interpretation(
    interp: Interpretation, *, explain: bool, sources: dict[str, str] | None = None
) -> None:
    """The summary line, the instance tree and, with `explain`, the rejected hypotheses;
    then the notes at the knowledge base's lines (`constraint_notes`, with the source lines
    of ``sources``)."""
    from aida_kb.diagnostics.render import render_text
    from aida_kb.interpret.report import explanation, instance_tree

    print(interp.message)
    for line in instance_tree(interp):
        print("  " + line)
    if interp.accepted and interp.residuals:
        worst = max(interp.residuals, key=lambda r: r.normalised_cost / r.threshold)
        where = f" at {worst.where}" if worst.where else ""
        print(
            f"  {len(interp.residuals)} constraints; closest to its threshold: {worst.label}"
            f"{where} ({worst.kind}, {', '.join(worst.parts)}) normalised cost "
            f"{worst.normalised_cost:.2f} of {worst.threshold:.3g}"
        )
    if explain:
        lines = explanation(interp)
        print("rejected hypotheses:" if lines else "no hypothesis was rejected")
        for line in lines:
            print("  " + line)
    notes = constraint_notes(interp, explain=explain)
    if notes:
        print()
        print(render_text(notes, sources or {}))


def run(args: argparse.Namespace) -> int:
    """Interpret; print the tree; write interpretation.json and .kb when asked."""
    from aida_kb.interpret.kbfile import write_interpretation_kb
    from aida_kb.interpret.result import write_interpretation
    from aida_kb.interpret.run import check_goal, interpret
    from aida_kb.interpret.verdict import judge, with_verdict
    from aida_kb.io.atomic import check_outputs
    from aida_kb.io.evidence import read_evidence

    outputs = [args.output, kb_output(args.output)] if args.output else []
    check_outputs(outputs, [args.kb, args.evidence])
    kb, sources = load_kb(args.kb)
    check_outputs(outputs, [*kb.files, args.evidence])  # nor over a file the kb imports
    args.goal = check_goal(kb, args.goal)
    evidence = read_evidence(args.evidence)
    interp = interpret(kb, evidence, goal=args.goal, source=args.evidence)
    interp = with_verdict(interp, judge(kb, interp, evidence))
    print_interpretation(interp, explain=args.explain, sources=sources)
    if args.output:
        write_interpretation(args.output, interp)
        write_interpretation_kb(outputs[1], kb, interp, args.kb)
        print(f"wrote {args.output} and {outputs[1]}")
    return verdict_status(interp)


def kb_output(output: str) -> str:
    """The interpretation's ``.kb`` file beside ``-o FILE``: FILE with the suffix ``.kb``."""
    return str(Path(output).with_suffix(".kb"))


EXIT_DOUBTFUL = 3  # an interpretation was found, but the verdict doubts it (reasons printed)
EXIT_NOTHING = 4  # no interpretation of the goal was found


def verdict_status(interp: Interpretation) -> int:
    """The exit status of a result: 0 verified, EXIT_DOUBTFUL, EXIT_NOTHING."""
    if interp.verdict == "doubtful":
        return EXIT_DOUBTFUL
    if interp.verdict == "nothing" or not interp.accepted:
        return EXIT_NOTHING
    return 0
