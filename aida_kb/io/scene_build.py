"""Building a scene directory from a user's own material (`aida-kb scene init`, `from-colmap`).

`build_scene` copies image pairs (their bytes, not re-encoded) into a new scene directory with
their calibration(s), poses and scale, published as a whole (`aida_kb.io.atomic.publish_dir`):
a failed run leaves nothing behind, and nothing is ever written over an input. `colmap_views`
turns a COLMAP sparse model into such views (`aida_kb.io.colmap.stereo_views`), with the world
frame moved to the first view's left camera, as the scene format wants.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aida_kb.errors import FormatError
from aida_kb.io.atomic import check_outputs, publish_dir, write_bytes_atomic
from aida_kb.io.colmap import ColmapModel, PairingRule, StereoPair, stereo_views
from aida_kb.io.scene import (
    CALIB_FILE,
    SCENE_VERSION,
    FloatArray,
    Pose,
    ScaleField,
    SceneIndex,
    StereoCalib,
    ViewEntry,
    pose_entry,
    read_image,
    write_calib,
    write_index,
)
from aida_kb.limits import MAX_VIEWS


@dataclass(frozen=True)
class SourceView:
    """One view to build: its two image files, its rig, its left camera's pose (or None)."""

    left: Path
    right: Path
    calib: StereoCalib
    pose: Pose | None = None


def check_images(view: SourceView) -> None:
    """Refuse (FormatError naming the file) an image that is unreadable or not the rig's size."""
    width, height = view.calib.image_size
    for path in (view.left, view.right):
        image = read_image(path, grey=True)
        if image.shape != (height, width):
            raise FormatError(
                f"{path}: image is {image.shape[1]}x{image.shape[0]}, the calibration says "
                f"{width}x{height}"
            )
    if view.left.resolve() == view.right.resolve():
        raise FormatError(f"{view.right}: the same file as the left image")


def build_scene(
    out: str | os.PathLike[str],
    views: Sequence[SourceView],
    *,
    shared_calib: StereoCalib | None = None,
    scale: ScaleField = "metres",
    name: str = "",
    inputs: Sequence[str | os.PathLike[str]] = (),
) -> Path:
    """Write a new scene directory `out` (version 2) from `views`; returns its path.

    The images are checked (readable 8-bit, the calibration's size) and copied byte for byte
    to views/NN/left.EXT and right.EXT. shared_calib : written once as calib.yaml when every
    view uses it (then views name no calibration of their own); else each view's rig goes to
    views/NN/calib.yaml. `out` must be new or an empty folder and may not hold or lie inside
    an input (the image files, the calibration, `inputs`).
    """
    if not views:
        raise FormatError("no image pairs given")
    if len(views) > MAX_VIEWS:
        raise FormatError(f"{len(views)} views, more than the limit of {MAX_VIEWS}")
    target = Path(out)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise FormatError(f"{target}: exists and is not an empty folder; give a new folder")
    sources = [*inputs, *(p for v in views for p in (v.left, v.right))]
    existed = target.exists()
    try:
        check_outputs([], sources, directories=[target])
        for view in views:
            check_images(view)
        return _publish(target, views, shared_calib, scale, name)
    except BaseException:
        if not existed and target.is_dir() and not any(target.iterdir()):
            target.rmdir()  # the empty folder the check made: nothing is left behind
        raise


def _publish(
    target: Path,
    views: Sequence[SourceView],
    shared_calib: StereoCalib | None,
    scale: ScaleField,
    name: str,
) -> Path:
    entries = []
    with publish_dir(target) as work:
        for i, view in enumerate(views):
            vid = f"{i:02d}"
            base = Path("views") / vid
            names = []
            for side, src in (("left", view.left), ("right", view.right)):
                rel = (base / f"{side}{src.suffix.lower() or '.png'}").as_posix()
                write_bytes_atomic(work / rel, src.read_bytes())
                names.append(rel)
            calib_rel = None
            if shared_calib is None or view.calib is not shared_calib:
                calib_rel = (base / CALIB_FILE).as_posix()
                write_calib(work / calib_rel, view.calib)
            entries.append(
                ViewEntry(
                    id=vid,
                    left=names[0],
                    right=names[1],
                    calib=calib_rel,
                    pose=None if view.pose is None or i == 0 else pose_entry(view.pose),
                )
            )
        shared = shared_calib is not None and any(e.calib is None for e in entries)
        if shared and shared_calib is not None:
            write_calib(work / CALIB_FILE, shared_calib)
        index = SceneIndex(
            version=SCENE_VERSION,
            name=name,
            calib=CALIB_FILE if shared else None,
            scale=scale,
            views=entries,
        )
        write_index(work, index)
    return target


