"""The scene directory: the input format of the whole pipeline (reader and writer).

Layout (documented field by field in docs/formats.md)::

    DIR/scene.yaml               format, version, name, calib file, scale, list of views and
                                 their files (version 2: a view may name its own calibration
                                 and give its left camera's pose)
    DIR/calib.yaml               stereo rig as cv2.FileStorage writes it: K1 D1 K2 D2 R T
                                 image_width image_height (x_right = R·x_left + T, T in metres)
    DIR/views/NN/left.png        8-bit image (grey or BGR)
    DIR/views/NN/right.png       8-bit image (grey or BGR)
    DIR/views/NN/labels.png      optional 16-bit label image, 0 = unlabelled
    DIR/views/NN/depth_left.npy  synthetic only: float32 z in metres, left camera, NaN = no surface
    DIR/truth.json               synthetic only: parts, planes, polygons, view poses

World coordinates are those of the left camera of view 00 (OpenCV: x right, y down, z forward),
in metres -- or, in a scene whose scale is declared unknown, in the units of its calibration.
Every file is written atomically; every problem on reading raises `FormatError` naming the file
and the field.
"""

from __future__ import annotations

import math
import os
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import yaml
from pydantic import Field, field_validator, model_validator

from aida_kb.errors import FormatError
from aida_kb.io.atomic import make_dirs, write_text_atomic
from aida_kb.io.calib import (
    CALIB_ORTHONORMAL_TOL,
    FULL_BYTES_PER_PIXEL,
    WORKING_MAX_PIXELS,
    StereoCalib,
    memory_problem,
    nearest_rotation,
    read_calib,
    scaled_calib,
    working_scale,
    working_size,
    write_calib,
)
from aida_kb.io.images import read_depth, read_image, read_labels, write_npy, write_png
from aida_kb.io.jsonio import (
    FrozenModel,
    read_json_model,
    read_text_file,
    validate_model,
    write_json_model,
)
from aida_kb.io.model import Finite, Mat3, Vec3, ViewId
from aida_kb.io.truth import GroundTruth, PartTruth, PoseTruth, SceneTruth
from aida_kb.limits import (
    MAX_NESTING,
    MAX_VIEWS,
    MAX_YAML_BYTES,
    nesting_problem,
)

__all__ = [
    "CALIB_FILE",
    "CALIB_ORTHONORMAL_TOL",
    "FULL_BYTES_PER_PIXEL",
    "MIN_SCALE_PARALLAX_DEG",
    "SCENE_FILE",
    "SCENE_FORMAT",
    "SCENE_VERSION",
    "TRUTH_FILE",
    "WORKING_MAX_PIXELS",
    "BaselineScale",
    "DistanceScale",
    "GroundTruth",
    "PartTruth",
    "Pose",
    "PoseEntry",
    "PoseTruth",
    "ScaleEntry",
    "ScaleField",
    "ScaleKind",
    "Scene",
    "SceneIndex",
    "SceneTruth",
    "SceneView",
    "StereoCalib",
    "ViewData",
    "ViewEntry",
    "left_images",
    "memory_problem",
    "pose_entry",
    "read_calib",
    "read_depth",
    "read_image",
    "read_labels",
    "read_scene",
    "scaled_calib",
    "triangulate_pair",
    "working_scale",
    "working_size",
    "write_calib",
    "write_index",
    "write_scene",
]

SCENE_FORMAT = "aida-kb-scene"
SCENE_VERSION = 2
"""The version `write_scene` writes; version 1 (one rig for every view, metres) is still read."""
SCENE_FILE = "scene.yaml"
CALIB_FILE = "calib.yaml"
TRUTH_FILE = "truth.json"

FloatArray = npt.NDArray[np.float64]

# ---------------------------------------------------------------------------------------------
# scene.yaml


Vec2 = tuple[Finite, Finite]


class PoseEntry(FrozenModel):
    """A view's left-camera pose in the world: x_cam = R·x_world + t (t in scene units)."""

    R: Mat3
    t: Vec3


