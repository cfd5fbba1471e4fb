"""`aida-kb reconstruct`: a scene directory -> evidence, interpretation and the closed model."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
writes into OUT:
  evidence.json        what the vision front end measured (aida-kb evidence)
  interpretation.json  instances, residual of every constraint, hypothesis trace
  interpretation.kb    the result as instances of the knowledge base, importing it
                       (check: aida-kb lint OUT/interpretation.kb --import-path KB_FOLDER)
  model.json           each part's plane (n, d) and closed polygon; each view's camera
  model.obj, .mtl      the closed mesh, y up, textured (model_atlas.png) -- these and the
  model.glb            following only when the goal object was found: binary glTF, y up
  model.city.json      CityJSON 2.0, z up, a Building with semantic surfaces
  model_points.ply     the stereo points of every view
  report.html          every stage on one page (open it in a browser; works offline)
exit status: 0 verified, 3 doubtful (the reasons are printed first), 4 nothing found,
  1 an error, 2 unreadable input (aida_kb.interpret.verdict).

examples:
  aida-kb synth house -o out/house
  aida-kb reconstruct kb/buildings.kb out/house -o out/house-model
  aida-kb reconstruct kb/buildings.kb out/house -o out/m --views 00
  aida-kb reconstruct kb/buildings.kb out/house -o out/m --views 00 --explain --max-disp 96
"""


def register(subparsers: Any) -> None:
    """Add the `reconstruct` command."""
    from aida_kb.cli.evidence import add_max_disp

    p = subparsers.add_parser(
        "reconstruct",
        help="scene directory -> evidence -> interpretation -> closed 3-D model",
        description=(
            "Run the whole pipeline on a scene directory (calibrated stereo views): "
            "evidence, hypothesis-verification interpretation against the knowledge base, "
            "and the closed polyhedral model. The scene's truth.json is never read."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("kb", metavar="KB", help="knowledge base (.kb file)")
    p.add_argument("scene", metavar="SCENE_DIR", help="scene directory (scene.yaml)")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    p.add_argument(
        "--goal",
        default=None,
        help="goal concept (default: the knowledge base's only scene concept)",
    )
    p.add_argument(
        "--views", default=None, metavar="IDS", help="comma-separated view ids (default: all)"
    )
    add_max_disp(p)
    p.add_argument("--explain", action="store_true", help="say why rejected hypotheses fell")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Reconstruct; print the interpretation and the files written."""
    from rich.console import Console
    from rich.progress import Progress, TextColumn, TimeElapsedColumn

    from aida_kb.cli.evidence import check_max_disp, parse_views
    from aida_kb.cli.interpret import load_kb, print_interpretation, verdict_status
    from aida_kb.interpret.pipeline import reconstruct_scene
    from aida_kb.interpret.run import check_goal
    from aida_kb.io.atomic import make_dirs
    from aida_kb.report.html import write_report

    views = parse_views(args.views)
    check_max_disp(args.max_disp)
    make_dirs(args.output)
    kb, sources = load_kb(args.kb)
    args.goal = check_goal(kb, args.goal)
    console = Console(stderr=True)
    with Progress(
        TextColumn("{task.description}"), TimeElapsedColumn(), console=console, disable=args.quiet
    ) as progress:
        task = progress.add_task("reconstructing", total=None)

        def stage(view: str, name: str) -> None:
            where = f"view {view}: " if view != "-" else ""
            progress.update(task, description=f"{where}{name}")

        result = reconstruct_scene(
            kb,
            args.scene,
            args.output,
            goal=args.goal,
            views=views,
            stage=stage,
            max_disp=args.max_disp,
            warn=lambda text: console.print(f"warning: {text}", markup=False, soft_wrap=True),
            extra=write_report,
        )
    print_interpretation(result.interpretation, explain=args.explain, sources=sources)
    for path in result.files:
        print(f"wrote {path}")
    return verdict_status(result.interpretation)
