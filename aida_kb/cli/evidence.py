"""`aida-kb evidence`: the vision front end on a scene directory -> evidence.json."""

from __future__ import annotations

import argparse
from typing import Any

from aida_kb.cli.disparity import add_matcher

EXAMPLE = """\
Per view: rectify, NCC disparity + certainty, depth, regions (labels.png where the scene has
one, else planar regions of equal orientation), plane fits (n_init, c_init, w_c), line
segments and contours. View 00 is the world frame; later views are given in their own left
camera frame (see docs/formats.md, "Evidence file").

examples:
  aida-kb synth house -o out/house
  aida-kb evidence out/house -o out/house/evidence.json --debug out/house/debug
  aida-kb evidence out/house -o ev.json --segmentation orientation --views 00
  aida-kb evidence out/house -o ev-sgm.json --matcher sgm --views 00
"""


def register(subparsers: Any) -> None:
    """Add the `evidence` command."""
    p = subparsers.add_parser(
        "evidence",
        help="stereo evidence (regions, planes, lines) of a scene directory",
        description=(
            "Run the vision front end on every view of SCENE_DIR and write evidence.json: "
            "cameras, regions with certainty-weighted plane fits, line segments, contours."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", metavar="SCENE_DIR", help="scene directory (scene.yaml, calib.yaml)")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="evidence.json to write")
    p.add_argument("--debug", metavar="DIR", help="write PNG debug images of every view to DIR")
    p.add_argument("--views", metavar="IDS", help="comma-separated view ids (default: all)")
    p.add_argument(
        "--segmentation",
        choices=("auto", "labels", "orientation"),
        default="auto",
        help="auto: labels.png where present (default); labels: require it; orientation: "
        "always segment planar regions of equal orientation from the depth",
    )
    add_max_disp(p)
    p.add_argument(
        "--window", type=int, default=None, metavar="N", help="NCC window (odd; 11, sgm 7)"
    )
    add_matcher(p)
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=run)


def add_max_disp(p: argparse.ArgumentParser) -> None:
    """Add the ``--max-disp`` option of the commands that match stereo pairs."""
    p.add_argument(
        "--max-disp",
        type=int,
        default=None,
        metavar="N",
        help="search disparities 0..N-1 (default: the range found from sparse feature "
        "matches of the rectified pair; a warning says when a result fills the range)",
    )


def check_max_disp(value: int | None) -> None:
    """VisionError unless ``--max-disp`` is unset or within 3..256."""
    from aida_kb.errors import VisionError

    if value is not None and not 3 <= value <= MAX_DISP_LIMIT:
        raise VisionError(f"--max-disp {value}: must lie within 3..{MAX_DISP_LIMIT}")


MAX_DISP_LIMIT = 256  # the matcher's limit (aida_kb.vision.stereo.ncc_disparity)


def parse_views(option: str | None) -> list[str] | None:
    """The ``--views`` option as a list of view ids (None: all); VisionError if malformed."""
    from aida_kb.errors import VisionError

    views = [v.strip() for v in option.split(",")] if option else None
    if views is not None and ("" in views or len(set(views)) != len(views)):
        raise VisionError(f"--views {option!r}: expected distinct comma-separated view ids")
    return views


def run(args: argparse.Namespace) -> int:
    """Compute and write the evidence (and the debug images)."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from aida_kb.errors import VisionError
    from aida_kb.io.atomic import check_outputs
    from aida_kb.io.evidence import write_evidence
    from aida_kb.io.scene import read_scene
    from aida_kb.vision.debug import write_debug
    from aida_kb.vision.evidence import DEFAULT_WINDOW, STAGES, VisionParams, scene_evidence

    check_max_disp(args.max_disp)
    scene = read_scene(args.scene, with_truth=False)
    check_outputs([args.output], scene.files, directories=[args.debug] if args.debug else [])
    views = parse_views(args.views)
    params = VisionParams(
        num_disp=args.max_disp,
        window=args.window or DEFAULT_WINDOW,
        matcher="sgm" if args.matcher == "sgm" else "ncc",
    )
    n_views = len(views) if views is not None else len(scene.views)
    console = Console(stderr=True)
    with Progress(
        TextColumn("{task.description:<28}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} stages"),
        TimeElapsedColumn(),
        console=console,
        disable=args.quiet,
    ) as progress:
        task = progress.add_task("evidence", total=n_views * len(STAGES))

        def stage(view: str, name: str) -> None:
            progress.update(task, advance=1, description=f"view {view}: {name}")

        evidence, products = scene_evidence(
            scene, views=views, params=params, segmentation=args.segmentation, stage=stage
        )
    for prod in products:
        for warning in prod.warnings:
            console.print(f"warning: {warning}", markup=False, soft_wrap=True)
    for view, prod in zip(evidence.views, products, strict=True):
        lo, num = prod.disparity_range
        console.print(
            f"view {view.id}: {prod.rectified}; disparities searched {lo}..{lo + num - 1} px",
            markup=False,
            soft_wrap=True,
        )
        console.print(
            f"view {view.id} ({view.frame} frame, {view.segmentation}): "
            f"{len(view.regions)} regions, {len(view.lines)} lines, "
            f"depth density {view.disparity_density:.2f}"
        )
        if not view.regions:
            console.print(
                f"warning: view {view.id}: no planar region (featureless or unrelated images, "
                "or a calibration that does not fit them?)",
                markup=False,
                soft_wrap=True,
            )
    if not any(view.regions for view in evidence.views):
        raise VisionError(
            f"{args.scene}: no planar region in any view; nothing written to {args.output}"
        )
    write_evidence(args.output, evidence)
    if args.debug:
        for prod in products:
            write_debug(args.debug, prod)
        console.print(f"debug images in {args.debug}")
    console.print(f"wrote {args.output}")
    return 0
