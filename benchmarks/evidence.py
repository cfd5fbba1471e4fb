"""Benchmark: plane normals of the evidence against the truth, per synthetic preset (not a test).

Each preset is rendered at 640x480 (two views, seed 0) and run through `scene_evidence` with the
manual segmentation (labels.png); for every face that covers at least 2 % of a view's image the
angle between the region's n_init and the true plane normal is measured. Reported per preset:
the largest angle over both views (`<preset>_max_normal_err_deg`) and the face it belongs to,
once with the default pipeline (disparity fit refined by direct image alignment) and once
with the disparity fits alone (`photometric_window = 0`), so that the effect of the refinement
stays visible. Ends with ONE line of JSON.

With ``--random-start S --random-count N`` it measures instead the randomised scenes of
`aida_kb.synth.randomised` (as benchmarks/robustness.py draws them, ``--max-views`` views,
labels.png or not): every evidence region that lies on a true plane, by the kind of that
plane -- wall (normal within `WALL_TILT_DEG` of horizontal), roof (facing up), ground (the
truth's ground) -- gives its normal's angle to the truth and its signed vertical tilt (the
angle of its normal above the horizontal less the truth's: a bias would show as a mean far
from zero), and the error in units of the fit's own 1-sigma as the interpreter reads it
(`aida_kb.interpret.observe.fit_sigma_rad`). ``--kept DIR`` reads the scene directories
``DIR/scene-SEED`` a robustness run kept instead of rendering them.

Run: .venv/bin/python benchmarks/evidence.py [--random-start S --random-count N | --kept DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from aida_kb.interpret.observe import FIT_CORRELATED_PX, fit_sigma_rad
from aida_kb.io.evidence import Evidence
from aida_kb.io.scene import Scene, read_labels, read_scene
from aida_kb.synth.randomised import random_scene
from aida_kb.synth.scenes import preset, render_scene
from aida_kb.vision.evaluate import angle_deg, truth_planes_camera
from aida_kb.vision.evidence import ViewProducts, VisionParams, original_rays, scene_evidence

PRESETS: dict[str, tuple[str, dict[str, str]]] = {
    "house": ("house", {}),
    "flat": ("house", {"roof": "flat"}),
    "hip": ("house", {"roof": "hip"}),
    "shed": ("house", {"roof": "shed"}),
    "lshape": ("lshape", {}),
    "lshape135": ("lshape", {"meeting_deg": "135"}),
    "oriel": ("oriel", {}),
}
MIN_FRACTION = 0.02
LIMIT_DEG = 2.0


def face_errors(scene: Scene, evidence: Evidence) -> list[tuple[float, str, str]]:
    """(angle deg, view id, face role) of every face covering >= MIN_FRACTION of its view;
    a face without a region counts as 180 degrees."""
    assert scene.truth is not None
    roles = {p.label: p.role for p in scene.truth.parts}
    out = []
    for view in evidence.views:
        sv = scene.view(view.id)
        assert sv.labels is not None
        labels = read_labels(sv.labels)
        planes = truth_planes_camera(scene.truth, view.id)
        ids, counts = np.unique(labels, return_counts=True)
        by_label = {r.label: r for r in view.regions if r.label is not None}
        for label, count in zip(ids.tolist(), counts.tolist(), strict=True):
            if label == 0 or count < MIN_FRACTION * labels.size:
                continue
            role = roles.get(label, "ground")
            region = by_label.get(label)
            if region is None:
                out.append((180.0, view.id, role))
                continue
            out.append((angle_deg(np.array(region.n_init), planes[label][0]), view.id, role))
    return out


# A truth plane whose normal lies within this many degrees of horizontal is a wall.
WALL_TILT_DEG = 10.0
# A region without labels is taken to lie on the truth plane nearest its centroid when its
# normal is within MATCH_DEG of that plane's and its centroid within MATCH_M of it; a region
# further off lies on no face (clutter, an occluder, a merged corner) and is not measured.
MATCH_DEG = 8.0
MATCH_M = 1.0
# A fit further off than this is a failed fit (a dark roof or blank wall whose disparities are
# noise: no plane inliers), counted apart so that the medians describe the fits that worked.
GROSS_DEG = 10.0
KINDS = ("wall", "roof", "ground")


def _up(scene: Scene) -> np.ndarray:
    """The world's up direction (unit, world = view 00's left camera): the truth ground's
    normal, else the camera's -y axis (its views are level on average)."""
    assert scene.truth is not None
    if scene.truth.ground is not None:
        return np.asarray(scene.truth.ground.normal, float)
    return np.array([0.0, -1.0, 0.0])


