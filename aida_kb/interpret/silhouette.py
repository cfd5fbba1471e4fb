"""Parts the knowledge placed, moved onto the outline the registered views show of them.

A part no region measures (a house's back wall behind the views) is placed by the knowledge
and the support of the points seen (`aida_kb.interpret.unseen`): a metre off is common, the
stereo points thinning out towards the outline. Yet where the part meets a part a view faces,
and the view does not face it, their edge is the object's outline in that image: a long,
straight step against whatever lies behind. The image rounds fit the model's edges within
`aida_kb.vision.lines.SEARCH_PX` of their projection (`aida_kb.register.image_edges`), too
near to find an outline ten pixels off, so the part stayed unmeasured and its vertices off.

Here each such outline edge is looked for across a band of `OUTLINE_REACH_PX` either side of
its projection: the edge's line shifted in steps of `OUTLINE_STEP_PX`, each shift fitted to
the image (`aida_kb.vision.lines.fit_segments`). An edge is found only when exactly one
straight line in the band has edge points along `OUTLINE_MIN_SHARE` of its length and
scatters by no more than the image rounds accept; the shift of that line is the part's
offset step (the edge moves within the faced part's plane as the hidden part moves along its
normal: ``s = Δd / (n_P · w)``, w the direction in that plane across the edge). A part moves
when every view's outline of it agrees (`OUTLINE_AGREE_REL`). The step is taken from the
edge's shift across its middle, so it is good to a pixel or so where perspective tilts the
moved edge: a start, not a measurement. The image rounds that follow
fit the moved edges like any other and the adjustment places the part; the verdict judges it
as measured or not by those fits, as before.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.imagefit import (
    CORROBORATE_PX,
    IMAGE_MAX_POINT_SIGMA_PX,
    segments_along,
)
from aida_kb.register import RigidModel
from aida_kb.register.evidence import ViewMeasurements
from aida_kb.register.register import POLISH_MARGIN_PX, POLISH_MIN_EDGE_PX
from aida_kb.vision.lines import END_MARGIN, SEARCH_PX, fit_segments

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "OUTLINE_AGREE_REL",
    "OUTLINE_COVER_SAMPLES",
    "OUTLINE_FACE_SHARE",
    "OUTLINE_MAX_DEG",
    "OUTLINE_MAX_STEP_REL",
    "OUTLINE_MIN_SHARE",
    "OUTLINE_REACH_PX",
    "OUTLINE_SEPARATE_PX",
    "OUTLINE_SHOWN_SHARE",
    "OUTLINE_STEP_PX",
    "OutlineStep",
    "outline_shift",
    "outline_steps",
    "shown_share",
]

OUTLINE_REACH_PX = 30.0
"""An outline edge is looked for this far either side of its projection, pixels: the hidden
parts of the dev scenes stand up to about a metre off, 7-11 px in their 640-px views (74015's
back wall: 1.1 m)."""
OUTLINE_STEP_PX = 1.5 * SEARCH_PX
"""The shifted lines lie this far apart, pixels: each fit looks `SEARCH_PX` either side, so
the band is covered with overlap."""
OUTLINE_MIN_SHARE = 0.8
"""A line counts as the outline only with edge points along this share of its samples: the
outline runs the edge's whole length, a window's frame or a texture's stripe beside it a
fraction (`aida_kb.vision.lines.MIN_SUPPORT` is half: a refined segment, not a whole edge)."""
OUTLINE_MAX_DEG = 2.0
"""... and within this angle of the projected edge, degrees (the part moves parallel)."""
OUTLINE_SEPARATE_PX = 2.0
"""Lines found further apart than this, pixels, are distinct lines: more than one in the band
and the outline is not decided (nothing moves)."""
OUTLINE_FACE_SHARE = 0.5
"""Towards the faced part the band reaches no further than this share of that part's width
across the edge, in the image: a narrow side wall seen at a grazing angle is a few dozen
pixels wide, and a band across it finds the column of its windows or its other corner (dev
74021: a back wall pulled 5.6 m onto the window column of a 53-px side wall)."""
OUTLINE_MAX_STEP_REL = 0.08
"""No part moves further than this share of the model's size: the points seen place the
parts the knowledge inserts to a metre or so (74015: 1.1 m, 4.7 % of 23.6 m); a larger step
is another line."""
OUTLINE_SHOWN_SHARE = 0.5
"""The outline found must be shown by the view's own line segments (found without the model:
a contrast the line detector's a-contrario test accepts, not the texture's noise) along this
share of its length, within `aida_kb.interpret.imagefit.CORROBORATE_PX` and `CORROBORATE_DEG`
of it. Any segment counts, not only those bounding a region: the stereo's regions stop short
of an outline (74015's back beside its right wall: the outline's segment has no region on
either side)."""
OUTLINE_AGREE_REL = 0.01
"""A part moves only when its outlines' steps agree within this share of the model's size
(a part seen in two views, or by two edges, must be moved alike by each)."""


@dataclass(frozen=True)
class OutlineStep:
    """A part moved along its normal onto its outlines.

    part : its index; step_m : the offset step, metres; edges : the outline edges found
    (view index, the faced part's index).
    """

    part: int
    step_m: float
    edges: tuple[tuple[int, int], ...]


def outline_shift(
    grey: npt.NDArray[np.uint8],
    a: FloatArray,
    b: FloatArray,
    band_px: tuple[float, float] = (-OUTLINE_REACH_PX, OUTLINE_REACH_PX),
) -> float | None:
    """The one straight line within `band_px` (from, to: pixels along the left normal of the
    image segment a-b, (2,) each) that runs along the segment, as its shift across it (pixels,
    along that normal), or None when there is none or more than one."""
    t, n = _direction(a, b)
    shifts = np.arange(band_px[0], band_px[1] + 1e-9, OUTLINE_STEP_PX)
    if shifts.size == 0:
        return None
    segs = np.concatenate([a + shifts[:, None] * n, b + shifts[:, None] * n], axis=1)
    fits = fit_segments(grey, segs)
    length = float(np.linalg.norm(b - a))
    q1, q2 = fits.segments[:, :2], fits.segments[:, 2:]
    d = q2 - q1
    cos = np.abs(d @ t) / np.maximum(np.linalg.norm(d, axis=1), 1e-9)
    offset = 0.5 * ((q1 - a) @ n + (q2 - a) @ n)
    good = (
        (fits.support >= OUTLINE_MIN_SHARE * (1.0 - 2.0 * END_MARGIN) * length)
        & (fits.sigma_px <= IMAGE_MAX_POINT_SIGMA_PX)
        & (cos >= np.cos(np.radians(OUTLINE_MAX_DEG)))
        & (offset >= band_px[0] - SEARCH_PX)
        & (offset <= band_px[1] + SEARCH_PX)
    )
    if not good.any():
        return None
    found = np.sort(offset[good])
    if found[-1] - found[0] > OUTLINE_SEPARATE_PX:
        return None
    return float(np.median(found))


def shown_share(view: ViewMeasurements, a: FloatArray, b: FloatArray) -> float:
    """The share of the image segment a-b ((2,) each, pixels) that the view's own segments
    lying along it show: both their ends within `CORROBORATE_PX` of its line and within
    `CORROBORATE_DEG` of its direction (`aida_kb.interpret.imagefit.segments_along`); 0-1."""
    if view.p1.shape[0] == 0 or float(np.linalg.norm(b - a)) <= 0:
        return 0.0
    off, parallel, lo, hi, length = segments_along(a[None, :], b[None, :], view)
    near = (off[0] <= CORROBORATE_PX) & parallel[0]
    if not near.any():
        return 0.0
    samples = np.linspace(0.0, float(length[0]), OUTLINE_COVER_SAMPLES)
    inside = (samples[:, None] >= lo[0, near][None, :]) & (samples[:, None] <= hi[0, near][None, :])
    return float(inside.any(axis=1).mean())


OUTLINE_COVER_SAMPLES = 64
"""Points along an outline at which `shown_share` asks whether a segment covers it."""


def outline_steps(
    model: RigidModel,
    cameras: Sequence[PinholeCamera],
    greys: Sequence[npt.NDArray[np.uint8] | None],
    movable: npt.NDArray[np.bool_],
    views: Sequence[ViewMeasurements | None] | None = None,
) -> list[OutlineStep]:
    """The offset steps that put the `movable` parts ((P,) mask: those the knowledge placed)
    on the outlines the views' images show of them.

    An outline edge is an edge between a movable part the camera does not face and a part it
    faces that is not movable, visible (`RigidModel.visible_edges`). Parts with no outline
    found, or whose outlines disagree (`OUTLINE_AGREE_REL`), are not returned.

    cameras : the views' cameras (world frame); greys : each view's left image, undistorted
    (None: not used), (H, W) 8-bit; views : each view's segments, which must show an outline
    (`shown_share`; None: not asked).
    """
    found: dict[int, list[tuple[float, int, int]]] = {}
    for k, (camera, grey) in enumerate(zip(cameras, greys, strict=True)):
        if grey is None:
            continue
        front = model.front_facing(camera.centre)
        vis = model.visible_edges(
            camera, min_length_px=POLISH_MIN_EDGE_PX, margin_px=POLISH_MARGIN_PX
        )
        for e, qa, qb in zip(vis.index, vis.a, vis.b, strict=True):
            i, j = (int(x) for x in model.edge_faces[e])
            for p, q in ((i, j), (j, i)):
                if not movable[p] or movable[q] or front[p] or not front[q]:
                    continue
                n_p, n_q = model.normals[p], model.normals[q]
                u = np.cross(n_p, n_q)
                w = np.cross(n_q, u)
                along = float(n_p @ w)
                if abs(along) < 1e-6 * float(np.linalg.norm(w)):
                    continue
                mid = model.edge_ends[e].mean(axis=0)
                h = 1e-3 * model.size
                m2 = camera.project(np.stack([mid, mid + (h / along) * w]))
                _, normal = _direction(qa, qb)
                px_per_m = float((m2[1] - m2[0]) @ normal) / h
                if abs(px_per_m) < 1e-9:
                    continue
                band = _band(model, camera, q, qa, qb)
                shift = None if band is None else outline_shift(grey, qa, qb, band)
                if shift is None or abs(shift / px_per_m) > OUTLINE_MAX_STEP_REL * model.size:
                    continue
                view = None if views is None else views[k]
                if view is not None and (
                    shown_share(view, qa + shift * normal, qb + shift * normal)
                    < OUTLINE_SHOWN_SHARE
                ):
                    continue
                found.setdefault(p, []).append((shift / px_per_m, k, q))
    out = []
    for p, steps in sorted(found.items()):
        values = np.array([s for s, _, _ in steps])
        if float(np.ptp(values)) > OUTLINE_AGREE_REL * model.size:
            continue
        out.append(OutlineStep(p, float(values.mean()), tuple((k, q) for _, k, q in steps)))
    return out


def _band(
    model: RigidModel, camera: PinholeCamera, q: int, a: FloatArray, b: FloatArray
) -> tuple[float, float] | None:
    """The band (from, to: pixels along the left normal of the image edge a-b) an outline
    beside the faced part `q` is looked for in: `OUTLINE_REACH_PX` away from the part, and
    towards it no more than `OUTLINE_FACE_SHARE` of its width across the edge. None when the
    part's polygon is not in front of the camera."""
    if not model.polygons:
        return (-OUTLINE_REACH_PX, OUTLINE_REACH_PX)
    poly = model.polygons[q]
    z = poly @ camera.R_cam_world[2] + camera.t_cam_world[2]
    if np.any(z <= 0):
        return None
    across = (camera.project(poly) - a) @ _direction(a, b)[1]
    inward = float(across[np.argmax(np.abs(across))])
    reach = min(OUTLINE_REACH_PX, OUTLINE_FACE_SHARE * abs(inward))
    return (-reach, OUTLINE_REACH_PX) if inward < 0 else (-OUTLINE_REACH_PX, reach)


def _direction(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The unit direction of the image segment a-b and its left normal, (2,) each."""
    t = (b - a) / max(float(np.linalg.norm(b - a)), 1e-9)
    return t, np.array([-t[1], t[0]])
