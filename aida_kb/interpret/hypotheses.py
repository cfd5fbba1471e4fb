"""Hypotheses for planar parts: predicted orientation, candidate regions, inserted planes.

A composite world instance (a house body, a wing, an oriel) has an *instance frame*: the
horizontal direction its front faces (`front`), the direction to its right as seen from
the front (`right`) and `up`. Role names give each planar part a predicted orientation in
that frame (DOMAIN.md): ``front``/``back``/``left``/``right`` face +front, -front, -right,
+right horizontally (roof planes with those names are tilted up by their pitch),
``top`` faces up and ``floor``/``bottom`` face down. Candidates for a part are the regions
whose orientation fits the prediction and whose slope lies in the part concept's attribute
range (`tilt` of a wall, `pitch` of a roof plane). Parts without a candidate that the
reference camera could not see are *inserted* from the knowledge; their plane is initialised
from the prediction and, for the offset, from the support function of the points observed
on the same solid (a face of a convex solid touches the observed surface points that are
most extreme along its normal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.observe import CameraView, RegionView, slope_deg

FloatArray = npt.NDArray[np.float64]

HORIZONTAL_ROLES = ("front", "back", "left", "right")
UP_ROLES = ("top",)
DOWN_ROLES = ("floor", "bottom")

# How far a region's orientation may stray from the prediction and still be a candidate.
HORIZONTAL_WINDOW_DEG = 30.0  # between horizontal directions (walls, pitched roof planes)
CONE_WINDOW_DEG = 15.0  # around up or down (flat roofs, floors)
DEFAULT_PITCH_DEG = 30.0  # an inserted roof plane with no seen counterpart


@dataclass(frozen=True)
class Frame:
    """An instance frame: unit vectors in the world frame, (3,) each, right-handed."""

    front: FloatArray
    right: FloatArray
    up: FloatArray

    @classmethod
    def from_front(cls, normal: FloatArray, up: FloatArray) -> Frame:
        """The frame whose front is the horizontal part of `normal` (a front wall's normal)."""
        h = normal - float(normal @ up) * up
        norm = float(np.linalg.norm(h))
        if norm < 1e-6:
            raise ValueError("a horizontal plane cannot define a front")
        front = h / norm
        right = np.cross(-front, up)
        return cls(front, right / np.linalg.norm(right), up)

    def horizontal(self, role: str) -> FloatArray:
        """The horizontal direction a part named `role` faces (front/back/left/right)."""
        table = {"front": self.front, "back": -self.front, "left": -self.right}
        out: FloatArray = table.get(role, self.right)
        return out


@dataclass(frozen=True)
class PlanarPart:
    """A planar part to be matched: its role path, role name, concept and slope range."""

    role: str  # absolute role path, e.g. "body.roof.front"
    name: str  # the last role name, e.g. "front"
    concept: str  # Wall, RoofPlane, Floor ...
    slope_range_deg: tuple[float, float] | None  # from the concept's tilt / pitch attribute
    pitched: bool  # a roof plane (tilted towards its horizontal direction)


def predicted_normal(part: PlanarPart, frame: Frame, pitch_deg: float) -> FloatArray:
    """The unit outward normal (world, (3,)) a part is expected to have in `frame`."""
    if part.name in DOWN_ROLES:
        return -frame.up
    if part.name in UP_ROLES or part.name not in HORIZONTAL_ROLES:
        return frame.up
    h = frame.horizontal(part.name)
    if not part.pitched:
        return h
    p = math.radians(pitch_deg)
    out: FloatArray = math.cos(p) * frame.up + math.sin(p) * h
    return out


def _angle_deg(a: FloatArray, b: FloatArray) -> float:
    c = float(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0))
    return math.degrees(math.acos(c))


def fits(part: PlanarPart, region: RegionView, frame: Frame) -> bool:
    """True if `region` can be the evidence of `part` in `frame` (orientation and slope)."""
    slope = slope_deg(region.normal, frame.up)
    if part.slope_range_deg is not None:
        lo, hi = part.slope_range_deg
        if not lo - 1e-9 <= slope <= hi + 1e-9:
            return False
    if part.name in DOWN_ROLES:
        return _angle_deg(region.normal, -frame.up) <= CONE_WINDOW_DEG
    if part.name not in HORIZONTAL_ROLES:
        return _angle_deg(region.normal, frame.up) <= CONE_WINDOW_DEG
    h = region.normal - float(region.normal @ frame.up) * frame.up
    if float(np.linalg.norm(h)) < math.sin(math.radians(5.0)):
        return False  # horizontal plane: it faces no side
    if part.pitched and slope < 5.0:
        return False
    return _angle_deg(h, frame.horizontal(part.name)) <= HORIZONTAL_WINDOW_DEG


def candidates(
    part: PlanarPart, regions: list[RegionView], frame: Frame, limit: int = 2
) -> list[RegionView]:
    """The regions that fit `part`, heaviest (most certain) first, at most `limit`."""
    found = [r for r in regions if fits(part, r, frame)]
    found.sort(key=lambda r: (-r.weight, r.id))
    return found[:limit]


def faces_camera(normal: FloatArray, point_m: FloatArray, camera: CameraView) -> bool:
    """True if a plane with outward `normal` through `point_m` faces the camera (>= 10 deg)."""
    to_cam = camera.centre_m - point_m
    return float(normal @ to_cam) > math.sin(math.radians(10.0)) * float(np.linalg.norm(to_cam))


def support_offset(normal: FloatArray, points_m: FloatArray) -> float:
    """d = max_p normal·p over observed surface points (N, 3): a convex solid's face offset."""
    return float(np.max(points_m @ normal))


def front_region(walls: list[RegionView], camera: CameraView) -> RegionView | None:
    """The region most likely to be a body's front: heavy and facing the camera.

    Maximises weight × cos(angle between the normal and the direction to the camera).
    """
    best, score = None, 0.0
    for r in walls:
        to_cam = camera.centre_m - r.centroid_m
        c = float(r.normal @ to_cam) / float(np.linalg.norm(to_cam))
        s = r.weight * c
        if s > score:
            best, score = r, s
    return best
