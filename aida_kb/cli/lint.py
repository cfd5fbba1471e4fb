"""`aida-kb lint`: check .kb files and report every error and warning, compiler-style."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from aida_kb.cli._kbfiles import add_import_path_option

EXAMPLE = """\
exit status: 0 clean (warnings allowed unless --strict), 1 errors found,
             2 usage error or unreadable file

examples:
  aida-kb lint kb/buildings.kb
  aida-kb lint kb/                       # every *.kb below kb/
  aida-kb lint --format json kb/examples/broken_syntax.kb
  aida-kb lint --strict kb/              # warnings fail too
"""


def add_check_command(
    subparsers: Any, name: str, help: str, description: str, epilog: str, run: Any
) -> None:
    """Add `lint` or `validate`: the two share their arguments."""
    p = subparsers.add_parser(
        name,
        help=help,
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("paths", nargs="+", metavar="PATH", help=".kb file or directory (recursive)")
    p.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="text (default): compiler-style messages with the source line; "
        "json: one JSON array of diagnostics on stdout",
    )
    p.add_argument("--strict", action="store_true", help="warnings make the run fail too")
    add_import_path_option(p)
    p.add_argument(
        "--color",
        choices=("auto", "always", "never"),
        default="auto",
        help="colour the text output (auto: on a terminal, unless NO_COLOR is set)",
    )
    p.set_defaults(run=run)


def register(subparsers: Any) -> None:
    """Add the `lint` command."""
    add_check_command(
        subparsers,
        "lint",
        help="check .kb files: every error and warning",
        description=(
            "Parse and compile each .kb file (with its imports) and report every error and "
            "warning found, like a compiler: file:line:col, the source line, a caret, a hint."
        ),
        epilog=EXAMPLE,
        run=run,
    )


def run_check(args: argparse.Namespace, *, errors_only: bool) -> int:
    """Check the files of ``args.paths``; print diagnostics; return the exit code.

    ``errors_only`` (validate) leaves warnings out unless ``--strict`` makes them fatal.
    """
    from aida_kb.cli._kbfiles import (
        EXIT_ERRORS,
        EXIT_OK,
        EXIT_USAGE,
        check,
        collect_kb_files,
        print_error,
        use_color,
    )
    from aida_kb.diagnostics.core import Diagnostic, Severity
    from aida_kb.diagnostics.render import render_json, render_summary, render_text
    from aida_kb.errors import FormatError

    files, problems = collect_kb_files(args.paths)
    shown = {Severity.ERROR, Severity.WARNING}
    if errors_only and not args.strict:
        shown = {Severity.ERROR}
    found: dict[tuple[object, ...], Diagnostic] = {}
    sources: dict[str, str] = {}
    checked = 0
    for path in files:
        try:
            result = check(path, args.import_path)
        except FormatError as exc:
            problems.append(str(exc))
            continue
        checked += 1
        sources.update(result.sources)
        for d in result.diagnostics:
            if d.severity in shown:  # a file imported twice reports its findings once
                found.setdefault((d.code, d.span, d.message), d)
    diagnostics = sorted(found.values(), key=Diagnostic.sort_key)
    if args.format == "json":
        sys.stdout.write(render_json(diagnostics) + "\n")
    else:
        color = use_color(sys.stdout, args.color)
        if diagnostics:
            sys.stdout.write(render_text(diagnostics, sources, color=color) + "\n\n")
        sys.stdout.write(render_summary(diagnostics, checked, color=color) + "\n")
    sys.stdout.flush()
    for message in problems:
        print_error(message)
    if problems:
        return EXIT_USAGE
    failing = any(
        d.is_error or (args.strict and d.severity is Severity.WARNING) for d in diagnostics
    )
    return EXIT_ERRORS if failing else EXIT_OK


def run(args: argparse.Namespace) -> int:
    """Lint the files; exit 0 clean, 1 errors (or warnings with --strict), 2 unreadable."""
    return run_check(args, errors_only=False)
