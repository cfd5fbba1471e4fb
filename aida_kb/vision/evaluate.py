"""Evaluation against the ground truth of synthetic scenes (truth.json + labels.png).

Used by the tests and benchmarks/stereo.py: exact disparity of the rectified left image by
ray-plane intersection with the labelled part's plane, and bad-pixel rates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.io.scene import SceneTruth
from aida_kb.vision.rectify import Rectification, remap

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]


def truth_planes_camera(truth: SceneTruth, view: str) -> dict[int, tuple[F64, float]]:
    """label -> (unit normal, offset) of every truth plane in the view's left camera frame.

    n_cam·x_cam = d_cam with n_cam = R·n, d_cam = d + n_cam·t (x_cam = R·x_world + t).
    """
    pose = truth.pose(view)
    R, t = np.asarray(pose.R, float), np.asarray(pose.t, float)
    planes: dict[int, tuple[F64, float]] = {}
    items = [(p.label, p.normal, p.d) for p in truth.parts]
    if truth.ground is not None:
        items.append((truth.ground.label, truth.ground.normal, truth.ground.d))
    for label, normal, d in items:
        n_cam = R @ np.asarray(normal, float)
        planes[label] = (n_cam, float(d + n_cam @ t))
    return planes


def truth_disparity(
    truth: SceneTruth, view: str, labels: npt.NDArray[np.uint16], rect: Rectification
) -> F32:
    """Exact disparity (H', W') float32 of the rectified left image; NaN where no labelled part.

    labels : (H, W) labels.png of the ORIGINAL left image; each rectified pixel takes the label
    of the nearest original pixel and the exact depth of that label's plane along its ray.
    """
    planes = truth_planes_camera(truth, view)
    W, H = rect.rect_size
    lab = remap(labels.astype(np.float32), rect.map_left, nearest=True, border=0.0)
    lab = lab.astype(np.int64)
    f = rect.focal_px
    cx, cy = rect.P1[0, 2], rect.P1[1, 2]
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(xs - cx) / f, (ys - cy) / rect.P1[1, 1], np.ones_like(xs)], axis=-1)
    rays_orig = rays @ rect.R1  # R1^T · r as row vectors
    z = np.full((H, W), np.nan)
    for label, (n, d) in planes.items():
        sel = lab == label
        if not np.any(sel):
            continue
        z[sel] = d / (rays_orig[sel] @ n)  # depth along the rectified z (ray z = 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        disp = np.where(z > 0, f * rect.baseline_m / z, np.nan)
    return disp.astype(np.float32)


@dataclass(frozen=True)
class DisparityScore:
    """Density and bad-pixel rates of a disparity map against the truth (pixels with truth)."""

    density: float  # fraction of truth pixels that have an estimate
    bad1: float  # fraction of estimated pixels with |error| > 1 px
    bad2: float  # fraction of estimated pixels with |error| > 2 px
    mean_abs_px: float  # mean |error| over estimated pixels


def score_disparity(
    estimate: F32, truth: F32, *, mask: npt.NDArray[np.bool_] | None = None
) -> DisparityScore:
    """Compare `estimate` (NaN = none) with `truth` (NaN = unknown) on the pixels with truth.

    mask : optional (H, W) bool; only pixels where it is True count.
    """
    if estimate.shape != truth.shape:
        raise VisionError(f"estimate {estimate.shape} and truth {truth.shape} differ in shape")
    known = ~np.isnan(truth)
    if mask is not None:
        known &= mask
    has = known & ~np.isnan(estimate)
    n_known, n_has = int(known.sum()), int(has.sum())
    if n_known == 0:
        raise VisionError("no pixel with a true disparity to compare with")
    err = np.abs(estimate[has] - truth[has])
    return DisparityScore(
        density=n_has / n_known,
        bad1=float((err > 1.0).mean()) if n_has else 0.0,
        bad2=float((err > 2.0).mean()) if n_has else 0.0,
        mean_abs_px=float(err.mean()) if n_has else 0.0,
    )


def angle_deg(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Angle between two 3-vectors, degrees."""
    u, v = np.asarray(a, float), np.asarray(b, float)
    c = float(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
