"""Synthetic rectified stereo pairs with a known disparity, for the matcher tests.

`random_texture` is a band-limited random grey texture (what block matching needs);
`warp_right` makes the right image of a surface whose disparity is given at each right pixel.
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

F32 = npt.NDArray[np.float32]

__all__ = ["random_texture", "warp_right"]


def random_texture(h: int, w: int, seed: int = 0) -> F32:
    """(h, w) float32 grey levels around 128 (std 40, clipped to 0..255), blurred white noise
    (sigma 1.2 px): texture with detail at every scale a 5-15 px window sees."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, 1.0, (h, w)).astype(np.float32)
    tex = cv2.GaussianBlur(noise, (0, 0), 1.2)
    tex = (tex - tex.mean()) / tex.std()
    return np.asarray(np.clip(128 + 40 * tex, 0, 255), dtype=np.float32)


def warp_right(left: F32, disparity: F32) -> F32:
    """The right image right(x_r, y) = left(x_r + d(x_r, y), y) (bicubic), for a disparity
    map (h, w, pixels) given at the RIGHT pixel: the left-image disparity of a slanted
    surface differs from it (d_left(x) = d(x - d_left(x)))."""
    h, w = left.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.asarray(
        cv2.remap(left, xs + disparity.astype(np.float32), ys, cv2.INTER_CUBIC), np.float32
    )
