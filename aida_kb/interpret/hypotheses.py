"""Hypotheses for planar parts: predicted orientation, candidate regions, inserted planes.

A composite world instance declared with a frame (``frame from ANCHOR``, docs/language.md
§3.9) has an *instance frame*: the horizontal direction its anchor part faces (`front`), the
direction to its right as seen from the front (`right`) and `up`. The knowledge base orients
each planar part in that frame (``orient PART: DIRECTION [tilted by T]``): forward, backward,
leftward, rightward face +front, -front, -right, +right horizontally (tilted parts rise from
the ground towards that side by their tilt), upward and downward face up and down. Candidates
for a part are the regions whose orientation fits the prediction and whose slope lies in the
range of the part concept's slope attribute (``is slope(self)``). Parts without a candidate
that the reference camera could not see are *inserted* from the knowledge; their plane is
initialised from the prediction and, for the offset, from the support function of the points
observed on the same solid (a face of a convex solid touches the observed surface points that
are most extreme along its normal), moved out by the knowledge's placements (`placed_offsets`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aida_kb.diagnostics.core import Span
from aida_kb.errors import InterpretError
from aida_kb.interpret.observe import CameraView, RegionView, slope_deg
from aida_kb.kb.model import PlacementKind

FloatArray = npt.NDArray[np.float64]

#: the directions of the language that face a side, and the vertical ones
HORIZONTAL = ("forward", "backward", "leftward", "rightward")
UPWARD, DOWNWARD = "upward", "downward"

# How far a region's orientation may stray from the prediction and still be a candidate.
HORIZONTAL_WINDOW_DEG = 30.0  # between horizontal directions (walls, pitched roof planes)
CONE_WINDOW_DEG = 15.0  # around up or down (flat roofs, floors)
# the initial tilt of an inserted tilted plane when neither a seen plane of its structure nor
# the knowledge (a constant tilt or the tilt attribute's default) gives one
DEFAULT_PITCH_DEG = 30.0


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

    @classmethod
    def facing(cls, normal: FloatArray, up: FloatArray, name: str) -> Frame:
        """The frame in which the horizontal direction `name` of the language (one of
        `HORIZONTAL`) is the horizontal part of `normal` ((3,), world): a side wall's normal
        gives the frame of the structure it belongs to as a front wall's gives its own."""
        h = normal - float(normal @ up) * up
        front = {
            "forward": h,
            "backward": -h,
            "rightward": np.cross(h, up),
            "leftward": np.cross(up, h),
        }[name]
        return cls.from_front(front, up)

    def direction(self, name: str) -> FloatArray:
        """The unit vector (world, (3,)) of a direction of the language in this frame."""
        table = {
            "forward": self.front,
            "backward": -self.front,
            "leftward": -self.right,
            "rightward": self.right,
            UPWARD: self.up,
            DOWNWARD: -self.up,
        }
        return table[name]


@dataclass(frozen=True)
class PlanarPart:
    """A planar part to be matched: role path, role name, concept, slope range, orientation."""

    role: str  # absolute role path
    name: str  # the last role name
    concept: str
    slope_range_deg: tuple[float, float] | None  # from the concept's slope attribute
    pitched: bool  # tilted towards the side it faces (``orient P: forward tilted by T``)
    direction: str | None = None  # the direction it faces in its structure's frame
    tilt_deg: float | None = None  # its declared tilt (None: the evidence says)
    default_tilt_deg: float | None = None  # its slope attribute's default
    orient_span: Span | None = None  # the ``orient`` declaration it follows (None: none)


def predicted_normal(part: PlanarPart, frame: Frame, pitch_deg: float) -> FloatArray:
    """The unit outward normal (world, (3,)) a part is expected to have in `frame`.

    ``pitch_deg`` is the tilt of a tilted part (its slope against the ground).

    Raises
    ------
    InterpretError
        The part is not oriented by the knowledge base (no ``orient`` declares it).
    """
    if part.direction is None:
        raise InterpretError(
            f"{part.role} ({part.concept}) faces no declared direction: the knowledge base "
            "has no 'orient' for it, so it cannot be inserted"
        )
    d = frame.direction(part.direction)
    if part.direction not in HORIZONTAL or not part.pitched:
        return d
    p = math.radians(pitch_deg)
    out: FloatArray = math.cos(p) * frame.up + math.sin(p) * d
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
    if part.direction is None:
        return False  # the knowledge says nothing about which way it faces
    if part.direction not in HORIZONTAL:
        return _angle_deg(region.normal, frame.direction(part.direction)) <= CONE_WINDOW_DEG
    h = region.normal - float(region.normal @ frame.up) * frame.up
    if float(np.linalg.norm(h)) < math.sin(math.radians(5.0)):
        return False  # horizontal plane: it faces no side
    if part.pitched and slope < 5.0:
        return False
    return _angle_deg(h, frame.direction(part.direction)) <= HORIZONTAL_WINDOW_DEG


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


