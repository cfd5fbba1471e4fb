"""Matching projected model edges to image line segments, and the chamfer score of a pose.

Everything is computed for all edges against all segments at once ((E, S) arrays); there is
no loop over segments. Pixels are those of the undistorted (pinhole) image.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

__all__ = ["Matches", "chamfer_cost", "match_segments"]


@dataclass(frozen=True)
class Matches:
    """Segment-to-edge correspondences.

    edge : (M,) index into the projected edges given to `match_segments`; segment : (M,) index
    into the segments; distance_px : (M,) mean distance of the segment's ends from the edge's
    line, pixels.
    """

    edge: IntArray
    segment: IntArray
    distance_px: FloatArray

    @property
    def size(self) -> int:
        """Number of matches M."""
        return int(self.edge.size)


def _frame(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    d = b - a
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-12)[:, None]
    n = np.stack([-u[:, 1], u[:, 0]], axis=1)
    return u, n, length


def match_segments(
    a: FloatArray,
    b: FloatArray,
    p1: FloatArray,
    p2: FloatArray,
    *,
    max_distance_px: float,
    max_angle_rad: float,
    min_overlap: float | None = 0.5,
    mean_distance: bool = False,
    allowed: BoolArray | None = None,
) -> Matches:
    """Assign each image segment to the projected model edge it most likely shows.

    A segment may show edge e when its direction is within ``max_angle_rad`` of the edge's,
    its ends lie within ``max_distance_px`` of the edge's line (both ends, or with
    ``mean_distance`` their mean), at least ``min_overlap`` of its length projects onto the
    edge (``min_overlap`` None: the edges are whole lines through a and b, no overlap asked)
    and ``allowed`` (when given) admits the pair. Among those it takes the edge whose line is
    nearest (mean distance of its two ends; the first edge on a tie). An edge may receive
    several segments (an edge broken into pieces). This is the one segment-to-edge matcher:
    registration calls it with projected model edges, the interpreter
    (`aida_kb.interpret.edges`) with the image lines of adjacent parts' plane intersections.

    Parameters
    ----------
    a, b : (E, 2) projected edge end points (or two points of each line), pixels.
    p1, p2 : (S, 2) segment end points, pixels.
    allowed : (E, S) bool, the pairs that may match; None: every pair.
    """
    if a.shape[0] == 0 or p1.shape[0] == 0:
        empty = np.zeros(0, dtype=np.intp)
        return Matches(empty, empty.copy(), np.zeros(0))
    u, n, length = _frame(a, b)
    v, _, seg_len = _frame(p1, p2)
    sin = np.abs(u[:, None, 0] * v[None, :, 1] - u[:, None, 1] * v[None, :, 0])  # (E, S)
    rel1 = p1[None, :, :] - a[:, None, :]  # (E, S, 2)
    rel2 = p2[None, :, :] - a[:, None, :]
    d1 = np.abs(np.einsum("esk,ek->es", rel1, n))
    d2 = np.abs(np.einsum("esk,ek->es", rel2, n))
    mean = 0.5 * (d1 + d2)
    ok = (sin < np.sin(max_angle_rad)) & (
        (mean if mean_distance else np.maximum(d1, d2)) < max_distance_px
    )
    if min_overlap is not None:
        t1 = np.einsum("esk,ek->es", rel1, u)
        t2 = np.einsum("esk,ek->es", rel2, u)
        top = np.minimum(np.maximum(t1, t2), length[:, None])
        overlap = top - np.maximum(np.minimum(t1, t2), 0.0)
        ok &= overlap >= min_overlap * seg_len[None, :]
    if allowed is not None:
        ok &= allowed
    score = np.where(ok, mean, np.inf)
    best = np.argmin(score, axis=0)  # (S,)
    best_score = score[best, np.arange(score.shape[1])]
    seg = np.flatnonzero(np.isfinite(best_score))
    return Matches(best[seg].astype(np.intp), seg.astype(np.intp), best_score[seg])


def chamfer_cost(
    a: FloatArray,
    b: FloatArray,
    p1: FloatArray,
    p2: FloatArray,
    *,
    cap_px: float,
    max_angle_rad: float,
    samples: int = 12,
) -> float:
    """Mean capped squared distance from the projected model edges to the image segments.

    Each edge is sampled at ``samples`` points; a point's distance is to the nearest segment
    whose direction is within ``max_angle_rad`` of the edge's, capped at ``cap_px``; the mean
    is weighted by edge length and divided by ``cap_px²`` (0: every edge lies on segments,
    1: none does). With no visible edge the cost is 1.

    Parameters
    ----------
    a, b : (E, 2) projected (visible, clipped) edge end points, pixels.
    p1, p2 : (S, 2) segment end points, pixels.
    """
    if a.shape[0] == 0:
        return 1.0
    if p1.shape[0] == 0:
        return 1.0
    u, _, length = _frame(a, b)
    v, _, seg_len = _frame(p1, p2)
    s = (np.arange(samples) + 0.5) / samples
    pts = a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]  # (E, K, 2)
    rel = pts[:, :, None, :] - p1[None, None, :, :]  # (E, K, S, 2)
    t = np.clip(np.einsum("eksj,sj->eks", rel, v), 0.0, seg_len[None, None, :])
    closest = p1[None, None, :, :] + t[..., None] * v[None, None, :, :]
    dist2 = np.sum((pts[:, :, None, :] - closest) ** 2, axis=3)
    sin = np.abs(u[:, None, 0] * v[None, :, 1] - u[:, None, 1] * v[None, :, 0])  # (E, S)
    dist2 = np.where((sin < np.sin(max_angle_rad))[:, None, :], dist2, np.inf)
    per_point = np.minimum(np.min(dist2, axis=2), cap_px * cap_px)  # (E, K)
    weight = length / max(float(length.sum()), 1e-12)
    return float(weight @ per_point.mean(axis=1)) / (cap_px * cap_px)
