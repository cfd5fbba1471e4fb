"""The ground a view shows: the plane the `elevation(p)` measure is taken from.

The knowledge may say that an object stands on the ground (docs/language.md 3.10:
``attribute elevation: length in [-1 m, 1 m] is elevation(floor)``). The ground is not a part
of the object: it is read from the evidence as the **lowest level surface** of the reference
view — of the regions whose fitted normal lies within `GROUND_LEVEL_DEG` of the estimated
vertical, whose fit kept its pixels (`OUTLINE_INLIER_SHARE`) and which carry at least
`GROUND_MIN_SHARE` of the view's region pixels, the one whose centre lies lowest along up.
A scene's ground is the lowest level surface there is (a flat roof, a car's roof, a table
top lie above it); a view that shows no such region has no ground, and the measure is then
not taken. A part's elevation is taken above that region's fitted plane, where it lies under
the part (`elevation`): not above the height of its centre, which lies tens of metres before
the object, where the camera looks down on it. The
vertical is estimated from the walls, up to a few degrees off (dev seeds 61628: 5.6 degrees,
63013: 1.85), and the terrain may fall; either tilts the ground's height at its centre
against its height under the object by the distance between them times the angle. Against
the truth's floors on the kept development scenes (61500-63035: 50 houses whose lowest
level region is the ground), the height at the centre put floors on the ground up to 0.73 m
off (63013: 0.36 m, its true body then rejected for a plinth of 1.08 m), the plane under
them within 0.11 m (the ground's own fit is good to 0.01-0.4 degrees).

The ground is not the object: a hypothesis's own regions (bound to its parts, or lying on
its top) are left out when its elevation is measured (`plausibility.on_object`): with the
ground unlabelled or absent, a flat roof's region was the lowest level surface left, and
the house floated 8.6 m below it (held-out 61713, nothing found).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError

from aida_kb.interpret.observe import RegionView

__all__ = [
    "BENEATH_MARGIN",
    "GROUND_LEVEL_DEG",
    "GROUND_MIN_SHARE",
    "OUTLINE_INLIER_SHARE",
    "EvidenceGround",
    "GroundFit",
    "elevation",
    "ground_plane",
    "ground_region",
    "lowest_beneath",
]

FloatArray = npt.NDArray[np.float64]
GroundFit = tuple[FloatArray, float]
"""A plane n·x = d: its unit normal (3,), world frame, and d, metres."""

# a region is level when its normal lies within this angle of up: the ground seen at a
# grazing angle (the camera 2 m high, the ground 30 m away) fits its plane to a few degrees
GROUND_LEVEL_DEG = 10.0
# ... and it is ground only with at least this share of the view's region pixels: a level
# patch of a few hundred pixels (a window sill, a car's roof far away) is no ground, while
# the ground in front of a building fills a tenth of the image or more
GROUND_MIN_SHARE = 0.05
# a point is seen beneath a part when it lies this fraction of the part's footprint's size
# (its diagonal) inside the footprint: the outlines of regions on the walls, back-projected
# onto planes fitted to their edges, and a slight leak below a wall's foot lie on the
# footprint's border, not under it (`plausibility.INSIDE_MARGIN`, the same reason); a tree's
# trunk stands under its crown's middle, half the crown's width inside
BENEATH_MARGIN = 0.05
# a region's outline lies on its fitted plane only where the fit kept at least this share of
# its pixels (`verdict.PLANE_INLIER_SHARE`: below it the plane tells neither depth nor
# orientation, and an outline back-projected onto it lands metres off)
OUTLINE_INLIER_SHARE = 0.05


def ground_region(
    regions: Sequence[RegionView], up: FloatArray, exclude: Collection[str] = ()
) -> RegionView | None:
    """The view's ground: of its level regions (normal within `GROUND_LEVEL_DEG` of `up`,
    either way) carrying at least `GROUND_MIN_SHARE` of its region pixels, whose plane fit
    kept `OUTLINE_INLIER_SHARE` of them, the one whose centre lies lowest along `up`; None if
    there is none. A fit that kept fewer puts its plane anywhere: dev 72030's dark gable roof,
    none of its 7,785 pixels kept, fitted level 8 m above the floor, was taken for the ground
    and every roofed body measured a plinth of -9.15 m.

    regions : the regions of one view (world frame); up : (3,) unit vector, world frame;
    exclude : ids of regions that are no ground (the object's own: they still count in the
    view's region pixels).
    """
    total = sum(r.area_px for r in regions)
    if total <= 0.0:
        return None
    cos_level = float(np.cos(np.radians(GROUND_LEVEL_DEG)))
    level = [
        r
        for r in regions
        if abs(float(r.normal @ up)) >= cos_level
        and r.area_px >= GROUND_MIN_SHARE * total
        and r.id not in exclude
        and plane_fitted(r)
    ]
    return min(level, key=lambda r: float(r.centroid_m @ up)) if level else None


def plane_fitted(region: RegionView) -> bool:
    """Whether a region's fitted plane tells where its surface lies: the fit kept at least
    `OUTLINE_INLIER_SHARE` of its pixels (or the region says nothing of its fit)."""
    return region.inliers is None or region.inliers >= OUTLINE_INLIER_SHARE * region.area_px


def ground_plane(
    regions: Sequence[RegionView], up: FloatArray, exclude: Collection[str] = ()
) -> GroundFit | None:
    """The plane of the view's ground (`ground_region`), its normal turned to face `up`; None
    if there is none.

    regions : the regions of one view (world frame); up : (3,) unit vector, world frame;
    exclude : ids of regions that are no ground (`ground_region`).
    """
    ground = ground_region(regions, up, exclude)
    if ground is None:
        return None
    normal = ground.normal if float(ground.normal @ up) >= 0.0 else -ground.normal
    return normal, float(normal @ ground.centroid_m)


def elevation(points: FloatArray, up: FloatArray, ground: GroundFit) -> float:
    """How far the lowest of `points` lies above the ground's plane, along `up`, metres
    (negative: below it).

    points : (N, 3) array, metres, world frame; up : (3,) unit vector; ground : the ground's
    plane (`ground_plane`), its normal facing up (within `GROUND_LEVEL_DEG`).
    """
    normal, offset = ground
    heights = (points @ normal - offset) / float(normal @ up)
    return float(heights.min())


def lowest_beneath(part: FloatArray, up: FloatArray, points: FloatArray) -> float | None:
    """The height along `up` of the lowest of `points` seen beneath `part`: inside its
    footprint (the convex hull of its corners projected along `up`, by `BENEATH_MARGIN`) and
    lower than its lowest corner; None if there is none.

    Something the views see beneath a part stands on the ground, so the ground there lies at
    least that low: a house's floor rests on the ground, and no surface is seen under it, but
    a tree's box-shaped crown shows its trunk beneath it (dev clutter 64240, the views showing
    no ground region: the camera 0.5 m high sees the ground at too grazing an angle).

    part : (K, 3) corners of the part's faces, metres, world frame; up : (3,) unit vector;
    points : (N, 3) points on the surfaces seen (regions that are not the object's own).
    """
    if len(points) == 0 or len(part) < 3:
        return None
    helper = np.array([1.0, 0.0, 0.0]) if abs(float(up[0])) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(up, helper)
    e1 /= float(np.linalg.norm(e1))
    e2 = np.cross(up, e1)
    flat = np.stack([part @ e1, part @ e2], axis=1)
    try:
        hull = flat[ConvexHull(flat).vertices]  # 2-D: counter-clockwise
    except QhullError:  # the part is seen edge-on from above: it has no footprint
        return None
    low = float((part @ up).min())
    heights = points @ up
    candidates = heights < low
    if not candidates.any():
        return None
    xy = np.stack([points[candidates] @ e1, points[candidates] @ e2], axis=1)
    a, b = hull, np.roll(hull, -1, axis=0)  # counter-clockwise: inside is left of every edge
    edge = b - a
    length = np.maximum(np.linalg.norm(edge, axis=1), 1e-12)
    left = (edge[None, :, 0] * (xy[:, None, 1] - a[None, :, 1])) - (
        edge[None, :, 1] * (xy[:, None, 0] - a[None, :, 0])
    )  # (N, E): each point's distance inside each edge, times the edge's length
    size = float(np.linalg.norm(np.ptp(hull, axis=0)))
    inside = np.all(left / length[None, :] >= BENEATH_MARGIN * size, axis=1)
    if not inside.any():
        return None
    return float(heights[candidates][inside].min())


class EvidenceGround:
    """The ground one view's evidence shows under a part: its ground region's plane
    (`ground_plane`) and the surfaces it sees beneath the part (`lowest_beneath`).

    regions : the view's regions (world frame); points_on : region id -> (N, 3) points on its
    plane (centroid, outline), metres, world frame; own : ids of the object's own regions
    (no ground, and not beneath it); up : (3,) unit vector; beneath_only : the ground region's
    plane left out (the verdict's: a refined model's part moved along a grazing ray sinks or
    lifts it against that plane, and it is still the object, wrongly placed; a surface seen
    beneath it shows the object itself hanging in the air). The surfaces' points are read
    once, when first needed.
    """

    def __init__(
        self,
        regions: Sequence[RegionView],
        points_on: Callable[[str], FloatArray],
        own: Collection[str],
        up: FloatArray,
        *,
        beneath_only: bool = False,
    ) -> None:
        self.up = up
        self.plane = None if beneath_only else ground_plane(regions, up, own)
        self._others = [r for r in regions if r.id not in own and plane_fitted(r)]
        self._points_on = points_on
        self._seen: FloatArray | None = None

    def seen(self) -> FloatArray:
        """(N, 3) points of the surfaces the view sees that are not the object's own."""
        if self._seen is None:
            pts = [self._points_on(r.id) for r in self._others]
            self._seen = np.concatenate(pts) if pts else np.zeros((0, 3))
        return self._seen

    def elevation(self, corners: FloatArray) -> float | None:
        """How far the lowest of a part's `corners` (K, 3; metres, world frame) lies above the
        ground the evidence shows, metres: above the ground's plane under it (`elevation`) or
        above the lowest surface seen beneath it (`lowest_beneath`: the ground lies at least
        that low there), whichever of the two lies lower; None where it shows neither."""
        values = []
        if self.plane is not None:
            values.append(elevation(corners, self.up, self.plane))
        beneath = lowest_beneath(corners, self.up, self.seen())
        if beneath is not None:
            values.append(float((corners @ self.up).min()) - beneath)
        return max(values) if values else None
