"""`aida-kb lint`: check .kb files and report every error and warning, compiler-style."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aida_kb.cli._kbfiles import add_force_exclude_option, add_import_path_option
from aida_kb.diagnostics.core import Diagnostic, Severity
from aida_kb.errors import FormatError

if TYPE_CHECKING:
    from aida_kb.kb import CompileResult

EXAMPLE = """\
exit status: 0 clean (warnings allowed unless --strict), 1 errors found,
             2 usage error or unreadable file

examples:
  aida-kb lint kb/buildings.kb
  aida-kb lint kb/                       # the project kb/ (kb/aida-kb.toml), roots with imports
  aida-kb lint --format json kb/examples/broken_syntax.kb
  aida-kb lint --format sarif kb/ > kb.sarif
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
        choices=("text", "json", "sarif"),
        default="text",
        help="text (default): compiler-style messages with the source line; "
        "json: one JSON array of diagnostics on stdout; "
        "sarif: a SARIF 2.1.0 log for code scanning",
    )
    p.add_argument("--strict", action="store_true", help="warnings make the run fail too")
    add_import_path_option(p)
    add_force_exclude_option(p)
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


def _context_roots(
    library: Path, command: str, import_paths: Sequence[str], done: set[str]
) -> list[CompileResult]:
    """The roots of `library`'s project that import it (directly or not), compiled.

    Only files whose text names the library's file name are compiled (an import must)."""
    from aida_kb.cli._kbfiles import check, collect_kb_files, read_source
    from aida_kb.kb.project import find_project

    project = find_project(library)
    candidates, _ = collect_kb_files([str(project.folder)], command)
    key = os.path.realpath(library)
    found = []
    for path in candidates:
        if os.path.realpath(path) in done:
            continue
        try:
            if library.name not in read_source(path):
                continue
            result = check(path, import_paths, library=True)
        except FormatError:
            continue
        if not result.library and key in {os.path.realpath(f) for f in result.files[1:]}:
            found.append(result)
    return found


def lint_in_context(
    files: Sequence[Path], command: str, import_paths: Sequence[str], problems: list[str]
) -> tuple[list[Diagnostic], dict[str, str], int]:
    """Check `files` as a project (docs/language.md §2.3): every root (a file that declares
    layers) with what it imports; a library (no layers) in the context of the roots that
    import it — among `files`, else in its project — and on its own when none does.

    Returns the diagnostics (each once), the sources for rendering, and the number of files
    checked; an unreadable file named in `files` is appended to `problems`.
    """
    from aida_kb.cli._kbfiles import check

    results: dict[str, CompileResult] = {}
    for path in files:
        try:
            results[os.path.realpath(path)] = check(path, import_paths, library=True)
        except FormatError as exc:
            problems.append(str(exc))
    covered: set[str] = set()
    for result in results.values():
        if not result.library:
            covered |= {os.path.realpath(f) for f in result.files[1:]}
    found: dict[tuple[object, ...], Diagnostic] = {}
    sources: dict[str, str] = {}

    def take(result: CompileResult, only: str | None = None) -> None:
        sources.update(result.sources)
        for d in result.diagnostics:  # a file imported twice reports its findings once
            if only is None or os.path.realpath(d.span.file) == only:
                found.setdefault((d.code, d.span, d.message), d)

    for key, result in results.items():
        if not result.library:
            take(result)
        elif key not in covered:
            roots = _context_roots(Path(result.files[0]), command, import_paths, set(results))
            for root in roots:
                take(root, only=key)
            if not roots:
                take(result)
    diagnostics = sorted(found.values(), key=Diagnostic.sort_key)
    return diagnostics, sources, len(results)


def run_check(args: argparse.Namespace, *, errors_only: bool) -> int:
    """Check the files of ``args.paths``; print diagnostics; return the exit code.

    ``errors_only`` (validate) leaves warnings out unless ``--strict`` makes them fatal.
    """
    from aida_kb.cli._kbfiles import (
        EXIT_ERRORS,
        EXIT_OK,
        EXIT_USAGE,
        collect_kb_files,
        print_error,
        use_color,
    )
    from aida_kb.diagnostics.render import render_json, render_sarif, render_summary, render_text

    command = "validate" if errors_only else "lint"
    try:
        files, problems = collect_kb_files(args.paths, command, force_exclude=args.force_exclude)
    except FormatError as exc:
        print_error(str(exc))
        return EXIT_USAGE
    shown = {Severity.ERROR, Severity.WARNING}
    if errors_only and not args.strict:
        shown = {Severity.ERROR}
    everything, sources, checked = lint_in_context(files, command, args.import_path, problems)
    diagnostics = [d for d in everything if d.severity in shown]
    if args.format == "json":
        sys.stdout.write(render_json(diagnostics) + "\n")
    elif args.format == "sarif":
        sys.stdout.write(render_sarif(diagnostics, sources) + "\n")
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
