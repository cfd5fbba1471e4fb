"""Merging a view's plane regions: coplanar neighbours (`merge_coplanar`) and the fragments of
one plane split by dropouts (`merge_fragments`), on the region map of
`aida_kb.vision.segmentation`."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]


# Merging coplanar regions (window recesses, shallow relief and dropouts split a facade into
# tens of regions that share one plane). Two regions merge when their normals lie within
# COPLANAR_DEG of each other, each one's centroid lies within COPLANAR_REL of its distance from
# the other's plane (2 %: 0.4 m at 20 m, the depth of a window reveal; stereo noise on a wall
# is well below), and they come within MERGE_GAP_PX of each other in the image (across a
# window hole or a dropout).
COPLANAR_DEG = 3.0
COPLANAR_REL = 0.02
MERGE_GAP_PX = 16
_MERGE_STEP_PX = 4  # the label map is sampled on this grid to find neighbours


def _separation(
    regions: I32, index: npt.NDArray[np.int64], R: int, within_px: int = MERGE_GAP_PX
) -> F64:
    """(R, R) symmetric: how close the regions (by `index`, region id -> 0..R-1, -1 none)
    come to each other along an image row or column, pixels (on a grid of _MERGE_STEP_PX;
    inf: not within `within_px`)."""
    grid = index[regions[::_MERGE_STEP_PX, ::_MERGE_STEP_PX]]
    gap = np.full((R, R), np.inf)
    for k in range(max(1, within_px // _MERGE_STEP_PX), 0, -1):  # the closest written last
        for a, b in ((grid[:, :-k], grid[:, k:]), (grid[:-k, :], grid[k:, :])):
            ok = (a >= 0) & (b >= 0) & (a != b)
            gap[a[ok], b[ok]] = k * _MERGE_STEP_PX
            gap[b[ok], a[ok]] = k * _MERGE_STEP_PX
    return gap


def _neighbours(regions: I32, index: npt.NDArray[np.int64], R: int) -> npt.NDArray[np.bool_]:
    """(R, R) symmetric: the regions (by `index`) within MERGE_GAP_PX of each other."""
    return np.isfinite(_separation(regions, index, R))


def merge_coplanar(
    regions: I32,
    ids: npt.NDArray[np.int64],
    normals: F64,
    centroids: F64,
    *,
    points: F32 | None = None,
    focal_px: float | None = None,
) -> I32:
    """The region map (H, W) with coplanar neighbouring regions given one id (the smallest).

    regions : (H, W) int32 ids, 0 = none. ids : (R,) the ids with a plane; normals : (R, 3)
    unit normals and centroids : (R, 3) metres, one frame (the camera's). Regions without a
    plane are left as they are. See COPLANAR_DEG, COPLANAR_REL, MERGE_GAP_PX. With `points`
    ((H, W, 3) float32 metres, that frame, NaN = no depth; the camera's, z its depth) and the
    camera's `focal_px`, the pieces whose points lie on one plane within their own scatter are
    merged too (`merge_fragments`).
    """
    R = len(ids)
    if R < 2:
        return regions
    index = np.full(int(max(int(regions.max()), int(ids.max()))) + 1, -1, np.int64)
    index[ids] = np.arange(R)
    near = _neighbours(regions, index, R)
    cos = np.clip(np.abs(normals @ normals.T), -1.0, 1.0)
    dist = np.abs(np.einsum("ik,ijk->ij", normals, centroids[None, :, :] - centroids[:, None, :]))
    rel = dist / np.linalg.norm(centroids, axis=1)[:, None]
    ok = (
        near
        & (cos >= np.cos(np.radians(COPLANAR_DEG)))
        & (rel <= COPLANAR_REL)
        & (rel.T <= COPLANAR_REL)
    )
    n, comp = connected_components(csr_matrix(ok), directed=False)
    merged = regions
    if n < R:
        first = np.full(n, np.iinfo(np.int64).max)
        np.minimum.at(first, comp, ids)
        lut = np.arange(index.size, dtype=np.int64)
        lut[ids] = first[comp]
        merged = lut[regions].astype(np.int32)
    if points is None or focal_px is None:
        return merged
    return merge_fragments(merged, np.unique(merged[np.isin(merged, ids)]), points, focal_px)


# Merging the fragments of one plane. Narrow or weakly textured faces (a wall between windows,
# seen at 30 m) come out of `segment_planes` as tens of small regions whose own plane fits
# scatter by 5-30 degrees (a few hundred pixels each): COPLANAR_DEG cannot tell them from
# different planes, and a part bound to one of them is a sliver (a wall 0.35 m wide). Whether
# two neighbours are pieces of one plane is asked of their points instead: fit one plane to
# both, and each piece's points must scatter about it by at most FRAGMENT_SIGMAS times their
# scatter about the piece's own plane (RMS: relief and stereo noise as the piece shows them).
# Pieces of one wall pass (development scene 2000: 1.00-1.13); a wall and a roof (tens of
# degrees apart) or a wall and a porch (parallel, a metre out) leave a piece far off the
# joint plane (a wall piece beside a noisier one of a wing at 45 degrees: 3.5). Merging is
# greedy, the best-fitting pair first, and each merged group is tested again as a whole: a
# noisy sliver at an eave may fit the wall or the roof, but wall and roof never fit one plane.
FRAGMENT_SIGMAS = 1.5  # a piece's RMS about the joint plane at most 1.5 times its own
FRAGMENT_MIN_RMS_M = 0.01  # scatter never below 1 cm (exact synthetic depth: no zero divide)
FRAGMENT_MIN_POINTS = 10  # a region needs this many points with depth to be tested
FRAGMENT_GAP_M = 1.5  # pieces this far apart at their depth may be one plane (a window wide),
# and MERGE_GAP_PX more (the rims of a hole, where the matcher's window smears the depth step,
# have no region either: development scene 2000's wall pieces lie 1.9 m apart at 32 m)
FRAGMENT_GAP_PX = 64  # the widest gap in pixels searched (speed)


def _moments(regions: I32, ids: npt.NDArray[np.int64], points: F32) -> tuple[F64, F64, F64, F64]:
    """Per id (R,): the count of its points with depth, their sum (R, 3) and the sum of
    their outer products (R, 3, 3), metres, about `origin` (3,), the mean of all points in
    regions (numerical range)."""
    has = np.isfinite(points).all(axis=-1) & (regions > 0)
    lab = regions[has].astype(np.int64)
    xyz = points[has].astype(np.float64)
    origin = xyz.mean(axis=0) if len(xyz) else np.zeros(3)
    xyz = xyz - origin
    index = np.full(int(max(int(regions.max()), int(ids.max()))) + 1, -1, np.int64)
    index[ids] = np.arange(len(ids))
    k = index[lab]
    sel = k >= 0
    k, xyz = k[sel], xyz[sel]
    R = len(ids)
    count = np.bincount(k, minlength=R).astype(np.float64)
    s1 = np.stack([np.bincount(k, xyz[:, i], minlength=R) for i in range(3)], axis=1)
    s2 = np.stack(
        [np.bincount(k, xyz[:, i] * xyz[:, j], minlength=R) for i in range(3) for j in range(3)],
        axis=1,
    ).reshape(R, 3, 3)
    return count, np.asarray(s1, np.float64), np.asarray(s2, np.float64), origin


def _scatter(count: F64, s1: F64, s2: F64) -> tuple[F64, F64]:
    """The mean (..., 3) and covariance (..., 3, 3) of groups given by their moments."""
    n = np.maximum(count, 1.0)[..., None]
    mean = s1 / n
    cov = s2 / n[..., None] - mean[..., :, None] * mean[..., None, :]
    return mean, cov


def _off_plane(normal: F64, through: F64, mean: F64, cov: F64) -> F64:
    """RMS distance (P,) metres of point groups (means (P, 3), covariances (P, 3, 3)) from
    planes of unit normals (P, 3) through points (P, 3)."""
    spread = np.einsum("pk,pkl,pl->p", normal, cov, normal)
    shift = np.einsum("pk,pk->p", normal, mean - through)
    return np.asarray(np.sqrt(np.maximum(spread, 0.0) + shift**2), np.float64)


def merge_fragments(regions: I32, ids: npt.NDArray[np.int64], points: F32, focal_px: float) -> I32:
    """The region map (H, W) with neighbouring pieces of one plane given one id (the
    smallest): see FRAGMENT_SIGMAS. regions : (H, W) int32 ids, 0 = none; ids : (R,) the
    regions that may merge (others stay); points : (H, W, 3) float32 metres, the camera
    frame (z the depth), NaN = no depth; focal_px : the camera's focal length, pixels (turns
    FRAGMENT_GAP_M into pixels). Neighbours: regions that come within FRAGMENT_GAP_M of each
    other at their depth, along an image row or column."""
    R = len(ids)
    if R < 2:
        return regions
    count, s1, s2, origin = _moments(regions, ids, points)
    index = np.full(int(max(int(regions.max()), int(ids.max()))) + 1, -1, np.int64)
    index[ids] = np.arange(R)
    depth = np.abs(s1[:, 2] / np.maximum(count, 1.0) + origin[2])
    gap_px = focal_px * FRAGMENT_GAP_M / np.maximum(depth, 1e-9) + MERGE_GAP_PX
    sep = _separation(regions, index, R, FRAGMENT_GAP_PX)
    near = sep <= np.minimum(gap_px[:, None], gap_px[None, :])
    near &= (count >= FRAGMENT_MIN_POINTS)[:, None] & (count >= FRAGMENT_MIN_POINTS)[None, :]
    group = np.arange(R)  # each region's group: the index of its group's first member
    while True:
        a, b = np.nonzero(np.triu(near, 1))
        if len(a) == 0:
            break
        mean, cov = _scatter(count, s1, s2)
        own = np.sqrt(np.maximum(np.linalg.eigvalsh(cov)[:, 0], 0.0))
        own = np.maximum(own, FRAGMENT_MIN_RMS_M)
        mean_u, cov_u = _scatter(count[a] + count[b], s1[a] + s1[b], s2[a] + s2[b])
        n_u = np.linalg.eigh(cov_u)[1][:, :, 0]  # (P, 3) the joint plane's normal

        ratio = np.maximum(
            _off_plane(n_u, mean_u, mean[a], cov[a]) / (FRAGMENT_SIGMAS * own[a]),
            _off_plane(n_u, mean_u, mean[b], cov[b]) / (FRAGMENT_SIGMAS * own[b]),
        )
        best = int(np.argmin(ratio))
        if ratio[best] > 1.0:
            break
        i, j = int(a[best]), int(b[best])  # j joins i
        count[i] += count[j]
        s1[i] += s1[j]
        s2[i] += s2[j]
        count[j] = 0.0
        near[i] |= near[j]
        near[:, i] |= near[:, j]
        near[i, i] = False
        near[j, :] = False
        near[:, j] = False
        group[group == j] = i
    if np.all(group == np.arange(R)):
        return regions
    first = np.full(R, np.iinfo(np.int64).max)
    np.minimum.at(first, group, ids)
    lut = np.arange(index.size, dtype=np.int64)
    lut[ids] = first[group]
    merged: I32 = lut[regions].astype(np.int32)
    return merged