def placed_offsets(
    placements: Sequence[tuple[Any, Mapping[str, str]]],
    normal: FloatArray,
    frame: Frame,
    planes: Mapping[str, tuple[FloatArray, float]],
    centroids: Mapping[str, FloatArray],
    points_of: Callable[[str], FloatArray],
    directions: Callable[[str], str | None],
    reach_front: float | None,
) -> list[float]:
    """The offsets (n·x = d, metres) the knowledge's placements give an unseen part.

    Parameters
    ----------
    placements : the ``unseen`` declarations that apply (`PlacementModel`), each with the map
        from its relative paths to absolute role paths (`Knowledge.placements`).
    normal : (3,) the unseen part's predicted unit normal, world frame.
    frame : its structure's frame.
    planes : role path -> (unit normal (3,), offset m) of the seen parts (their regions' plane
        fits) and of the verified levels' parts.
    centroids : role path -> (3,) centroid of a seen part's region, world frame, metres.
    points_of : role path of a seen part -> (N, 3) its evidence points, world frame, metres.
    directions : role path -> the direction the part faces (None: not oriented).
    reach_front : where a ``reach`` meets its line: a coordinate along the frame's forward
        axis, metres (the structure's own ridge, `unseen.reach_front`); None: not known.

    ``mirror REF about edge(A, B)``: as far beyond the line as REF lies before it, along the
    horizontal direction REF faces; the line is the far boundary of A's evidence along that
    direction (when B is seen too, the line where the planes of A and B meet). ``at D from
    REF``: parallel to REF, D behind it. ``reach edge(A, B)``: the point of the line where it
    lies at ``reach_front`` along the frame's forward axis. A
    placement whose references are not seen (nor verified) gives nothing.
    """
    out: list[float] = []
    for p, paths in placements:
        ref = paths.get(p.ref) if p.ref is not None else None
        line = tuple(paths[x] for x in p.line) if p.line is not None else None
        if (
            p.kind is PlacementKind.MIRROR
            and ref is not None
            and line is not None
            and ref in centroids
        ):
            found = _mirrored(ref, line, frame, planes, centroids, points_of, directions)
            if found is not None:
                out.append(float(normal @ found))
        elif (
            p.kind is PlacementKind.OFFSET
            and ref is not None
            and ref in planes
            and p.value is not None
        ):
            n_ref, d_ref = planes[ref]
            on_ref = centroids.get(ref, n_ref * d_ref)
            out.append(float(normal @ (on_ref - p.value * n_ref)))
        elif p.kind is PlacementKind.REACH and line is not None:
            point = _reached(line, frame, planes, reach_front)
            if point is not None:
                out.append(float(normal @ point))
    return out


def _mirrored(
    ref: str,
    line: tuple[str, ...],
    frame: Frame,
    planes: Mapping[str, tuple[FloatArray, float]],
    centroids: Mapping[str, FloatArray],
    points_of: Callable[[str], FloatArray],
    directions: Callable[[str], str | None],
) -> FloatArray | None:
    """The mirror image (3,) of REF's centroid about the line, along REF's direction."""
    facing = directions(ref)
    if facing not in HORIZONTAL:
        return None
    u = frame.direction(facing)
    a, b = line
    if a in centroids and b in centroids:
        meet = _line(planes[a], planes[b])
        if meet is None:
            return None
        far = float(u @ meet[0])
    elif a in centroids:
        along = points_of(a) @ u
        if len(along) < 2:
            return None
        far = float(along.min())
    else:
        return None
    c = centroids[ref]
    out: FloatArray = c + 2.0 * (far - float(u @ c)) * u
    return out


def _line(
    p1: tuple[FloatArray, float], p2: tuple[FloatArray, float]
) -> tuple[FloatArray, FloatArray] | None:
    """The line where two planes meet: a point (3,) and a direction (3,), or None if parallel."""
    (n1, d1), (n2, d2) = p1, p2
    u = np.cross(n1, n2)
    if float(np.linalg.norm(u)) < 1e-6:
        return None
    p0 = np.linalg.solve(np.stack([n1, n2, u]), np.array([d1, d2, 0.0]))
    return p0, u


def _reached(
    line: tuple[str, ...],
    frame: Frame,
    planes: Mapping[str, tuple[FloatArray, float]],
    reach_front: float | None,
) -> FloatArray | None:
    """The point (3,) of the line edge(A, B) at ``reach_front`` (metres) along the frame's
    forward axis (None: A or B unknown, the line across that axis, no reach given)."""
    a, b = line
    if a not in planes or b not in planes or reach_front is None:
        return None
    meet = _line(planes[a], planes[b])
    if meet is None:
        return None
    p0, u = meet
    if abs(float(frame.front @ u)) < 0.1 * float(np.linalg.norm(u)):
        return None
    t = (reach_front - float(frame.front @ p0)) / float(frame.front @ u)
    point: FloatArray = p0 + t * u
    return point
