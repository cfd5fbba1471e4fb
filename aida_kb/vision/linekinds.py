"""Each line segment structural, texture or unknown, by the depth on its two sides
(`line_kinds`)."""

from __future__ import annotations

import warnings
from typing import Literal

import numpy as np
import numpy.typing as npt

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]


# Structural lines told from texture lines. A segment is structural when the surface changes
# across it: its two sides belong to two different regions, or to a region and to nothing (an
# outline), or the 3-D points on its two sides lie apart by more than the plane's tolerance (a
# window frame in front of its recess). It is texture when both sides lie on one plane within
# that tolerance (masonry joints, painted decoration, shadows); unknown (None) when neither
# side has a plane, or a side has no depth to tell by. Sides are sampled LINE_SIDE_PX away
# from the segment (at the working resolution), beyond half the matcher's window (11 px), over
# which it smears depth steps.
LINE_SIDE_PX = 8.0
LINE_SAMPLES = 9  # points per side, spread over the middle 80 % of the segment
LINE_MIN_DEPTH_SAMPLES = 3  # a side needs this many points with depth to say where it lies


def line_kinds(
    segments: F64,
    regions: I32,
    points: F32,
    ids: npt.NDArray[np.int64],
    normals: F64,
    offsets: F64,
    tolerances: F64,
    *,
    side_px: float = LINE_SIDE_PX,
) -> list[Literal["structural", "texture"] | None]:
    """Per segment (N, 4) [x1, y1, x2, y2] pixels: "structural", "texture" or None (unknown).

    regions : (H, W) region ids of the same image, 0 = none; points : (H, W, 3) float32 metres,
    a camera frame, NaN = no depth; ids : (R,) the regions with a plane, normals : (R, 3) unit
    and offsets : (R,) metres (n·x = d) in that frame, tolerances : (R,) metres (see
    `complete_regions`). side_px : how far from the segment its sides are sampled, pixels.
    """
    n = len(segments)
    if n == 0:
        return []
    H, W = regions.shape
    size = int(max(int(regions.max()), int(ids.max()) if len(ids) else 0)) + 1
    has_plane = np.zeros(size, bool)
    has_plane[ids] = True
    nrm = np.zeros((size, 3))
    nrm[ids] = normals
    off = np.zeros(size)
    off[ids] = offsets
    tol = np.zeros(size)
    tol[ids] = tolerances
    p1, p2 = segments[:, :2], segments[:, 2:]
    t = (p2 - p1) / np.maximum(np.linalg.norm(p2 - p1, axis=1, keepdims=True), 1e-9)
    across = np.stack([t[:, 1], -t[:, 0]], axis=1)
    s = np.linspace(0.1, 0.9, LINE_SAMPLES)
    base = p1[:, None, :] + s[None, :, None] * (p2 - p1)[:, None, :]  # (N, S, 2)
    sides = []
    for sign in (1.0, -1.0):
        pts = base + sign * side_px * across[:, None, :]
        xi = np.clip(np.rint(pts[..., 0]).astype(np.intp), 0, W - 1)
        yi = np.clip(np.rint(pts[..., 1]).astype(np.intp), 0, H - 1)
        lab = regions[yi, xi].astype(np.int64)  # (N, S)
        votes = (lab[:, :, None] == lab[:, None, :]).sum(axis=2)  # (N, S)
        k = np.argmax(votes, axis=1)
        major = lab[np.arange(n), k]
        major = np.where(votes[np.arange(n), k] * 2 > LINE_SAMPLES, major, 0)
        sides.append((major, points[yi, xi].astype(np.float64)))  # (N,), (N, S, 3)
    (a, xyz_l), (b, xyz_r) = sides
    two = (a != b) & (has_plane[a] | has_plane[b])
    one = (a == b) & has_plane[a]
    n_a = nrm[a]  # (N, 3)

    def offset(xyz: F64) -> tuple[F64, npt.NDArray[np.int64]]:
        dist = np.einsum("nsk,nk->ns", xyz, n_a) - off[a][:, None]
        good = ~np.isnan(dist)
        with np.errstate(all="ignore"):
            med = np.nanmedian(np.where(good, dist, np.nan), axis=1)
        return med, good.sum(axis=1)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: no depth on a side
        off_l, n_l = offset(xyz_l)
        off_r, n_r = offset(xyz_r)
    measured = (n_l >= LINE_MIN_DEPTH_SAMPLES) & (n_r >= LINE_MIN_DEPTH_SAMPLES)
    step = measured & (np.abs(off_l - off_r) > tol[a])
    out: list[Literal["structural", "texture"] | None] = []
    for i in range(n):
        if two[i] or (one[i] and step[i]):
            out.append("structural")
        elif one[i] and measured[i]:
            out.append("texture")
        else:
            out.append(None)
    return out
