"""Checks (b), (f) and (g) in one view: the regions inside the model's projection lie on its faces,
no large surface joined to the model is left out, and the surfaces near it are mostly its own."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.observe import FIT_CORRELATED_PX, fit_sigma_rad
from aida_kb.interpret.verdict.edges import edge_cover
from aida_kb.interpret.verdict.geometry import (
    FloatArray,
    densified,
    inside_polygon,
    model_faces,
    model_size,
    outline_points,
)
from aida_kb.interpret.verdict.outcome import ViewCheck
from aida_kb.interpret.verdict.tolerances import (
    ADJOINING_MIN_SHARE,
    ADJOINING_SPAN,
    DEPTH_TOLERANCE,
    DEPTH_TOLERANCE_MIN_M,
    MIN_WEIGHT_SHARE,
    NEAR_MARGIN,
    NORMAL_TOLERANCE_DEG,
    OUTLINE_INSIDE_MIN,
    OUTLINE_ON_MIN,
    PLANE_INLIER_SHARE,
    REGION_NORMAL_SIGMAS,
    STANDING_OUT_MAX,
)
from aida_kb.interpret.verify import TILT_FIT_SIGMA_FACTOR
from aida_kb.io.evidence import Region, ViewEvidence
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel


def check_view(
    view: ViewEvidence,
    model: ReconstructedModel,
    image: npt.NDArray[np.uint8] | None = None,
    occluders: Sequence[ModelPart] = (),
) -> ViewCheck | None:
    """Check (b) for one view at the model's camera of that view (None: no such camera);
    image: its left image, for the edges' steps; occluders: the faces of the scene's other
    objects, which hide the model's edges or make them flush (`edges.edge_coverage`)."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    regions = [r for r in view.regions if r.w_c > 0 and r.depth_pixel_count > 0]
    if camera is None or not regions:
        return None
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    C = -R.T @ t
    centres = np.array([r.c_init for r in regions], dtype=np.float64)
    normals = np.array([r.n_init for r in regions], dtype=np.float64)
    if view.frame == "camera":  # this view's own left camera -> world
        centres = (centres - t) @ R
        normals = normals @ R
    weights = np.array([r.w_c for r in regions], dtype=np.float64)
    keep = weights >= MIN_WEIGHT_SHARE * weights.sum()
    rays = centres - C  # (M, 3); the region's centre at parameter 1
    dist = np.linalg.norm(rays, axis=1)
    tol = np.maximum(DEPTH_TOLERANCE * dist, DEPTH_TOLERANCE_MIN_M)
    cos_tol = math.cos(math.radians(NORMAL_TOLERANCE_DEG))
    cos_on = normal_tolerance_cos(regions)  # (M,): lies on a face within its own fit
    m = len(regions)
    nearest = np.full(m, np.inf)  # ray parameter of the first model face the ray meets
    nearest_cos = np.zeros(m)  # |cos| between the region's normal and that face's
    faces = model_faces(model)
    rays_px = _OutlineRays(view, regions, camera)
    on_by_role: dict[str, npt.NDArray[np.bool_]] = {}
    for role, n, d, poly in faces:
        # (1) the region lies on this face: its centre, or (below) most of its outline
        cand = (np.abs(centres @ n - d) <= tol) & (np.abs(normals @ n) >= cos_on)
        if cand.any():
            on = np.zeros(m, bool)
            on[cand] = inside_polygon(centres[cand], poly, n)
            on_by_role[role] = on
            rays_px.meet(cand, role, n, d, poly)
        # (2) where the ray through the region's centre meets this face
        denom = rays @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (d - C @ n) / denom
        hit_ok = np.isfinite(s) & (s > 0)
        if hit_ok.any():
            idx = np.nonzero(hit_ok)[0]
            pts = C + s[idx, None] * rays[idx]
            hit = np.zeros(m, bool)
            hit[idx] = inside_polygon(pts, poly, n)
            closer = hit & (s < nearest)
            nearest[closer] = s[closer]
            nearest_cos[closer] = np.abs(normals[closer] @ n)
    explained = np.zeros(m, bool)
    for on in on_by_role.values():
        explained |= on
    for k, role in rays_px.lying_on(~explained).items():
        on_by_role[role][k] = explained[k] = True
    on_face: dict[str, float] = {}
    turned_on: dict[str, float] = {}
    for role, on in on_by_role.items():
        on_face[role] = float(weights[on & keep].sum())
        if on_face[role] > 0:
            n = next(f[1] for f in faces if f[0] == role)
            cos = np.clip(np.abs(normals[on & keep] @ n), 0.0, 1.0)
            turned_on[role] = float(np.degrees(np.arccos(cos)) @ weights[on & keep] / on_face[role])
    # a region lies inside the projection when the ray through its centre meets the model —
    # except one continuing a face's plane beyond the face (the ground beyond the floors)
    # whose outline lies mostly outside the projection: a street's ground region, its centre
    # seen behind one house, lies mostly beside the houses
    share = rays_px.share_in(faces)
    beside = ~explained & (share < OUTLINE_INSIDE_MIN)
    for i in np.nonzero(beside)[0]:
        beside[i] = _continues_face(normals[i], centres[i], float(tol[i]), faces, float(cos_on[i]))
    inside = keep & np.isfinite(nearest) & ~beside
    gap = (nearest - 1.0) * dist  # > 0: the model's surface lies beyond the region
    size = model_size(model)
    # in front of the model: something standing before it (neutral) unless it is close to
    # the surface and parallel to it (a part standing out that the model lacks: an oriel)
    before = inside & ~explained & (gap > tol)
    standing_out = before & (gap < STANDING_OUT_MAX * size) & (nearest_cos >= cos_tol)
    in_front = before & ~standing_out
    counted = inside & ~in_front
    through = counted & ~explained & (gap < -tol)
    # turned on the surface: only a region whose plane fit tells its orientation
    fitted = np.array([r.inlier_count >= PLANE_INLIER_SHARE * r.pixel_count for r in regions])
    turned = counted & ~explained & ~through & ~standing_out & fitted
    total = float(weights[counted].sum())
    contradicting = []
    for i in np.nonzero(through | turned | standing_out)[0]:
        if through[i]:
            why = f"seen {-gap[i]:.2f} m beyond the model's surface"
        elif standing_out[i]:
            why = f"standing {gap[i]:.2f} m out of the model's surface, parallel to it"
        else:
            angle = math.degrees(math.acos(min(1.0, nearest_cos[i])))
            why = f"on the model's surface at {angle:.0f} deg to its face"
        contradicting.append((regions[i].id, float(weights[i]) / max(total, 1e-12), why))
    contradicting.sort(key=lambda c: -c[1])
    return ViewCheck(
        view.id,
        total,
        float(weights[counted & explained].sum()),
        contradicting,
        edge_cover(view, model, image=image, occluders=occluders),
        on_face,
        tuple(int(regions[i].id) for i in np.nonzero(counted & explained)[0]),
        tuple(int(regions[i].id) for i in np.nonzero(~counted)[0]),
        float(weights[standing_out & keep].sum()),
        turned_on,
    )


