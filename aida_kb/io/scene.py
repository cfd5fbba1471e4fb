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

import contextlib
import math
import os
import sys
from collections.abc import Collection, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from tokenize import TokenError
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import yaml
from pydantic import Field, field_validator, model_validator

from aida_kb.errors import FormatError
from aida_kb.io.atomic import atomic_path, make_dirs, write_text_atomic
from aida_kb.io.jsonio import (
    FrozenModel,
    read_json_model,
    validate_model,
    write_json_model,
)
from aida_kb.io.model import Finite, Mat3, Vec3, ViewId, check_camera
from aida_kb.limits import (
    BYTES_PER_PIXEL,
    MAX_CALIB_BYTES,
    MAX_IMAGE_BYTES,
    MAX_NESTING,
    MAX_VIEWS,
    MAX_YAML_BYTES,
    MEMORY_BUDGET_ENV,
    image_header_size,
    image_size_problem,
    memory_budget,
    nesting_problem,
    read_limited,
)

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
# truth.json


def _unit(n: Vec3, what: str) -> Vec3:
    norm = math.sqrt(sum(c * c for c in n))
    if abs(norm - 1.0) > 1e-6:
        raise ValueError(f"{what} must have unit length (has {norm:.6g})")
    return n


class PartTruth(FrozenModel):
    """One planar face of the synthetic object, in world coordinates (metres).

    `normal` is the unit normal pointing out of the solid; the plane is normal·x = d.
    `polygon` lists the face's vertices in order, counter-clockwise seen from outside.
    `label` is the id used for this part in views/NN/labels.png.
    """

    role: str = Field(min_length=1)
    concept: str = Field(min_length=1)
    label: int = Field(ge=1, le=65535)
    material: str = ""
    normal: Vec3
    d: Finite
    polygon: list[Vec3] = Field(min_length=3)

    @field_validator("normal")
    @classmethod
    def _unit_normal(cls, n: Vec3) -> Vec3:
        return _unit(n, "normal")


class GroundTruth(FrozenModel):
    """The ground plane (not a part of the object): normal·x = d, normal pointing up (out)."""

    label: int = Field(ge=1, le=65535)
    normal: Vec3
    d: Finite

    @field_validator("normal")
    @classmethod
    def _unit_normal(cls, n: Vec3) -> Vec3:
        return _unit(n, "normal")


class PoseTruth(FrozenModel):
    """The left camera of one view: x_cam = R·x_world + t, pixels = K·x_cam (before distortion)."""

    view: ViewId
    K: Mat3
    R: Mat3
    t: Vec3

    @model_validator(mode="after")
    def _camera(self) -> PoseTruth:
        check_camera(self.K, self.R)
        return self


class SceneTruth(FrozenModel):
    """The content of truth.json (synthetic scenes only)."""

    version: Literal[1] = 1
    object: str = Field(min_length=1, description="scene concept, e.g. House or ReferenceObject")
    parts: list[PartTruth]
    ground: GroundTruth | None = None
    views: list[PoseTruth]
    parameters: dict[str, float | str | bool] = Field(default_factory=dict)
    concepts: dict[str, str] = Field(
        default_factory=dict,
        description="role path -> the concept it must be specialised to (e.g. the roof's kind)",
    )

    def part(self, role: str) -> PartTruth:
        """The part with role path `role` (KeyError if there is none)."""
        for p in self.parts:
            if p.role == role:
                return p
        raise KeyError(role)

    def pose(self, view: str) -> PoseTruth:
        """The left-camera pose of view `view` (KeyError if there is none)."""
        for v in self.views:
            if v.view == view:
                return v
        raise KeyError(view)


# ---------------------------------------------------------------------------------------------
# calib.yaml


_D_LENGTHS = (4, 5, 8, 12, 14)


