"""Camera-centred depth from disparity, in the ORIGINAL left camera and image (paper §2).

The disparity map lives on the rectified left image; the evidence is given in the original
left camera (whose frame is the world frame for view 00). `depth_map` turns disparity into 3-D
points of the original left camera frame (the rectified camera is the original one turned by
R1, same centre) and resamples them onto the original image grid. Pixels whose certainty is
below a threshold, whose neighbourhood straddles a dropout, or whose bilinear sample would mix
the two sides of a depth discontinuity become dropouts (NaN) — no depth is invented.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.vision.rectify import Rectification
from aida_kb.vision.stereo import DisparityMap

F32 = npt.NDArray[np.float32]

MAX_BLEND = 0.01  # relative depth difference between bilinear and nearest sample: a discontinuity


@dataclass(frozen=True)
class DepthMap:
    """Depth on the original left image, all (H, W) unless noted.

    depth_m : float32, z in the original left camera frame, metres; NaN = dropout.
    points : (H, W, 3) float32, metres, original left camera frame; NaN = dropout.
    certainty : float32 in [0, 1] on the original image (0 at dropouts).
    """

    depth_m: F32
    points: F32
    certainty: F32

    @property
    def density(self) -> float:
        """Fraction of pixels with a depth."""
        return float(np.count_nonzero(~np.isnan(self.depth_m))) / max(1, self.depth_m.size)


def depth_map(
    disparity: DisparityMap, rect: Rectification, *, min_certainty: float = 0.05
) -> DepthMap:
    """Depth, 3-D points and certainty on the original left image.

    disparity : the NCC result on the rectified pair of `rect`.
    min_certainty : pixels less certain than this (0..1) become dropouts.
    """
    disp = np.where(disparity.certainty >= min_certainty, disparity.disparity, np.nan)
    pts_rect_grid = rect.points_from_disparity(disp.astype(np.float32))
    pts = rect.to_original(pts_rect_grid)
    z_near = rect.to_original(pts_rect_grid[..., 2], nearest=True)
    with np.errstate(invalid="ignore"):
        blended = np.abs(pts[..., 2] - z_near) > MAX_BLEND * np.abs(z_near)
    pts[blended] = np.nan
    certainty = rect.to_original(disparity.certainty)
    bad = np.isnan(pts[..., 2]) | np.isnan(certainty)
    pts[bad] = np.nan
    certainty = np.where(bad, 0.0, np.clip(certainty, 0.0, 1.0)).astype(np.float32)
    return DepthMap(
        depth_m=np.ascontiguousarray(pts[..., 2]),
        points=pts.astype(np.float32),
        certainty=certainty,
    )
