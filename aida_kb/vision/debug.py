"""Debug images a person can look at: depth, certainty, disparity, segmentation, lines."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.io.atomic import atomic_path
from aida_kb.vision.evidence import ViewProducts

U8 = npt.NDArray[np.uint8]


def colour_map(values: npt.NDArray[np.floating], *, invert: bool = False) -> U8:
    """(H, W) floats -> (H, W, 3) BGR (turbo colour map over the 1..99 % range), NaN black."""
    ok = np.isfinite(values)
    out = np.zeros((*values.shape, 3), np.uint8)
    if not np.any(ok):
        return out
    lo, hi = np.percentile(values[ok], [1, 99])
    scaled = np.clip((values - lo) / max(float(hi - lo), 1e-9), 0.0, 1.0)
    if invert:
        scaled = 1.0 - scaled
    grey = np.where(ok, scaled * 255.0, 0.0).astype(np.uint8)
    coloured = np.asarray(cv2.applyColorMap(grey, cv2.COLORMAP_TURBO), np.uint8)
    out[ok] = coloured[ok]
    return out


def region_colours(n: int) -> U8:
    """n distinct-looking BGR colours (golden-angle hues), row i for region id i (0 = black)."""
    hues = (np.arange(n) * 137.508) % 180.0
    hsv = np.stack([hues, np.full(n, 200.0), np.full(n, 230.0)], axis=1).astype(np.uint8)
    bgr = np.asarray(cv2.cvtColor(hsv[None], cv2.COLOR_HSV2BGR)[0], np.uint8)
    bgr[0] = 0
    return bgr


def segmentation_image(products: ViewProducts) -> U8:
    """Regions in colour over the dimmed left image, with contours and region ids."""
    regions = products.regions
    ids = np.unique(regions)
    lut_ids = {int(r): i for i, r in enumerate(ids)}
    index = np.searchsorted(ids, regions)
    colours = region_colours(len(ids) + 1)[1:] if ids[0] != 0 else region_colours(len(ids))
    base = cv2.cvtColor(products.left, cv2.COLOR_GRAY2BGR).astype(np.float32) * 0.5
    over = colours[index].astype(np.float32)
    mask = (regions > 0)[..., None]
    img = np.where(mask, 0.45 * base + 0.55 * over, base).astype(np.uint8)
    for contour in products.evidence.contours:
        pts = np.round(np.asarray(contour.points)).astype(np.int32).reshape(-1, 1, 2)
        colour = (0, 0, 255) if contour.hole else (255, 255, 255)
        cv2.polylines(img, [pts], True, colour, 1, cv2.LINE_AA)
    for region in products.evidence.regions:
        ys, xs = np.nonzero(regions == region.id)
        if len(xs) == 0 or region.id not in lut_ids:
            continue
        org = (int(np.median(xs)), int(np.median(ys)))
        cv2.putText(img, str(region.id), org, cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 3)
        cv2.putText(img, str(region.id), org, cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1)
    return img


def lines_image(products: ViewProducts) -> U8:
    """Line segments over the left image: green borders two regions, yellow one, red none."""
    img = cv2.cvtColor(products.left, cv2.COLOR_GRAY2BGR)
    for line in products.evidence.lines:
        colour = {2: (0, 220, 0), 1: (0, 220, 220)}.get(len(line.regions), (0, 0, 255))
        p1 = (round(line.p1[0] * 16), round(line.p1[1] * 16))
        p2 = (round(line.p2[0] * 16), round(line.p2[1] * 16))
        cv2.line(img, p1, p2, colour, 1, cv2.LINE_AA, shift=4)
    return np.asarray(img, np.uint8)


def debug_images(products: ViewProducts) -> dict[str, U8]:
    """name -> 8-bit image, for one view."""
    cert = np.clip(products.depth.certainty * 255.0, 0, 255).astype(np.uint8)
    return {
        "left_rectified": products.left_rectified,
        "disparity": colour_map(products.disparity.disparity),
        "depth": colour_map(products.depth.depth_m, invert=True),
        "certainty": cert,
        "segmentation": segmentation_image(products),
        "lines": lines_image(products),
    }


def write_debug(directory: str | os.PathLike[str], products: ViewProducts) -> list[Path]:
    """Write the debug images of one view as DIR/<view>_<name>.png (atomically)."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, image in debug_images(products).items():
        path = out / f"{products.evidence.id}_{name}.png"
        with atomic_path(path) as tmp:
            cv2.imwrite(str(tmp), image)
        written.append(path)
    return written
