"""`aida-kb scene init` / `scene from-colmap`: a scene directory from a user's own material."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
scene init: one stereo calibration (an OpenCV FileStorage calib.yaml as `aida-kb calibrate`
writes it, a Middlebury calib.txt, or a text file with a P1/P2 pair of 3x4 projection matrices)
and image pairs (--pair LEFT RIGHT, repeated, or --images DIR: every *left*/*right*, im0/im1
twin). scene from-colmap: a COLMAP sparse model (sparse/0: cameras, images, points3D as .txt or
.bin) and its image folder; image pairs with a sideways baseline become stereo views (the rule:
docs/formats.md). A structure-from-motion model has no scale: the scene says `scale: unknown`
(the model is then up to scale) unless one known distance is given.

examples:
  aida-kb synth house -o out/house
  aida-kb scene init --calib out/house/calib.yaml --images out/house/views/00 -o out/mine
  aida-kb scene init --calib calib.txt --images Motorcycle/ -o out/moto     # Middlebury
  aida-kb scene init --calib P.txt --pair l.png r.png --unit unknown -o out/p
  aida-kb scene from-colmap sparse/0 --images images/ -o out/sfm
  aida-kb scene from-colmap sparse/0 --images images/ -o out/sfm --known-distance a.jpg b.jpg 1.2
"""


