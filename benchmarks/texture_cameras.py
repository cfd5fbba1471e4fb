"""What the texture factors do to the later views' cameras (not a test). Prints a line per
registered later view, then ONE line of JSON.

For each kept robustness scene (``benchmarks/robustness.py --keep DIR``), the image rounds'
last problem is built again at the kept model and cameras (as `benchmarks/camera_limits.py`
builds it: `aida_kb.interpret.joint.joint_problem`) and solved again with the texture factors
of every later view added (`aida_kb.interpret.photometric.texture_factors`: patches of the
first view's left image on the model's faces, seen again in the view's left image), coarse to
fine over the blurs `BLURS_PX`, each level's factors made at the previous level's solution
with their noise measured there (`texture_noise_grey`). A view whose factors are not
well-posed (`well_posed`) gets none. Each later camera's rotation error against the truth and
its deviation (the reconstruction's covariance, `problem_information`, which rescales the
texture residuals by their own variance factor but treats them as independent) are given
before (the kept run) and after.

JSON: ``cameras`` (views), ``textured`` (views with texture factors); before and after: the
median error (deg), the share within 0.1 deg, the median sd (deg), the share of errors within
2 sd; the median seconds per scene with texture factors. ``--noise-factor F`` multiplies
the texture residuals' measured sigma (their weight in the solve; the deviations rescale it).

Measured (this session, kept runs of main 4660278; "textured": the views with texture
factors, all other views keep their cameras unless the texture of another view of their scene
moves the model):

- dev 67000-67035 (31 later views, 13 textured, 5 scenes' texture left out): median error
  0.072 -> 0.088 deg, within 0.1 deg 0.52 -> 0.52, median sd 0.170 -> 0.110 deg, within 2 sd
  1.00 -> 0.84; the textured views 0.062 -> 0.088 deg (6 better, 7 worse), 0.62 of them within
  2 sd. With ``--noise-factor 3``: 0.072 -> 0.107 deg, within 2 sd 0.81.
- control 66000-66035 (kept runs of main of session 22; 35 views, 10 textured): 0.067 ->
  0.067 deg, within 0.1 deg 0.66 -> 0.60, median sd 0.104 -> 0.081, within 2 sd 1.00 -> 0.89;
  the textured views 0.071 -> 0.073 (4 better, 6 worse; 66026 0.119 -> 0.022, 66012 0.114 ->
  0.309), 0.60 within 2 sd.
- 4-20 s a scene with texture (two levels, two solves each, about 100-450 patches a view).

Not better and not honest: the kept model's planes are off in the first view's frame (dev
67003 front wall 0.10 deg, roof 0.27 deg) and the texture, which fixes a later camera against
the planes (with the TRUE planes held, dev 67003's camera 0.045 -> 0.0045 deg), does not fix
the planes' turn: their cost changes by 17 (of 20,000 residuals) between the solution 0.13
deg off and the truth. Hence the factors are not in the reconstruction.

Run: ``python benchmarks/texture_cameras.py KEEP [--seeds A-B]``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

sys.path.insert(0, str(Path(__file__).resolve().parent))

if TYPE_CHECKING:
    from aida_kb.constraints import Constraint
    from aida_kb.geometry.camera import PinholeCamera
    from aida_kb.kb.model import KnowledgeBase
    from aida_kb.register import RigidModel
    from aida_kb.solve.problem import Problem

FloatArray = npt.NDArray[np.float64]

BLURS_PX = (2.0, 1.0)
"""The Gaussian blurs (sd, pixels) of the coarse-to-fine levels: a start a few pixels off
still lies in the blurred texture's basin (the prototype's pyramid 2/1/0 reached the same
cameras from 2/1)."""

STEREO = True
"""Also the first view's texture seen again in its own right image (fixes the planes)."""


AGREE_SIGMAS = 2.0
"""The texture is left out of a scene (every camera as before) when it moves a later camera
by more than this many of the camera's deviations without it: it disagrees with the other
evidence (a wrong part, a bias), and the verdict must not lean on it (dev 67005: view 01 went
0.06 -> 0.19 deg off, its untextured view 02 0.12 -> 0.46)."""

FAR_DEG = 1.0
"""A kept camera this far off the truth is another registration's problem: left out."""


def _rotation_error_deg(cam: PinholeCamera, true_R: FloatArray) -> float:
    """The angle between a camera's rotation and the truth's, degrees."""
    from scipy.spatial.transform import Rotation

    rel = Rotation.from_matrix(cam.R_cam_world @ true_R.T).as_rotvec()
    return float(np.degrees(np.linalg.norm(rel)))