# ---------------------------------------------------------------------------------------------
# COLMAP


def rig_of(model: ColmapModel, pair: StereoPair) -> StereoCalib:
    """The stereo calibration of a pair of `model` (translations in model units)."""
    K1, D1 = model.cameras[pair.left.camera_id].opencv()
    K2, D2 = model.cameras[pair.right.camera_id].opencv()
    cam = model.cameras[pair.left.camera_id]
    if len(D1) != len(D2):  # one FULL_OPENCV, one not: both as 8 coefficients
        D1, D2 = (np.resize(np.append(D, np.zeros(3)), 8) for D in (D1, D2))
    return StereoCalib(K1, D1, K2, D2, pair.R, pair.T, (cam.width, cam.height))


def colmap_views(
    model: ColmapModel,
    images_dir: str | os.PathLike[str],
    *,
    rule: PairingRule | None = None,
    max_views: int | None = None,
) -> tuple[list[SourceView], list[StereoPair]]:
    """The stereo views of `model` with their image files below `images_dir`.

    Poses are moved to the scene's world, the left camera of view 00: for view k,
    R_k' = R_k·R_0^T and t_k' = t_k - R_k'·t_0 (model units). Raises FormatError when no pair
    of images makes a usable view (naming the rule) or an image file is missing.
    """
    pairs = stereo_views(model, rule, max_views)
    if not pairs:
        r = rule or PairingRule()
        raise FormatError(
            f"{model.root}: no pair of its {len(model.images)} images makes a stereo view "
            f"(needs: same image size, at least {r.min_shared} shared points, a median "
            f"disparity of at least {r.min_disparity_px:g} px, baseline / depth at most "
            f"{r.max_ratio:g}, optical axes within {r.max_axis_deg:g} "
            f"deg, baseline within {r.max_forward_deg:g} deg of the image plane)"
        )
    root = Path(images_dir)
    R0, t0 = pairs[0].left.R, pairs[0].left.t
    views = []
    for pair in pairs:
        files = []
        for image in (pair.left, pair.right):
            path = root / image.name
            if not path.is_file():
                raise FormatError(
                    f"{model.root}: image {image.id} ({image.name}): no such file {path}"
                )
            files.append(path)
        R = pair.left.R @ R0.T
        t = pair.left.t - R @ t0
        views.append(SourceView(files[0], files[1], rig_of(model, pair), (R, t)))
    return views, pairs


def model_distance(model: ColmapModel, a: str, b: str) -> float:
    """The distance (model units) between two images' camera centres or two 3-D points.

    a, b : image file names as in images.txt, or ``point:ID`` for a 3-D point of points3D.
    """

    def where(key: str) -> FloatArray:
        if key.startswith("point:"):
            try:
                pid = int(key.removeprefix("point:"))
            except ValueError:
                raise FormatError(f"{key!r}: expected point:ID with an integer ID") from None
            hit = np.flatnonzero(model.point_ids == pid)
            if not hit.size:
                raise FormatError(f"{model.root}: no 3-D point {pid} in points3D")
            p: FloatArray = model.points[hit[0]]
            return p
        try:
            return model.image_named(key).centre
        except KeyError:
            raise FormatError(f"{model.root}: no image named {key!r} in images") from None

    dist = float(np.linalg.norm(where(a) - where(b)))
    if not (math.isfinite(dist) and dist > 0):
        raise FormatError(f"{a} and {b}: the same place; no distance to fix the scale")
    return dist