def gyration_m(rays: np.ndarray, n: np.ndarray, d: float, up: np.ndarray) -> tuple[float, float]:
    """The radii of gyration (m) of a region's pixels on its plane n·x = d along the plane's
    vertical (up projected onto it) and its horizontal. rays : (N, 3) the pixels' viewing
    rays (z = 1), camera frame; n, up : unit (3,), camera frame."""
    depth = d / (rays @ n)
    points = rays[depth > 0] * depth[depth > 0, None]
    vertical = up - (up @ n) * n
    vertical /= np.linalg.norm(vertical)
    horizontal = np.cross(n, vertical)
    return float(np.std(points @ vertical)), float(np.std(points @ horizontal))


def region_errors(
    scene: Scene, evidence: Evidence, products: list[ViewProducts]
) -> list[dict[str, Any]]:
    """One row per evidence region on a true plane: view, kind, labelled, angle_deg (to the
    true normal), tilt_deg (signed: its elevation above the horizontal less the truth's),
    z (angle over the fit's 1-sigma, `fit_sigma_rad`, which spreads the region over a square
    of its area), z_tilt (|tilt| over that sigma) and z_tilt_own (|tilt| over the sigma the
    same fit has about the plane's horizontal axis: its spread along the plane's vertical,
    `gyration_m`, instead of the square's), inliers. Every view's evidence is in its own
    camera frame (no poses given) or, for view 00, the world frame: the same."""
    truth = scene.truth
    assert truth is not None
    ground = truth.ground.label if truth.ground is not None else None
    up_world = _up(scene)
    rows: list[dict[str, Any]] = []
    for view, made in zip(evidence.views, products, strict=True):
        rays = original_rays(scene.view(view.id).rig)
        planes = truth_planes_camera(truth, view.id)
        up = np.asarray(truth.pose(view.id).R, float) @ up_world
        labels = np.array(list(planes))
        normals = np.array([planes[k][0] for k in planes])
        offsets = np.array([planes[k][1] for k in planes])
        for region in view.regions:
            n, c = np.array(region.n_init), np.array(region.c_init)
            if region.label is not None:
                if region.label not in planes:
                    continue
                label = region.label
            else:
                angles = np.degrees(np.arccos(np.clip(normals @ n, -1.0, 1.0)))
                dist = np.where(angles < MATCH_DEG, np.abs(normals @ c - offsets), np.inf)
                best = int(np.argmin(dist))
                if not dist[best] <= MATCH_M:
                    continue
                label = int(labels[best])
            n_true = planes[label][0]
            elevation = float(np.degrees(np.arcsin(np.clip(n_true @ up, -1.0, 1.0))))
            if label == ground:
                kind = "ground"
            elif abs(elevation) <= WALL_TILT_DEG:
                kind = "wall"
            elif elevation > 0.0:
                kind = "roof"
            else:
                continue  # an underside (eaves, an oriel's bottom)
            sigma = float(
                fit_sigma_rad(region.rms_m, region.inlier_count / FIT_CORRELATED_PX, region.area_m2)
            )
            angle = angle_deg(n, n_true)
            tilt = z_tilt = z_own = aspect = None
            if kind != "ground":  # a level plane has no vertical tilt: its angle is all of it
                tilt = float(np.degrees(np.arcsin(np.clip(n @ up, -1.0, 1.0)))) - elevation
                g_vertical, _ = gyration_m(rays[made.regions == region.id], n, region.d_init, up)
                square = float(np.sqrt(region.area_m2 / 12.0))
                if np.isfinite(sigma) and g_vertical > 0.0:
                    z_tilt = float(np.radians(abs(tilt)) / sigma)
                    z_own = z_tilt * g_vertical / square
                    aspect = square / g_vertical
            rows.append(
                {
                    "view": view.id,
                    "kind": kind,
                    "labelled": region.label is not None,
                    "angle_deg": angle,
                    "tilt_deg": tilt,
                    "z": float(np.radians(angle) / sigma) if np.isfinite(sigma) else None,
                    "z_tilt": z_tilt,
                    "z_tilt_own": z_own,
                    "aspect": aspect,
                    "inliers": region.inlier_count,
                }
            )
    return rows