def _sds_deg(problem: Problem, parts: int, cameras: list[PinholeCamera], views: int) -> list[float]:
    """The rotation deviation of each of the `views` - 1 later views' cameras (free, after
    the fixed first), degrees (inf where open)."""
    from aida_kb.interpret.uncertainty import (
        camera_rotation_covariance,
        covariance_of,
        problem_information,
    )

    free = list(range(1, views))
    info = problem_information(problem, parts, cameras, free)
    if info is None:
        return [math.inf] * len(free)
    cov = covariance_of(info.Jw.T @ info.Jw)
    out = []
    for k in free:
        rot = camera_rotation_covariance(cov, parts, k - 1, cameras[k])
        out.append(
            math.degrees(math.sqrt(float(np.trace(rot)))) if np.all(np.isfinite(rot)) else math.inf
        )
    return out


def _rebuilt(
    base: Problem,
    normals: FloatArray,
    offsets: FloatArray,
    cameras: tuple[PinholeCamera, ...],
    rigid: RigidModel,
    extra: list[Constraint],
) -> Problem:
    """`base`'s factors and `extra` at the planes and cameras given."""
    from aida_kb.interpret.joint import part_centres
    from aida_kb.solve import build_problem

    return build_problem(
        normals,
        offsets,
        [*base.constraints, *extra],
        centres=part_centres(rigid),
        names=rigid.names,
        cameras=cameras,
        free_cameras=base.free_cameras,
        derived=base.derived,
    )


def scene_views(
    keep: Path,
    seed: int,
    kb_of: Callable[[str], KnowledgeBase],
    noise_factor: float = 1.0,
) -> tuple[list[dict[str, object]], float]:
    """One record per registered later view of the kept scene `seed`; the scene's seconds.
    The texture residuals' sigma is their measured scale times `noise_factor`."""
    import cv2
    from camera_limits import _problem, registered_views

    from aida_kb.constraints import TextureImage
    from aida_kb.errors import AidaError
    from aida_kb.interpret.imagefit import right_images, view_images
    from aida_kb.interpret.joint import JOINT_F_SCALE, JOINT_LOSS
    from aida_kb.interpret.photometric import (
        agreeing_patches,
        texture_factors,
        texture_noise_grey,
        well_posed,
    )
    from aida_kb.interpret.result import read_interpretation
    from aida_kb.io.evidence import read_evidence
    from aida_kb.io.scene import read_scene
    from aida_kb.register import RigidModel
    from aida_kb.register.evidence import camera_of, measurements_of
    from aida_kb.solve import solve

    out_dir = keep / f"out-{seed}"
    if not (out_dir / "interpretation.json").is_file():
        return [], 0.0
    scene = read_scene(keep / f"scene-{seed}")
    truth = scene.truth
    interp = read_interpretation(out_dir / "interpretation.json")
    evidence = read_evidence(out_dir / "evidence.json")
    model = interp.model
    if truth is None or model is None or len(model.cameras) < 2:
        return [], 0.0
    by_id = {v.id: v for v in evidence.views}
    order, placed, true_poses = registered_views(evidence, model, truth)
    if not order:
        return [], 0.0
    kb = kb_of(str(truth.parameters.get("knowledge", "buildings.kb")))
    start = time.perf_counter()
    try:
        rigid = RigidModel.from_model(model)
        cams = [camera_of(placed[v]) for v in order]
        base, _ = _problem(kb, interp, evidence, scene, rigid, cams, order)
        P = len(rigid.names)
        sd0 = _sds_deg(base, P, cams, len(order))
        right = right_images(scene, [order[0]])[0]
        greys = view_images(scene, evidence, [measurements_of(by_id[v]) for v in order])
        normals, offsets, now = rigid.normals, rigid.offsets, tuple(base.cameras)
        textured: dict[int, int] = {}
        problem, cameras = base, now
        for blur in BLURS_PX:
            blurred = [
                None if g is None else cv2.GaussianBlur(g.astype(np.float64), (0, 0), blur)
                for g in greys
            ]
            ref = blurred[0]
            if ref is None:
                break
            current = RigidModel.from_polygons(
                list(rigid.names), normals, offsets, list(rigid.polygons)
            )
            extra: list[Constraint] = []
            for k in range(1, len(order)):
                img = blurred[k]
                if img is None:
                    continue
                tex = texture_factors(
                    current, now[0], ref, now[k], k, TextureImage(img), 1.0, order[k]
                )
                if not well_posed(tex, normals):
                    continue
                sigma = texture_noise_grey(normals, offsets, now, tex)
                extra += [replace(c, sigma=sigma * noise_factor) for c in tex]
                textured[k] = len(tex)
            if not extra:
                break
            cameras = now
            if STEREO and right is not None:  # the first view's own right image
                rig, right_image = right
                cameras = (*now, rig.right_of(now[0]))
                rb = cv2.GaussianBlur(right_image.astype(np.float64), (0, 0), blur)
                st = texture_factors(
                    current, now[0], ref, cameras[-1], len(now), TextureImage(rb), 1.0, "00 right"
                )
                sigma = texture_noise_grey(normals, offsets, cameras, st)
                extra += [replace(c, sigma=sigma * noise_factor) for c in st]
            for _ in range(2):
                problem = _rebuilt(base, normals, offsets, cameras, rigid, extra)
                result = solve(problem, loss=JOINT_LOSS, f_scale=JOINT_F_SCALE)
                normals, offsets, cameras = result.normals, result.offsets, result.cameras
                extra = agreeing_patches(extra, normals, offsets, cameras)
            now = cameras[: len(base.cameras)]
            problem = _rebuilt(base, normals, offsets, cameras, rigid, extra)
        sd1 = _sds_deg(problem, P, list(cameras), len(order))
        moved = [_rotation_error_deg(now[k], cams[k].R_cam_world) for k in range(1, len(order))]
        agrees = all(
            m <= AGREE_SIGMAS * s for m, s in zip(moved, sd0, strict=True) if math.isfinite(s)
        )
        if not agrees:  # the texture disagrees with the other evidence: left out
            now, sd1 = tuple(cams), sd0
    except AidaError as exc:
        print(f"seed {seed}: {exc}", file=sys.stderr)
        return [], time.perf_counter() - start
    seconds = time.perf_counter() - start
    records: list[dict[str, object]] = []
    for k in range(1, len(order)):
        true_R = np.asarray(true_poses[order[k]].R, dtype=np.float64)
        e0 = _rotation_error_deg(cams[k], true_R)
        if e0 > FAR_DEG:
            continue
        e1 = _rotation_error_deg(now[k], true_R)
        s1 = sd1[k - 1]
        records.append(
            {
                "seed": seed,
                "view": order[k],
                "patches": textured.get(k, 0) if agrees else 0,
                "left_out": not agrees,
                "moved_deg": round(moved[k - 1], 4),
                "error_deg": round(e0, 4),
                "sd_deg": round(sd0[k - 1], 4),
                "after_error_deg": round(e1, 4),
                "after_sd_deg": round(s1, 4),
            }
        )
    return records, seconds