@dataclass(frozen=True)
class StereoCalib:
    """A calibrated stereo rig in OpenCV's stereoCalibrate conventions.

    K1, K2 : (3, 3) camera matrices, pixels. D1, D2 : (5,) distortion k1 k2 p1 p2 k3 (or any
    length OpenCV accepts: 4, 5, 8, 12, 14). R : (3, 3) and T : (3,) metres, mapping left-camera
    to right-camera coordinates, x_right = R·x_left + T. image_size : (width, height), pixels.
    """

    K1: FloatArray
    D1: FloatArray
    K2: FloatArray
    D2: FloatArray
    R: FloatArray
    T: FloatArray
    image_size: tuple[int, int]

    def __post_init__(self) -> None:
        sizes = {"K1": (9,), "D1": _D_LENGTHS, "K2": (9,), "D2": _D_LENGTHS, "R": (9,), "T": (3,)}
        for name, allowed in sizes.items():
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if arr.size not in allowed:
                raise FormatError(f"stereo calibration: field {name}: has {arr.size} elements")
            if not np.all(np.isfinite(arr)):
                raise FormatError(f"stereo calibration: field {name}: contains NaN or infinity")
        w, h = self.image_size
        if not (int(w) == w > 0 and int(h) == h > 0):
            raise FormatError(f"stereo calibration: image size {w}x{h} is not positive pixels")

    @property
    def baseline_m(self) -> float:
        """Distance between the two camera centres, metres."""
        return float(np.linalg.norm(self.T))


# Photos of 12-24 megapixels are matched at a working resolution of at most this many pixels
# (about 1730x1150 at 3:2): dense matching costs pixels x disparities, i.e. grows with the
# 1.5th power of the pixels (a 24 MP pair at full size: about 60 times the work and 7 GB of
# cost volumes), while the evidence needs plane normals, which come from thousands of pixels
# per face even at this size (the real scenes' walls within 0.7 deg at 0.7 MP). Line segments
# are still found on the full image, whose pixels the evidence is given in.
WORKING_MAX_PIXELS = 2_000_000


def working_scale(width: int, height: int) -> float:
    """The factor (<= 1) that takes a `width` x `height` image to the working resolution."""
    pixels = width * height
    return 1.0 if pixels <= WORKING_MAX_PIXELS else math.sqrt(WORKING_MAX_PIXELS / pixels)


def working_size(width: int, height: int) -> tuple[int, int]:
    """(width, height) of a `width` x `height` image at the working resolution."""
    s = working_scale(width, height)
    return (width, height) if s == 1.0 else (max(1, round(width * s)), max(1, round(height * s)))


# Peak memory per pixel of the FULL images beyond the working resolution's BYTES_PER_PIXEL
# (aida_kb.limits): the images themselves, the line segments found on them and the depth and
# region maps given back in their pixels. benchmarks/real.py measured a 17.5-megapixel pair
# (working 1732x1155) at a peak of 1.47 GB: 0.6 GB for the working size, 50 bytes a full pixel.
FULL_BYTES_PER_PIXEL = 60


def memory_problem(width: int, height: int) -> str | None:
    """Why a scene of `width` x `height` images is over the memory budget of a run, or None
    (the working resolution's cost and the full images', see FULL_BYTES_PER_PIXEL)."""
    ww, wh = working_size(width, height)
    need = BYTES_PER_PIXEL * ww * wh + FULL_BYTES_PER_PIXEL * width * height
    budget = memory_budget()
    if need <= budget:
        return None
    return (
        f"images of {width}x{height} pixels need about {need / 2**30:.1f} GiB "
        f"(matched at {ww}x{wh}), more than the memory budget of "
        f"{budget / 2**30:.1f} GiB (set {MEMORY_BUDGET_ENV} to change it)"
    )


def scaled_calib(calib: StereoCalib, size: tuple[int, int]) -> StereoCalib:
    """`calib` for its images resampled to `size` (width, height): K rows scaled about pixel
    centres at integer coordinates (c' = (c + 0.5)·s - 0.5), distortion and pose unchanged."""
    W, H = calib.image_size
    sx, sy = size[0] / W, size[1] / H

    def scale(K: FloatArray) -> FloatArray:
        out = np.array(K, dtype=np.float64)
        out[0, :] *= sx
        out[1, :] *= sy
        out[0, 2] += 0.5 * sx - 0.5
        out[1, 2] += 0.5 * sy - 0.5
        return out

    return replace(calib, K1=scale(calib.K1), K2=scale(calib.K2), image_size=size)


