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

FloatArray = npt.NDArray[np.float64]

MAX_ANGLE_DEG = 12.0  # between a segment and the projected edge line
MAX_DISTANCE_PX = 25.0  # mean distance of the segment's ends from the projected edge line


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


def _fit(segment: SegmentView, line: FloatArray) -> tuple[float, float]:
    """(mean end distance in px, angle in degrees) of a segment against an image line."""
    ends = np.column_stack([segment.ends_px, np.ones(2)])
    distance = float(np.mean(np.abs(ends @ line)))
    seg = segment.ends_px[1] - segment.ends_px[0]
    seg_dir = seg / max(float(np.linalg.norm(seg)), 1e-12)
    line_dir = np.array([-line[1], line[0]])
    angle = math.degrees(math.acos(min(1.0, abs(float(seg_dir @ line_dir)))))
    return distance, angle


def _ordered(a: str, b: str) -> tuple[str, str]:
    return (a, b) if a <= b else (b, a)


def match_segments(
    segments: Iterable[SegmentView],
    binding: Mapping[str, str],
    planes: Mapping[str, tuple[FloatArray, float]],
    adjacency: Mapping[str, frozenset[str]],
    cameras: Mapping[str, CameraView],
    max_distance_px: float = MAX_DISTANCE_PX,
) -> list[EdgeMatch]:
    """Explain segments as edges between adjacent parts.

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
    matches: list[EdgeMatch] = []
    for seg in segments:
        camera = cameras.get(seg.view)
        if camera is None or seg.length_px < 8.0:
            continue
        bound = sorted({binding[r] for r in seg.regions if r in binding})
        if len(bound) == 2:
            pairs = [(bound[0], bound[1])] if bound[1] in adjacency.get(bound[0], ()) else []
        elif len(bound) == 1:
            pairs = [_ordered(bound[0], other) for other in adjacency.get(bound[0], ())]
        else:
            continue
        best: tuple[float, tuple[str, str]] | None = None
        for a, b in sorted(set(pairs)):
            if a not in planes or b not in planes:
                continue
            line3 = plane_line(planes[a][0], planes[a][1], planes[b][0], planes[b][1])
            if line3 is None:
                continue
            line = image_line(camera, *line3)
            if not line.any():
                continue
            distance, angle = _fit(seg, line)
            if angle > MAX_ANGLE_DEG or distance > max_distance_px:
                continue
            if best is None or distance < best[0]:
                best = (distance, (a, b))
        if best is not None:
            matches.append(EdgeMatch(seg, best[1], best[0]))
    return matches