# The true faces of a view without labels.png, from the truth's exact depth (depth_left.npy):
# a pixel lies on the true face whose plane its point is nearest, when within FACE_TOL_REL of
# its depth (the renderer's depth and this module's undistorted rays agree to ~1e-4 of it at a
# grazing ground; a point lies that near another face's plane only along their common edge).
# Coplanar faces (an L's flush fronts, the floor under the ground) count as one face: no
# region could tell them apart.
FACE_TOL_REL = 2e-3
COPLANAR_TOL = 1e-6  # 1 - cos of the angle and relative offset within which planes coincide
MIN_FACE_SHARE = 0.005  # faces covering less of the view are not measured (a sliver, 0.5 %)
SPLIT_SHARE = 0.2  # a face is split when a second region holds this share of its pixels too
MERGE_SHARE = 0.1  # a face's main region is merged when another face holds this share of it
LOST_COVER = 0.25  # a face whose main region covers less of it than this is lost
FLAT_DEG = 5.0  # a slope's region fitted flat: its normal this much nearer "up" than the truth


def truth_face_map(scene: Scene, view_id: str) -> np.ndarray:
    """(H, W) int64 of the view's original left image: the label of the true face each pixel
    shows (coplanar faces: the ground's, else the smallest label), 0 where none (sky, an
    occluder, no depth). See FACE_TOL_REL."""
    assert scene.truth is not None
    view = scene.view(view_id)
    assert view.depth_left is not None
    z = np.load(view.depth_left).astype(np.float64)
    points = original_rays(view.rig) * z[..., None]
    planes = truth_planes_camera(scene.truth, view_id)
    ground = scene.truth.ground.label if scene.truth.ground is not None else None
    labels = np.array(sorted(planes, key=lambda k: (k != ground, k)), np.int64)
    normals = np.array([planes[k][0] for k in labels])
    offsets = np.array([planes[k][1] for k in labels])
    scale = np.maximum(np.abs(offsets), 1.0)
    cos = normals @ normals.T  # a floor is the ground's plane facing the other way
    same = (np.abs(cos) >= 1.0 - COPLANAR_TOL) & (
        np.abs(offsets[:, None] - np.sign(cos) * offsets[None, :]) <= COPLANAR_TOL * scale[:, None]
    )
    first = labels[np.argmax(same, axis=1)]  # the ground, else the smallest label of the group
    with np.errstate(invalid="ignore"):
        dist = np.abs(points @ normals.T - offsets)  # (H, W, L)
        best = np.argmin(np.where(np.isnan(dist), np.inf, dist), axis=-1)
        near = np.take_along_axis(dist, best[..., None], axis=-1)[..., 0] <= FACE_TOL_REL * z
    return np.where(near, first[best], 0)


def _face_kind(scene: Scene, view_id: str, label: int, n_true: np.ndarray) -> str | None:
    """wall, roof or ground (as `region_errors` tells them), None for an underside."""
    truth = scene.truth
    assert truth is not None
    if truth.ground is not None and label == truth.ground.label:
        return "ground"
    up = np.asarray(truth.pose(view_id).R, float) @ _up(scene)
    elevation = float(np.degrees(np.arcsin(np.clip(n_true @ up, -1.0, 1.0))))
    if abs(elevation) <= WALL_TILT_DEG:
        return "wall"
    return "roof" if elevation > 0.0 else None


