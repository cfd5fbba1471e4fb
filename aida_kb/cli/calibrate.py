"""`aida-kb calibrate`: stereo calibration from chessboard image pairs -> calib.yaml."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
CHESSBOARD_DIR holds image pairs: a scene directory (views/NN/left.png, views/NN/right.png)
or a folder of left_*.png / right_*.png. The defaults (--pattern 9x6 --square 0.06) match
`aida-kb synth chessboard`. Output: calib.yaml of the scene format (cv2.FileStorage: K1 D1 K2
D2 R T image_width image_height; T in metres), and the RMS reprojection errors.

examples:
  aida-kb synth chessboard -o out/board
  aida-kb calibrate out/board -o out/calib.yaml
  aida-kb calibrate photos/ -o calib.yaml --pattern 8x5 --square 0.025
"""


def register(subparsers: Any) -> None:
    """Add the `calibrate` command."""
    p = subparsers.add_parser(
        "calibrate",
        help="calibrate a stereo rig from chessboard image pairs",
        description=(
            "Find the chessboard's inner corners (subpixel) in every left/right pair, "
            "calibrate each camera (cv2.calibrateCamera) and the pair (cv2.stereoCalibrate), "
            "and write calib.yaml; reports the RMS reprojection errors in pixels."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("directory", metavar="CHESSBOARD_DIR", help="folder with the image pairs")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="calib.yaml to write")
    p.add_argument(
        "--pattern", default="9x6", metavar="COLSxROWS", help="inner corners (default 9x6)"
    )
    p.add_argument(
        "--square", type=float, default=0.06, metavar="M", help="square side, metres (0.06)"
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Calibrate and write calib.yaml."""
    import math
    import sys

    from aida_kb.errors import VisionError
    from aida_kb.io.atomic import check_output
    from aida_kb.io.scene import write_calib
    from aida_kb.vision.calibration import calibrate_stereo, find_pairs

    cols, sep, rows = str(args.pattern).lower().partition("x")
    if not sep or not cols.isdigit() or not rows.isdigit():
        raise VisionError(f"--pattern {args.pattern!r}: expected COLSxROWS, e.g. 9x6")
    if int(cols) < 2 or int(rows) < 2:
        raise VisionError(f"--pattern {args.pattern!r}: need at least 2x2 inner corners")
    if not (math.isfinite(args.square) and args.square > 0):
        raise VisionError(f"--square {args.square}: expected a positive side length in metres")
    check_output(args.output)  # a wrong -o fails at once, before the images are looked for
    pairs = find_pairs(args.directory)
    check_output(args.output, [p for pair in pairs for p in pair])
    result = calibrate_stereo(pairs, (int(cols), int(rows)), float(args.square))
    write_calib(args.output, result.calib)
    print(
        f"wrote {args.output}: {len(result.used)} of {len(pairs)} views used; RMS reprojection "
        f"error left {result.rms_left_px:.3f} px, right {result.rms_right_px:.3f} px, "
        f"stereo {result.rms_stereo_px:.3f} px; baseline {result.calib.baseline_m:.4f} m",
        file=sys.stderr,
    )
    for name in result.rejected:
        print(f"  no complete chessboard in both images of {name}", file=sys.stderr)
    return 0
