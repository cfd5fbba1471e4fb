"""Matching image line segments to model edges (the data of the edge constraints, eq. 5).

A segment that borders the regions of two parts is the edge where those parts meet. A
segment that borders the region of one part only (a silhouette, or the border with ground
or sky) is the edge between that part and the adjacent part whose intersection line, as the
camera sees it, lies closest to the segment and runs in its direction. Segments that match
no edge closely enough stay unexplained.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.observe import CameraView, SegmentView
from aida_kb.register.match import match_segments as register_match

FloatArray = npt.NDArray[np.float64]

MAX_ANGLE_DEG = 12.0  # between a segment and the projected edge line
MAX_DISTANCE_PX = 25.0  # mean distance of the segment's ends from the projected edge line
MIN_SEGMENT_PX = 8.0  # shorter segments give no reliable direction to match an edge by


@dataclass(frozen=True)
class EdgeMatch:
    """A segment explained as the edge between two parts (role paths, in a fixed order)."""

    segment: SegmentView
    parts: tuple[str, str]
    distance_px: float  # mean distance of the ends from the edge line, at the time of matching


def plane_line(
    n_a: FloatArray, d_a: float, n_b: FloatArray, d_b: float
) -> tuple[FloatArray, FloatArray] | None:
    """Where planes n·x = d meet: a point (3,) and a unit direction (3,); None if parallel."""
    direction = np.cross(n_a, n_b)
    norm = float(np.linalg.norm(direction))
    if norm < math.sin(math.radians(2.0)):
        return None
    direction = direction / norm
    A = np.array([n_a, n_b, direction])
    point = np.linalg.solve(A, np.array([d_a, d_b, 0.0]))
    return point, direction


def image_line(camera: CameraView, point_m: FloatArray, direction: FloatArray) -> FloatArray:
    """Homogeneous image line (3,), normalised so that (a, b) is a unit vector, or zeros."""
    P = camera.P
    x1 = P @ np.append(point_m, 1.0)
    x2 = P @ np.append(direction, 0.0)  # the vanishing point of the line
    line = np.cross(x1, x2)
    norm = float(np.hypot(line[0], line[1]))
    out: FloatArray = line / norm if norm > 1e-12 else np.zeros(3)
    return out


def _ordered(a: str, b: str) -> tuple[str, str]:
    return (a, b) if a <= b else (b, a)


def _candidates(
    segment: SegmentView, binding: Mapping[str, str], adjacency: Mapping[str, frozenset[str]]
) -> set[tuple[str, str]]:
    """The edges a segment may show, by the parts its regions are bound to (module doc)."""
    bound = sorted({binding[r] for r in segment.regions if r in binding})
    if len(bound) == 2:
        return {(bound[0], bound[1])} if bound[1] in adjacency.get(bound[0], ()) else set()
    if len(bound) == 1:
        return {_ordered(bound[0], other) for other in adjacency.get(bound[0], ())}
    return set()


def match_segments(
    segments: Iterable[SegmentView],
    binding: Mapping[str, str],
    planes: Mapping[str, tuple[FloatArray, float]],
    adjacency: Mapping[str, frozenset[str]],
    cameras: Mapping[str, CameraView],
    max_distance_px: float = MAX_DISTANCE_PX,
) -> list[EdgeMatch]:
    """Explain segments as edges between adjacent parts.

    Each view's candidate edges (the pairs its segments' region bindings admit) are projected
    as whole image lines and matched by `aida_kb.register.match.match_segments`, the project's
    one matcher, with the mean end distance and the pairs as its ``allowed`` mask.

    Parameters
    ----------
    segments : the evidence's line segments
    binding : region id -> the role path of the part it is bound to
    planes : role path -> (unit normal (3,), offset d in metres), world frame, current values
    adjacency : role path -> the role paths of the parts it meets
    cameras : view id -> camera
    max_distance_px : the largest mean distance of a segment's ends from its edge's line

    Returns
    -------
    The matches, in the order of the segments; a segment matches at most one edge.
    """
    by_view: dict[str, list[tuple[int, SegmentView, set[tuple[str, str]]]]] = {}
    for k, seg in enumerate(segments):
        if seg.view not in cameras or seg.length_px < MIN_SEGMENT_PX:
            continue
        pairs = {
            (a, b) for a, b in _candidates(seg, binding, adjacency) if a in planes and b in planes
        }
        if pairs:
            by_view.setdefault(seg.view, []).append((k, seg, pairs))
    found: list[tuple[int, EdgeMatch]] = []
    for view, items in by_view.items():
        edges = sorted(set().union(*(pairs for _, _, pairs in items)))
        lines = [_edge_line(cameras[view], planes[a], planes[b]) for a, b in edges]
        keep = [i for i, line in enumerate(lines) if line is not None]
        if not keep:
            continue
        ends = np.array([lines[i] for i in keep])  # (E, 2, 2): two points of each image line
        col = {edges[i]: e for e, i in enumerate(keep)}
        allowed = np.zeros((len(keep), len(items)), dtype=bool)
        for s, (_, _, pairs) in enumerate(items):
            allowed[[col[p] for p in pairs if p in col], s] = True
        px = np.array([seg.ends_px for _, seg, _ in items])  # (S, 2, 2)
        m = register_match(
            ends[:, 0],
            ends[:, 1],
            px[:, 0],
            px[:, 1],
            max_distance_px=max_distance_px,
            max_angle_rad=math.radians(MAX_ANGLE_DEG),
            min_overlap=None,
            mean_distance=True,
            allowed=allowed,
        )
        for e, s, d in zip(m.edge, m.segment, m.distance_px, strict=True):
            k, seg, _ = items[int(s)]
            found.append((k, EdgeMatch(seg, edges[keep[int(e)]], float(d))))
    return [match for _, match in sorted(found, key=lambda km: km[0])]


def _edge_line(
    camera: CameraView, plane_a: tuple[FloatArray, float], plane_b: tuple[FloatArray, float]
) -> FloatArray | None:
    """Two points (2, 2) px of the image line where two planes meet; None when it has none."""
    line3 = plane_line(plane_a[0], plane_a[1], plane_b[0], plane_b[1])
    if line3 is None:
        return None
    line = image_line(camera, *line3)
    if not line.any():
        return None
    foot = -line[2] * line[:2]  # the line's point nearest the image origin
    return np.array([foot, foot + np.array([-line[1], line[0]])])
