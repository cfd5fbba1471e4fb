"""A wall's foot in an image: its measurements lean towards the ground (`FOOT_SHADOW_PX`).

Where a wall stands on the ground the image shows the wall against the ground, and often the
ground darkened beside the foot by the shadow the wall casts there: the line a segment or a
fit finds is the shadow's edge, off the true foot towards the ground, never into the wall. An
edge measurement of a foot is therefore whitened as a split normal (`aida_kb.constraints.
EdgeData.lean`): its usual sigma where the model's edge lies on the ground's side of the
measured line, and `FOOT_SHADOW_PX` more (in quadrature) where it lies on the wall's side.
`foot_leans` gives the lean of measurements of known foot edges (the joint adjustments,
`aida_kb.interpret.joint`); `leaning_feet` marks the edge constraints of a single view's
verification on the edges of its ground part (`aida_kb.interpret.adjust`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, EdgeData
from aida_kb.geometry.camera import PinholeCamera

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

__all__ = ["FOOT_SHADOW_PX", "RISE_SHARE", "foot_leans", "lean_scale", "leaning_feet"]

FOOT_SHADOW_PX = 2.0
"""A foot edge's measurement (a fit or a segment) may lie off the true foot towards the ground
by this much more, pixels (one standard deviation of its mean offset on that side, added in
quadrature to its own; `lean_scale`): the line is pulled to the edge of the shadow the wall
casts on the ground beside its foot, never into the wall. At the TRUE models and cameras of dev
67000-69035, the clean fits (points within 0.5 px of their line) of feet seen below 1 deg have
15 of 194 end points more than 1 px into the ground (up to 2.8 px) and none into the wall; the
line detector's segments there 15 of 232 more than 1 px into the ground, none into the wall.
Seen from higher up the shadow's band is less foreshortened: dev 69005's left foot, seen at
20-25 deg, lay 0-6 px above the line the joint adjustments fitted to the shadow's edge, and the
floor followed it 2.4 deg off (walls within 0.4-0.6 deg)."""

RISE_SHARE = 0.1
"""The point that tells a foot's wall side in the image lies this share of its distance from
the camera above the foot (any height shows the side; a share keeps scenes up to scale)."""


def lean_scale(sd_px: FloatArray) -> FloatArray:
    """(K,) the `EdgeData.lean_scale` of foot measurements whose offset is known to `sd_px`
    (K,) pixels: ``sd / hypot(sd, FOOT_SHADOW_PX)``."""
    out: FloatArray = sd_px / np.hypot(sd_px, FOOT_SHADOW_PX)
    return out


def foot_leans(
    camera: PinholeCamera,
    p1: FloatArray,
    p2: FloatArray,
    feet: FloatArray,
    up: FloatArray,
) -> IntArray:
    """(K,) the `EdgeData.lean` of the image lines from `p1` to `p2` (K, 2) px measuring foot
    edges through the points `feet` (K, 3), world frame, seen by `camera`: the sign of the
    residual (`aida_kb.constraints.edge.edge_kernel`'s, across the line's left normal) of a
    model edge lying on the wall's side of the line, the side where a point above the foot
    (`up` (3,), unit, world frame; `RISE_SHARE`) is seen; 0 where the foot or that point is not
    in front of the camera or the line has no length."""
    K = len(p1)
    out = np.zeros(K, dtype=np.int64)
    if K == 0:
        return out
    distance = np.linalg.norm(feet - camera.centre[None, :], axis=1)
    above = feet + RISE_SHARE * distance[:, None] * up[None, :]
    seen = camera.in_front(feet) & camera.in_front(above)
    if not seen.any():
        return out
    wall = np.zeros((K, 2))
    wall[seen] = camera.project(above[seen]) - camera.project(feet[seen])
    d = p2 - p1
    left = np.stack([-d[:, 1], d[:, 0]], axis=1)  # as `edge_kernel`'s image normal
    side = np.sign(np.einsum("ij,ij->i", left, wall)).astype(np.int64)
    out[seen] = side[seen]
    return out


def leaning_feet(
    constraints: Sequence[Constraint],
    normals: FloatArray,
    offsets: FloatArray,
    ground: int | None,
    cameras: Sequence[PinholeCamera],
) -> list[Constraint]:
    """`constraints` with a lean (`foot_leans`, `lean_scale` of their sigma) on the edge
    measurements in pixels of the edges between the part `ground` (its plane's normal points
    down, `normals` (P, 3) and `offsets` (P,) world frame) and another part: the foot of that
    part, through the point where the ray to the segment's middle meets the other part's
    plane. Unchanged where `ground` is None."""
    if ground is None:
        return list(constraints)
    up = -normals[ground] / np.linalg.norm(normals[ground])
    out = list(constraints)
    for k, c in enumerate(constraints):
        e = c.edge
        if (
            c.kind != "edge"
            or e is None
            or ground not in c.parts
            or c.unit != "px"
            or c.sigma is None
            or c.sqrt_information is not None
            or not 0 <= e.camera < len(cameras)
        ):
            continue
        wall = c.parts[1] if c.parts[0] == ground else c.parts[0]
        camera = cameras[e.camera]
        p1, p2 = np.array([e.p1_px]), np.array([e.p2_px])
        centre, ray = camera.unproject(0.5 * (p1 + p2))
        n, d = normals[wall], float(offsets[wall])
        along = float(ray[0] @ n)
        if abs(along) < 1e-9:
            continue  # the ray runs in the wall's plane: no foot point
        foot = centre + (d - float(centre @ n)) / along * ray[0]
        lean = int(foot_leans(camera, p1, p2, foot[None, :], up)[0])
        if lean == 0:
            continue
        scale = float(lean_scale(np.array([c.sigma]))[0])
        out[k] = replace(c, edge=EdgeData(e.camera, e.p1_px, e.p2_px, lean, scale))
    return out
