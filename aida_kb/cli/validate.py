"""`aida-kb validate`: check .kb files and report errors only (for CI and pre-commit hooks)."""

from __future__ import annotations

import argparse
from typing import Any

from aida_kb.cli.lint import add_check_command, run_check

EXAMPLE = """\
exit status: 0 no errors, 1 errors found (or warnings with --strict),
             2 usage error or unreadable file

examples:
  aida-kb validate kb/buildings.kb
  aida-kb validate --format json kb/ > diagnostics.json
  git diff --name-only -- '*.kb' | xargs aida-kb validate    # pre-commit
"""


def register(subparsers: Any) -> None:
    """Add the `validate` command."""
    add_check_command(
        subparsers,
        "validate",
        help="check .kb files: errors only (for CI and pre-commit)",
        description=(
            "Like 'aida-kb lint' but reports errors only; warnings are left out unless "
            "--strict makes them fail the run."
        ),
        epilog=EXAMPLE,
        run=run,
    )


def run(args: argparse.Namespace) -> int:
    """Validate the files; exit 0 no errors, 1 errors, 2 unreadable."""
    return run_check(args, errors_only=True)
