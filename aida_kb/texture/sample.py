"""Bilinear image lookups at many arbitrary positions."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.vision.rectify import sample_points


def sample_bilinear(
    image: npt.NDArray[np.uint8], x: npt.ArrayLike, y: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """Colours (N, C) of an (H, W, C) image at pixel positions x, y (N,) (pixel centres at
    integer coordinates); positions outside repeat the border (`vision.rectify.sample_points`)."""
    channels = 1 if image.ndim == 2 else image.shape[2]
    if np.asarray(x).size == 0:
        return np.zeros((0, channels))
    out = sample_points(image, x, y, border=cv2.BORDER_REPLICATE)
    return out.reshape(-1, channels)