class _OutlineRays:
    """The rays through the view's model camera of its regions' outer outlines, a point every
    OUTLINE_STEP_PX (world frame), and where they meet the model's faces."""

    def __init__(self, view: ViewEvidence, regions: list[Region], camera: ModelCamera) -> None:
        index = {r.id: i for i, r in enumerate(regions)}
        pixels = [np.zeros((0, 2))]
        owner = [np.zeros(0, np.int64)]
        for c in view.contours:
            if c.hole or c.region not in index:
                continue
            px = densified(np.asarray(c.points, dtype=np.float64))
            pixels.append(px)
            owner.append(np.full(len(px), index[c.region], np.int64))
        px = np.vstack(pixels)
        self.owner = np.concatenate(owner)  # (P,): the index of the region each point bounds
        self.regions = len(regions)
        K = np.asarray(camera.K, dtype=np.float64)
        R = np.asarray(camera.R, dtype=np.float64)
        t = np.asarray(camera.t, dtype=np.float64)
        self.centre = -R.T @ t  # (3,)
        self.rays = np.linalg.solve(K, np.vstack([px.T, np.ones(len(px))])).T @ R  # (P, 3)
        self.on: dict[str, npt.NDArray[np.bool_]] = {}  # role -> (P,) the point lies in it

    def hits(
        self, n: FloatArray, d: float, poly: FloatArray, wanted: npt.NDArray[np.bool_]
    ) -> npt.NDArray[np.bool_]:
        """(P,): the `wanted` points (P,) whose rays meet the face (unit normal n (3,),
        offset d, polygon (N, 3)) in front of the camera, inside it."""
        denom = self.rays @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (d - self.centre @ n) / denom
        ok = np.isfinite(s) & (s > 0) & wanted
        out = np.zeros(len(self.rays), bool)
        if ok.any():
            idx = np.nonzero(ok)[0]
            out[idx] = inside_polygon(self.centre + s[idx, None] * self.rays[idx], poly, n)
        return out

    def meet(
        self, regions: npt.NDArray[np.bool_], role: str, n: FloatArray, d: float, poly: FloatArray
    ) -> None:
        """Note which outline points of the `regions` (M,) lying in a face's plane meet it."""
        self.on[role] = self.hits(n, d, poly, regions[self.owner])

    def lying_on(self, regions: npt.NDArray[np.bool_]) -> dict[int, str]:
        """Of the `regions` (M,), those (index -> the face's role holding most of it) with at
        least OUTLINE_ON_MIN of their outline's points in faces whose planes they lie in
        (`meet`): a region joining the fronts of two oriels, its centre between them on the
        wall behind, lies on them (dev 61413 view 01, 61314 view 00: "standing 1.35 m out
        of the model's surface" of the true models)."""
        out: dict[int, str] = {}
        if not self.on or not regions.any():
            return out
        roles = list(self.on)
        on = np.vstack([self.on[r] for r in roles])  # (F, P)
        counts = np.bincount(self.owner, minlength=self.regions).astype(np.float64)
        held = np.vstack([np.bincount(self.owner, o, minlength=self.regions) for o in on])
        inside = np.bincount(self.owner, on.any(axis=0), minlength=self.regions)
        for i in np.nonzero(regions & (inside >= OUTLINE_ON_MIN * np.maximum(counts, 1)))[0]:
            if counts[i] > 0:
                out[int(i)] = roles[int(np.argmax(held[:, i]))]
        return out

    def share_in(self, faces: list[tuple[str, FloatArray, float, FloatArray]]) -> FloatArray:
        """Per region (M,): the share of its outline's points whose rays meet one of the
        `faces` (`model_faces`); NaN where it has no outline."""
        hit = np.zeros(len(self.rays), bool)
        for _, n, d, poly in faces:
            hit |= self.hits(n, d, poly, ~hit)
        counts = np.bincount(self.owner, minlength=self.regions).astype(np.float64)
        hits = np.bincount(self.owner, hit.astype(np.float64), minlength=self.regions)
        out = np.full(self.regions, np.nan)
        out[counts > 0] = hits[counts > 0] / counts[counts > 0]
        return out


