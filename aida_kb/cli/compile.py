"""`aida-kb compile`: the resolved knowledge base (inheritance, SI units, constraints) as JSON."""

from __future__ import annotations

import argparse
from typing import Any

from aida_kb.cli._kbfiles import add_import_path_option

EXAMPLE = """\
The output is the KnowledgeBase model (its JSON Schema: 'aida-kb schema'): concepts with
inherited members resolved, constraints expanded into primitives in SI units (radians,
metres), templates and instances. Nothing is written when the knowledge base has errors.

examples:
  aida-kb compile kb/buildings.kb -o buildings.json
  aida-kb compile kb/buildings.kb | python -m json.tool | less
"""


def register(subparsers: Any) -> None:
    """Add the `compile` command."""
    p = subparsers.add_parser(
        "compile",
        help="write the resolved knowledge base of a .kb file as JSON",
        description=(
            "Compile a .kb file (with its imports) and write the resolved, checked model as "
            "JSON. Diagnostics go to stderr; on errors nothing is written and the exit status "
            "is 1."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", metavar="FILE", help="the .kb file")
    p.add_argument(
        "-o", "--output", metavar="OUT", default=None, help="JSON file to write (default: stdout)"
    )
    add_import_path_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Compile FILE and write its model; exit 1 (writing nothing) if it has errors."""
    from pathlib import Path

    from aida_kb.cli._kbfiles import check_output_file, compile_or_report, write_output

    check_output_file(args.output, [args.file])
    kb = compile_or_report(Path(args.file), args.import_path)
    if kb is None:
        return 1
    write_output(args.output, kb.model_dump_json(indent=2) + "\n", [args.file, *kb.files])
    return 0
