"""Faces without texture: the areas of no region that image edges enclose and whose outline
stereo measures nearly all round (`outlined_patches`)."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]


# Faces without texture. A roof whose tiles' texture lies below the camera's noise (dark tiles
# in shade) or a blank wall gets no certain disparity inside, so `segment_planes` grows no
# region on it (development scenes 61600-61635 without labels: 30 of 59 roof faces had no
# region, and their houses were taken for flat-roofed ones). Its outline against the sky, the
# walls or a lighter face is an edge that the matcher measures (exact NCC), and the outline of
# a planar face lies on its plane. `outlined_patches` takes the areas of no region that the
# image's edges enclose and whose outline has certain depth within OUTLINE_REACH_PX nearly all
# round (OUTLINE_SUPPORT) -- where it can: an outline along the epipolar lines (within
# EPIPOLAR_DEG of the image's rows: a ridge, an eave) has no disparity for any matcher, and is
# not asked for; the image's border never supports (the sky is cut by it, and so is a face
# whose outline is not seen whole). The evidence fits each patch's plane to the certain
# points along its outline (`aida_kb.vision.evidence`).
# Nor is a patch's left outline (the patch to its right) without certain depth asked for: the
# right camera sees everything shifted left by its disparity, so a face in front covers the
# strip of the background just left of its left outline (a half-occlusion as wide as their
# disparities differ), and every matching window across that outline holds pixels the other
# image does not show. A dark roof in front of the far field loses its whole left verge so
# (development scene 61816: the measurable outline 337 px, 167 of them certain, none on the
# left verge; its right verge and the eave fix the plane to 0.25 deg). Where the left outline
# is measured it counts as any other; the plane's own tests in the evidence (one plane, tilt
# fixed) still judge what the rest of the outline gives.
# The outline counts as measured only by the depth the face's plane is then fitted to: of no
# region, or of a region within OUTLINE_EDGE_PX of an edge (where the face meets it). A
# region's depth away from any edge lies on the region's surface, not on the face's outline:
# where no edge parts them they may be one surface, and a patch held so was fitted to the
# rest of its outline alone (unlabelled development scene 61935 view 00: far ground and a wall
# striped along the rows, 88,000 px, held by the near ground's region and fitted as the wall,
# 90 deg off; 61914 view 01 likewise). On the unlabelled 61902-61935 this leaves out 2 of the
# 10 outlined regions far off their face, and none of the 12 right ones (within 2.2 deg).
EDGE_BLUR_PX = 1.5  # Gaussian sigma before the edge detector: the sensor noise's edges go
EDGE_LOW = 20  # Canny's hysteresis thresholds on the blurred image's Sobel gradient, grey
EDGE_HIGH = 60  # levels per pixel (x 4 of Sobel's kernel): a step of 5 and of 15 grey levels
OUTLINE_REACH_PX = 4  # the edge's dilated width and a pixel: where the outline's depth lies
OUTLINE_SUPPORT = 0.7  # the share of the measurable outline with certain depth within reach
OUTLINE_CERTAINTY = 0.1  # a depth at least this certain measures the outline
EPIPOLAR_DEG = 15.0  # an outline closer than this to the image's rows is not measurable
OUTLINE_EDGE_PX = 2  # 2 px off the eave a wall's point is ~0.1 m off the roof at 50 m


def outlined_patches(
    regions: I32,
    image: npt.NDArray[np.uint8],
    certainty: F32,
    *,
    min_pixels: int,
) -> tuple[I32, npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """The areas of no region enclosed by image edges and measured all round their outline.

    regions : (H, W) int32 ids, 0 = none; image : (H, W) the grey image of the same pixels
    (rows along the epipolar lines); certainty : (H, W) the depth's certainty there (0 = no
    depth). Returns the patches (H, W) int32 ids 1..P, 0 = none, the pixels with certain
    depth and the edges (one pixel wide), both (H, W) bool. Patches of fewer than `min_pixels`
    pixels are left out. See
    EDGE_BLUR_PX, OUTLINE_SUPPORT, OUTLINE_CERTAINTY, EPIPOLAR_DEG.
    """
    H, W = regions.shape
    certain = certainty >= OUTLINE_CERTAINTY
    blurred = cv2.GaussianBlur(image, (0, 0), EDGE_BLUR_PX)
    thin = cv2.Canny(blurred, EDGE_LOW, EDGE_HIGH)
    edges = cv2.dilate(thin, np.ones((3, 3), np.uint8)) > 0
    free = ((regions == 0) & ~edges).astype(np.uint8)
    n, comp, stats, _ = cv2.connectedComponentsWithStats(free, connectivity=4)
    side = 2 * OUTLINE_REACH_PX + 1
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (side, side))
    # the depth the face's plane is fitted to: of no region, or a region's right at an edge
    edge_side = 2 * OUTLINE_EDGE_PX + 1
    at_edge = cv2.dilate(thin, np.ones((edge_side, edge_side), np.uint8)) > 0
    usable = certain & ((regions == 0) | at_edge)
    near = cv2.dilate(usable.astype(np.uint8), disc) > 0
    border = np.ones((H, W), bool)
    border[1:-1, 1:-1] = False
    square = np.ones((3, 3), np.uint8)
    inner = cv2.erode(free, square, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    outline = (free > 0) & (inner == 0)  # a patch's pixels next to an edge, a region, the border
    # the outline's direction from the patches' mask: across a row-wise outline the mask
    # changes along the columns only
    smooth = cv2.GaussianBlur(free.astype(np.float32), (0, 0), 1.5)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1)
    measurable = outline & (np.abs(gx) >= np.sin(np.radians(EPIPOLAR_DEG)) * np.hypot(gx, gy))
    measurable |= outline & border
    # the patch's left outline (the mask rising to the right) unmeasured: a half-occlusion
    occluded = outline & ~border & ~near & (gx > 0)
    asked = measurable & ~occluded
    labels = comp[asked]
    total = np.bincount(labels, minlength=n)
    held = np.bincount(labels[near[asked] & ~border[asked]], minlength=n)
    ok = (stats[:, cv2.CC_STAT_AREA] >= min_pixels) & (held >= OUTLINE_SUPPORT * total)
    ok &= total > 0
    ok[0] = False
    lut = np.zeros(n, np.int32)
    lut[ok] = np.arange(1, int(ok.sum()) + 1, dtype=np.int32)
    return lut[comp], certain, thin > 0