def register(subparsers: Any) -> None:
    """Add the `scene` command and its subcommands."""
    p = subparsers.add_parser(
        "scene",
        help="build a scene directory from your own calibration and photos, or from COLMAP",
        description="Build a scene directory (docs/formats.md) from a user's own material.",
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="scene_command", metavar="SUBCOMMAND")
    init = sub.add_parser(
        "init",
        help="a scene from a stereo calibration and image pairs",
        description=(
            "Copy image pairs and their stereo calibration into a new scene directory "
            "(nothing is re-encoded; images are checked against the calibration's size)."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    init.add_argument("--calib", required=True, metavar="FILE", help="stereo calibration")
    init.add_argument(
        "--pair",
        nargs=2,
        action="append",
        metavar=("LEFT", "RIGHT"),
        help="one view's left and right image (repeat for more views)",
    )
    init.add_argument("--images", metavar="DIR", help="folder of image pairs (instead of --pair)")
    init.add_argument(
        "--unit",
        choices=("m", "mm", "unknown"),
        default=None,
        help="unit of the calibration's translation (default: metres; Middlebury's mm); "
        "'unknown': the scene is known up to scale only",
    )
    init.add_argument(
        "--baseline",
        type=float,
        metavar="M",
        help="the rig's true baseline in metres: fixes the scale",
    )
    init.add_argument("-o", "--output", required=True, metavar="DIR", help="new scene directory")
    init.add_argument("--name", default="", help="scene name (free text)")
    init.set_defaults(run=run_init)
    col = sub.add_parser(
        "from-colmap",
        help="a scene from a COLMAP sparse model (pairs with known relative pose)",
        description=(
            "Read a COLMAP sparse model (text or binary), choose image pairs that make stereo "
            "views, and write a scene with each view's own calibration and pose."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    col.add_argument("model", metavar="MODEL_DIR", help="COLMAP sparse model folder")
    col.add_argument("--images", required=True, metavar="DIR", help="the model's image folder")
    col.add_argument("-o", "--output", required=True, metavar="DIR", help="new scene directory")
    col.add_argument(
        "--known-distance",
        nargs=3,
        metavar=("A", "B", "METRES"),
        help="a true distance that fixes the scale: between two images' camera centres "
        "(their names) or two 3-D points (point:ID)",
    )
    col.add_argument("--max-views", type=int, default=None, metavar="N", help="at most N views")
    col.add_argument("--name", default="", help="scene name (free text)")
    col.set_defaults(run=run_from_colmap)
    p.set_defaults(run=lambda _args: _usage(p))


def _usage(parser: argparse.ArgumentParser) -> int:
    import sys

    parser.print_help(sys.stderr)
    return 2


def _positive_metres(value: float, what: str) -> float:
    import math

    from aida_kb.errors import FormatError

    if not (math.isfinite(value) and value > 0):
        raise FormatError(f"{what} {value}: expected a positive length in metres")
    return value


def folder_pairs(directory: str) -> list[tuple[str, str]]:
    """Left/right image pairs in a folder: names that differ only in left/right, im0/im1,
    Left/Right, LEFT/RIGHT, _L/_R, _l/_r or cam0/cam1 (the last occurrence), sorted."""
    from pathlib import Path

    from aida_kb.errors import FormatError

    root = Path(directory)
    if not root.is_dir():
        raise FormatError(f"{root}: not a directory")
    markers = (
        ("left", "right"),
        ("Left", "Right"),
        ("LEFT", "RIGHT"),
        ("im0", "im1"),
        ("_L", "_R"),
        ("_l", "_r"),
        ("cam0", "cam1"),
    )
    suffixes = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".ppm", ".pgm", ".webp"}
    files = sorted(p for p in root.iterdir() if p.is_file() and p.suffix.lower() in suffixes)
    pairs = []
    taken: set[Path] = set()
    for f in files:
        for left, right in markers:
            k = f.name.rfind(left)
            if k < 0 or f in taken:
                continue
            twin = f.with_name(f.name[:k] + right + f.name[k + len(left) :])
            if twin.is_file() and twin not in taken:
                pairs.append((str(f), str(twin)))
                taken |= {f, twin}
                break
    if not pairs:
        raise FormatError(
            f"{root}: no image pairs found (names differing only in left/right, im0/im1, "
            "_L/_R or cam0/cam1)"
        )
    return pairs


def run_init(args: argparse.Namespace) -> int:
    """Build a scene from a calibration and image pairs."""
    import sys
    from pathlib import Path

    from aida_kb.errors import FormatError
    from aida_kb.io.calibtext import read_any_calib
    from aida_kb.io.scene import BaselineScale, ScaleEntry, ScaleField, read_image
    from aida_kb.io.scene_build import SourceView, build_scene

    if bool(args.pair) == bool(args.images):
        raise FormatError("give the image pairs as --pair LEFT RIGHT (repeated) or --images DIR")
    if args.baseline is not None:
        _positive_metres(args.baseline, "--baseline")
        if args.unit == "unknown":
            raise FormatError("--baseline fixes the scale: it contradicts --unit unknown")
    pairs = [tuple(p) for p in args.pair] if args.pair else folder_pairs(args.images)
    text = read_any_calib(args.calib)
    size = text.size
    if size is None:  # the file has none: the images'
        first = read_image(pairs[0][0], grey=True)
        size = (first.shape[1], first.shape[0])
    unit = {"m": 1.0, "mm": 1e-3, "unknown": None}[args.unit] if args.unit else text.unit_m
    rig = text.rig(size, unit)
    scale: ScaleField = "metres" if unit is not None else "unknown"
    if args.baseline is not None:
        scale = ScaleEntry(baseline=BaselineScale(view="00", metres=args.baseline))
    views = [SourceView(Path(left), Path(right), rig) for left, right in pairs]
    inputs = [args.calib, *([args.images] if args.images else [])]
    out = build_scene(
        args.output, views, shared_calib=rig, scale=scale, name=args.name, inputs=inputs
    )
    what = {"metres": "metres", "unknown": "unknown (up to scale)"}.get(
        str(scale), "fixed by the baseline"
    )
    print(
        f"wrote {out}: {len(views)} view(s), {size[0]}x{size[1]}, {text.form} calibration, "
        f"baseline {rig.baseline_m:.4g} {'m' if unit is not None else 'units'}, scale {what}",
        file=sys.stderr,
    )
    if text.max_disp is not None:
        print(
            f"  the calibration gives ndisp={text.max_disp}: use --max-disp {text.max_disp}",
            file=sys.stderr,
        )
    return 0


def run_from_colmap(args: argparse.Namespace) -> int:
    """Build a scene from a COLMAP sparse model."""
    import sys

    from aida_kb.errors import FormatError
    from aida_kb.io.colmap import read_colmap
    from aida_kb.io.scene import BaselineScale, ScaleEntry, ScaleField
    from aida_kb.io.scene_build import build_scene, colmap_views, model_distance

    if args.max_views is not None and args.max_views < 1:
        raise FormatError(f"--max-views {args.max_views}: expected a positive number")
    model = read_colmap(args.model)
    views, pairs = colmap_views(model, args.images, max_views=args.max_views)
    scale: ScaleField = "unknown"
    if args.known_distance:
        a, b, metres = args.known_distance
        try:
            true_m = float(metres)
        except ValueError:
            raise FormatError(f"--known-distance: {metres!r} is not a length in metres") from None
        _positive_metres(true_m, "--known-distance")
        factor = true_m / model_distance(model, a, b)
        # recorded as view 00's baseline in metres: the files keep COLMAP's units
        scale = ScaleEntry(
            baseline=BaselineScale(view="00", metres=factor * views[0].calib.baseline_m)
        )
    out = build_scene(
        args.output, views, scale=scale, name=args.name, inputs=[args.model, args.images]
    )
    print(
        f"wrote {out}: {len(views)} view(s) from {len(model.images)} images of {args.model}; "
        f"scale {'unknown (up to scale)' if scale == 'unknown' else 'fixed by the known distance'}",
        file=sys.stderr,
    )
    for i, pair in enumerate(pairs):
        print(
            f"  view {i:02d}: {pair.left.name} | {pair.right.name}: {pair.shared} shared points, "
            f"baseline/depth {pair.ratio:.3f}",
            file=sys.stderr,
        )
    return 0