def write_calib(path: str | os.PathLike[str], calib: StereoCalib) -> None:
    """Write `calib` with cv2.FileStorage (YAML), atomically."""
    import cv2

    target = Path(path)
    with atomic_path(target) as tmp:
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
        try:
            fs.write("image_width", int(calib.image_size[0]))
            fs.write("image_height", int(calib.image_size[1]))
            fs.write("K1", np.asarray(calib.K1, dtype=np.float64).reshape(3, 3))
            fs.write("D1", np.asarray(calib.D1, dtype=np.float64).reshape(1, -1))
            fs.write("K2", np.asarray(calib.K2, dtype=np.float64).reshape(3, 3))
            fs.write("D2", np.asarray(calib.D2, dtype=np.float64).reshape(1, -1))
            fs.write("R", np.asarray(calib.R, dtype=np.float64).reshape(3, 3))
            fs.write("T", np.asarray(calib.T, dtype=np.float64).reshape(3, 1))
        finally:
            fs.release()


def _calib_matrix(fs: Any, file: Path, name: str, sizes: tuple[int, ...]) -> FloatArray:
    import cv2

    node = fs.getNode(name)
    if node.empty():
        raise FormatError(f"{file}: field {name}: missing")
    if not node.isMap():
        raise FormatError(f"{file}: field {name}: not a matrix (expected an opencv-matrix)")
    try:
        mat = node.mat()
    except cv2.error:  # e.g. a truncated file: the node lacks its dt or data entries
        raise FormatError(
            f"{file}: field {name}: malformed opencv-matrix (needs rows, cols, dt and data)"
        ) from None
    if mat is None:
        raise FormatError(f"{file}: field {name}: not a matrix (expected an opencv-matrix)")
    arr = np.asarray(mat, dtype=np.float64)
    if arr.size not in sizes:
        want = " or ".join(str(s) for s in sizes)
        raise FormatError(f"{file}: field {name}: has {arr.size} elements, expected {want}")
    if not np.all(np.isfinite(arr)):
        raise FormatError(f"{file}: field {name}: contains NaN or infinite values")
    return arr


def _calib_int(fs: Any, file: Path, name: str) -> int:
    node = fs.getNode(name)
    if node.empty():
        raise FormatError(f"{file}: field {name}: missing")
    if not node.isInt():
        raise FormatError(f"{file}: field {name}: expected a positive integer")
    value = int(node.real())
    if value <= 0:
        raise FormatError(f"{file}: field {name}: expected a positive integer, got {value}")
    return value


# A rotation written with 6 significant digits (Strecha's .camera files, many text exports) is
# orthonormal only to about 1e-6; the cameras built from it want 1e-9. Such an R is replaced by
# the nearest rotation (SVD), which moves it by no more than its own rounding. 1e-4 admits
# rotations rounded to 5 digits or more (an angle error below 0.01 deg); an R further from
# orthonormal is not a rounded rotation and is refused.
CALIB_ORTHONORMAL_TOL = 1e-4


def _nearest_rotation(R: FloatArray, file: Path, name: str = "R") -> FloatArray:
    """The rotation nearest to R (3, 3) (Frobenius norm), or FormatError naming `file`.

    R must be orthonormal to CALIB_ORTHONORMAL_TOL (max |R R^T - I|) and have det > 0.
    """
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > CALIB_ORTHONORMAL_TOL or np.linalg.det(R) <= 0:
        raise FormatError(
            f"{file}: field {name}: not a rotation matrix (max |R R^T - I| = {err:.2g}, tolerance "
            f"{CALIB_ORTHONORMAL_TOL:g}; det {np.linalg.det(R):.6g}, must be +1)"
        )
    U, _, Vt = np.linalg.svd(R)
    nearest: FloatArray = U @ Vt
    return nearest