class ViewEntry(FrozenModel):
    """One view of scene.yaml: an id and its files, relative to the scene directory.

    Version 2 only: `calib`, the view's own stereo calibration (else the scene's), and `pose`,
    the left camera's pose in the world (view 00's is the identity by definition).
    """

    id: ViewId
    left: str = Field(min_length=1)
    right: str = Field(min_length=1)
    labels: str | None = None
    depth_left: str | None = None
    calib: str | None = None
    pose: PoseEntry | None = None


class BaselineScale(FrozenModel):
    """The scale from one known baseline: the distance between the two cameras of `view`."""

    view: ViewId
    metres: Finite = Field(gt=0)


class DistanceScale(FrozenModel):
    """The scale from one known distance between two points seen in both images of `view`.

    left, right : the two points' pixel positions (x, y) in the left and in the right image
    (original, distorted images, OpenCV pixel centres); metres : their true distance.
    """

    view: ViewId
    left: tuple[Vec2, Vec2]
    right: tuple[Vec2, Vec2]
    metres: Finite = Field(gt=0)


class ScaleEntry(FrozenModel):
    """scene.yaml `scale:` as a mapping: exactly one known length that fixes the scale."""

    baseline: BaselineScale | None = None
    distance: DistanceScale | None = None

    @model_validator(mode="after")
    def _one(self) -> ScaleEntry:
        if (self.baseline is None) == (self.distance is None):
            raise ValueError("give exactly one of baseline, distance")
        return self


ScaleField = Literal["metres", "unknown"] | ScaleEntry


class SceneIndex(FrozenModel):
    """The content of scene.yaml (version 1 or 2)."""

    format: Literal["aida-kb-scene"] = "aida-kb-scene"
    version: Literal[1, 2] = 1
    name: str = ""
    calib: str | None = CALIB_FILE
    scale: ScaleField = "metres"
    truth: str | None = None
    views: list[ViewEntry] = Field(min_length=1, max_length=MAX_VIEWS)

    @field_validator("views")
    @classmethod
    def _unique_ids(cls, views: list[ViewEntry]) -> list[ViewEntry]:
        ids = [v.id for v in views]
        dupes = sorted({i for i in ids if ids.count(i) > 1})
        if dupes:
            raise ValueError(f"view ids must be unique; repeated: {', '.join(dupes)}")
        return views

    @model_validator(mode="after")
    def _version_fields(self) -> SceneIndex:
        if self.version == 1:
            if self.scale != "metres":
                raise ValueError("scale: needs version 2")
            if self.calib is None:
                raise ValueError("calib: version 1 needs the scene's calibration")
            for i, v in enumerate(self.views):
                if v.calib is not None or v.pose is not None:
                    raise ValueError(f"views[{i}]: calib and pose need version 2")
        for i, v in enumerate(self.views):
            if v.calib is None and self.calib is None:
                raise ValueError(f"views[{i}].calib: missing (and the scene has no calib)")
        return self


# ---------------------------------------------------------------------------------------------
# the scene as a whole


Pose = tuple[FloatArray, FloatArray]
"""(R_cam_world (3, 3), t_cam_world (3,)): x_cam = R·x_world + t, t in the scene's units."""


@dataclass(frozen=True)
class SceneView:
    """One view of a scene: its id, absolute file paths (labels/depth may be absent), its
    stereo calibration, and its left camera's pose in the world if the scene gives it."""

    id: str
    left: Path
    right: Path
    labels: Path | None = None
    depth_left: Path | None = None
    calib: StereoCalib | None = None
    pose: Pose | None = None

    @property
    def rig(self) -> StereoCalib:
        """The view's stereo calibration (every view read by `read_scene` has one)."""
        if self.calib is None:
            raise FormatError(f"view {self.id}: has no stereo calibration")
        return self.calib


ScaleKind = Literal["metres", "unknown"]


