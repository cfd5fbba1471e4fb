"""The vertical from the vanishing point of an image's line segments, with its uncertainty.

A straight image segment and the camera centre span its *interpretation plane*, whose unit
normal m = (K⁻¹p₁ × K⁻¹p₂) / |…| is known from the segment alone (camera frame). Every segment
of a 3-D line with direction u has m·u = 0, so the direction shared by the most segments is
the vanishing direction of a bundle of parallel 3-D lines. Buildings carry many vertical
lines (wall corners, window jambs, masonry joints, downpipes); their vanishing direction is the
vertical, which one wall's plane fit cannot give (its normal only says "perpendicular to up").

`vertical_direction`:
1. candidates: segments whose interpretation plane lies within `prior_window_deg` of the
   prior (the camera's -y axis, or a given direction) — near-vertical segments in the image of
   a camera held roughly upright, however far it is pitched;
2. hypotheses: the cross products of every pair of the longest candidates (deterministic,
   vectorised); the one whose inliers (|m·u| below INLIER_SIN) sum the largest length wins;
3. refinement: the direction most perpendicular to its inliers' normals, weighted by length²
   (the inverse variance of a segment's direction from end points of fixed pixel noise): the
   eigenvector of the smallest eigenvalue of Σ wᵢ mᵢ mᵢᵀ, the inliers re-selected a few times.

The uncertainty is that of the weighted least-squares solution: the residual variance
σ² = Σ wᵢ (mᵢ·u)² / (Σ wᵢ) · n/(n - 2) times the inverse of the scatter in the plane
perpendicular to u, and the calibration's share (CALIBRATION_SIGMA_DEG) in quadrature;
`sigma_deg` is the larger axis of that 1-σ cone. It grows when the
segments are few, short or nearly parallel in the image (a vanishing point far away and seen
through segments that all point at it from one side).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError

F64 = npt.NDArray[np.float64]

# Segments shorter than this (pixels) have directions too noisy to vote: with end points good
# to ~0.5 px a 20 px segment's direction is uncertain by ~3 degrees.
MIN_SEGMENT_PX = 20.0
# Hypotheses come from pairs of the longest candidates only: 60 give 1770 pairs, enough that
# some pair of true verticals is among them on every building seen so far, cheap to score.
MAX_SEED_SEGMENTS = 60
# A segment supports a direction when that direction lies within ~0.5 degrees of its
# interpretation plane (the direction error of a 60 px segment with 0.25 px end-point noise).
INLIER_SIN = math.sin(math.radians(0.5))
# A pair of seed segments whose planes are closer than this to each other gives no direction
# (their cross product is noise).
MIN_PAIR_SIN = math.sin(math.radians(2.0))
# At least this many supporting segments, or there is no vanishing point to speak of.
MIN_SUPPORT = 8
REFINE_ROUNDS = 4
# The calibration's own share of the uncertainty, added in quadrature to the statistical one: a
# principal point off by 2 px at a focal length of 700 px turns every ray, and so the vertical,
# by 0.16 degrees; no number of segments averages that away.
CALIBRATION_SIGMA_DEG = 0.15


@dataclass(frozen=True)
class VanishingDirection:
    """A vanishing direction in the camera frame.

    direction : (3,) unit vector, camera frame (x right, y down, z forward), oriented to agree
        with the prior it was sought near.
    sigma_deg : 1-σ angular uncertainty of the direction, degrees (the cone's larger axis).
    support : number of segments that support it; support_px : their summed length, pixels.
    inliers : (N,) bool over the segments given, True for the supporting ones.
    """

    direction: F64
    sigma_deg: float
    support: int
    support_px: float
    inliers: npt.NDArray[np.bool_]


def interpretation_normals(segments_px: F64, K: F64) -> F64:
    """Unit normals (N, 3), camera frame, of the planes through the camera centre and each
    segment. segments_px : (N, 2, 2) end points (x, y), undistorted pixels; K : (3, 3)."""
    seg = np.asarray(segments_px, np.float64).reshape(-1, 2, 2)
    K_inv = np.linalg.inv(np.asarray(K, np.float64))
    ends = np.concatenate([seg, np.ones((*seg.shape[:2], 1))], axis=2) @ K_inv.T
    m = np.cross(ends[:, 0], ends[:, 1])
    norm = np.linalg.norm(m, axis=1, keepdims=True)
    if np.any(norm == 0.0):
        raise VisionError("interpretation_normals: a segment has two equal end points")
    normals: F64 = m / norm
    return normals


def vertical_direction(
    segments_px: F64,
    K: F64,
    *,
    prior: F64 | None = None,
    prior_window_deg: float = 30.0,
) -> VanishingDirection | None:
    """The vanishing direction of the dominant near-vertical line bundle (see module docstring).

    Parameters
    ----------
    segments_px : (N, 2, 2) segment end points (x, y), pixels of an undistorted image.
    K : (3, 3) its camera matrix, pixels.
    prior : (3,) expected up direction, camera frame (default (0, -1, 0): the camera's up).
    prior_window_deg : how far from the prior the answer may lie, degrees.

    Returns
    -------
    VanishingDirection or None
        Oriented to agree with the prior (so it points up); None when fewer than MIN_SUPPORT
        segments agree on a direction.
    """
    seg = np.asarray(segments_px, np.float64).reshape(-1, 2, 2)
    up0 = np.array([0.0, -1.0, 0.0]) if prior is None else np.asarray(prior, np.float64)
    up0 = up0 / np.linalg.norm(up0)
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    long = length >= MIN_SEGMENT_PX
    none = np.zeros(len(seg), bool)
    if np.count_nonzero(long) < MIN_SUPPORT:
        return None
    m = np.zeros((len(seg), 3))
    m[long] = interpretation_normals(seg[long], K)
    window = math.sin(math.radians(prior_window_deg))
    cand = long & (np.abs(m @ up0) < window)
    if np.count_nonzero(cand) < MIN_SUPPORT:
        return None
    idx = np.flatnonzero(cand)
    seeds = idx[np.argsort(-length[idx], kind="stable")[:MAX_SEED_SEGMENTS]]
    i, j = np.triu_indices(len(seeds), k=1)
    hyp = np.cross(m[seeds[i]], m[seeds[j]])
    hn = np.linalg.norm(hyp, axis=1)
    ok = hn > MIN_PAIR_SIN
    hyp = hyp[ok] / hn[ok, None]
    hyp *= np.where(hyp @ up0 < 0, -1.0, 1.0)[:, None]
    hyp = hyp[hyp @ up0 > math.cos(math.radians(prior_window_deg))]
    if len(hyp) == 0:
        return None
    support = np.abs(m[idx] @ hyp.T) < INLIER_SIN  # (candidates, hypotheses)
    score = length[idx] @ support
    u = hyp[int(np.argmax(score))]
    weights = np.where(cand, length * length, 0.0)
    inl = none
    for _ in range(REFINE_ROUNDS):
        inl = cand & (np.abs(m @ u) < INLIER_SIN)
        if np.count_nonzero(inl) < MIN_SUPPORT:
            return None
        u = _least_perpendicular(m[inl], weights[inl], u)
    inl = cand & (np.abs(m @ u) < INLIER_SIN)
    if np.count_nonzero(inl) < MIN_SUPPORT:
        return None
    sigma = math.hypot(_sigma_deg(m[inl], weights[inl], u), CALIBRATION_SIGMA_DEG)
    return VanishingDirection(
        direction=u,
        sigma_deg=sigma,
        support=int(np.count_nonzero(inl)),
        support_px=float(length[inl].sum()),
        inliers=inl,
    )


def _least_perpendicular(m: F64, w: F64, near: F64) -> F64:
    """The unit u minimising Σ wᵢ (mᵢ·u)², oriented like `near`. m (N, 3), w (N,)."""
    scatter = (m * w[:, None]).T @ m
    _, vectors = np.linalg.eigh(scatter)
    u: F64 = vectors[:, 0]
    return u if float(u @ near) >= 0 else -u


def _sigma_deg(m: F64, w: F64, u: F64) -> float:
    """1-σ angular uncertainty (degrees) of the weighted least-squares direction u."""
    n = len(m)
    r = m @ u
    wn = w / w.sum()
    var = float(np.sum(wn * r * r)) * n / max(n - 2, 1)
    # tangent basis of u; scatter of the normals there (in units of 1 / effective count)
    a = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    T = np.stack([a, b], axis=1)  # (3, 2)
    mt = m @ T
    n_eff = float(w.sum() ** 2 / np.sum(w * w))  # effective number of equally weighted segments
    S = (mt * wn[:, None]).T @ mt * n_eff
    try:
        cov = var * np.linalg.inv(S)
    except np.linalg.LinAlgError:
        return 180.0
    largest = float(np.max(np.linalg.eigvalsh(cov)))
    return math.degrees(math.sqrt(max(largest, 0.0)))
