"""`aida-kb fmt`: rewrite .kb files in the canonical layout (docs/language.md §8)."""

from __future__ import annotations

import argparse
from typing import Any

from aida_kb.cli._kbfiles import add_force_exclude_option

EXAMPLE = """\
exit status: 0 every file is formatted (or was rewritten), 1 a file has a syntax error or
             (with --check) would change, 2 usage error or unreadable file

examples:
  aida-kb fmt --check kb/                # which files would change; writes nothing
                                         # (kb/aida-kb.toml's [fmt] exclude is left out)
  aida-kb fmt kb/buildings.kb            # rewrite the file in place
"""


def register(subparsers: Any) -> None:
    """Add the `fmt` command."""
    p = subparsers.add_parser(
        "fmt",
        help="rewrite .kb files in the canonical layout",
        description=(
            "Lay out each .kb file the one canonical way: four-space indentation, one member "
            "per line, canonical spacing, comments kept where they were. A file with a syntax "
            "error is left as it is. Files are rewritten atomically, only when they change."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("paths", nargs="+", metavar="PATH", help=".kb file or directory (recursive)")
    p.add_argument(
        "--check",
        action="store_true",
        help="write nothing; list the files that would change and exit 1 if there are any",
    )
    add_force_exclude_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Format (or check) the files of ``args.paths``; return the exit code."""
    from aida_kb.cli._kbfiles import (
        EXIT_ERRORS,
        EXIT_OK,
        EXIT_USAGE,
        collect_kb_files,
        display_path,
        print_error,
        read_source,
    )
    from aida_kb.dsl.format import format_source
    from aida_kb.errors import FormatError
    from aida_kb.io.atomic import write_text_atomic

    try:
        files, problems = collect_kb_files(args.paths, "fmt", force_exclude=args.force_exclude)
    except FormatError as exc:
        print_error(str(exc))
        return EXIT_USAGE
    failed = False
    changed = 0
    refused = 0  # files with a syntax error
    for path in files:
        shown = display_path(path)
        try:
            text = read_source(path)
        except FormatError as exc:
            problems.append(str(exc))
            continue
        try:
            result = format_source(text, shown)
        except FormatError as exc:
            print_error(str(exc))
            failed = True
            refused += 1
            continue
        if not result.changed:
            continue
        changed += 1
        if args.check:
            print(f"would reformat {shown}")
            failed = True
        else:
            write_text_atomic(path, result.text)
            print(f"reformatted {shown}")
    verb = "would be reformatted" if args.check else "reformatted"
    print(f"{changed} file(s) {verb}, {len(files) - changed - refused} left unchanged")
    for message in problems:
        print_error(message)
    if problems:
        return EXIT_USAGE
    return EXIT_ERRORS if failed else EXIT_OK