def read_calib(path: str | os.PathLike[str]) -> StereoCalib:
    """Read a calib.yaml (or .xml/.json) written by cv2.FileStorage; validate every field."""
    import cv2

    file = Path(path)
    if not file.exists():
        raise FormatError(f"{file}: no such file")
    # OpenCV's parser recurses per level (50,000 levels: SIGSEGV): size and nesting first
    text = _read_text(file, MAX_CALIB_BYTES)
    problem = nesting_problem(text, indentation=True, xml=True)
    if problem is not None:
        raise FormatError(f"{file}:{problem}")
    try:
        fs = cv2.FileStorage(str(file), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:
        cause = exc.__cause__ or exc.__context__ or exc
        text = str(cause).strip()
        msg = text.splitlines()[-1] if text else "parse error"
        raise FormatError(f"{file}: not a cv2.FileStorage file: {msg}") from None
    try:
        if not fs.isOpened():
            raise FormatError(f"{file}: cannot be opened by cv2.FileStorage")
        width = _calib_int(fs, file, "image_width")
        height = _calib_int(fs, file, "image_height")
        K1 = _calib_matrix(fs, file, "K1", (9,)).reshape(3, 3)
        D1 = _calib_matrix(fs, file, "D1", _D_LENGTHS).ravel()
        K2 = _calib_matrix(fs, file, "K2", (9,)).reshape(3, 3)
        D2 = _calib_matrix(fs, file, "D2", _D_LENGTHS).ravel()
        R = _calib_matrix(fs, file, "R", (9,)).reshape(3, 3)
        T = _calib_matrix(fs, file, "T", (3,)).ravel()
    except cv2.error as exc:  # a truncated or hand-edited matrix node
        last = (str(exc).strip().splitlines() or ["parse error"])[-1]
        raise FormatError(f"{file}: malformed cv2.FileStorage content: {last}") from None
    finally:
        fs.release()
    for name, K in (("K1", K1), ("K2", K2)):
        if (
            K[0, 0] <= 0
            or K[1, 1] <= 0
            or abs(K[2, 2] - 1.0) > 1e-9
            or np.any(K[2, :2] != 0)
            or K[1, 0] != 0
        ):
            raise FormatError(
                f"{file}: field {name}: not a camera matrix "
                "(need [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0)"
            )
    R = _nearest_rotation(R, file)
    if np.linalg.norm(T) <= 0:
        raise FormatError(f"{file}: field T: zero baseline")
    return StereoCalib(K1=K1, D1=D1, K2=K2, D2=D2, R=R, T=T, image_size=(width, height))


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


def _read_text(file: Path, limit: int) -> str:
    """The UTF-8 text of `file` (a regular file of at most `limit` bytes); FormatError."""
    try:
        return read_limited(file, limit).decode("utf-8")
    except FileNotFoundError:
        raise FormatError(f"{file}: no such file") from None
    except OSError as exc:
        raise FormatError(f"{file}: cannot be read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise FormatError(f"{file}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


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
    text = _read_text(file, MAX_YAML_BYTES)
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
    R = _nearest_rotation(R, index_file, f"{where}.R")
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


def _existing_file(file: Path) -> Path:
    """`file`, or a FormatError saying that there is none (before OpenCV logs its own)."""
    if not file.is_file():
        raise FormatError(f"{file}: no such file" if not file.exists() else f"{file}: not a file")
    return file


def _image_bytes(file: Path) -> npt.NDArray[np.uint8]:
    """The encoded bytes of an image file whose header size is within the limits.

    A regular file of at most `MAX_IMAGE_BYTES`; PNG, JPEG, BMP and PNM headers are read
    before anything is decoded (a 20000x15000 PNG is refused unread), other formats are
    checked once decoded (`_decoded`).
    """
    _existing_file(file)
    try:
        data = read_limited(file, MAX_IMAGE_BYTES)
    except OSError as exc:
        raise FormatError(f"{file}: cannot be read: {exc.strerror or exc}") from None
    size = image_header_size(data)
    problem = None if size is None else image_size_problem(*size)
    if problem is not None:
        raise FormatError(f"{file}: {problem}")
    return np.frombuffer(data, np.uint8)


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence file descriptor 2 (libpng and libjpeg print their own lines on a broken file;
    the one-line FormatError says it instead)."""
    try:
        saved = os.dup(2)
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # no descriptor to spare: let the libraries speak
        yield
        return
    try:
        sys.stderr.flush()
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def _decoded(file: Path, data: npt.NDArray[np.uint8], flags: int) -> npt.NDArray[Any]:
    import cv2

    with _quiet_stderr():
        img = cv2.imdecode(data, flags) if data.size else None
    if img is None:
        raise FormatError(f"{file}: not a readable image")
    problem = image_size_problem(img.shape[1], img.shape[0])
    if problem is not None:
        raise FormatError(f"{file}: {problem}")
    return np.asarray(img)


def left_images(
    scene: Scene, ids: Collection[str] | None = None
) -> dict[str, npt.NDArray[np.uint8]]:
    """View id -> its left image, 8-bit grey, as taken (of every view, or of those in `ids`)."""
    return {v.id: read_image(v.left, grey=True) for v in scene.views if ids is None or v.id in ids}


def read_image(path: str | os.PathLike[str], *, grey: bool = False) -> npt.NDArray[np.uint8]:
    """Load an 8-bit view image: (H, W) if grey, else (H, W, 3) BGR (grey files are expanded)."""
    import cv2

    file = Path(path)
    data = _image_bytes(file)
    # look at the stored depth first: IMREAD_COLOR would silently scale 16 bits down to 8
    raw = _decoded(file, data, cv2.IMREAD_UNCHANGED)
    if raw.dtype != np.uint8:
        raise FormatError(f"{file}: expected an 8-bit image, got {raw.dtype}")
    del raw
    img = _decoded(file, data, cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR)
    return np.asarray(img, dtype=np.uint8)


def read_labels(path: str | os.PathLike[str]) -> npt.NDArray[np.uint16]:
    """Load a 16-bit label image (H, W); 0 = unlabelled."""
    import cv2

    file = Path(path)
    img = _decoded(file, _image_bytes(file), cv2.IMREAD_UNCHANGED)
    if img.ndim != 2:
        raise FormatError(f"{file}: a label image must have one channel, has {img.shape[2]}")
    if img.dtype not in (np.uint16, np.uint8):
        raise FormatError(f"{file}: a label image must be 8- or 16-bit, got {img.dtype}")
    return np.asarray(img, dtype=np.uint16)


def read_depth(path: str | os.PathLike[str]) -> npt.NDArray[np.float32]:
    """Load a depth map (H, W) float32, metres along the left camera's z axis, NaN = none."""
    file = Path(path)
    try:
        # the header first: a shape beyond the image limit is refused before the array is read
        with _existing_file(file).open("rb") as fh:
            fmt = np.lib.format
            version = fmt.read_magic(fh)
            read_header = (
                fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
            )
            shape, _, _ = read_header(fh)
    except (OSError, ValueError, SyntaxError, TokenError) as exc:  # numpy parses the header
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise FormatError(f"{file}: not a numpy .npy array: {why}") from None
    if len(shape) == 2:
        problem = image_size_problem(shape[1], shape[0])
        if problem is not None:
            raise FormatError(f"{file}: {problem}")
    try:
        arr = np.load(file, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise FormatError(f"{file}: not a numpy .npy array: {exc}") from None
    if arr.ndim != 2 or arr.dtype != np.float32:
        raise FormatError(
            f"{file}: expected a 2-D float32 depth map, got {arr.dtype} of shape {arr.shape}"
        )
    known = arr[~np.isnan(arr)]
    if known.size and not (np.all(np.isfinite(known)) and known.min() > 0):
        raise FormatError(f"{file}: depths must be positive finite metres (NaN = no surface)")
    return np.asarray(arr, dtype=np.float32)


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


def _write_png(path: Path, image: npt.NDArray[Any]) -> None:
    import cv2

    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), image, [cv2.IMWRITE_PNG_COMPRESSION, 3]):
            raise FormatError(f"{path}: could not be written as PNG")


def _write_npy(path: Path, array: npt.NDArray[Any]) -> None:
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        np.save(fh, array, allow_pickle=False)


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
        _write_png(root / base / "left.png", view.left)
        _write_png(root / base / "right.png", view.right)
        labels_rel = depth_rel = calib_rel = None
        if view.labels is not None:
            labels_rel = (base / "labels.png").as_posix()
            _write_png(root / labels_rel, np.asarray(view.labels, dtype=np.uint16))
        if view.depth_left is not None:
            depth_rel = (base / "depth_left.npy").as_posix()
            _write_npy(root / depth_rel, np.asarray(view.depth_left, dtype=np.float32))
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
