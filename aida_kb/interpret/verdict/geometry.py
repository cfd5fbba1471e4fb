"""The model's geometry as the checks read it: faces, size, points inside a face, projection into a
model camera, and region outlines on their fitted planes."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.verdict.tolerances import (
    ENCLOSED_TOLERANCE,
    INSIDE_MARGIN,
    OUTLINE_STEP_PX,
    OUTLINE_TOLERANCE_PX,
)
from aida_kb.io.evidence import ViewEvidence
from aida_kb.io.export import solids
from aida_kb.io.model import ModelCamera, ReconstructedModel

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def model_faces(model: ReconstructedModel) -> list[tuple[str, FloatArray, float, FloatArray]]:
    """(role, unit normal (3,), offset d, polygon (N, 3)) of every part, world frame."""
    return [
        (p.role, np.asarray(p.normal, dtype=np.float64), float(p.offset_m), np.asarray(p.polygon))
        for p in model.parts
    ]


def model_size(model: ReconstructedModel) -> float:
    """The diagonal of the model's bounding box, metres."""
    pts = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts])
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def enclosed_parts(model: ReconstructedModel) -> frozenset[str]:
    """The roles of the faces that lie inside another solid of the model: no surface of it.

    A solid (`aida_kb.io.export.solids`: faces welded along shared edges) is taken as the
    intersection of its faces' half-spaces ``n·x <= d`` when it is convex (its own corners
    satisfy them to ENCLOSED_TOLERANCE of the model's size); a face of another solid whose
    corners all satisfy them too lies within it (a wing's end the knowledge reaches into the
    body up to the ridge). Non-convex solids enclose nothing here.
    """
    if not model.parts:
        return frozenset()
    tol = ENCLOSED_TOLERANCE * model_size(model)
    faces = model_faces(model)
    groups = solids(model)
    out: set[str] = set()
    for group in groups:
        n = np.array([faces[i][1] for i in group]).reshape(-1, 3)
        d = np.array([faces[i][2] for i in group])
        own = np.vstack([faces[i][3] for i in group])
        if len(group) < 4 or np.any(own @ n.T - d > tol):
            continue  # no closed solid, or not convex
        members = set(group)
        for k, (role, _, _, poly) in enumerate(faces):
            if k not in members and len(poly) and np.all(poly @ n.T - d <= tol):
                out.add(role)
    return frozenset(out)


def inside_polygon(points: FloatArray, poly: FloatArray, normal: FloatArray) -> FloatArray:
    """Even-odd test of points (M, 3) on the plane of `poly` (N, 3); the polygon is grown by
    INSIDE_MARGIN of its size about its centre. Returns (M,) bool."""
    centre = poly.mean(axis=0)
    grown = centre + (poly - centre) * (1.0 + INSIDE_MARGIN)
    a = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(a) < 0.1:
        a = np.cross(normal, [0.0, 1.0, 0.0])
    u = a / np.linalg.norm(a)
    v = np.cross(normal, u)
    pu, pv = points @ u, points @ v
    qu, qv = grown @ u, grown @ v
    inside = np.zeros(len(points), bool)
    for i in range(len(qu)):
        au, av, bu, bv = qu[i], qv[i], qu[i - 1], qv[i - 1]
        if av == bv:
            continue
        crosses = (av > pv) != (bv > pv)
        inside ^= crosses & (pu < au + (pv - av) * ((bu - au) / (bv - av)))
    return inside


def project(camera: ModelCamera, points: FloatArray) -> FloatArray:
    """Pixels (N, 2) of world points (N, 3) in a model camera (pinhole; distortion left out)."""
    x = points @ np.asarray(camera.R, dtype=np.float64).T + np.asarray(camera.t, dtype=np.float64)
    x = x @ np.asarray(camera.K, dtype=np.float64).T
    out: FloatArray = x[:, :2] / x[:, 2:3]
    return out


def densified(polygon_px: FloatArray) -> FloatArray:
    """A closed polygon (N, 2) sampled every OUTLINE_STEP_PX along its sides (M, 2)."""
    nxt = np.roll(polygon_px, -1, axis=0)
    steps = np.maximum(1, (np.linalg.norm(nxt - polygon_px, axis=1) // OUTLINE_STEP_PX)).astype(int)
    owner = np.repeat(np.arange(len(polygon_px)), steps)
    frac = np.arange(int(steps.sum())) - np.repeat(np.cumsum(steps) - steps, steps)
    frac = frac / steps[owner]
    out: FloatArray = polygon_px[owner] + (nxt[owner] - polygon_px[owner]) * frac[:, None]
    return out


def outline_points(
    view: ViewEvidence, region_ids: tuple[int, ...], model: ReconstructedModel
) -> tuple[FloatArray, FloatArray]:
    """The outlines of the view's regions `region_ids` on their fitted planes: points (K, 3),
    metres, world frame, and each one's tolerance (K,), metres: OUTLINE_TOLERANCE_PX at its
    distance from the camera (outlines of segmented regions are good to a few pixels; lens
    distortion is left out, as it moves them by less). Empty without the view's camera."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    wanted = set(region_ids)
    planes = {r.id: r for r in view.regions if r.id in wanted}
    contours = [c for c in view.contours if c.region in planes and not c.hole]
    if camera is None or not contours:
        return np.zeros((0, 3)), np.zeros(0)
    K = np.asarray(view.left.K, dtype=np.float64)
    R_cam_frame = np.asarray(view.left.R, dtype=np.float64)
    t_cam_frame = np.asarray(view.left.t, dtype=np.float64)
    out, tol = [], []
    for c in contours:
        r = planes[c.region]
        px = densified(np.asarray(c.points, dtype=np.float64))
        rays = np.linalg.solve(K, np.vstack([px.T, np.ones(len(px))])).T  # (N, 3) camera frame
        n_cam = R_cam_frame @ np.asarray(r.n_init, dtype=np.float64)
        d_cam = float(r.d_init) + float(n_cam @ t_cam_frame)
        denom = rays @ n_cam
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = d_cam / denom
        ok = np.isfinite(depth) & (depth > 0)  # on the plane in front of the camera
        x_cam = rays[ok] * depth[ok, None]
        x_frame = (x_cam - t_cam_frame) @ R_cam_frame
        if view.frame == "camera":  # this view's own left camera -> world, as in check_view
            R = np.asarray(camera.R, dtype=np.float64)
            t = np.asarray(camera.t, dtype=np.float64)
            x_frame = (x_frame - t) @ R
        out.append(x_frame)
        tol.append(OUTLINE_TOLERANCE_PX * x_cam[:, 2] / float(K[0, 0]))
    return np.vstack(out), np.concatenate(tol)
