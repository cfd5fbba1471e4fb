"""The stereo points of every view, in the world frame, coloured from the left images."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.io.model import ReconstructedModel
from aida_kb.io.scene import Scene, read_image
from aida_kb.vision.evidence import ViewProducts

FloatArray = npt.NDArray[np.float64]

# points whose stereo certainty is below this are left out (the matcher's weakest matches)
MIN_POINT_CERTAINTY = 0.1


def stereo_points(
    products: Sequence[ViewProducts], model: ReconstructedModel, scene: Scene
) -> tuple[FloatArray, npt.NDArray[np.uint8]]:
    """Points (N, 3), world frame, metres, and colours (N, 3) uint8 RGB of every view's depth.

    A view's points are in its left camera's frame; the model's camera of that view
    (x_cam = R·x_world + t) takes them to the world frame. Views the model has no camera for
    are left out.
    """
    poses = {c.view: c for c in model.cameras}
    all_points, all_colours = [], []
    for prod in products:
        cam = poses.get(prod.evidence.id)
        if cam is None:
            continue
        depth = prod.depth
        keep = np.isfinite(depth.depth_m) & (depth.certainty >= MIN_POINT_CERTAINTY)
        p_cam = depth.points[keep].astype(np.float64)
        R = np.array(cam.R, dtype=np.float64)
        t = np.array(cam.t, dtype=np.float64)
        all_points.append((p_cam - t) @ R)  # R^T (p - t) per row
        image = read_image(scene.view(prod.evidence.id).left)
        all_colours.append(image[keep][:, ::-1])
    if not all_points:
        return np.zeros((0, 3)), np.zeros((0, 3), np.uint8)
    return np.concatenate(all_points), np.concatenate(all_colours).astype(np.uint8)