def face_rows(
    scene: Scene, evidence: Evidence, products: list[ViewProducts]
) -> list[dict[str, Any]]:
    """One row per true face covering at least MIN_FACE_SHARE of a view: how the evidence's
    regions cover it. view, kind, labelled (the view's regions are labels.png's), share (of
    the image), cover (of the face's pixels in any region), main_cover (in its main region,
    the one holding most of it), purity (of the main region's pixels on true faces, the share
    on this one), merged (the other faces' kinds holding MERGE_SHARE of the main region), split
    (further regions holding SPLIT_SHARE of the face), angle_deg (main region's normal to the
    truth), z (that over the fit's 1-sigma, `fit_sigma_rad`), flat_deg (for a roof: how much
    nearer up the main region's normal is than the truth's; > 0 flatter)."""
    truth = scene.truth
    assert truth is not None
    up_world = _up(scene)
    rows: list[dict[str, Any]] = []
    for view, made in zip(evidence.views, products, strict=True):
        faces = truth_face_map(scene, view.id)
        planes = truth_planes_camera(truth, view.id)
        regions = made.regions.astype(np.int64)
        n_face, n_region = int(faces.max()) + 1, int(regions.max()) + 1
        table = np.bincount(
            faces.ravel() * n_region + regions.ravel(), minlength=n_face * n_region
        ).reshape(n_face, n_region)  # pixels of face f in region r
        on_faces = table[1:].sum(axis=0)  # per region: its pixels on any true face
        by_id = {r.id: r for r in view.regions}
        up = np.asarray(truth.pose(view.id).R, float) @ up_world
        kinds = {
            int(f): _face_kind(scene, view.id, int(f), planes[int(f)][0])
            for f in np.flatnonzero(table.sum(axis=1))
            if f > 0
        }
        for f, kind in kinds.items():
            size = int(table[f].sum())
            if kind is None or size < MIN_FACE_SHARE * faces.size:
                continue
            in_regions = table[f, 1:]
            main = int(np.argmax(in_regions)) + 1
            main_px = int(table[f, main])
            row: dict[str, Any] = {
                "view": view.id,
                "face": f,
                "kind": kind,
                "labelled": view.segmentation == "labels",
                "share": size / faces.size,
                "cover": float(in_regions.sum()) / size,
                "main_cover": main_px / size,
                "purity": None,
                "merged": [],
                "split": int(np.count_nonzero(in_regions >= SPLIT_SHARE * size)) - 1,
                "angle_deg": None,
                "z": None,
                "flat_deg": None,
            }
            if main_px > 0:
                total = int(on_faces[main])
                row["purity"] = main_px / max(total, 1)
                row["merged"] = sorted(
                    str(kinds.get(int(g)) or "underside")
                    for g in np.flatnonzero(table[:, main] >= MERGE_SHARE * total)
                    if g not in (0, f)
                )
                region = by_id.get(main)
                if region is not None:
                    n, n_true = np.array(region.n_init), planes[f][0]
                    row["angle_deg"] = angle_deg(n, n_true)
                    sigma = float(
                        fit_sigma_rad(
                            region.rms_m, region.inlier_count / FIT_CORRELATED_PX, region.area_m2
                        )
                    )
                    if np.isfinite(sigma):
                        row["z"] = float(np.radians(row["angle_deg"]) / sigma)
                    if kind == "roof":
                        row["flat_deg"] = float(
                            np.degrees(np.arccos(np.clip(n_true @ up, -1.0, 1.0)))
                            - np.degrees(np.arccos(np.clip(n @ up, -1.0, 1.0)))
                        )
            rows.append(row)
    return rows