@dataclass(frozen=True)
class Scene:
    """A scene directory as read by `read_scene`: calibration, views, optional ground truth.

    ``calib`` is the first view's calibration (every view's own is ``views[i].calib``).
    ``scale`` is "metres" when lengths are metres (given so, or fixed by one known length:
    ``scale_factor`` is the factor the file's translations were multiplied by), "unknown"
    when the scene is known up to scale only (structure from motion): lengths are then in
    the calibration's arbitrary units, and nothing derived from them is metric.
    ``files`` lists every file of the scene (scene.yaml, the calibrations, the view images,
    labels and depth maps, truth.json): the inputs no output may overwrite.
    """

    root: Path
    name: str
    calib: StereoCalib
    views: tuple[SceneView, ...]
    truth: SceneTruth | None = None
    files: tuple[Path, ...] = ()
    scale: ScaleKind = "metres"
    scale_factor: float = 1.0

    def view(self, view_id: str) -> SceneView:
        """The view with id `view_id` (KeyError if there is none)."""
        for v in self.views:
            if v.id == view_id:
                return v
        raise KeyError(view_id)

    @property
    def metric(self) -> bool:
        """Whether the scene's lengths are metres (False: known up to scale only)."""
        return self.scale == "metres"


class _IndexLoader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases: ``*a`` repeated builds exponentially large data
    (the 'billion laughs'), and scene.yaml has no use for them."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            mark = self.peek_event().start_mark  # type: ignore[no-untyped-call]
            where = f"{mark.line + 1}:{mark.column + 1}"
            raise yaml.YAMLError(f"{where}: aliases (*name) are not allowed")
        return super().compose_node(parent, index)