def _median(values: list[float]) -> float | None:
    finite = [v for v in values if math.isfinite(v)]
    return round(float(np.median(finite)), 4) if finite else None


def summary(records: list[dict[str, object]], seconds: list[float]) -> dict[str, object]:
    """The JSON line's figures (module docstring)."""

    def col(name: str) -> list[float]:
        return [float(r[name]) for r in records]  # type: ignore[arg-type]

    out: dict[str, object] = {
        "cameras": len(records),
        "textured": sum(1 for r in records if r["patches"]),
        "left_out": sum(1 for r in records if r["left_out"]),
    }
    for tag, err, sd in (
        ("before", "error_deg", "sd_deg"),
        ("after", "after_error_deg", "after_sd_deg"),
    ):
        e, s = np.array(col(err)), np.array(col(sd))
        out[tag] = {
            "median_error_deg": _median(list(e)),
            "within_0.1_deg": round(float(np.mean(e <= 0.1)), 3) if e.size else None,
            "median_sd_deg": _median(list(s)),
            "within_2sd": round(float(np.mean(e <= 2.0 * s)), 3) if e.size else None,
        }
    out["median_seconds_per_scene"] = _median(seconds)
    return out


def main(argv: list[str] | None = None) -> None:
    """Read the kept scenes, print a line per view and the JSON summary."""
    from camera_limits import kept_seeds, knowledge_bases

    parser = argparse.ArgumentParser(description="The texture factors and the later cameras.")
    parser.add_argument("keep", type=Path, help="a robustness --keep folder")
    parser.add_argument("--seeds", default="", help="only these seeds: A-B (inclusive)")
    parser.add_argument(
        "--noise-factor", type=float, default=1.0, help="the texture sigma's factor (default 1)"
    )
    args = parser.parse_args(argv)
    kb_of = knowledge_bases()
    records: list[dict[str, object]] = []
    seconds: list[float] = []
    for seed in kept_seeds(args.keep, args.seeds):
        recs, s = scene_views(args.keep, seed, kb_of, args.noise_factor)
        for r in recs:
            print(json.dumps(r), file=sys.stderr, flush=True)
        records += recs
        if any(r["patches"] or r["left_out"] for r in recs):  # the scenes with texture
            seconds.append(s)
    print(json.dumps(summary(records, seconds)))


if __name__ == "__main__":
    main()
