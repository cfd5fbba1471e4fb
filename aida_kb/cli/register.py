"""`aida-kb register`: the pose of one view of a scene against a fixed model (paper §6.2)."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

EXAMPLE = """\
what it does:
  runs the vision front end on view NN of SCENE_DIR, then finds that view's camera pose
  with the model of MODEL (model.json) held fixed: a coarse search over the turn about the
  model's vertical axis, then match model edges to image segments of both images of the
  stereo pair, solve for the 6 pose parameters (edge constraints, and position constraints
  from the view's depth), re-match and solve again. No initial guess is needed;
  --init-angle narrows the search to +-30 degrees about a rough turn (for a symmetric
  object, the turn decides which of the equally good poses is meant). The scene's
  truth.json is never read.

prints:
  the pose (R_cam_world, t_cam_world, rotation vector and centre C in metres), the turn
  about the vertical relative to the reference camera (degrees), the RMS edge residual in
  pixels and how many segments and regions it rests on.

examples:
  aida-kb synth house -o out/house
  aida-kb reconstruct kb/buildings.kb out/house -o out/m --views 00
  aida-kb register out/m/model.json out/house --view 01
  aida-kb register out/m/model.json out/house --view 01 --init-angle 45 --json
"""


def register(subparsers: Any) -> None:
    """Add the `register` command."""
    from aida_kb.cli.evidence import add_max_disp

    p = subparsers.add_parser(
        "register",
        help="find a view's camera pose against a fixed model (viewpoint registration)",
        description=(
            "Register view NN of a scene directory against the model in MODEL: the camera "
            "pose that makes the model's edges fall on the view's image segments."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", metavar="MODEL", help="model.json (aida-kb reconstruct)")
    p.add_argument("scene", metavar="SCENE_DIR", help="scene directory (scene.yaml)")
    p.add_argument("--view", required=True, metavar="NN", help="id of the view to register")
    p.add_argument(
        "--init-angle",
        type=float,
        default=None,
        metavar="DEG",
        help="rough turn about the vertical from the reference camera, degrees",
    )
    p.add_argument(
        "--reference",
        default=None,
        metavar="NN",
        help="the model camera to start from (default: the model's first camera)",
    )
    p.add_argument("--no-regions", action="store_true", help="edge constraints only")
    add_max_disp(p)
    p.add_argument(
        "--left-only",
        action="store_true",
        help="only the left image's segments (default: the right image's as well)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Register the view and print its pose and residual."""
    import sys

    import numpy as np

    from aida_kb.cli.evidence import check_max_disp
    from aida_kb.errors import FormatError
    from aida_kb.io.model import read_model
    from aida_kb.io.scene import read_image, read_scene
    from aida_kb.register import RigidModel
    from aida_kb.register.evidence import (
        camera_of,
        check_reference_camera,
        register_evidence_view,
        right_segments,
    )
    from aida_kb.vision.evidence import VisionParams, scene_evidence

    check_max_disp(args.max_disp)
    if args.init_angle is not None and not math.isfinite(args.init_angle):
        raise FormatError(f"--init-angle must be a finite number of degrees, got {args.init_angle}")
    model_file = read_model(args.model)
    if not model_file.cameras:
        raise FormatError(f"{args.model}: field cameras: the model has no camera to start from")
    views = [c.view for c in model_file.cameras]
    if args.reference is not None and args.reference not in views:
        have = ", ".join(views)
        raise FormatError(f"{args.model}: no camera of view {args.reference!r} (has {have})")
    index = 0 if args.reference is None else views.index(args.reference)
    ref_entry = model_file.cameras[index]
    model = RigidModel.from_model(model_file)
    check_reference_camera(model, ref_entry, args.model, index)
    scene = read_scene(args.scene, with_truth=False)
    evidence, products = scene_evidence(
        scene, views=[args.view], params=VisionParams(num_disp=args.max_disp)
    )
    for text in products[0].warnings:
        print(f"warning: {text}", file=sys.stderr)
    reg = register_evidence_view(
        model,
        camera_of(ref_entry),
        evidence.views[0],
        init_angle_deg=args.init_angle,
        use_regions=not args.no_regions,
        stereo=None if args.left_only else right_segments(scene, args.view),
        image=read_image(scene.view(args.view).left, grey=True),
    )
    cam = reg.camera
    pose = cam.pose
    out = {
        "view": args.view,
        "reference": ref_entry.view,
        "R_cam_world": np.round(cam.R_cam_world, 9).tolist(),
        "t_cam_world_m": np.round(cam.t_cam_world, 6).tolist(),
        "rvec_rad": np.round(pose[:3], 9).tolist(),
        "centre_m": np.round(pose[3:], 6).tolist(),
        "turn_deg": round(reg.angle_deg, 4),
        "rms_px": round(reg.rms_px, 4),
        "segments": reg.n_edges,
        "regions": reg.n_regions,
        "chamfer_cost": round(reg.cost, 4),
        "turn_sigma_deg": _finite(reg.turn_sigma_deg, 4),
        "rotation_sigma_deg": _finite(reg.rotation_sigma_deg, 4),
        "centre_sigma_m": [_finite(math.sqrt(v), 6) for v in np.diag(reg.covariance)[3:]],
        "alternative_turns_deg": [round(a, 1) for a, _ in reg.alternatives],
        "undecided_turns_deg": [round(a, 1) for a in reg.undecided],
    }
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"view {args.view} registered against {args.model} (reference view {ref_entry.view})")
    print(f"  turn about the vertical: {reg.angle_deg:.4f} deg")
    print(f"  centre C: {_vec(pose[3:])} m")
    print(f"  rotation vector: {_vec(pose[:3])} rad")
    print("  R_cam_world:")
    for row in cam.R_cam_world:
        print(f"    {_vec(row)}")
    print(f"  t_cam_world: {_vec(cam.t_cam_world)} m")
    print(
        f"  residual: {reg.rms_px:.3f} px RMS over {reg.n_edges} segments"
        f" and {reg.n_regions} regions (chamfer cost {reg.cost:.3f})"
    )
    print(
        f"  uncertainty (1 sigma, from the adjustment): turn {reg.turn_sigma_deg:.4f} deg,"
        f" rotation {reg.rotation_sigma_deg:.4f} deg about its least determined axis"
    )
    if reg.alternatives:
        turns = ", ".join(f"{a:.1f} deg (chamfer cost {c:.3f})" for a, c in reg.alternatives)
        print(f"  ambiguous: the image fits turns of {turns} about as well")
    if reg.undecided:
        turns = ", ".join(f"{a:.1f}" for a in reg.undecided)
        print(
            f"  undecided: nothing in the view rules out the turns {turns} deg (the model "
            "looks the same turned so); the turn taken is the one nearest the expected turn"
        )
    return 0


def _finite(value: float, digits: int) -> float | None:
    """`value` rounded, or None (JSON null) when the evidence leaves it undetermined."""
    return round(value, digits) if math.isfinite(value) else None


def _vec(v: Any) -> str:
    return "[" + ", ".join(f"{float(x): .6f}" for x in v) + "]"
