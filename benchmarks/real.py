"""Benchmark on real photographs (not a test): the shared Strecha scenes and Middlebury Motorcycle.

Scenes: every scene directory under ``/work/shared/real`` (or the folder given as the first
argument), run as a user would: ``scene_evidence`` without labels (segmentation by
orientation, the disparity range found from feature matches), then the interpretation
against ``kb/buildings.kb`` (goal House). Nothing here is tuned on these scenes: the vision
constants were chosen on synthetic scenes and physical reasoning (see each module).

Per scene (the ground truth only measures; the tool never reads it):
- ``vertical_err_deg``: angle between the estimated up (``interpret.observe.estimate_up`` on
  the evidence, with the line segments) and the true up from ``cameras_world.json`` (its world
  +z points down);
- ``main_wall_tilt_err_deg``: the main wall is the heaviest region (summed certainty) whose
  normal lies within 30 deg of horizontal under the estimated up; its normal's angle from
  horizontal under the TRUE up (0 for a vertical wall);
- ``density``: fraction of the left image with a depth;
- ``wall_regions``: regions coplanar with the main wall (normals within 5 deg, centroids
  within 0.5 m of its plane), and ``wall_largest_share``: the main wall region's share of their
  pixels (1.0 = one region covers the wall); where the scene has ``reference_labels.png``
  (label 1 = main wall) or a hand-drawn outline in ``benchmarks/data/real_wall_outlines.json``
  (Herz-Jesu: drawn for this benchmark in the castle labels' convention — the facade's
  outline with its openings, portals and relief, without sky, roof, steps and ground;
  ``wall_labels`` says which), ``wall_label_coverage``: the share of that label covered by
  the main wall region, ``wall_surface_coverage`` (outlines only): the same without the deep
  openings drawn inside the outline (a portal's door and jambs lie metres behind the wall:
  other surfaces, which a segmentation by planes rightly keeps apart),
  ``wall_visible_coverage``: the coverage of the wall's visible area — the surface where
  openings are drawn, else the label (``done_when_wall_one_region_0p8_labelled``: at least
  0.8 on every labelled scene), ``wall_region_outside_label``: the share of
  that region outside the label (what it claims that is not the main wall),
  ``wall_label_share_in_both_images``: the share of the label whose point on the main wall's
  plane the right camera sees too (stereo can measure nothing elsewhere), and
  ``wall_label_coverage_in_both_images``: the coverage of that part;
- ``lines``: the evidence's line segments by kind (structural, texture, unknown); with
  reference labels, ``label_boundary_lines`` (the kinds of the lines between two labels:
  structural or unknown is right, texture wrong) and ``wall_interior_lines`` (the kinds of the
  lines inside the main wall's label: mostly texture);
- ``disparity_range``, ``rectified`` (size, zoom, share of the left image kept), the
  ``warnings`` of the vision front end;
- ``outcome``: the verdict (`aida_kb.interpret.verdict.judge`: verified, doubtful or
  nothing) and ``verdict``: the interpretation's message with the verdict's reasons;
  ``evidence_s``, ``interpret_s``: wall times;
- ``front_part``: the model part bound to the main wall region, and how close it lies to the
  wall's stereo points (every 3-D point of the depth map within WALL_RELIEF_M of the main
  wall region's plane: the wall with its relief; distances taken along the wall, in its
  plane): ``front_vertex_to_wall_points_max_m`` over its vertices stereo could measure
  (inside both images by the matcher's half window: ``front_vertices_measurable``; each
  vertex's distance in ``front_vertex_to_wall_points_m``), ``front_vertex_to_wall_plane_max_m``
  over all (`_front_on_wall`); ``front_vertex_to_plane_band_points_max_m``: the distance as
  first measured (3-D, to the points within FRONT_ON_WALL_M of the plane: a vertex at the
  wall's foot above a plinth standing out 0.4 m counted 0.43 m);
  ``front_outline_to_wall_points_max_m``: the same along the outline's edges (where stereo
  could measure them and nothing stands before the wall: ``front_outline_measurable_share``),
  information only (the issue
  asks for the vertices); ``done_when_front_on_wall_0p3m``: no VERIFIED object whose front
  has either beyond FRONT_ON_WALL_M (issue 15: "no verified object whose front is not the
  real main wall"), ``found_front_on_wall_0p3m``: the same for every object found, verified
  or doubtful (stricter); ``done_when_not_nothing``: no scene ends with nothing found.

Motorcycle (Middlebury 2014, as scikit-image ships it: 741x500, disparity with inf = unknown;
read from the installed package, never downloaded): aida's NCC (window 11, range found from
feature matches) and OpenCV's SGBM with the parameters in ``SGBM_PARAMS`` (3-way, block 5,
P1 = 8·25, P2 = 32·25, uniqueness 10, speckle window 100 / range 2, disp12MaxDiff 1, range
0..numDisparities-1 with numDisparities the smallest multiple of 16 above the true maximum):
density and bad2 of each, and aida's bad2 at SGBM's density (its most certain pixels).
The same for aida's semi-global matcher (`aida_kb.vision.sgm`, its default parameters), whose
parameters were chosen on the top half of the image: its figures are also given per half
(``top``: where they were chosen; ``bottom``: held out), each against SGBM on that half.

``large_photo``: the first labelled scene's pair upsampled 5x (5120x3415, 17.5 megapixels),
run in a child process: it is matched at the working resolution (``WORKING_MAX_PIXELS`` of
aida_kb.io.scene) and its evidence given in the full image; its figures, its time and the
child's peak memory (``peak_rss_mb``). Upsampling adds no detail: the figures show that the
path holds and what it costs, not the accuracy of a real 17-megapixel photo.
``peak_rss_mb``: this process's peak resident memory over the whole run, MiB.

Run: .venv/bin/python benchmarks/real.py [REAL_DIR | --motorcycle | --scenes | --help]   (prints
ONE line of JSON at the end; --motorcycle: only the Motorcycle comparison; --scenes: only the
scenes, without large_photo and Motorcycle)
"""

