"""The ground a view shows: the plane the `elevation(p)` measure is taken from.

The knowledge may say that an object stands on the ground (docs/language.md 3.10:
``attribute elevation: length in [-1 m, 1 m] is elevation(floor)``). The ground is not a part
of the object: it is read from the evidence as the **lowest level surface** of the reference
view — of the regions whose fitted normal lies within `GROUND_LEVEL_DEG` of the estimated
vertical and which carry at least `GROUND_MIN_SHARE` of the view's region pixels, the one
whose centre lies lowest along up. A scene's ground is the lowest level surface there is (a
flat roof, a car's roof, a table top lie above it); a view that shows no such region has no
ground, and the measure is then not taken. A part's elevation is taken above that region's
fitted plane, where it lies under the part (`elevation`): not above the height of its centre,
which lies tens of metres before the object, where the camera looks down on it. The
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

from collections.abc import Collection, Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.observe import RegionView

__all__ = [
    "GROUND_LEVEL_DEG",
    "GROUND_MIN_SHARE",
    "GroundFit",
    "elevation",
    "ground_plane",
    "ground_region",
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


def ground_region(
    regions: Sequence[RegionView], up: FloatArray, exclude: Collection[str] = ()
) -> RegionView | None:
    """The view's ground: of its level regions (normal within `GROUND_LEVEL_DEG` of `up`,
    either way) carrying at least `GROUND_MIN_SHARE` of its region pixels, the one whose
    centre lies lowest along `up`; None if there is none.

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
    ]
    return min(level, key=lambda r: float(r.centroid_m @ up)) if level else None


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
