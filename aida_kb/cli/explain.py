"""`aida-kb explain`: the long explanation of a diagnostic code, with a bad and a fixed example."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
examples:
  aida-kb explain KB003
  aida-kb explain kb3          # the same code
  aida-kb explain KB120 --color never > KB120.md
  aida-kb explain --list       # every code with its one-line summary
"""


def register(subparsers: Any) -> None:
    """Add the `explain` command."""
    p = subparsers.add_parser(
        "explain",
        help="explain a diagnostic code (KB001 ...) with a bad and a fixed example",
        description=(
            "Print the long explanation of a diagnostic code that 'aida-kb lint' reports: "
            "what it means, how to fix it, a bad and a fixed example."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("code", nargs="?", metavar="CODE", help="the code, e.g. KB003")
    p.add_argument("--list", action="store_true", help="list every code and its summary")
    p.add_argument(
        "--color",
        choices=("auto", "always", "never"),
        default="auto",
        help="format the Markdown for the terminal (auto: on a terminal, unless NO_COLOR is set)",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print the explanation; exit 2 for an unknown code."""
    import sys

    from aida_kb.cli._kbfiles import EXIT_OK, EXIT_USAGE, print_error, use_color
    from aida_kb.diagnostics import codes
    from aida_kb.diagnostics.explain import explanation

    if args.list or args.code is None:
        if args.code is None and not args.list:
            print_error("give a CODE to explain (or --list for all codes)")
            return EXIT_USAGE
        for entry in sorted(codes.REGISTRY.values(), key=lambda c: c.code):
            print(f"{entry.code}  {entry.severity.value:<7}  {entry.summary}")
        return EXIT_OK
    found = explanation(args.code)
    if found is None:
        known = sorted(codes.REGISTRY)
        span = f"{known[0]} ... {known[-1]}" if known else "none"
        print_error(
            f"unknown diagnostic code {args.code!r}; known codes: {span} "
            "('aida-kb explain --list' shows them all)"
        )
        return EXIT_USAGE
    if use_color(sys.stdout, args.color):
        from rich.console import Console
        from rich.markdown import Markdown

        Console(force_terminal=True).print(Markdown(found.text))
    else:  # the Markdown as written: for pipes, files and NO_COLOR
        sys.stdout.write(found.text if found.text.endswith("\n") else found.text + "\n")
    return EXIT_OK
