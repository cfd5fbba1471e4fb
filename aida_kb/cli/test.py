"""`aida-kb test`: run interpretation fixtures written in the language (docs/testing.md)."""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any

from aida_kb.cli._kbfiles import add_import_path_option

EXAMPLE = """\
what it does:
  finds every fixture under the paths: a folder with expected.kb and evidence.json (or a
  scene: scene.yaml and its images), or a file NAME.expected.kb beside NAME.json (or the
  scene folder NAME/). Each expected.kb holds the instances the interpretation must find,
  importing the knowledge base, and '// expect:' annotations: the verdict, rejections,
  tolerances (docs/language.md 5.1). The input is interpreted (a scene: reconstructed) with
  that knowledge base and the result compared: the verdict, the instances by role path
  (specialisations, bindings, inserted parts, evidence ids), measured values within their
  tolerance, the rejections. A difference is printed at the expectation's line:
    tests/fixtures/wing_135.expected.kb:67: expected body.wings[0] of RightWing, got SkewWing
  exit status: 0 every fixture passed, 1 a fixture failed, 2 usage error or a bad fixture
  (an expectation with lint errors, no input beside it), 5 no fixture found.
  --update rewrites each failing expectation from the result (its annotations kept), for
  review with git diff; refused when the environment variable CI is set, unless --force.

examples:
  aida-kb test tests/fixtures --import-path kb
  aida-kb test tests/fixtures/wing_135.expected.kb --import-path kb
  aida-kb test tests/fixtures/wing_135.expected.kb --import-path kb --update
"""

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_NO_FIXTURES = 5  # as pytest's "no tests collected"


def register(subparsers: Any) -> None:
    """Add the `test` command."""
    p = subparsers.add_parser(
        "test",
        help="run interpretation fixtures: expected instances (.kb) against the result",
        description=(
            "Run every interpretation fixture under the paths: interpret its input with the "
            "knowledge base its expectation imports and compare the result with the expected "
            "instances, verdict, rejections and measured values."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "paths", nargs="+", metavar="PATH", help="an expectation file, or a folder (recursive)"
    )
    add_import_path_option(p)
    p.add_argument(
        "--update",
        action="store_true",
        help="rewrite each failing expectation from the result, for review",
    )
    p.add_argument("--force", action="store_true", help="allow --update although CI is set")
    p.add_argument("-q", "--quiet", action="store_true", help="print failures and the summary only")
    p.set_defaults(run=run)


def in_ci() -> bool:
    """True when the environment says a CI service runs us (CI set, and not 0 or false)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def run(args: argparse.Namespace) -> int:
    """Find, run and report the fixtures; the exit status as the epilog says."""
    from aida_kb.interpret.fixture import find_fixtures

    if args.update and in_ci() and not args.force:
        print(
            "aida-kb test: error: refusing --update in CI (the environment variable CI is "
            "set): an expectation is rewritten only for a person to review; --force overrides",
            file=sys.stderr,
        )
        return EXIT_USAGE
    try:
        paths = find_fixtures(args.paths)
    except FileNotFoundError as exc:
        print(f"aida-kb test: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    if not paths:
        print(f"no fixtures found under {', '.join(args.paths)}", file=sys.stderr)
        return EXIT_NO_FIXTURES
    start = time.perf_counter()
    counts = {"passed": 0, "failed": 0, "error": 0, "updated": 0}
    for path in paths:
        outcome = _run_one(path, args)
        counts[outcome.status] += 1
        head = f"{path}: {outcome.status.upper() if outcome.status != 'passed' else 'passed'}"
        if outcome.status != "passed" or not args.quiet:
            print(f"{head} ({outcome.seconds:.1f} s)", flush=True)
        for line in outcome.lines:
            print("  " + line)
        if outcome.status == "updated":
            print(f"  rewrote {path} from the result: review it (git diff {path})")
    summary = ", ".join(f"{n} {status}" for status, n in counts.items() if n)
    print(
        f"{len(paths)} fixture{'s' if len(paths) != 1 else ''}: {summary} "
        f"in {time.perf_counter() - start:.1f} s"
    )
    if counts["error"]:
        return EXIT_USAGE
    return EXIT_FAILED if counts["failed"] else EXIT_OK


def _run_one(path: Any, args: argparse.Namespace) -> Any:
    """Run one fixture; on a terminal, a transient line on stderr says which stage of a
    scene's reconstruction it is in."""
    from rich.console import Console
    from rich.progress import Progress, TextColumn, TimeElapsedColumn

    from aida_kb.interpret.fixture import default_interpreter, run_fixture

    console = Console(stderr=True)
    with Progress(
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        disable=args.quiet or not console.is_terminal,
    ) as progress:
        task = progress.add_task(f"{path}", total=None)

        def stage(text: str) -> None:
            progress.update(task, description=f"{path}: {text}")

        return run_fixture(
            path, args.import_path, update=args.update, interpret=default_interpreter(stage)
        )