def adjoining(view: ViewEvidence, model: ReconstructedModel, check: ViewCheck) -> list[str]:
    """Check (f) in one view (reasons): a region outside the model's projection or in front
    of it (which (b) leaves alone: it may be something standing before the object) whose outline
    meets a model face in 3-D (on its plane within OUTLINE_TOLERANCE_PX, inside the face)
    along at least ADJOINING_SPAN of the model's size, and which covers at least
    ADJOINING_MIN_SHARE of the view's region pixels, is a surface joined to the object
    that the model does not have (a hip roof's slope above walls taken for a flat roof's).
    A region lying in a model face's plane continues that face (the ground the floor) and
    is not counted; nor is anything in front (its outline is nearer than the faces), nor a
    region (b) takes for noise (lighter than MIN_WEIGHT_SHARE of the view's weight): its
    plane fit kept next to no depth, so its outline has no place in 3-D to meet the model
    at (dev 61334: a dark roof slope, 56 of its 8,538 pixels with depth and no inlier, its
    fitted plane 72 degrees off the roof it shows, met the right model's roof along 10.5 m)."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    total = sum(r.pixel_count for r in view.regions)
    weight = sum(r.w_c for r in view.regions if r.w_c > 0 and r.depth_pixel_count > 0)
    big = [
        r
        for r in view.regions
        if r.id in set(check.free_ids)
        and r.pixel_count >= ADJOINING_MIN_SHARE * total
        and r.w_c >= MIN_WEIGHT_SHARE * weight
    ]
    if camera is None or not big:
        return []
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    faces = model_faces(model)
    size = model_size(model)
    reasons = []
    for r in big:
        points, tol = outline_points(view, (r.id,), model)
        if len(points) < 2:
            continue
        if _continues_face(*_region_plane(view, r, R, t), faces, _cos_of(r)):
            continue  # it continues a face's plane
        best = (0.0, "")
        for role, n, d, poly in faces:
            near = np.abs(points @ n - d) <= tol
            if np.count_nonzero(near) < 2:
                continue
            touching = points[near][inside_polygon(points[near], poly, n)]
            if len(touching) >= 2:
                span = float(np.linalg.norm(touching.max(axis=0) - touching.min(axis=0)))
                best = max(best, (span, role))
        if best[0] >= ADJOINING_SPAN * size:
            reasons.append(
                f"view {view.id}: region {view.id}/{r.id} ({100 * r.pixel_count / total:.0f}% "
                f"of its pixels) meets {best[1]} along {best[0]:.1f} m, but the model does "
                "not explain it (a part the model lacks)"
            )
    return reasons


def _region_plane(
    view: ViewEvidence, region: Region, R: FloatArray, t: FloatArray
) -> tuple[FloatArray, FloatArray, float]:
    """A region's fitted plane in the world frame: its unit normal (3,), its centre (3,),
    metres, and how far off a face's plane it may lie and still be on it, metres
    (DEPTH_TOLERANCE of its distance from the view's camera, R, t: world -> camera, at
    least DEPTH_TOLERANCE_MIN_M)."""
    normal = np.asarray(region.n_init, dtype=np.float64)
    centre = np.asarray(region.c_init, dtype=np.float64)
    if view.frame == "camera":  # this view's own left camera -> world
        normal, centre = normal @ R, (centre - t) @ R
    dist = float(np.linalg.norm(centre + R.T @ t))
    return normal, centre, max(DEPTH_TOLERANCE * dist, DEPTH_TOLERANCE_MIN_M)


def normal_tolerance_cos(regions: list[Region]) -> FloatArray:
    """Cosine of the angle within which each region's normal lies on a face's, (M,): the
    wider of NORMAL_TOLERANCE_DEG and REGION_NORMAL_SIGMAS of its plane fit's sigma
    (`observe.fit_sigma_rad` of its inliers over its area, times verify's
    TILT_FIT_SIGMA_FACTOR). A region with little depth (a dark roof: 42 of its 17,495 pixels
    with a disparity, no inlier, sigma 19 degrees) does not tell its orientation: its fit,
    11 degrees off its true face, is no surface the model lacks."""
    if not regions:
        return np.zeros(0)
    rms = np.array([r.rms_m for r in regions], dtype=np.float64)
    samples = np.maximum(np.array([r.inlier_count for r in regions]) / FIT_CORRELATED_PX, 1.0)
    area = np.array([r.area_m2 for r in regions], dtype=np.float64)
    sigma = TILT_FIT_SIGMA_FACTOR * fit_sigma_rad(rms, samples, area)  # inf: unknown fit
    angle = np.maximum(math.radians(NORMAL_TOLERANCE_DEG), REGION_NORMAL_SIGMAS * sigma)
    return np.cos(np.minimum(angle, 0.5 * math.pi))


def _cos_of(region: Region) -> float:
    """`normal_tolerance_cos` of one region."""
    return float(normal_tolerance_cos([region])[0])


def _continues_face(
    normal: FloatArray,
    centre: FloatArray,
    tol: float,
    faces: list[tuple[str, FloatArray, float, FloatArray]],
    cos_tol: float,
) -> bool:
    """A plane (unit normal (3,), a point (3,), world frame) lies in a face's plane within
    the angle of cosine `cos_tol` (`normal_tolerance_cos`) and `tol` metres (the ground
    continues the floor)."""
    return any(
        abs(float(normal @ n)) >= cos_tol and abs(float(centre @ n) - d) <= tol
        for _, n, d, _ in faces
    )


def unexplained_near(
    view: ViewEvidence, model: ReconstructedModel, check: ViewCheck
) -> tuple[float, list[int]]:
    """Check (g) in one view: the share of the weight of the regions on the model and near
    it that the model explains, and the ids of the near regions it leaves (heaviest first).
    Near: a region outside the model's projection or in front of it (which (b) leaves
    alone), at least MIN_WEIGHT_SHARE of the view's weight, whose centre lies within
    NEAR_MARGIN of the model's size of its bounding box, and which continues no face's
    plane. An L-shaped house taken for its body leaves the wing's walls there."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    if camera is None:
        return 1.0, []
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    corners = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts])
    grow = NEAR_MARGIN * model_size(model)
    low, high = corners.min(axis=0) - grow, corners.max(axis=0) + grow
    faces = model_faces(model)
    total = sum(r.w_c for r in view.regions)
    free = set(check.free_ids)
    near: list[tuple[float, int]] = []
    for r in view.regions:
        if r.id not in free or r.depth_pixel_count == 0 or r.w_c < MIN_WEIGHT_SHARE * total:
            continue
        normal, centre, tol = _region_plane(view, r, R, t)
        if _continues_face(normal, centre, tol, faces, _cos_of(r)):
            continue
        if bool(np.all(centre >= low)) and bool(np.all(centre <= high)):
            near.append((float(r.w_c), int(r.id)))
    left = sum(w for w, _ in near)
    explained = check.explained_weight
    share = explained / (explained + left) if explained + left > 0 else 1.0
    return share, [i for _, i in sorted(near, reverse=True)]