def _read_index(file: Path) -> SceneIndex:
    if not file.exists():
        raise FormatError(f"{file}: no such file (is {file.parent} a scene directory?)")
    text = read_text_file(file, MAX_YAML_BYTES)
    problem = nesting_problem(text, indentation=True)
    if problem is not None:
        raise FormatError(f"{file}:{problem}")
    try:
        data = yaml.load(text, Loader=_IndexLoader)
    except RecursionError:
        raise FormatError(f"{file}: nested more than {MAX_NESTING} deep") from None
    except ValueError as exc:  # e.g. an integer beyond Python's conversion limit
        raise FormatError(f"{file}: not valid YAML: {exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f":{mark.line + 1}:{mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc) or "syntax error"
        problem = problem.strip().splitlines()[0] if problem.strip() else "syntax error"
        raise FormatError(f"{file}{where}: not valid YAML: {problem}") from None
    if not isinstance(data, dict):
        raise FormatError(f"{file}: expected a mapping with fields format, version, views")
    return validate_model(SceneIndex, data, str(file))


def _resolve(root: Path, index_file: Path, field_name: str, rel: str) -> Path:
    path = Path(rel)
    if path.is_absolute() or ".." in path.parts:
        raise FormatError(
            f"{index_file}: field {field_name}: must be a path inside the scene directory: {rel}"
        )
    full = root / path
    try:
        exists = full.exists()
        resolved = full.resolve() if exists else full
        regular = full.is_file()
    except (OSError, ValueError) as exc:  # a name too long, a NUL byte ...
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise FormatError(f"{index_file}: field {field_name}: not a usable path: {why}") from None
    if not exists:
        raise FormatError(f"{index_file}: field {field_name}: file not found: {full}")
    # symlinks (of the file or of a folder on the way) must not lead out of the scene
    if not resolved.is_relative_to(root.resolve()):
        raise FormatError(
            f"{index_file}: field {field_name}: {rel} leads outside the scene directory "
            f"(to {resolved})"
        )
    if not regular:
        raise FormatError(f"{index_file}: field {field_name}: not a regular file: {full}")
    return full


def read_scene(directory: str | os.PathLike[str], *, with_truth: bool = True) -> Scene:
    """Read and validate a scene directory (scene.yaml, calib.yaml, truth.json if listed).

    Images are not loaded here (see `read_image`, `read_labels`, `read_depth`); their files must
    exist. Raises FormatError naming the file and the field on any problem.
    """
    root = Path(directory)
    if not root.is_dir():
        raise FormatError(f"{root}: not a directory (expected a scene directory)")
    index_file = root / SCENE_FILE
    index = _read_index(index_file)
    calibs: dict[str, tuple[Path, StereoCalib]] = {}

    def calib_of(field_name: str, rel: str) -> tuple[Path, StereoCalib]:
        if rel not in calibs:
            file = _resolve(root, index_file, field_name, rel)
            calib = read_calib(file)
            # before any image is decoded or any pyramid allocated: the run's memory
            over_budget = memory_problem(*calib.image_size)
            if over_budget is not None:
                raise FormatError(f"{file}: {over_budget}")
            calibs[rel] = (file, calib)
        return calibs[rel]

    if index.calib is not None:
        calib_of("calib", index.calib)
    views = []
    for i, v in enumerate(index.views):
        prefix = f"views[{i}]"
        if v.calib is not None:
            _, view_calib = calib_of(f"{prefix}.calib", v.calib)
        else:
            _, view_calib = calib_of("calib", index.calib or "")
        pose = None if v.pose is None else _pose(v.pose, index_file, f"{prefix}.pose", i)
        views.append(
            SceneView(
                id=v.id,
                left=_resolve(root, index_file, f"{prefix}.left", v.left),
                right=_resolve(root, index_file, f"{prefix}.right", v.right),
                labels=None
                if v.labels is None
                else _resolve(root, index_file, f"{prefix}.labels", v.labels),
                depth_left=None
                if v.depth_left is None
                else _resolve(root, index_file, f"{prefix}.depth_left", v.depth_left),
                calib=view_calib,
                pose=pose,
            )
        )
    for i, view in enumerate(views):
        if view.left.resolve() == view.right.resolve():
            raise FormatError(
                f"{index_file}: field views[{i}].right: the same file as the left image"
            )
    scale: ScaleKind = "unknown" if index.scale == "unknown" else "metres"
    factor = 1.0
    if isinstance(index.scale, ScaleEntry):
        factor = _scale_factor(index.scale, views, index_file)
        views = [_scaled(v, factor) for v in views]
    files = [index_file] + [f for f, _ in calibs.values()]
    files += [p for v in views for p in (v.left, v.right, v.labels, v.depth_left) if p]
    if index.truth is not None:
        files.append(root / index.truth)
    truth = None
    if with_truth and index.truth is not None:
        truth_file = _resolve(root, index_file, "truth", index.truth)
        truth = read_json_model(truth_file, SceneTruth)
        ids = {v.id for v in views}
        for j, pose_truth in enumerate(truth.views):
            if pose_truth.view not in ids:
                raise FormatError(
                    f"{truth_file}: field views[{j}].view: {pose_truth.view!r} is not a view "
                    f"of {index_file}"
                )
        labels = [p.label for p in truth.parts] + ([truth.ground.label] if truth.ground else [])
        if len(set(labels)) != len(labels):
            raise FormatError(f"{truth_file}: field parts: label ids must be unique")
    return Scene(
        root=root,
        name=index.name,
        calib=views[0].rig,
        views=tuple(views),
        truth=truth,
        files=tuple(files),
        scale=scale,
        scale_factor=factor,
    )


def _pose(entry: PoseEntry, index_file: Path, where: str, i: int) -> Pose:
    """The pose of scene.yaml's `where` as arrays; the rotation re-orthonormalised."""
    R = np.asarray(entry.R, dtype=np.float64)
    t = np.asarray(entry.t, dtype=np.float64)
    R = nearest_rotation(R, index_file, f"{where}.R")
    if i == 0 and (np.abs(R - np.eye(3)).max() > 1e-9 or np.abs(t).max() > 1e-12):
        raise FormatError(
            f"{index_file}: field {where}: view 00's left camera is the world frame; its pose "
            "must be the identity (R = I, t = 0) or be left out"
        )
    return R, t


def _scaled(view: SceneView, factor: float) -> SceneView:
    """`view` with every translation (the rig's T, the pose's t) multiplied by `factor`."""
    rig = view.rig
    calib = StereoCalib(
        K1=rig.K1, D1=rig.D1, K2=rig.K2, D2=rig.D2, R=rig.R, T=rig.T * factor,
        image_size=rig.image_size,
    )  # fmt: skip
    pose = None if view.pose is None else (view.pose[0], view.pose[1] * factor)
    return SceneView(
        id=view.id,
        left=view.left,
        right=view.right,
        labels=view.labels,
        depth_left=view.depth_left,
        calib=calib,
        pose=pose,
    )


MIN_SCALE_PARALLAX_DEG = 0.05
"""A known distance whose points' two rays meet at less than this angle is refused: their
triangulated depth (and so the scale) is undetermined. 0.05 deg is a disparity of about one
pixel at a focal length of 1,100 px."""


def triangulate_pair(calib: StereoCalib, left_px: FloatArray, right_px: FloatArray) -> FloatArray:
    """Points (N, 3), left camera frame, scene units, from pixels (N, 2) in both images.

    The pixels are of the original (distorted) images; the midpoint of the two rays' closest
    approach. Raises FormatError for rays that are parallel (to MIN_SCALE_PARALLAX_DEG) or
    meet behind a camera.
    """
    import cv2

    def rays(px: FloatArray, K: FloatArray, D: FloatArray) -> FloatArray:
        flat = cv2.undistortPoints(px.reshape(-1, 1, 2).astype(np.float64), K, D).reshape(-1, 2)
        d = np.column_stack([flat, np.ones(len(flat))])
        unit: FloatArray = d / np.linalg.norm(d, axis=1, keepdims=True)
        return unit

    d1 = rays(left_px, calib.K1, calib.D1)
    # right camera centre and rays in the left frame: x_left = R^T (x_right - T)
    c2 = -calib.R.T @ calib.T
    d2 = rays(right_px, calib.K2, calib.D2) @ calib.R
    cross = np.cross(d1, d2)
    sin = np.linalg.norm(cross, axis=1)
    if np.any(sin < math.sin(math.radians(MIN_SCALE_PARALLAX_DEG))):
        raise FormatError("the two rays of a point are parallel: no depth from this pair")
    # closest approach of the rays s·d1 and c2 + u·d2 (per point)
    b = np.einsum("ij,ij->i", d1, d2)
    d_ = -(d1 @ c2)
    e = -(d2 @ c2)
    denom = 1.0 - b * b
    s = (b * e - d_) / denom
    u = (e - b * d_) / denom
    if np.any(s <= 0) or np.any(u <= 0):
        raise FormatError("a point's rays meet behind a camera")
    mid: FloatArray = 0.5 * (d1 * s[:, None] + (c2 + d2 * u[:, None]))
    return mid


def _scale_factor(entry: ScaleEntry, views: Sequence[SceneView], index_file: Path) -> float:
    """The factor that turns the scene's units into metres, from its one known length."""
    known = entry.baseline or entry.distance
    assert known is not None  # the model's validator wants exactly one
    kind = "baseline" if entry.baseline is not None else "distance"
    match = [v for v in views if v.id == known.view]
    if not match:
        raise FormatError(f"{index_file}: field scale.{kind}.view: no view {known.view!r}")
    rig = match[0].rig
    if entry.distance is not None:
        try:
            pts = triangulate_pair(
                rig,
                np.asarray(entry.distance.left, dtype=np.float64),
                np.asarray(entry.distance.right, dtype=np.float64),
            )
        except FormatError as exc:
            raise FormatError(f"{index_file}: field scale.distance: {exc}") from None
        units = float(np.linalg.norm(pts[0] - pts[1]))
        if units <= 0:
            raise FormatError(f"{index_file}: field scale.distance: the two points coincide")
    else:
        units = rig.baseline_m
    return float(known.metres) / units


def left_images(
    scene: Scene, ids: Collection[str] | None = None
) -> dict[str, npt.NDArray[np.uint8]]:
    """View id -> its left image, 8-bit grey, as taken (of every view, or of those in `ids`)."""
    return {v.id: read_image(v.left, grey=True) for v in scene.views if ids is None or v.id in ids}


# ---------------------------------------------------------------------------------------------
# writing


@dataclass
class ViewData:
    """The images of one view to write: 8-bit left/right, optional labels and depth."""

    left: npt.NDArray[np.uint8]
    right: npt.NDArray[np.uint8]
    labels: npt.NDArray[np.uint16] | None = None
    depth_left: npt.NDArray[np.float32] | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    calib: StereoCalib | None = None
    """The view's own stereo calibration (written to views/NN/calib.yaml); None: the scene's."""
    pose: Pose | None = None
    """The left camera's (R_cam_world, t_cam_world), scene units; None: not known."""


def write_scene(
    directory: str | os.PathLike[str],
    calib: StereoCalib | None,
    views: Sequence[ViewData],
    *,
    truth: SceneTruth | None = None,
    name: str = "",
    view_ids: Sequence[str] | None = None,
    scale: ScaleField = "metres",
) -> Path:
    """Write a scene directory (version 2); every file atomically, scene.yaml last.

    calib : the scene's stereo rig (calib.yaml), or None when every view has its own.
    views : one `ViewData` per view; ids default to "00", "01", ... A view's own `calib` is
    written to views/NN/calib.yaml, its `pose` into scene.yaml.
    scale : "metres", "unknown" (translations in arbitrary units) or one known length.
    Returns the directory.
    """
    root = make_dirs(directory)
    ids = list(view_ids) if view_ids is not None else [f"{i:02d}" for i in range(len(views))]
    if len(ids) != len(views):
        raise FormatError(f"{root}: {len(ids)} view ids for {len(views)} views")
    entries = []
    for vid, view in zip(ids, views, strict=True):
        rig = view.calib or calib
        if rig is None:
            raise FormatError(
                f"{root}: view {vid}: no calibration (neither its own nor the scene's)"
            )
        width, height = rig.image_size
        for what, img in (("left", view.left), ("right", view.right)):
            if img.dtype != np.uint8 or img.shape[:2] != (height, width):
                raise FormatError(
                    f"{root}: view {vid}: {what} image must be uint8 of size {width}x{height}, "
                    f"got {img.dtype} {img.shape}"
                )
        base = Path("views") / vid
        write_png(root / base / "left.png", view.left)
        write_png(root / base / "right.png", view.right)
        labels_rel = depth_rel = calib_rel = None
        if view.labels is not None:
            labels_rel = (base / "labels.png").as_posix()
            write_png(root / labels_rel, np.asarray(view.labels, dtype=np.uint16))
        if view.depth_left is not None:
            depth_rel = (base / "depth_left.npy").as_posix()
            write_npy(root / depth_rel, np.asarray(view.depth_left, dtype=np.float32))
        if view.calib is not None:
            calib_rel = (base / CALIB_FILE).as_posix()
            write_calib(root / calib_rel, view.calib)
        pose = None if view.pose is None else pose_entry(view.pose)
        entries.append(
            ViewEntry(
                id=vid,
                left=(base / "left.png").as_posix(),
                right=(base / "right.png").as_posix(),
                labels=labels_rel,
                depth_left=depth_rel,
                calib=calib_rel,
                pose=pose,
            )
        )
    if calib is not None:
        write_calib(root / CALIB_FILE, calib)
    if truth is not None:
        write_json_model(root / TRUTH_FILE, truth)
    index = SceneIndex(
        version=SCENE_VERSION,
        name=name,
        calib=CALIB_FILE if calib is not None else None,
        scale=scale,
        truth=TRUTH_FILE if truth else None,
        views=entries,
    )
    write_index(root, index)
    return root


def write_index(root: Path, index: SceneIndex) -> None:
    """Write `index` as root/scene.yaml, atomically."""
    data = index.model_dump(exclude_none=True, mode="json")
    if data.get("calib") is None:
        data["calib"] = None  # explicit: no scene-wide calibration (else the default applies)
    text = "# aida-kb scene directory (see docs/formats.md)\n" + yaml.safe_dump(
        data, sort_keys=False
    )
    write_text_atomic(root / SCENE_FILE, text)


def pose_entry(pose: Pose) -> PoseEntry:
    """The scene.yaml entry of a pose (R (3, 3), t (3,))."""
    R, t = pose
    return PoseEntry(
        R=tuple(tuple(float(x) for x in row) for row in np.asarray(R).reshape(3, 3)),
        t=tuple(float(x) for x in np.asarray(t).ravel()),
    )
