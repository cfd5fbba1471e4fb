"""`aida-kb batch`: reconstruct every scene under some folders on a Dask cluster (resumable)."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
writes into OUT:
  scenes/KEY/          per scene what `aida-kb reconstruct` writes, and outcome.json;
                       KEY is the scene's path below the folder common to all scenes
  summary.csv          one row per scene: status, objects, verdicts, times, error, model
  summary.json         the same with every outcome in full (docs/formats.md)
  city.jsonl           every accepted building as a CityJSONSeq (one feature per scene)

A scene is a folder with scene.yaml. Each scene's folder appears whole when the scene ends,
so a run that is stopped loses only the scenes in flight: run the same command again to
finish the rest (finished scenes, failed ones too, are kept; --retry-failed runs failed
ones again). A failing scene is recorded and the run goes on; the exit status is 1 if any
scene failed.

examples:
  aida-kb synth house -o city/a --seed 1
  aida-kb synth lshape -o city/b --seed 2
  aida-kb batch city -o city-models
  aida-kb batch --list scenes.txt -o models --workers 4 --memory-limit 3GB
  aida-kb batch city -o city-models --scheduler tcp://10.0.0.5:8786
"""


def register(subparsers: Any) -> None:
    """Add the `batch` command."""
    p = subparsers.add_parser(
        "batch",
        help="reconstruct every scene under some folders on a Dask cluster (resumable)",
        description=(
            "Run `aida-kb reconstruct` on every scene (a folder with scene.yaml) under the "
            "given folders, or listed in a file, in parallel on Dask: a local cluster of one "
            "worker process per core by default, or an existing cluster. The workers of an "
            "existing cluster must see the scenes and OUT under the same paths."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("dirs", nargs="*", metavar="DIR", help="a scene folder or a folder of scenes")
    p.add_argument(
        "--list",
        metavar="FILE",
        help="a file naming one scene folder per line (relative to the file's folder)",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    p.add_argument(
        "--kb", default=None, metavar="KB", help="knowledge base (default: the shipped buildings)"
    )
    p.add_argument(
        "--goal",
        default=None,
        help="goal concept (default: the knowledge base's only scene concept)",
    )
    p.add_argument(
        "--views", default=None, metavar="IDS", help="comma-separated view ids (default: all)"
    )
    p.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="an existing Dask scheduler"
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local cluster: worker processes (default: one per core)",
    )
    p.add_argument(
        "--memory-limit",
        default="auto",
        metavar="SIZE",
        help="local cluster: memory per worker, e.g. 3GB (default: the machine's memory / N)",
    )
    p.add_argument("--retry-failed", action="store_true", help="run failed scenes again")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Collect the scenes, run them, print where the summary is; 1 if any scene failed."""
    from pathlib import Path

    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from aida_kb.batch.cityseq import CITYSEQ_FILE
    from aida_kb.batch.outcome import SUMMARY_CSV, SceneOutcome
    from aida_kb.batch.run import BatchOptions, run_batch
    from aida_kb.batch.scenes import find_scenes, read_scene_list, scene_refs
    from aida_kb.cli._kbfiles import packaged_kb
    from aida_kb.cli.evidence import parse_views
    from aida_kb.cli.interpret import load_kb
    from aida_kb.errors import FormatError
    from aida_kb.interpret.run import check_goal

    if args.workers is not None and args.workers < 1:
        raise FormatError(f"--workers {args.workers}: must be at least 1")
    if args.scheduler is not None and args.workers is not None:
        raise FormatError("--workers is for the local cluster; an existing one has its own")
    if not args.dirs and args.list is None:
        raise FormatError("no scenes: give folders (DIR...) or --list FILE")
    views = parse_views(args.views)
    paths = find_scenes(args.dirs)
    if args.list is not None:
        paths += read_scene_list(args.list)
    refs = scene_refs(paths)
    if not refs:
        raise FormatError(f"no scene (a folder with scene.yaml) under {', '.join(args.dirs)}")
    kb_path = args.kb or str(packaged_kb("buildings.kb"))
    kb, _ = load_kb(kb_path)
    args.goal = check_goal(kb, args.goal)
    options = BatchOptions(
        goal=args.goal,
        views=views,
        scheduler=args.scheduler,
        workers=args.workers,
        memory_limit=args.memory_limit,
        retry_failed=args.retry_failed,
    )
    console = Console(stderr=True)
    failed = 0
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        disable=args.quiet,
    ) as bar:
        task = bar.add_task("scenes", total=len(refs))

        def progress(done: int, total: int, outcome: SceneOutcome) -> None:
            nonlocal failed
            failed += outcome.status == "error"
            where = f", {failed} failed" if failed else ""
            bar.update(task, completed=done, description=f"scenes{where}")

        summary = run_batch(kb, kb_path, refs, Path(args.output), options, progress)
    for row in summary.rows:
        if row.outcome.status == "error" and not row.resumed:
            print(f"{row.outcome.scene}: error: {row.outcome.error}")
    print(
        f"{summary.scenes} scenes: {summary.accepted} with a {args.goal}, "
        f"{summary.nothing} without, {summary.errors} failed "
        f"({summary.resumed} finished by an earlier run); "
        f"{summary.workers} workers, {summary.seconds:.1f} s"
    )
    print(f"wrote {Path(args.output) / SUMMARY_CSV} and {Path(args.output) / CITYSEQ_FILE}")
    return 1 if summary.errors else 0