from __future__ import annotations

import json
import math
import resource
import sys
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stereo import at_density, opencv_disparity

from aida_kb.interpret.observe import estimate_up, slope_deg, view_of
from aida_kb.interpret.run import interpret
from aida_kb.interpret.verdict import NOTHING, VERIFIED, judge, with_verdict
from aida_kb.io.scene import read_labels, read_scene
from aida_kb.kb import compile_path
from aida_kb.vision.disprange import disparity_range
from aida_kb.vision.evaluate import score_disparity
from aida_kb.vision.evidence import VisionParams, original_rays, scene_evidence
from aida_kb.vision.sgm import sgm_disparity
from aida_kb.vision.stereo import ncc_disparity

ROOT = Path(__file__).resolve().parents[1]
REAL = Path("/work/shared/real")
WALL_WINDOW_DEG = 30.0  # a wall candidate's normal within this of horizontal (estimated up)
COPLANAR_DEG = 5.0  # regions of the main wall: normals within this ...
COPLANAR_M = 0.5  # ... and centroids within this of its plane
WALL_COVERAGE_DONE = 0.8  # issue 15: the main wall one region covering 80 % of its area
OUTLINES = ROOT / "benchmarks" / "data" / "real_wall_outlines.json"  # hand-drawn, no labels
OPENING_LABEL = 4  # an opening inside a hand-drawn wall outline (counted as wall, see below)
MOTORCYCLE_WINDOW = 11
SGBM_PARAMS: dict[str, Any] = {
    "blockSize": 5,
    "P1": 8 * 25,
    "P2": 32 * 25,
    "uniquenessRatio": 10,
    "speckleWindowSize": 100,
    "speckleRange": 2,
    "disp12MaxDiff": 1,
    "mode": cv2.STEREO_SGBM_MODE_SGBM_3WAY,
}


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    c = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _seen_by_right(scene: Any, wall: Any) -> np.ndarray:
    """(H, W) bool: left-image pixels whose ray meets the wall's plane at a point the right
    camera also sees (inside its image, in front of it): where stereo can measure the wall."""
    calib = scene.views[0].rig
    rays = original_rays(calib)
    n, c = np.asarray(wall.normal, float), np.asarray(wall.centroid_m, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (n @ c) / (rays @ n)
    pts = rays * t[..., None]
    right = pts @ calib.R.T + calib.T.ravel()
    z = right[..., 2]
    pix = right @ calib.K2.T
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = pix[..., 0] / z, pix[..., 1] / z
    W, H = calib.image_size
    ok: np.ndarray = (t > 0) & (z > 0) & (x >= 0) & (x <= W - 1) & (y >= 0) & (y <= H - 1)
    return ok


LINE_SIDE_PX = 8.0  # a line's sides are looked up this far away on the reference labels


def _line_kinds_against_labels(lines: Any, labels: np.ndarray) -> dict[str, Any]:
    """The lines' kinds against the hand-drawn labels: the kinds of the lines whose two sides
    lie in two different labels (wall / roof / ground: they should be structural or unknown,
    never texture), and of those with both sides on the main wall (label 1; masonry joints and
    decoration should be texture, window frames and relief may be either). Sides sampled
    LINE_SIDE_PX away at a third and two thirds of the line's length, both agreeing."""
    H, W = labels.shape
    boundary: dict[str, int] = {"structural": 0, "texture": 0, "unknown": 0}
    inside = dict(boundary)
    for line in lines:
        p1, p2 = np.array(line.p1), np.array(line.p2)
        t = (p2 - p1) / max(float(np.linalg.norm(p2 - p1)), 1e-9)
        across = np.array([t[1], -t[0]])
        sides = []
        for sign in (1.0, -1.0):
            got = set()
            for f in (1 / 3, 2 / 3):
                x, y = p1 + f * (p2 - p1) + sign * LINE_SIDE_PX * across
                row, col = min(max(round(float(y)), 0), H - 1), min(max(round(float(x)), 0), W - 1)
                got.add(int(labels[row, col]))
            sides.append(got.pop() if len(got) == 1 else -1)
        a, b = sides
        kind = line.kind or "unknown"
        if a > 0 and b > 0 and a != b:
            boundary[kind] += 1
        elif a == b == 1:
            inside[kind] += 1
    return {"label_boundary_lines": boundary, "wall_interior_lines": inside}


def _wall_labels(path: Path, shape: tuple[int, int]) -> tuple[np.ndarray, str] | None:
    """The main wall's reference labels of view 00 (1 = wall) and where they come from:
    the scene's ``reference_labels.png``, else a hand-drawn outline of `OUTLINES` (openings
    inside it labelled `OPENING_LABEL`), rasterised at the image's `shape` (rows, columns);
    None when the scene has neither."""
    labels_file = path / "reference_labels.png"
    if labels_file.is_file():
        return read_labels(labels_file), "reference_labels.png"
    outline = json.loads(OUTLINES.read_text()).get(path.name)
    if outline is None:
        return None
    if tuple(outline["size"]) != (shape[1], shape[0]):
        raise SystemExit(f"{OUTLINES}: {path.name}: drawn on {outline['size']}, image {shape}")
    labels = np.zeros(shape, np.uint8)
    cv2.fillPoly(labels, [np.asarray(outline["wall"], np.int32)], 1)
    openings = [np.asarray(o, np.int32) for o in outline["openings"]]
    holes = np.zeros(shape, np.uint8)
    cv2.fillPoly(holes, openings, 1)
    labels[(labels == 1) & (holes == 1)] = OPENING_LABEL
    return labels.astype(np.int32), f"hand outline ({OUTLINES.relative_to(ROOT)})"


def real_scene(
    path: Path, kb: Any, matcher: str = "ncc", *, both_images: bool = True
) -> dict[str, Any]:
    """Evidence, vertical, main wall and verdict of one real scene directory (both_images:
    also the label's share seen by both cameras, a full-size computation of its own)."""
    scene = read_scene(path, with_truth=False)
    start = time.perf_counter()
    evidence, products = scene_evidence(
        scene,
        views=[scene.views[0].id],
        segmentation="orientation",
        params=VisionParams(matcher="sgm" if matcher == "sgm" else "ncc"),
    )
    t_evidence = time.perf_counter() - start
    prod = products[0]
    view = view_of(evidence)
    camera = view.camera
    regions = list(view.regions.values())
    up = estimate_up(regions, camera, segments_px=view.lines_px.get(camera.view))
    truth = json.loads((path / "cameras_world.json").read_text())
    R_world_cam = np.array(truth["left_world"]["R_cam_to_world"], float)
    up_true = R_world_cam.T @ np.array([0.0, 0.0, -1.0])  # world +z is down; world = camera
    walls = [r for r in regions if abs(slope_deg(r.normal, up) - 90.0) < WALL_WINDOW_DEG]
    labels_file = path / "reference_labels.png"
    out: dict[str, Any] = {
        "vertical_err_deg": round(_angle(up, up_true), 3),
        "density": round(evidence.views[0].disparity_density, 3),
        "regions": len(regions),
    }
    if walls:
        main = max(walls, key=lambda r: r.weight)
        out["main_wall_tilt_err_deg"] = round(abs(90.0 - slope_deg(main.normal, up_true)), 3)
        same = [
            r
            for r in regions
            if _angle(r.normal, main.normal) < COPLANAR_DEG
            and abs(float(main.normal @ (r.centroid_m - main.centroid_m))) < COPLANAR_M
        ]
        out["wall_regions"] = len(same)
        out["wall_largest_share"] = round(main.area_px / sum(r.area_px for r in same), 3)
        reference = _wall_labels(path, prod.regions.shape)
        if reference is not None:
            labels, out["wall_labels"] = reference
            wall = (labels == 1) | (labels == OPENING_LABEL)
            rid = int(main.id.split("/")[1])
            mine = prod.regions == rid
            covered = wall & mine
            out["wall_label_coverage"] = round(float(np.count_nonzero(covered) / wall.sum()), 3)
            out["wall_visible_coverage"] = out["wall_label_coverage"]
            if np.any(labels == OPENING_LABEL):  # the wall's surface alone, openings out
                surface = labels == 1
                out["wall_surface_coverage"] = round(
                    float(np.count_nonzero(surface & mine) / surface.sum()), 3
                )
                out["wall_visible_coverage"] = out["wall_surface_coverage"]
            out["wall_region_outside_label"] = round(
                float(np.count_nonzero(mine & ~wall) / max(1, np.count_nonzero(mine))), 3
            )
            if both_images:
                both = wall & _seen_by_right(scene, main)
                share = float(both.sum() / wall.sum())
                out["wall_label_share_in_both_images"] = round(share, 3)
                out["wall_label_coverage_in_both_images"] = round(
                    float(np.count_nonzero(covered & both) / max(1, both.sum())), 3
                )
    kinds = [line.kind for line in evidence.views[0].lines]
    out["lines"] = {
        "structural": kinds.count("structural"),
        "texture": kinds.count("texture"),
        "unknown": kinds.count(None),
    }
    if labels_file.is_file():
        out |= _line_kinds_against_labels(evidence.views[0].lines, read_labels(labels_file))
    lo, num = prod.disparity_range
    out["disparity_range"] = [lo, lo + num - 1]
    out["rectified"] = prod.rectified
    out["warnings"] = list(prod.warnings)
    start = time.perf_counter()
    result = interpret(kb, evidence, goal="House", source=str(path))
    result = with_verdict(result, judge(kb, result, evidence))
    out["interpret_s"] = round(time.perf_counter() - start, 2)
    out["accepted"] = result.accepted
    out["outcome"] = result.verdict or NOTHING
    if walls:
        out |= _front_on_wall(result, main, prod, evidence, scene.views[0].rig)
    out["verdict"] = result.message
    out["evidence_s"] = round(t_evidence, 2)
    return out


FRONT_ON_WALL_M = 0.3  # issue 15: the found front's vertices within this of the wall's points
# a vertex is measured against the wall's stereo points only where stereo could have measured
# it: inside both images by at least the block matcher's half window (nearer the border no
# window fits, so no point can lie there however right the vertex is)
STEREO_MARGIN_PX = VisionParams().window // 2
# the wall's stereo points are those within this of its plane: a facade's relief — plinth,
# cornice, pilasters, window surrounds — stands out of the wall up to about a metre and is
# the wall (castle courtyard: plinth 0.4 m, cornice 0.45-0.66 m proud of the plastered plane,
# which a 0.3 m band left out: the wall's foot seemed to end 0.43 m from the front's corner)
WALL_RELIEF_M = 1.0


def _in_image(pix_h: np.ndarray, width: int, height: int, margin: float) -> np.ndarray:
    """(N,) bool: homogeneous pixels (N, 3), in front of the camera and at least `margin`
    pixels inside a width x height image."""
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = pix_h[:, 0] / pix_h[:, 2], pix_h[:, 1] / pix_h[:, 2]
    inside: np.ndarray = (
        (pix_h[:, 2] > 0)
        & (x >= margin)
        & (x <= width - 1 - margin)
        & (y >= margin)
        & (y <= height - 1 - margin)
    )
    return inside


def _front_on_wall(result: Any, main: Any, prod: Any, evidence: Any, rig: Any) -> dict[str, Any]:
    """Whether the model's part bound to the main wall region is the real main wall.

    Its closed polygon's vertices that stereo could measure — inside the left and the right
    image by STEREO_MARGIN_PX (``front_vertices_measurable`` of ``front_vertices``) — must lie
    near the wall's stereo points (its relief within WALL_RELIEF_M of its plane included):
    the largest distance along the wall (vertex and points projected into the wall's plane)
    to the nearest one, ``front_vertex_to_wall_points_max_m`` (a face reaching beyond the
    measured wall shows here; one off it in ``front_vertex_to_wall_plane_max_m``);
    ``front_vertex_to_wall_points_m`` lists each vertex's (null: not measurable). A vertex
    the right camera does not see (the left image's strip beyond the right camera's view, a
    disparity wide: 57-284 px on the castle) or outside the left
    image has no stereo point near it however right it is (the wall goes on beyond the
    photo): it is measured against the region's plane only, as every vertex is in
    ``front_vertex_to_wall_plane_max_m``; where such a vertex lies along the wall, no view
    tells (the verdict names those parts as placed by the knowledge). No model or no part
    bound to the region: ``front_part`` null and no distances. ``rig``: the scene's first
    view's stereo calibration (the world frame is its left camera's)."""
    from scipy.spatial import cKDTree

    parts = {p.role: p for p in result.model.parts} if result.model is not None else {}
    # the region is bound to an instance at or below a planar part (its ``region`` role)
    bound = [
        r
        for i in result.instances
        if main.id in i.bindings
        for r in parts
        if i.role == r or i.role.startswith(r + ".")
    ]
    if not bound:
        return {"front_part": None}
    polygon = np.asarray(parts[bound[0]].polygon, float)
    view = evidence.views[0]
    R, t = np.asarray(view.left.R, float), np.asarray(view.left.t, float)
    pts_cam = prod.depth.points.reshape(-1, 3)
    pts_cam = pts_cam[np.all(np.isfinite(pts_cam), axis=1)].astype(float)
    points = (pts_cam - t) @ R  # camera -> world: R^T (x - t)
    # the wall's stereo points: every measured point on the main wall, its relief included
    # (the segmentation leaves out some of them: a cornice's foot, pixels at window frames)
    offset = float(main.normal @ main.centroid_m)
    off_plane = points @ main.normal - offset
    on_plane = points[np.abs(off_plane) <= FRONT_ON_WALL_M]
    keep = np.abs(off_plane) <= WALL_RELIEF_M
    # a vertex's distance to them is taken along the wall (both projected into its plane):
    # how far off the plane a vertex lies is measured apart, against the plane
    along = points[keep] - np.outer(off_plane[keep], main.normal)
    cam = polygon @ R.T + t
    shown = _in_image(
        cam @ np.asarray(view.left.K, float).T, view.image_width, view.image_height, 0.0
    )

    def stereo_sees(world: np.ndarray) -> np.ndarray:
        """(N,) bool: world points (N, 3) inside both images by STEREO_MARGIN_PX."""
        left = world @ R.T + t
        right = left @ np.asarray(rig.R, float).T + np.asarray(rig.T, float).ravel()
        W, H = rig.image_size
        return _in_image(
            left @ np.asarray(view.left.K, float).T,
            view.image_width,
            view.image_height,
            STEREO_MARGIN_PX,
        ) & _in_image(right @ np.asarray(rig.K2, float).T, W, H, STEREO_MARGIN_PX)

    measurable = stereo_sees(polygon)
    plane = np.abs(polygon @ main.normal - offset)
    out: dict[str, Any] = {
        "front_part": bound[0],
        "front_vertices": len(polygon),
        "front_vertices_in_view": int(shown.sum()),
        "front_vertices_measurable": int(measurable.sum()),
        "front_vertex_to_wall_plane_max_m": round(float(plane.max()), 3),
    }
    tree = cKDTree(along)
    dist, _ = tree.query(polygon - np.outer(polygon @ main.normal - offset, main.normal))
    out["front_vertex_to_wall_points_m"] = [
        round(float(d), 3) if m else None for d, m in zip(dist, measurable, strict=True)
    ]
    if measurable.any():
        out["front_vertex_to_wall_points_max_m"] = round(float(dist[measurable].max()), 3)
        # as measured before (to the points within FRONT_ON_WALL_M of the plane, in 3-D)
        plain, _ = cKDTree(on_plane).query(polygon[measurable])
        out["front_vertex_to_plane_band_points_max_m"] = round(float(plain.max()), 3)
    # the outline between the vertices, where stereo could measure it (a front whose corners
    # all lie beyond the photo still shows where it ends along its edges)
    f = np.linspace(0.0, 1.0, OUTLINE_SAMPLES, endpoint=False)[:, None, None]
    outline = (polygon + f * (np.roll(polygon, -1, axis=0) - polygon)).reshape(-1, 3)
    seen_o = stereo_sees(outline)
    # ... and where nothing stands in front of the wall (a tractor before its foot): no
    # measured point within a matching window of the sample's pixel lies nearer the camera
    # than the wall's relief reaches
    all_cam = prod.depth.points.astype(float)
    with np.errstate(invalid="ignore"):
        ahead = ((all_cam - t) @ R) @ main.normal - offset > WALL_RELIEF_M
    side = 2 * STEREO_MARGIN_PX + 1
    ahead = cv2.dilate(ahead.astype(np.uint8), np.ones((side, side), np.uint8)) > 0
    pix_o = (outline @ R.T + t) @ np.asarray(view.left.K, float).T
    with np.errstate(divide="ignore", invalid="ignore"):
        col = np.clip(np.nan_to_num(pix_o[:, 0] / pix_o[:, 2]), 0, ahead.shape[1] - 1)
        row = np.clip(np.nan_to_num(pix_o[:, 1] / pix_o[:, 2]), 0, ahead.shape[0] - 1)
    seen_o &= ~ahead[np.round(row).astype(int), np.round(col).astype(int)]
    out["front_outline_measurable_share"] = round(float(seen_o.mean()), 3)
    if seen_o.any():
        flat_o = outline[seen_o] - np.outer(outline[seen_o] @ main.normal - offset, main.normal)
        d_o, _ = tree.query(flat_o)
        out["front_outline_to_wall_points_max_m"] = round(float(d_o.max()), 3)
    return out


OUTLINE_SAMPLES = 200  # points per edge of the front's outline


def motorcycle() -> dict[str, Any]:
    """aida NCC and SGBM on Middlebury Motorcycle (scikit-image's copy)."""
    from skimage import data

    left_rgb, right_rgb, truth = data.stereo_motorcycle()
    left = cv2.cvtColor(np.ascontiguousarray(left_rgb), cv2.COLOR_RGB2GRAY)
    right = cv2.cvtColor(np.ascontiguousarray(right_rgb), cv2.COLOR_RGB2GRAY)
    truth = np.where(np.isfinite(truth), truth, np.nan).astype(np.float32)
    start = time.perf_counter()
    found = disparity_range(left, right)
    lo, num = (found.min_disp, found.num_disp) if found is not None else (0, 128)
    ncc = ncc_disparity(left, right, min_disp=lo, num_disp=num, window=MOTORCYCLE_WINDOW)
    t_ncc = time.perf_counter() - start
    num_sgbm = 16 * math.ceil((float(np.nanmax(truth)) + 1) / 16)
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num_sgbm, **SGBM_PARAMS)
    start = time.perf_counter()
    sgbm_d = opencv_disparity(sgbm.compute(left, right))
    t_sgbm = time.perf_counter() - start
    s_ncc = score_disparity(ncc.disparity, truth)
    s_sgbm = score_disparity(sgbm_d, truth)
    matched, matched_density = at_density(ncc.disparity, ncc.certainty, truth, s_sgbm.density)
    s_matched = score_disparity(matched, truth)
    start = time.perf_counter()
    sgm = sgm_disparity(left, right, min_disp=lo, num_disp=num)
    t_sgm = time.perf_counter() - start
    s_sgm = score_disparity(sgm.disparity, truth)
    sgm_matched, sgm_density = at_density(sgm.disparity, sgm.certainty, truth, s_sgbm.density)
    s_sgm_matched = score_disparity(sgm_matched, truth)
    halves: dict[str, Any] = {}
    top = np.zeros(truth.shape, bool)
    top[: truth.shape[0] // 2] = True
    for name, mask in (("top", top), ("bottom", ~top)):
        t_half = np.where(mask, truth, np.nan).astype(np.float32)
        sgbm_half = score_disparity(sgbm_d, truth, mask=mask)
        kept, kept_density = at_density(sgm.disparity, sgm.certainty, t_half, sgbm_half.density)
        halves[name] = {
            "sgbm_density": round(sgbm_half.density, 4),
            "sgbm_bad2": round(sgbm_half.bad2, 4),
            "sgm_density_at_sgbm": round(kept_density, 4),
            "sgm_bad2_at_sgbm_density": round(score_disparity(kept, t_half).bad2, 4),
        }
    return {
        "size": f"{left.shape[1]}x{left.shape[0]}",
        "aida_range": [lo, lo + num - 1],
        "aida_window": MOTORCYCLE_WINDOW,
        "aida_density": round(s_ncc.density, 4),
        "aida_bad2": round(s_ncc.bad2, 4),
        "aida_s": round(t_ncc, 2),
        "sgbm_num_disparities": num_sgbm,
        "sgbm_params": {k: v for k, v in SGBM_PARAMS.items() if k != "mode"} | {"mode": "3WAY"},
        "sgbm_density": round(s_sgbm.density, 4),
        "sgbm_bad2": round(s_sgbm.bad2, 4),
        "sgbm_s": round(t_sgbm, 2),
        "aida_density_at_sgbm": round(matched_density, 4),
        "aida_bad2_at_sgbm_density": round(s_matched.bad2, 4),
        "sgm_density": round(s_sgm.density, 4),
        "sgm_bad2": round(s_sgm.bad2, 4),
        "sgm_s": round(t_sgm, 2),
        "sgm_density_at_sgbm": round(sgm_density, 4),
        "sgm_bad2_at_sgbm_density": round(s_sgm_matched.bad2, 4),
        "sgm_halves": halves,
        "done_when_bad2": bool(
            min(s_matched.bad2, s_sgm_matched.bad2) <= s_sgbm.bad2
            and max(matched_density, sgm_density) >= s_sgbm.density - 1e-3
        ),
    }


LARGE_FACTOR = 5  # the castle pair upsampled 5x: 5120x3415, 17.5 megapixels


def large_photo(path: Path, kb: Any) -> dict[str, Any]:
    """The working-resolution path on a 17.5-megapixel pair, in a child process of its own
    (its peak memory is the child's): the castle pair upsampled LARGE_FACTOR times (bicubic; it
    holds no more detail than the original: this measures time and memory, and that the
    figures hold, not the accuracy a real 17-megapixel photo would give)."""
    import subprocess
    import tempfile

    from aida_kb.io.scene import ViewData, read_image, scaled_calib, write_scene

    scene = read_scene(path, with_truth=False)
    rig = scene.views[0].rig
    W, H = rig.image_size
    size = (W * LARGE_FACTOR, H * LARGE_FACTOR)
    with tempfile.TemporaryDirectory(prefix="aida-real-large-") as tmp:
        images = [
            np.asarray(cv2.resize(read_image(f), size, interpolation=cv2.INTER_CUBIC), np.uint8)
            for f in (scene.views[0].left, scene.views[0].right)
        ]
        root = write_scene(
            Path(tmp) / "large", scaled_calib(rig, size), [ViewData(images[0], images[1])]
        )
        labels = read_labels(path / "reference_labels.png")
        big = cv2.resize(labels, size, interpolation=cv2.INTER_NEAREST)
        cv2.imwrite(str(root / "reference_labels.png"), big)
        (root / "cameras_world.json").write_text((path / "cameras_world.json").read_text())
        done = subprocess.run(
            [sys.executable, __file__, "--large-child", str(root)],
            capture_output=True,
            text=True,
            check=True,
        )
    out: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    out["size"] = f"{size[0]}x{size[1]}"
    return out


def _large_child(root: Path) -> None:
    """The child of `large_photo`: one scene run, its figures and the peak memory as JSON."""
    kb = compile_path(str(ROOT / "kb" / "buildings.kb")).kb
    out = real_scene(root, kb, both_images=False)
    keep = ("vertical_err_deg", "main_wall_tilt_err_deg", "wall_label_coverage", "density")
    figures = {k: out[k] for k in keep if k in out}
    figures["rectified"] = out["rectified"]
    figures["evidence_s"] = out["evidence_s"]
    figures["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    print(json.dumps(figures))


def main() -> None:
    """Run every real scene and Motorcycle; print one JSON line."""
    if {"-h", "--help"} & set(sys.argv[1:]):
        print(__doc__)
        return
    if sys.argv[1:2] == ["--large-child"]:
        _large_child(Path(sys.argv[2]))
        return
    only_motorcycle = sys.argv[1:] == ["--motorcycle"]
    only_scenes = "--scenes" in sys.argv[1:]
    args = [a for a in sys.argv[1:] if a != "--scenes"]
    real = Path(args[0]) if args and not only_motorcycle else REAL
    kb = compile_path(str(ROOT / "kb" / "buildings.kb")).kb
    assert kb is not None, "kb/buildings.kb has errors"
    out: dict[str, Any] = {}
    for path in sorted(p for p in real.iterdir() if (p / "scene.yaml").is_file()):
        if only_motorcycle:
            break
        out[path.name] = real_scene(path, kb)
        print(path.name, out[path.name], file=sys.stderr)
    labelled = [p for p in sorted(real.iterdir()) if (p / "reference_labels.png").is_file()]
    if labelled and not (only_motorcycle or only_scenes):
        out["large_photo"] = large_photo(labelled[0], kb)
        print("large_photo", out["large_photo"], file=sys.stderr)
    if not only_scenes:
        out["motorcycle"] = motorcycle()
    scenes = [v for k, v in out.items() if k != "motorcycle"]
    if scenes:
        out["done_when_vertical_0p5deg"] = all(s["vertical_err_deg"] <= 0.5 for s in scenes)
        out["done_when_wall_normal_1deg"] = all(
            s.get("main_wall_tilt_err_deg", 90.0) <= 1.0 for s in scenes
        )
        judged = [s for s in scenes if "outcome" in s]  # large_photo: vision figures only

        # no VERIFIED object whose front is not the real main wall (issue 15's wording: a
        # doubtful one says it may be wrong); ``found_front_on_wall_0p3m``, stricter: the
        # front of every object found, verified or doubtful, on the wall
        def on_wall(s: dict[str, Any]) -> bool:
            return (
                s.get("front_part") is not None
                and s["front_vertex_to_wall_plane_max_m"] <= FRONT_ON_WALL_M
                and s.get("front_vertex_to_wall_points_max_m", 0.0) <= FRONT_ON_WALL_M
            )

        out["done_when_front_on_wall_0p3m"] = all(
            s["outcome"] != VERIFIED or on_wall(s) for s in judged
        )
        out["found_front_on_wall_0p3m"] = all(s["outcome"] == NOTHING or on_wall(s) for s in judged)
        out["done_when_not_nothing"] = all(s["outcome"] != NOTHING for s in judged)
        labelled_scenes = [s for s in scenes if "wall_visible_coverage" in s]
        if labelled_scenes:  # one region covering 80 % of the wall (labels or outlines tell)
            out["done_when_wall_one_region_0p8_labelled"] = all(
                s["wall_visible_coverage"] >= WALL_COVERAGE_DONE for s in labelled_scenes
            )
    out["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    print(json.dumps(out))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