def coverage_figures(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per kind of face: faces, lost (main region under LOST_COVER of it), split, merged (and
    with which kinds), median cover / main cover / purity, median normal angle and z of the
    main region (over the faces not lost), and for roofs the ones fitted flat (FLAT_DEG)."""
    out: dict[str, Any] = {}
    for kind in KINDS:
        sel = [r for r in rows if r["kind"] == kind]
        kept = [r for r in sel if r["main_cover"] >= LOST_COVER]
        merged: dict[str, int] = {}
        for r in kept:
            for other in set(r["merged"]):
                merged[other] = merged.get(other, 0) + 1
        fig: dict[str, Any] = {
            "faces": len(sel),
            "lost": len(sel) - len(kept),
            "split": sum(1 for r in kept if r["split"] > 0),
            "merged": sum(1 for r in kept if r["merged"]),
            "merged_with": merged,
            "median_cover": _median([r["cover"] for r in sel]),
            "median_main_cover": _median([r["main_cover"] for r in sel]),
            "median_purity": _median([r["purity"] for r in kept]),
            "median_angle_deg": _median([r["angle_deg"] for r in kept]),
            "over_gross": sum(1 for r in kept if (r["angle_deg"] or 0.0) > GROSS_DEG),
            "median_z": _median([r["z"] for r in kept]),
        }
        if kind == "roof":
            fig["flat"] = sum(1 for r in kept if (r["flat_deg"] or 0.0) > FLAT_DEG)
        out[kind] = fig
    return out


def _median(values: list[float | None]) -> float | None:
    """The median of the known values, 2 decimals; None when none is known."""
    known = [v for v in values if v is not None]
    return round(float(np.median(known)), 2) if known else None


def kind_figures(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per kind: regions, failed fits (over GROSS_DEG), and over the others the median and
    90th percentile angle and the median angle in units of the fit's own 1-sigma (z); for walls
    and roofs also the mean and median signed tilt, the median |tilt|, the median |tilt| in
    units of that sigma (z_tilt) and of the sigma of the same fit about the plane's horizontal
    axis (z_tilt_own), and the median ratio of the square's spread to the region's vertical
    one (above 1: the square understates how little the region spreads vertically)."""
    out: dict[str, Any] = {}
    for kind in KINDS:
        sel = [r for r in rows if r["kind"] == kind]
        fits = [r for r in sel if r["angle_deg"] <= GROSS_DEG]
        fig: dict[str, Any] = {"regions": len(sel), "failed": len(sel) - len(fits)}
        if fits:
            angle = np.array([r["angle_deg"] for r in fits])
            fig.update(
                median_deg=round(float(np.median(angle)), 3),
                p90_deg=round(float(np.percentile(angle, 90)), 3),
                median_z=_median([r["z"] for r in fits]),
            )
            tilt = np.array([r["tilt_deg"] for r in fits if r["tilt_deg"] is not None])
            if len(tilt):
                fig.update(
                    tilt_mean_deg=round(float(tilt.mean()), 3),
                    tilt_median_deg=round(float(np.median(tilt)), 3),
                    abs_tilt_median_deg=round(float(np.median(np.abs(tilt))), 3),
                    median_z_tilt=_median([r["z_tilt"] for r in fits]),
                    median_z_tilt_own=_median([r["z_tilt_own"] for r in fits]),
                    median_square_over_vertical=_median([r["aspect"] for r in fits]),
                )
        out[kind] = fig
    return out


def random_scenes(
    seeds: range,
    kept: Path | None,
    max_views: int,
    *,
    coverage: bool = False,
    unlabelled: bool = False,
    params: VisionParams | None = None,
) -> None:
    """Per-kind figures of the region normals of randomised scenes, default pipeline and
    disparity fits alone; a line per scene on stderr, ONE line of JSON on stdout. With
    `coverage`, the default pipeline alone, and per kind of face how its regions cover the
    true faces (`face_rows`, `coverage_figures`), with a line per face on stderr. With
    `unlabelled`, only the scenes without labels.png. `params`: the pipeline's parameters
    (default VisionParams())."""
    base = params or VisionParams()
    rows: dict[str, list[dict[str, Any]]] = {"default": [], "disparity_fit_only": []}
    variants = {"default": base, "disparity_fit_only": replace(base, photometric_window=0)}
    if coverage:
        del variants["disparity_fit_only"], rows["disparity_fit_only"]
    faces: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            if kept is not None:
                scene_dir = kept / f"scene-{seed}"
                if not (scene_dir / "truth.json").is_file():
                    continue
            else:
                spec = random_scene(seed, max_views=max_views)
                if unlabelled and spec.write_labels:
                    continue
                scene_dir = render_scene(spec, Path(tmp) / f"scene-{seed}")
            scene = read_scene(scene_dir)
            if unlabelled and scene.views[0].labels is not None:
                continue
            views = [v.id for v in scene.views[:max_views]]
            for name, params in variants.items():
                evidence, products = scene_evidence(scene, views=views, params=params)
                found = region_errors(scene, evidence, products)
                rows[name] += [{**r, "seed": seed} for r in found]
            print(f"seed {seed}: {len(found)} regions on true planes", file=sys.stderr)
            if coverage:
                covered = [{**r, "seed": seed} for r in face_rows(scene, evidence, products)]
                faces += covered
                for r in covered:
                    print(f"  {_face_line(r)}", file=sys.stderr)
    summary: dict[str, Any] = {"seeds": f"{seeds.start}-{seeds.stop - 1}", "views": max_views}
    for name, found in rows.items():
        summary[name] = {
            "with_labels": kind_figures([r for r in found if r["labelled"]]),
            "without_labels": kind_figures([r for r in found if not r["labelled"]]),
        }
    if coverage:
        summary["coverage"] = {
            "with_labels": coverage_figures([r for r in faces if r["labelled"]]),
            "without_labels": coverage_figures([r for r in faces if not r["labelled"]]),
        }
    print(json.dumps(summary))


def _face_line(row: dict[str, Any]) -> str:
    """One face's coverage row as a line of text."""

    def fmt(value: float | None, digits: int = 2) -> str:
        return "-" if value is None else f"{value:.{digits}f}"

    return (
        f"{row['seed']} view {row['view']} face {row['face']:>2} {row['kind']:<6} "
        f"share {fmt(row['share'], 3)} cover {fmt(row['cover'])} main {fmt(row['main_cover'])} "
        f"purity {fmt(row['purity'])} split {row['split']} merged {','.join(row['merged']) or '-'}"
        f" angle {fmt(row['angle_deg'])} z {fmt(row['z'], 1)} flat {fmt(row['flat_deg'], 1)}"
    )


def main() -> None:
    """Presets (default) or randomised scenes (``--random-start``/``--kept``): see the module
    docstring."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random-start", type=int, help="first seed of randomised scenes")
    parser.add_argument("--random-count", type=int, default=12)
    parser.add_argument("--kept", type=Path, help="read DIR/scene-SEED instead of rendering")
    parser.add_argument("--max-views", type=int, default=3)
    parser.add_argument(
        "--coverage", action="store_true", help="how the regions cover the true faces"
    )
    parser.add_argument("--unlabelled", action="store_true", help="scenes without labels.png")
    parser.add_argument(
        "--approximate-ncc",
        action="store_true",
        help="the matcher's pixel-wise normalised NCC (VisionParams.ncc_exact = False)",
    )
    parser.add_argument(
        "--no-outlines",
        action="store_true",
        help="no regions on outlined faces without texture (VisionParams.outlined_faces)",
    )
    args = parser.parse_args()
    if args.random_start is not None:
        seeds = range(args.random_start, args.random_start + args.random_count)
        random_scenes(
            seeds,
            args.kept,
            args.max_views,
            coverage=args.coverage,
            unlabelled=args.unlabelled,
            params=VisionParams(
                ncc_exact=not args.approximate_ncc, outlined_faces=not args.no_outlines
            ),
        )
        return
    presets()


def presets() -> None:
    """Render each preset, build its evidence twice, print per-preset lines and the JSON."""
    summary: dict[str, Any] = {"image": "640x480", "min_face_fraction": MIN_FRACTION}
    worst_all = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for key, (name, params) in PRESETS.items():
            scene_dir = render_scene(preset(name, seed=0, params=params), Path(tmp) / key)
            scene = read_scene(scene_dir)
            start = time.perf_counter()
            evidence, _ = scene_evidence(scene)
            seconds = time.perf_counter() - start
            errors = face_errors(scene, evidence)
            plain, _ = scene_evidence(scene, params=VisionParams(photometric_window=0))
            errors_plain = face_errors(scene, plain)
            worst = max(errors)
            worst_plain = max(errors_plain)
            worst_all = max(worst_all, worst[0])
            summary[f"{key}_max_normal_err_deg"] = round(worst[0], 2)
            summary[f"{key}_worst_face"] = f"{worst[1]}/{worst[2]}"
            summary[f"{key}_max_normal_err_deg_disparity_fit_only"] = round(worst_plain[0], 2)
            summary[f"{key}_faces"] = len(errors)
            summary[f"{key}_evidence_s"] = round(seconds, 2)
            print(
                f"{key}: max {worst[0]:.2f} deg ({worst[1]}/{worst[2]}) over {len(errors)} "
                f"faces; disparity fits alone {worst_plain[0]:.2f} deg; {seconds:.1f} s",
                file=sys.stderr,
            )
    summary["max_normal_err_deg"] = round(worst_all, 2)
    summary["done_when_normals_2deg"] = worst_all <= LIMIT_DEG
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
