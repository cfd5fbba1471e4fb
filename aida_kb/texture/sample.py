"""Bilinear image lookups at many arbitrary positions."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

# cv2.remap needs maps below 32767 pixels a side: positions go in rows of this many
ROW = 4096


def sample_bilinear(
    image: npt.NDArray[np.uint8], x: npt.ArrayLike, y: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """Colours (N, C) of an (H, W, C) image at pixel positions x, y (N,) (pixel centres at
    integer coordinates); positions outside repeat the border."""
    xs = np.asarray(x, dtype=np.float32).ravel()
    ys = np.asarray(y, dtype=np.float32).ravel()
    n = len(xs)
    channels = 1 if image.ndim == 2 else image.shape[2]
    if n == 0:
        return np.zeros((0, channels))
    rows = -(-n // ROW)
    mx = np.zeros(rows * ROW, np.float32)
    my = np.zeros(rows * ROW, np.float32)
    mx[:n], my[:n] = xs, ys
    out = cv2.remap(
        image,
        mx.reshape(rows, ROW),
        my.reshape(rows, ROW),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return np.asarray(out, dtype=np.float64).reshape(rows * ROW, channels)[:n]
