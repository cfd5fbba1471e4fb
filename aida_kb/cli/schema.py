"""`aida-kb schema`: the JSON Schema of what `aida-kb compile` writes."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
examples:
  aida-kb schema > knowledge-base.schema.json
  aida-kb schema -o docs/schemas/knowledge-base.schema.json
"""


def register(subparsers: Any) -> None:
    """Add the `schema` command."""
    p = subparsers.add_parser(
        "schema",
        help="print the JSON Schema of the compiled knowledge base",
        description=(
            "Print the JSON Schema (draft 2020-12, from the pydantic model) of the "
            "KnowledgeBase JSON that 'aida-kb compile' writes."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "-o", "--output", metavar="OUT", default=None, help="file to write (default: stdout)"
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write the schema."""
    import json

    from aida_kb.cli._kbfiles import write_output
    from aida_kb.kb import KnowledgeBase

    schema = KnowledgeBase.model_json_schema(mode="serialization")
    write_output(args.output, json.dumps(schema, indent=2, ensure_ascii=False) + "\n")
    return 0
