"""Pose starts from a view's own planes: its regions' planes aligned with the model's.

A view with depth measures the planes of its regions in its own camera frame. A camera pose
``x_cam = R x_world + t`` carries each model plane ``N·x = d`` to normal ``R N`` through the
region's centre ``c``: ``(R N)·t = (R N)·c - d``. So

* two regions whose normals are not parallel, paired with two parts whose normals meet at the
  same angle, give the rotation in closed form (the two directions and their cross product,
  the least-squares rotation of `_rotations`); so do one region and the vertical, when the
  camera's vertical is known;
* given the rotation, three region-part pairs whose normals span space give ``t`` (a 3 x 3
  solve); two pairs and the camera's height give it where only two directions are seen (the
  walls of a house without its roof).

Every such hypothesis is scored by how many regions it puts on a part (the region's centre on
the part's plane, inside the part's bounding box grown by `BOX_MARGIN_REL`, the part facing
the camera, normals within `NORMAL_TOL_DEG`). The best few distinct poses are starts for the
edge refinement (`aida_kb.register.register.refine`): no orbit sampling needed, so a view
taken off the reference camera's orbit (another height, another distance) is found too.

Everything is vectorised over hypotheses; the enumeration is bounded by `MAX_REGIONS`.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

__all__ = ["part_boxes", "plane_poses", "regions_explained"]

NORMAL_TOL_DEG = 8.0
"""A region's normal and a part's (carried into the camera) agree within this angle, degrees:
stereo plane fits of a wall are within 1-3 degrees (the oriel preset: 0.3-2.4), a part
inserted from knowledge within a few more."""
MIN_SPREAD_DEG = 25.0
"""Two directions that fix a rotation must be at least this far from parallel, degrees: the
rotation about their mean is then within about NORMAL_TOL / sin(spread) of the truth."""
MIN_DET = 0.25
"""Three plane normals fix a translation when the determinant of the three is at least this
(0.25: e.g. two walls at 90 degrees and a roof pitched 15 degrees); else the solve is
ill-conditioned."""
POS_TOL_REL = 0.02
"""A region's centre lies on a part's plane when within this fraction of the model's size
(or 3 times its fit's RMS, if larger)."""
BOX_MARGIN_REL = 0.05
"""... and inside the part's bounding box grown by this fraction of the model's size (a
region's centre lies on its part, not on the plane's continuation)."""
VERTICAL_TOL_DEG = 20.0
"""With the camera's vertical given, a rotation that tilts it further than this (degrees) is
no hypothesis: the view is taken as upright as the reference within the elevation change of
a walk around a building (a box seen from below looks like a box seen from above, turned)."""
MAX_REGIONS = 16
"""At most this many regions (the best-fitting, by RMS) take part in the enumeration."""
MAX_ROTATIONS = 8
"""Distinct rotations (at least `ROTATION_SEP_DEG` apart) whose translations are enumerated."""
ROTATION_SEP_DEG = 4.0
"""Rotations closer than this (degrees) are one hypothesis."""
MAX_TRIPLES = 20_000
"""Cap on the translation hypotheses per rotation (the first, in region order)."""


def _rotations(a_cam: FloatArray, b_world: FloatArray) -> FloatArray:
    """(Q, 3, 3) rotations R with ``a ≈ R b`` for Q pairs of unit directions a, b (Q, 2, 3):
    the least-squares rotation of two direction pairs (SVD of ``Σ a bᵀ``, det fixed to +1)."""
    B = np.einsum("qki,qkj->qij", a_cam, b_world)
    U, _, Vt = np.linalg.svd(B)
    det = np.linalg.det(U @ Vt)
    D = np.ones((B.shape[0], 3))
    D[:, 2] = det
    out: FloatArray = (U * D[:, None, :]) @ Vt
    return out


def _angle(u: FloatArray, v: FloatArray) -> FloatArray:
    return np.degrees(np.arccos(np.clip(u @ v.T, -1.0, 1.0)))


def _distinct(order: IntArray, Rs: FloatArray, count: int) -> list[int]:
    """Indices of up to `count` rotations, in `order`, at least ROTATION_SEP_DEG apart."""
    chosen: list[int] = []
    cos_sep = math.cos(math.radians(ROTATION_SEP_DEG))
    for q in order:
        ok = True
        for c in chosen:
            tr = float(np.trace(Rs[q] @ Rs[c].T))
            if (tr - 1.0) / 2.0 > cos_sep:
                ok = False
                break
        if ok:
            chosen.append(int(q))
            if len(chosen) == count:
                break
    return chosen


def plane_poses(
    normals: FloatArray,
    offsets: FloatArray,
    boxes: FloatArray,
    size: float,
    normal_cam: FloatArray,
    centre_cam: FloatArray,
    rms_m: FloatArray,
    *,
    vertical: tuple[FloatArray, FloatArray, float] | None = None,
    count: int = 4,
) -> list[tuple[FloatArray, FloatArray, int]]:
    """Camera poses that put the view's regions on the model's parts, best first.

    Parameters
    ----------
    normals, offsets : (P, 3) unit part normals (out of the solid) and (P,) offsets, metres,
        world frame; boxes : (P, 2, 3) each part's bounding box (min, max), metres.
    size : the model's size, metres (tolerances are fractions of it).
    normal_cam, centre_cam, rms_m : the view's region planes in its camera frame: (M, 3) unit
        normals towards the camera, (M, 3) centres, metres, (M,) fit RMS, metres.
    vertical : (up_world (3,), up_cam (3,), height) when the camera's vertical is known: the
        model's up (world), the same direction in the camera frame, and the camera centre's
        height ``up_world · C`` (metres) to assume where the regions leave it open.
    count : the number of poses returned.

    Returns
    -------
    Up to `count` (R_cam_world (3, 3), t_cam_world (3,), regions explained), distinct, with
    at least two regions explained, ordered by regions explained then residual.
    """
    M = normal_cam.shape[0]
    if M == 0:
        return []
    keep = np.argsort(rms_m, kind="stable")[:MAX_REGIONS]
    n_c, c_c, rms = normal_cam[keep], centre_cam[keep], rms_m[keep]
    Rs = _rotation_hypotheses(normals, n_c, vertical)
    if Rs.shape[0] == 0:
        return []
    if vertical is not None:
        tilt = np.einsum("i,qij,j->q", vertical[1], Rs, vertical[0])
        Rs = Rs[tilt > math.cos(math.radians(VERTICAL_TOL_DEG))]
    cos_tol = math.cos(math.radians(NORMAL_TOL_DEG))
    agree = np.einsum("mi,qij,pj->qmp", n_c, Rs, normals) > cos_tol  # (Q, M, P)
    votes = agree.any(axis=2).sum(axis=1)
    order = np.lexsort((np.arange(votes.size), -votes))
    order = order[votes[order] >= 2]
    picks = _distinct(order, Rs, MAX_ROTATIONS)
    tol_m = np.maximum(POS_TOL_REL * size, 3.0 * rms)
    margin = BOX_MARGIN_REL * size
    poses: list[tuple[int, float, FloatArray, FloatArray]] = []
    for q in picks:
        R = _refined(Rs[q], n_c, normals, agree[q], vertical)
        on = np.einsum("mi,ij,pj->mp", n_c, R, normals) > cos_tol
        ri, pj = np.nonzero(on)  # candidate rows: region ri on part pj
        if ri.size < 2:
            continue
        a = normals[pj] @ R.T  # (L, 3) the part normals in the camera frame
        b = np.einsum("li,li->l", a, c_c[ri]) - offsets[pj]
        ts = _translations(a, b, ri, R, vertical)
        if ts.shape[0] == 0:
            continue
        explained, resid = _explained(R, ts, normals, offsets, boxes, c_c, on, tol_m, margin)
        best = np.lexsort((resid, -explained))[: 2 * count]
        for k in best:
            if explained[k] >= 2:
                poses.append((int(explained[k]), float(resid[k]), R, ts[k]))
    poses.sort(key=lambda p: (-p[0], p[1]))
    out: list[tuple[FloatArray, FloatArray, int]] = []
    for n, _, R, t in poses:
        C = -R.T @ t
        if any(
            np.linalg.norm(C + R2.T @ t2) < POS_TOL_REL * size
            and (np.trace(R @ R2.T) - 1.0) / 2.0 > math.cos(math.radians(ROTATION_SEP_DEG))
            for R2, t2, _ in out
        ):
            continue
        out.append((R, t, n))
        if len(out) == count:
            break
    return out


def _refined(
    R: FloatArray,
    n_c: FloatArray,
    normals: FloatArray,
    agree: npt.NDArray[np.bool_],
    vertical: tuple[FloatArray, FloatArray, float] | None,
) -> FloatArray:
    """The rotation fitted to every region that agrees with a part at ``R`` (each paired with
    the part it agrees with best) and the vertical: less off than the two pairs it came from."""
    cos = np.where(agree, np.einsum("mi,ij,pj->mp", n_c, R, normals), -np.inf)
    seen = np.flatnonzero(agree.any(axis=1))
    a = [n_c[seen]]
    b = [normals[np.argmax(cos[seen], axis=1)]]
    if vertical is not None:
        a.append(vertical[1][None])
        b.append(vertical[0][None])
    A, B = np.concatenate(a), np.concatenate(b)
    if np.linalg.matrix_rank(A, tol=math.sin(math.radians(MIN_SPREAD_DEG))) < 2:
        return R
    out: FloatArray = _rotations(A[None], B[None])[0]
    return out


def part_boxes(polygons: tuple[FloatArray, ...]) -> FloatArray:
    """(P, 2, 3) each polygon's bounding box (min, max), metres."""
    return np.stack([np.stack([p.min(axis=0), p.max(axis=0)]) for p in polygons])


def regions_explained(
    normals: FloatArray,
    offsets: FloatArray,
    boxes: FloatArray,
    size: float,
    R_cam_world: FloatArray,
    t_cam_world: FloatArray,
    normal_cam: FloatArray,
    centre_cam: FloatArray,
    rms_m: FloatArray,
) -> int:
    """How many of the view's regions a pose puts on a part of the model.

    A region is on a part when its normal, carried into the world, is within
    `NORMAL_TOL_DEG` of the part's, its centre within `POS_TOL_REL` of the model's size (or
    3 fit RMS) of the part's plane and inside its bounding box grown by `BOX_MARGIN_REL`, and
    the part faces the camera. Arguments as `plane_poses`; the pose is ``x_cam = R x + t``.
    """
    if normal_cam.shape[0] == 0:
        return 0
    cos_tol = math.cos(math.radians(NORMAL_TOL_DEG))
    on = np.einsum("mi,ij,pj->mp", normal_cam, R_cam_world, normals) > cos_tol
    tol_m = np.maximum(POS_TOL_REL * size, 3.0 * rms_m)
    count, _ = _explained(
        R_cam_world,
        t_cam_world[None],
        normals,
        offsets,
        boxes,
        centre_cam,
        on,
        tol_m,
        BOX_MARGIN_REL * size,
    )
    return int(count[0])


def _rotation_hypotheses(
    normals: FloatArray,
    n_c: FloatArray,
    vertical: tuple[FloatArray, FloatArray, float] | None,
) -> FloatArray:
    """(Q, 3, 3) rotations from region pairs matched to part pairs meeting at the same angle,
    and (with `vertical`) from single regions matched to parts with the vertical."""
    P = normals.shape[0]
    ang_r = _angle(n_c, n_c)  # (M, M)
    ang_p = _angle(normals, normals)  # (P, P)
    i, k = np.nonzero(np.triu((ang_r > MIN_SPREAD_DEG) & (ang_r < 180.0 - MIN_SPREAD_DEG), 1))
    pairs_a: list[FloatArray] = []
    pairs_b: list[FloatArray] = []
    if i.size:
        j, m = np.nonzero(~np.eye(P, dtype=bool))
        fit = np.abs(ang_r[i, k][:, None] - ang_p[j, m][None, :]) < NORMAL_TOL_DEG
        s, u = np.nonzero(fit)
        pairs_a.append(np.stack([n_c[i[s]], n_c[k[s]]], axis=1))
        pairs_b.append(np.stack([normals[j[u]], normals[m[u]]], axis=1))
    if vertical is not None:
        up_w, up_c, _ = vertical
        ar = _angle(n_c, up_c[None])[:, 0]  # (M,)
        ap = _angle(normals, up_w[None])[:, 0]  # (P,)
        good = (ar > MIN_SPREAD_DEG) & (ar < 180.0 - MIN_SPREAD_DEG)
        fit = good[:, None] & (np.abs(ar[:, None] - ap[None, :]) < NORMAL_TOL_DEG)
        s, u = np.nonzero(fit)
        pairs_a.append(np.stack([n_c[s], np.broadcast_to(up_c, (s.size, 3))], axis=1))
        pairs_b.append(np.stack([normals[u], np.broadcast_to(up_w, (u.size, 3))], axis=1))
    if not pairs_a:
        return np.zeros((0, 3, 3))
    return _rotations(np.concatenate(pairs_a), np.concatenate(pairs_b))


def _translations(
    a: FloatArray,
    b: FloatArray,
    region: IntArray,
    R: FloatArray,
    vertical: tuple[FloatArray, FloatArray, float] | None,
) -> FloatArray:
    """(H, 3) translations from triples of rows ``a·t = b`` of distinct regions whose normals
    span space, and (with `vertical`) from pairs plus the camera-height row."""
    L = a.shape[0]
    out: list[FloatArray] = []
    # triples i < j < k of rows on three different regions (L is a few dozen rows)
    i, j, k = (v.ravel() for v in np.meshgrid(*(np.arange(L),) * 3, indexing="ij"))
    sel = (i < j) & (j < k)
    i, j, k = i[sel], j[sel], k[sel]
    sel = (region[i] != region[j]) & (region[j] != region[k]) & (region[i] != region[k])
    i, j, k = i[sel][:MAX_TRIPLES], j[sel][:MAX_TRIPLES], k[sel][:MAX_TRIPLES]
    if i.size:
        A = np.stack([a[i], a[j], a[k]], axis=1)
        det = np.linalg.det(A)
        ok = np.abs(det) >= MIN_DET
        if np.any(ok):
            rhs = np.stack([b[i], b[j], b[k]], axis=1)[ok]
            out.append(np.linalg.solve(A[ok], rhs[..., None])[..., 0])
    if vertical is not None:
        up_w, _, height = vertical
        # height = up_w · C with C = -Rᵀ t: (-R up_w) · t = height
        h_row = -(R @ up_w)
        x, y = np.triu_indices(L, 1)
        sel = region[x] != region[y]
        x, y = x[sel], y[sel]
        if x.size:
            A = np.stack([a[x], a[y], np.broadcast_to(h_row, (x.size, 3))], axis=1)
            det = np.linalg.det(A)
            ok = np.abs(det) >= MIN_DET
            if np.any(ok):
                rhs = np.stack([b[x], b[y], np.full(x.size, height)], axis=1)[ok]
                out.append(np.linalg.solve(A[ok], rhs[..., None])[..., 0])
    return np.concatenate(out) if out else np.zeros((0, 3))


def _explained(
    R: FloatArray,
    ts: FloatArray,
    normals: FloatArray,
    offsets: FloatArray,
    boxes: FloatArray,
    c_c: FloatArray,
    agree: npt.NDArray[np.bool_],
    tol_m: FloatArray,
    margin: float,
) -> tuple[IntArray, FloatArray]:
    """For H translations (H, 3): the number of regions each puts on a part (facing the
    camera, normals agreeing) and the sum of their squared distances in tolerances."""
    X = np.einsum("ji,hmj->hmi", R, c_c[None] - ts[:, None, :])  # (H, M, 3) world centres
    C = -ts @ R  # (H, 3) camera centres: -Rᵀ t
    dist = np.abs(X @ normals.T - offsets)  # (H, M, P)
    lo, hi = boxes[:, 0] - margin, boxes[:, 1] + margin
    outside = np.maximum(lo[None, None] - X[:, :, None], 0.0) + np.maximum(
        X[:, :, None] - hi[None, None], 0.0
    )
    inside = np.all(outside <= 0.0, axis=3)  # (H, M, P)
    facing = (C @ normals.T - offsets)[:, None, :] > 0.0  # (H, 1, P)
    r = dist / tol_m[None, :, None]
    ok = agree[None] & inside & facing & (r <= 1.0)
    best = np.where(ok, r, np.inf).min(axis=2)  # (H, M)
    hit = np.isfinite(best)
    count: IntArray = hit.sum(axis=1).astype(np.intp)
    resid: FloatArray = np.where(hit, best**2, 1.0).sum(axis=1)
    return count, resid
