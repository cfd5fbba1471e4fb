"""How far a registered view's regions reach across the faces of a fixed model.

A part no region of the first view shows is placed by the knowledge (`interpret.unseen`): a
house whose front alone the first view shows gets the knowledge's least depth. A later view
that sees a side shows how deep the house is: the side's region, its pixels back-projected
onto its own plane (its stereo fit), covers the side as far back as it goes.
`reached_offsets` moves each such part out to where the regions on its neighbours reach,
before the view's joint adjustment: the adjustment matches segments within a few pixels of
the model's edges and cannot pull a back edge metres away (s19's 63015, 63017: flat houses
8.8 and 11.2 m deep, placed 2 m deep; the later view's adjustment left the knowledge's depth
range, and the view was left out).

Parts only move out, never in: a region ends short of its face's edge where something stands
before it or the image ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.register.model import RigidModel
from aida_kb.register.register import RegionMeasurements, region_parts

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

__all__ = ["Reach", "reached_offsets", "region_samples"]

SAMPLE_STEP_PX = 2
"""A region is sampled at every this many pixels across and down inside its outline (a wall of
some 10,000 pixels: 2,500 samples)."""

STRAND_PX = 5
"""A region's mask is opened (eroded, then dilated) with a square of this side (pixels): strands
and spikes narrower than it, where a region's outline runs out along texture, are not its
area."""

REACH_QUANTILE = 0.98
"""How far a region reaches beyond a plane: this quantile of its area's distances from it (each
sample weighed by the area it covers on the region's plane). Strands are opened away
(`STRAND_PX`) and what is left of a leak of a few pixels holds little area (dev 63028's front
wall: its outline runs out along the grass in thin strands, 0.6 m past the left wall by the
outline's own 0.9 quantile); the far edge of a face
seen whole is about 2 % of its length further (and the outline's pixels a pixel's footprint
either way), which the joint adjustment's edges then close."""

REACH_MIN_REL = 0.02
"""A part moves only when the regions reach beyond it by more than this fraction of the
model's size: the verdict's vertex target (2 %); less is the pose's and the outline's noise,
which the joint adjustment's edges settle."""

ON_FACE_SHARE = 0.1
"""A region is taken to lie on a face only when at least this share of its area falls within
the face's other bounds (`ON_FACE_MARGIN_REL`): a region that only touches the face's plane
beside it (an L-shape's wing front in line with the body's) is not its."""

ON_FACE_MARGIN_REL = 0.02
"""The margin (fraction of the model's size) within which a sample counts as within a face's
bound: a region's edge lies on the face's edge, a pose a degree off puts it beside."""

MAX_GRAZING_DEG = 75.0
"""Regions whose plane is seen at more than this angle from its normal (along the ray to its
centre) are not back-projected: at grazing incidence a pixel spans metres along the plane."""


@dataclass(frozen=True)
class Reach:
    """One part moved out by `reached_offsets`: its index, how far (metres) and the region
    (index into the view's regions) that reached furthest beyond it."""

    part: int
    moved_m: float
    region: int


def region_samples(
    outline: FloatArray, width: int, height: int, step_px: int = SAMPLE_STEP_PX
) -> FloatArray:
    """(N, 2) pixels inside a region's outline ((K, 2) pixels), on a grid of `step_px` within
    the image (`width` x `height`), but its strands (`STRAND_PX`); holes are not cut out (a
    window lies in its wall's plane)."""
    filled = np.zeros((height, width), dtype=np.uint8)
    cv2.fillPoly(filled, [np.round(outline * 16.0).astype(np.int32).reshape(-1, 1, 2)], 1, shift=4)
    opened = cv2.morphologyEx(filled, cv2.MORPH_OPEN, np.ones((STRAND_PX, STRAND_PX), np.uint8))
    ys, xs = np.nonzero(np.asarray(opened)[::step_px, ::step_px])
    out: FloatArray = np.column_stack([xs, ys]).astype(np.float64) * float(step_px)
    return out


def _weighted_quantile(values: FloatArray, weights: FloatArray, q: float) -> float:
    """The `q` quantile of `values` (N,) weighed by `weights` (N,), N > 0."""
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    k = int(np.searchsorted(cum, q * cum[-1]))
    return float(values[order][min(k, len(values) - 1)])


def _on_plane(
    camera: PinholeCamera, pixels: FloatArray, normal_cam: FloatArray, centre_cam: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """Where the rays of `pixels` (N, 2) meet a region's plane (its normal and centre in the
    camera frame): (N, 3) world points and (N,) the area each pixel covers there (relative:
    ``1 / |n·r|³`` for the ray r = K⁻¹(u, v, 1)); None when the plane is seen at grazing
    incidence (`MAX_GRAZING_DEG`) or a ray misses it."""
    d = float(normal_cam @ centre_cam)
    ray_c = centre_cam / np.linalg.norm(centre_cam)
    if abs(float(normal_cam @ ray_c)) < math.cos(math.radians(MAX_GRAZING_DEG)):
        return None
    rays = np.column_stack([pixels, np.ones(len(pixels))]) @ np.linalg.inv(camera.K).T
    denom = rays @ normal_cam
    if np.any(np.abs(denom) < 1e-12):
        return None
    depth = d / denom
    if np.any(depth <= 0):
        return None
    X = rays * depth[:, None]
    world: FloatArray = (X - camera.t_cam_world) @ camera.R_cam_world
    area: FloatArray = 1.0 / np.abs(denom) ** 3
    return world, area


def reached_offsets(
    model: RigidModel,
    camera: PinholeCamera,
    regions: RegionMeasurements,
    outlines: list[FloatArray | None],
    movable: BoolArray,
) -> tuple[FloatArray, list[Reach]]:
    """The model's offsets with each `movable` part moved out to where the view's regions
    reach beyond it on its neighbouring faces.

    Parameters
    ----------
    model : the fixed model (world frame, metres).
    camera : the view's registered camera (world frame).
    regions : the view's region plane fits (its camera frame).
    outlines : per region, its outer outline (K, 2) in the camera's (undistorted) pixels, or
        None where not known.
    movable : (P,) the parts that may move: those placed by the knowledge, which no view
        measured.

    Returns
    -------
    offsets : (P,) metres, ``n·x = d``; only movable parts change, and only outward.
    moved : one `Reach` per part moved.

    A region is paired with the part whose plane it lies on at the pose (`region_parts`);
    its pixels (`region_samples`), back-projected onto its own plane, must lie on that face
    for `ON_FACE_SHARE` of their area. For each movable neighbour of the face (a part it
    shares an edge with), the region's reach beyond it is the `REACH_QUANTILE` of the
    distances from it of the area within the face's other bounds; past `REACH_MIN_REL` of
    the model's size the neighbour moves out by it.
    """
    offsets = model.offsets.copy()
    moved: dict[int, tuple[float, int]] = {}
    keep, part = region_parts(model, camera, regions)
    margin = ON_FACE_MARGIN_REL * model.size
    least = REACH_MIN_REL * model.size
    ef = model.edge_faces
    for r in np.flatnonzero(keep):
        outline = outlines[int(r)]
        if outline is None or len(outline) < 3:
            continue
        pixels = region_samples(outline, camera.width, camera.height)
        if len(pixels) == 0:
            continue
        found = _on_plane(camera, pixels, regions.normal_cam[r], regions.centre_cam[r])
        if found is None:
            continue
        X, area = found
        p = int(part[r])
        nb = np.unique(np.concatenate([ef[ef[:, 0] == p, 1], ef[ef[:, 1] == p, 0]]))
        if nb.size == 0:
            continue
        beyond = X @ model.normals[nb].T - model.offsets[nb]  # (N, k) out of each bound
        out = beyond > margin
        if float(area[~out.any(axis=1)].sum()) < ON_FACE_SHARE * float(area.sum()):
            continue
        # a bound's reach is measured by the samples within the face's other bounds: what
        # leaks past another (into the ground below the floor) says nothing of this one
        others_in = (out.sum(axis=1)[:, None] - out) == 0  # (N, k)
        for j, q in enumerate(nb.tolist()):
            sel = others_in[:, j]
            if not movable[q] or not sel.any():
                continue
            s = _weighted_quantile(beyond[sel, j], area[sel], REACH_QUANTILE)
            if s > least and s > moved.get(q, (0.0, -1))[0]:
                moved[q] = (s, int(r))
    for q, (s, _) in moved.items():
        offsets[q] = model.offsets[q] + s
    return offsets, [Reach(q, s, r) for q, (s, r) in sorted(moved.items())]
