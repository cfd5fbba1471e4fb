"""`aida-kb synth`: render a synthetic scene directory with ground truth."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
presets:
  house       two stereo pairs of an apartment building (paper §6.1)
  turntable   reference box turned to 0, 85, 195, 265 degrees (paper §6.2)
  lshape      L-shaped house (main body + wing; --set meeting_deg=135 for a skew wing)
  oriel       gable house with box oriels on the front wall
  tower       square tower with a pyramid roof (kb/tower.kb)
  chessboard  chessboard poses for cv2.calibrateCamera / cv2.stereoCalibrate
  street      2-5 free-standing houses of different roofs in a row (--set houses=N;
              kb/street.kb, goal Street)
  terrace     2-5 touching gable houses sharing party walls (--set houses=N)
  occluded    a house half hidden behind another
  random      a randomised scene of --seed (aida_kb.synth.randomised): any of the above
              with random sizes, materials, cameras, light, occluders, 1-8 views, or no
              building at all; --set kind=NAME forces the kind (gable, hip, flat, shed,
              asymmetric_gable, lshape90, lshape135, oriel, turntable, chessboard, clutter)

examples:
  aida-kb synth house -o out/house
  aida-kb synth house -o out/hip --set roof=hip --set pitch_deg=30 --views 3
  aida-kb synth turntable -o out/box --seed 2
  aida-kb synth lshape -o out/l135 --set meeting_deg=135 --chessboard
  aida-kb synth random -o out/r7 --seed 7 --views 2
  aida-kb synth street -o out/street --set houses=2 --set image_width=480 --set image_height=360
"""


MAX_RANDOM_VIEWS = 8  # `random`: --views caps the number of views drawn (1 .. 8)


def register(subparsers: Any) -> None:
    """Add the `synth` command."""
    p = subparsers.add_parser(
        "synth",
        help="render a synthetic stereo scene directory with ground truth",
        description=(
            "Render a preset scene as a scene directory: scene.yaml, calib.yaml, "
            "views/NN/{left,right,labels}.png, views/NN/depth_left.npy and truth.json "
            "(see docs/formats.md)."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "preset",
        choices=(
            "house",
            "turntable",
            "lshape",
            "oriel",
            "tower",
            "chessboard",
            "street",
            "terrace",
            "occluded",
            "random",
        ),
        help="scene",
    )
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="scene directory to write")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="random seed (textures, noise), 0 .. 2147483647; default 0",
    )
    p.add_argument("--views", type=int, default=None, metavar="N", help="number of views")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        dest="settings",
        help="override a parameter, e.g. roof=hip, width=18, baseline=0.5, k1=-0.1 (repeatable)",
    )
    p.add_argument(
        "--chessboard",
        action="store_true",
        help="also write chessboard calibration views of the same rig to DIR/chessboard",
    )
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(run=run)


def _parse_settings(items: list[str]) -> dict[str, str]:
    from aida_kb.errors import GeometryError

    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise GeometryError(f"--set {item!r}: expected KEY=VALUE")
        out[key.strip()] = value.strip()
    return out


def run(args: argparse.Namespace) -> int:
    """Render the preset and write the scene directory."""
    from pathlib import Path

    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from aida_kb.errors import GeometryError
    from aida_kb.io.atomic import make_dirs
    from aida_kb.synth.scenes import COMMON_KEYS, preset, render_scene

    if args.views is not None and args.views < 1:
        raise GeometryError("--views must be at least 1")
    settings = _parse_settings(args.settings)
    if args.preset == "random":
        from aida_kb.synth.randomised import random_scene

        extra = set(settings) - {"kind"}
        if extra:
            raise GeometryError(f"--set: unknown key(s) {', '.join(sorted(extra))}; known: kind")
        spec = random_scene(
            args.seed, kind=settings.get("kind"), max_views=args.views or MAX_RANDOM_VIEWS
        )
    else:
        spec = preset(args.preset, seed=args.seed, views=args.views, params=settings)
    make_dirs(args.output)  # before rendering: a wrong -o fails at once
    jobs = [(spec, Path(args.output))]
    if args.chessboard and args.preset not in ("chessboard", "random"):
        rig_keys = {k: v for k, v in settings.items() if k in COMMON_KEYS}
        board = preset("chessboard", seed=args.seed, params=rig_keys)
        board.rig = spec.rig  # the same cameras as the scene
        jobs.append((board, Path(args.output) / "chessboard"))
    console = Console(stderr=True)
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} views"),
        TimeElapsedColumn(),
        console=console,
        disable=args.quiet,
    ) as progress:
        for sp, out in jobs:
            task = progress.add_task(f"rendering {sp.name}", total=len(sp.views_site))

            def tick(done: int, total: int, task: Any = task) -> None:
                progress.update(task, completed=done)

            render_scene(sp, out, progress=tick)
    for sp, out in jobs:
        console.print(f"wrote {out} ({sp.name}, {len(sp.views_site)} views)")
    return 0
