"""`aida-kb disparity`: NCC disparity (and certainty) of a rectified stereo pair."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
The pair must be rectified (epipolar lines = image rows, right camera to the right).
Output: float32 .npy (H, W), disparity x_left - x_right in pixels of the left image,
NaN where there is none (flat texture, occlusion, failed left-right check).

examples:
  aida-kb synth house -o out/house     # a rendered pair (its rig is rectified already)
  aida-kb disparity out/house/views/00/left.png out/house/views/00/right.png -o d.npy
  aida-kb disparity out/house/views/00/left.png out/house/views/00/right.png -o d.npy \
      --max-disp 32 --window 11 --certainty c.npy
  aida-kb disparity out/house/views/00/left.png out/house/views/00/right.png -o d.npy \
      --matcher sgm
"""


BLOCK_WINDOW = 15  # block matching's window for a pair of unknown content, pixels
FALLBACK_NUM_DISP = 64  # searched when no --max-disp is given and too few features match


def add_matcher(p: argparse.ArgumentParser) -> None:
    """Add the ``--matcher`` option of the commands that compute a dense disparity."""
    p.add_argument(
        "--matcher",
        choices=("ncc", "sgm"),
        default="ncc",
        help="ncc: NCC block matching (default); sgm: semi-global aggregation of the NCC "
        "costs: fills weak texture (with a low certainty there), fewer wrong matches at depth "
        "edges, several times slower",
    )


def register(subparsers: Any) -> None:
    """Add the `disparity` command."""
    p = subparsers.add_parser(
        "disparity",
        help="NCC disparity map of a rectified stereo pair",
        description=(
            "Block-wise normalised cross-correlation stereo with subpixel refinement, "
            "left-right check and a certainty map (NCC peak, distinctiveness, gradient)."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("left", help="left image (8-bit, rectified)")
    p.add_argument("right", help="right image (8-bit, rectified)")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="disparity .npy to write")
    p.add_argument(
        "--max-disp",
        type=int,
        default=None,
        metavar="N",
        help="disparities --min-disp..N-1 (default: the range found from sparse feature matches)",
    )
    p.add_argument("--min-disp", type=int, default=0, metavar="N", help="smallest disparity (0)")
    p.add_argument(
        "--window",
        type=int,
        default=None,
        metavar="N",
        help="odd window size (block matching 15, sgm 7)",
    )
    add_matcher(p)
    p.add_argument(
        "--exact",
        action="store_true",
        help="exact zero-mean NCC of each window (slower) instead of the correlation of "
        "locally normalised images",
    )
    p.add_argument("--certainty", metavar="FILE", help="also write the certainty map (.npy)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Compute and write the disparity (and certainty) maps."""
    import sys
    import time

    import numpy as np

    from aida_kb.errors import VisionError
    from aida_kb.io.atomic import atomic_path, check_outputs
    from aida_kb.io.scene import read_image
    from aida_kb.vision.disprange import (
        MAX_NUM_DISP,
        disparity_range,
        saturation_warnings,
        sparse_disparities,
    )
    from aida_kb.vision.sgm import SGM_WINDOW, sgm_disparity
    from aida_kb.vision.stereo import ncc_disparity

    if args.window is None:
        args.window = SGM_WINDOW if args.matcher == "sgm" else BLOCK_WINDOW
    if args.window < 3 or args.window % 2 == 0:
        raise VisionError(f"--window {args.window}: the window must be odd and >= 3 pixels")
    check_outputs([p for p in (args.output, args.certainty) if p], (args.left, args.right))
    left = read_image(args.left, grey=True)
    right = read_image(args.right, grey=True)
    if left.shape != right.shape:
        raise VisionError(
            f"{args.right}: size {right.shape[1]}x{right.shape[0]} differs from "
            f"{args.left}: {left.shape[1]}x{left.shape[0]}"
        )
    start = time.perf_counter()
    notes: list[str] = []
    if args.max_disp is None:
        found = disparity_range(left, right)
        if found is None:
            lo, num = args.min_disp, FALLBACK_NUM_DISP
            notes.append(
                f"{args.left}: too few feature matches to find the disparity range; "
                f"searched {lo}..{lo + num - 1} px (give --max-disp)"
            )
        else:
            lo = max(found.min_disp, args.min_disp)
            num = found.num_disp - (lo - found.min_disp)
    else:
        lo, num = args.min_disp, args.max_disp - args.min_disp
    if not 3 <= num <= MAX_NUM_DISP:
        raise VisionError(
            f"--min-disp {lo} --max-disp {lo + num}: 3..{MAX_NUM_DISP} disparities are searched"
        )
    if args.matcher == "sgm":
        result = sgm_disparity(left, right, min_disp=lo, num_disp=num, window=args.window)
    else:
        result = ncc_disparity(
            left, right, min_disp=lo, num_disp=num, window=args.window, exact=args.exact
        )
    elapsed = time.perf_counter() - start
    sparse = sparse_disparities(left, right) if args.max_disp is not None else None
    for text in notes + saturation_warnings(result, lo, num, sparse):
        print(f"warning: {text}", file=sys.stderr)
    outputs = [(args.output, result.disparity)]
    if args.certainty:
        outputs.append((args.certainty, result.certainty))
    for path, array in outputs:
        with atomic_path(path) as tmp, tmp.open("wb") as fh:
            np.save(fh, array, allow_pickle=False)
    print(
        f"wrote {args.output}: {left.shape[1]}x{left.shape[0]}, disparities {lo}..{lo + num - 1}, "
        f"density {result.density:.3f}, "
        f"{elapsed * 1000:.0f} ms",
        file=sys.stderr,
    )
    return 0
