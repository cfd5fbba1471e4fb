"""COLMAP sparse models (cameras, images, points3D; text or binary) and stereo views from them.

A reader of the formats COLMAP documents (``doc/format.rst``: cameras.txt / images.txt /
points3D.txt, and the little-endian .bin files its ``model_converter`` writes), and
`stereo_views`: the pairs of registered images that make usable stereo views, with each pair's
rig (intrinsics of both images, relative pose) and the left camera's pose in the world.

Conventions converted here: COLMAP puts the centre of the top-left pixel at (0.5, 0.5), OpenCV
(and aida-kb) at (0, 0), so a principal point moves by -0.5 px; an image's pose is
``x_cam = R(q)·x_world + t`` with the unit quaternion q = (qw, qx, qy, qz), as in aida-kb.
Only the pinhole models with OpenCV's polynomial distortion are read (SIMPLE_PINHOLE,
PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV); a fisheye or FOV camera is refused, named.
A model's translations are in the units of its reconstruction: structure from motion has no
scale (see the scene format's ``scale``).
"""

from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aida_kb.errors import FormatError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

MAX_COLMAP_BYTES = 1 << 30
"""A model file larger than 1 GiB is refused (a points3D file of some 10 million points)."""

# name -> (binary model id, number of parameters); COLMAP's own table (its camera_models.h)
CAMERA_MODELS: dict[str, tuple[int, int]] = {
    "SIMPLE_PINHOLE": (0, 3),
    "PINHOLE": (1, 4),
    "SIMPLE_RADIAL": (2, 4),
    "RADIAL": (3, 5),
    "OPENCV": (4, 8),
    "OPENCV_FISHEYE": (5, 8),
    "FULL_OPENCV": (6, 12),
    "FOV": (7, 5),
    "SIMPLE_RADIAL_FISHEYE": (8, 4),
    "RADIAL_FISHEYE": (9, 5),
    "THIN_PRISM_FISHEYE": (10, 12),
}
MODEL_NAMES = {mid: name for name, (mid, _) in CAMERA_MODELS.items()}
PINHOLE_MODELS = ("SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV", "FULL_OPENCV")

COLMAP_PIXEL_OFFSET = 0.5
"""COLMAP's pixel centre of the top-left pixel is (0.5, 0.5), OpenCV's (0, 0)."""


@dataclass(frozen=True)
class ColmapCamera:
    """One camera of cameras.txt/.bin: model name, image size (pixels), parameters."""

    id: int
    model: str
    width: int
    height: int
    params: tuple[float, ...]

    def opencv(self) -> tuple[FloatArray, FloatArray]:
        """(K (3, 3), D (5,) or (8,)) in OpenCV's conventions (pixel centre (0, 0))."""
        p = self.params
        if self.model in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
            fx = fy = p[0]
            cx, cy = p[1], p[2]
            k = list(p[3:]) + [0.0] * (2 - len(p[3:]))
            D = np.array([k[0], k[1], 0.0, 0.0, 0.0])
        elif self.model in ("PINHOLE", "OPENCV"):
            fx, fy, cx, cy = p[:4]
            rest = list(p[4:]) + [0.0] * (4 - len(p[4:]))
            D = np.array([rest[0], rest[1], rest[2], rest[3], 0.0])
        else:  # FULL_OPENCV: k1 k2 p1 p2 k3 k4 k5 k6, OpenCV's 8-coefficient order
            fx, fy, cx, cy = p[:4]
            D = np.array(p[4:12], dtype=np.float64)
        K = np.array(
            [
                [fx, 0.0, cx - COLMAP_PIXEL_OFFSET],
                [0.0, fy, cy - COLMAP_PIXEL_OFFSET],
                [0.0, 0.0, 1.0],
            ]
        )
        return K, D


@dataclass(frozen=True)
class ColmapImage:
    """One registered image: pose x_cam = R·x_world + t, its camera, file name, 2-D points.

    xy : (N, 2) keypoints, COLMAP pixels; point_ids : (N,) the 3-D point of each, -1 none.
    """

    id: int
    R: FloatArray
    t: FloatArray
    camera_id: int
    name: str
    xy: FloatArray
    point_ids: IntArray

    @property
    def centre(self) -> FloatArray:
        """The camera centre (3,), world frame, model units."""
        c: FloatArray = -self.R.T @ self.t
        return c


@dataclass(frozen=True)
class ColmapModel:
    """A sparse model: cameras and images by id; points (P, 3), world frame, model units."""

    root: Path
    cameras: dict[int, ColmapCamera]
    images: dict[int, ColmapImage]
    point_ids: IntArray
    points: FloatArray

    def image_named(self, name: str) -> ColmapImage:
        """The image whose file name is `name` (KeyError if none)."""
        for image in self.images.values():
            if image.name == name:
                return image
        raise KeyError(name)


def quaternion_to_rotation(q: FloatArray) -> FloatArray:
    """The rotation (3, 3) of the quaternion q = (w, x, y, z) (normalised first)."""
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotation_to_quaternion(R: FloatArray) -> FloatArray:
    """The unit quaternion (w, x, y, z), w >= 0, of the rotation R (3, 3)."""
    m = np.asarray(R, dtype=np.float64)
    # the largest of the four squared components first, for accuracy
    trace = np.trace(m)
    cands = np.array([trace, m[0, 0], m[1, 1], m[2, 2]])
    k = int(np.argmax(cands))
    if k == 0:
        s = math.sqrt(1.0 + trace) * 2
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif k == 1:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif k == 2:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    out = np.array(q)
    out /= np.linalg.norm(out)
    return out if out[0] >= 0 else -out


# ---------------------------------------------------------------------------------------------
# reading


def _file_bytes(file: Path) -> bytes:
    try:
        size = file.stat().st_size
    except OSError as exc:
        raise FormatError(f"{file}: cannot be read: {exc.strerror or exc}") from None
    if size > MAX_COLMAP_BYTES:
        raise FormatError(f"{file}: {size} bytes, more than the limit of {MAX_COLMAP_BYTES}")
    try:
        return file.read_bytes()
    except OSError as exc:
        raise FormatError(f"{file}: cannot be read: {exc.strerror or exc}") from None


def _camera(
    file: Path, where: str, cid: int, model: str, w: int, h: int, params: list[float]
) -> ColmapCamera:
    if model not in CAMERA_MODELS:
        raise FormatError(f"{file}{where}: camera {cid}: unknown camera model {model!r}")
    want = CAMERA_MODELS[model][1]
    if len(params) != want:
        raise FormatError(
            f"{file}{where}: camera {cid}: model {model} has {want} parameters, got {len(params)}"
        )
    if model not in PINHOLE_MODELS:
        raise FormatError(
            f"{file}{where}: camera {cid}: model {model} is not supported (only the pinhole "
            f"models with OpenCV's distortion: {', '.join(PINHOLE_MODELS)}); undistort the "
            "images with COLMAP's image_undistorter first"
        )
    if w <= 0 or h <= 0:
        raise FormatError(f"{file}{where}: camera {cid}: image size {w}x{h} is not positive")
    if not all(math.isfinite(p) for p in params) or params[0] <= 0:
        raise FormatError(f"{file}{where}: camera {cid}: parameters must be finite, focal > 0")
    if model in ("PINHOLE", "OPENCV", "FULL_OPENCV") and params[1] <= 0:
        raise FormatError(f"{file}{where}: camera {cid}: focal length fy must be > 0")
    return ColmapCamera(cid, model, w, h, tuple(params))


def _image(
    file: Path, where: str, iid: int, q: list[float], t: list[float], cid: int, name: str,
    xy: FloatArray, pids: IntArray,
) -> ColmapImage:  # fmt: skip
    qa = np.array(q, dtype=np.float64)
    if not (np.all(np.isfinite(qa)) and np.all(np.isfinite(t))):
        raise FormatError(f"{file}{where}: image {iid}: pose must be finite numbers")
    norm = float(np.linalg.norm(qa))
    if abs(norm - 1.0) > QUATERNION_NORM_TOL:
        raise FormatError(f"{file}{where}: image {iid}: quaternion has length {norm:.6g}, not 1")
    if not name:
        raise FormatError(f"{file}{where}: image {iid}: no file name")
    return ColmapImage(
        iid, quaternion_to_rotation(qa), np.array(t, dtype=np.float64), cid, name, xy, pids
    )


QUATERNION_NORM_TOL = 1e-3
"""A pose quaternion must have unit length to this (text files round to some 6-17 digits; a
length further off is not a rotation written by COLMAP)."""


def _text_lines(file: Path) -> list[tuple[int, str]]:
    """(line number, text) of the non-comment, non-blank lines of a text model file."""
    try:
        text = _file_bytes(file).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FormatError(f"{file}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    return [
        (i + 1, line.strip())
        for i, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("#")
    ]


def _numbers(file: Path, lineno: int, tokens: list[str], what: str) -> list[float]:
    try:
        values = [float(tok) for tok in tokens]
    except ValueError:
        raise FormatError(
            f"{file}:{lineno}: {what}: expected numbers, got {' '.join(tokens)[:60]!r}"
        ) from None
    return values


def _int(file: Path, lineno: int, token: str, what: str) -> int:
    try:
        return int(token)
    except ValueError:
        raise FormatError(
            f"{file}:{lineno}: {what}: expected an integer, got {token[:30]!r}"
        ) from None


def _read_cameras_text(file: Path) -> dict[int, ColmapCamera]:
    cameras: dict[int, ColmapCamera] = {}
    for lineno, line in _text_lines(file):
        tok = line.split()
        if len(tok) < 5:
            raise FormatError(f"{file}:{lineno}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]")
        cid = _int(file, lineno, tok[0], "CAMERA_ID")
        w, h = _int(file, lineno, tok[2], "WIDTH"), _int(file, lineno, tok[3], "HEIGHT")
        params = _numbers(file, lineno, tok[4:], "PARAMS")
        if cid in cameras:
            raise FormatError(f"{file}:{lineno}: camera {cid} given twice")
        cameras[cid] = _camera(file, f":{lineno}", cid, tok[1], w, h, params)
    return cameras


def _read_images_text(file: Path) -> dict[int, ColmapImage]:
    lines = _text_lines(file)
    images: dict[int, ColmapImage] = {}
    i = 0
    while i < len(lines):
        lineno, line = lines[i]
        tok = line.split()
        if len(tok) < 10:
            raise FormatError(
                f"{file}:{lineno}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME"
            )
        iid = _int(file, lineno, tok[0], "IMAGE_ID")
        pose = _numbers(file, lineno, tok[1:8], "QW QX QY QZ TX TY TZ")
        cid = _int(file, lineno, tok[8], "CAMERA_ID")
        name = " ".join(tok[9:])
        # the points line may be empty (then it is blank and was dropped: the next line is
        # an image line again, which has a different length pattern)
        xy = np.zeros((0, 2))
        pids = np.zeros(0, dtype=np.int64)
        if i + 1 < len(lines) and not _looks_like_image_line(lines[i + 1][1]):
            plineno, pline = lines[i + 1]
            ptok = pline.split()
            if len(ptok) % 3:
                raise FormatError(f"{file}:{plineno}: expected triples X Y POINT3D_ID")
            vals = _numbers(file, plineno, ptok, "POINTS2D")
            arr = np.array(vals, dtype=np.float64).reshape(-1, 3)
            xy = arr[:, :2]
            pids = arr[:, 2].astype(np.int64)
            i += 1
        if iid in images:
            raise FormatError(f"{file}:{lineno}: image {iid} given twice")
        images[iid] = _image(file, f":{lineno}", iid, pose[:4], pose[4:7], cid, name, xy, pids)
        i += 1
    return images


def _looks_like_image_line(line: str) -> bool:
    """An image line: an integer, seven numbers, an integer, then a name (not a number)."""
    tok = line.split()
    if len(tok) < 10:
        return False
    try:
        int(tok[0])
        [float(x) for x in tok[1:8]]
        int(tok[8])
    except ValueError:
        return False
    try:
        float(tok[9])
    except ValueError:
        return True
    return False


def _read_points_text(file: Path) -> tuple[IntArray, FloatArray]:
    ids: list[int] = []
    xyz: list[list[float]] = []
    for lineno, line in _text_lines(file):
        tok = line.split()
        if len(tok) < 8:
            raise FormatError(f"{file}:{lineno}: expected POINT3D_ID X Y Z R G B ERROR TRACK[]")
        ids.append(_int(file, lineno, tok[0], "POINT3D_ID"))
        p = _numbers(file, lineno, tok[1:4], "X Y Z")
        if not all(math.isfinite(v) for v in p):
            raise FormatError(f"{file}:{lineno}: point {ids[-1]}: coordinates must be finite")
        xyz.append(p)
    return np.array(ids, dtype=np.int64), np.array(xyz, dtype=np.float64).reshape(-1, 3)


class _Reader:
    """Little-endian records from a binary model file, each read naming the file and offset."""

    def __init__(self, file: Path) -> None:
        self.file = file
        self.data = _file_bytes(file)
        self.pos = 0

    def take(self, fmt: str, what: str) -> tuple[float | int, ...]:
        size = struct.calcsize("<" + fmt)
        if self.pos + size > len(self.data):
            raise FormatError(f"{self.file}: truncated at byte {self.pos} (reading {what})")
        values = struct.unpack_from("<" + fmt, self.data, self.pos)
        self.pos += size
        return tuple(values)

    def array(self, dtype: str, count: int, what: str) -> npt.NDArray[np.void]:
        dt = np.dtype(dtype)
        size = dt.itemsize * count
        if count < 0 or self.pos + size > len(self.data):
            raise FormatError(f"{self.file}: truncated at byte {self.pos} (reading {what})")
        arr = np.frombuffer(self.data, dtype=dt, count=count, offset=self.pos)
        self.pos += size
        return arr

    def name(self, what: str) -> str:
        end = self.data.find(b"\0", self.pos)
        if end < 0:
            raise FormatError(f"{self.file}: truncated at byte {self.pos} (reading {what})")
        raw = self.data[self.pos : end]
        self.pos = end + 1
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise FormatError(f"{self.file}: byte {self.pos}: {what} is not UTF-8") from None

    def count(self, what: str, min_record: int) -> int:
        (n,) = self.take("Q", what)
        # every record takes at least `min_record` bytes: a count beyond the file is a lie
        if int(n) * min_record > len(self.data) - self.pos:
            raise FormatError(f"{self.file}: byte {self.pos - 8}: {what} {n} exceeds the file")
        return int(n)

    def done(self) -> None:
        if self.pos != len(self.data):
            raise FormatError(
                f"{self.file}: {len(self.data) - self.pos} bytes after the last record"
            )


def _read_cameras_binary(file: Path) -> dict[int, ColmapCamera]:
    r = _Reader(file)
    cameras: dict[int, ColmapCamera] = {}
    for k in range(r.count("number of cameras", 24)):
        cid, mid, w, h = (int(v) for v in r.take("iiQQ", f"camera {k}"))
        if mid not in MODEL_NAMES:
            raise FormatError(f"{file}: camera {cid}: unknown camera model id {mid}")
        model = MODEL_NAMES[mid]
        params = [float(v) for v in r.take("d" * CAMERA_MODELS[model][1], f"camera {cid}")]
        if cid in cameras:
            raise FormatError(f"{file}: camera {cid} given twice")
        cameras[cid] = _camera(file, "", cid, model, w, h, params)
    r.done()
    return cameras


def _read_images_binary(file: Path) -> dict[int, ColmapImage]:
    r = _Reader(file)
    images: dict[int, ColmapImage] = {}
    for k in range(r.count("number of images", 64 + 2 + 8)):
        head = r.take("idddddddi", f"image {k}")
        iid, cid = int(head[0]), int(head[8])
        name = r.name(f"the name of image {iid}")
        n = r.count(f"the number of points of image {iid}", 24)
        rec = r.array("<f8,<f8,<i8", n, f"the points of image {iid}")
        xy = np.column_stack([rec["f0"], rec["f1"]]).astype(np.float64)
        pids = np.asarray(rec["f2"], dtype=np.int64)
        if iid in images:
            raise FormatError(f"{file}: image {iid} given twice")
        pose = [float(v) for v in head[1:8]]
        images[iid] = _image(file, "", iid, pose[:4], pose[4:7], cid, name, xy, pids)
    r.done()
    return images


def _read_points_binary(file: Path) -> tuple[IntArray, FloatArray]:
    r = _Reader(file)
    n = r.count("number of points", 43 + 8)
    ids = np.zeros(n, dtype=np.int64)
    xyz = np.zeros((n, 3))
    for k in range(n):
        head = r.take("QdddBBBd", f"point {k}")
        ids[k] = int(head[0])
        xyz[k] = [float(v) for v in head[1:4]]
        track = r.count(f"the track length of point {head[0]}", 8)
        r.array("<i4,<i4", track, f"the track of point {head[0]}")
    r.done()
    if not np.all(np.isfinite(xyz)):
        raise FormatError(f"{file}: a point's coordinates are not finite")
    return ids, xyz


def read_colmap(directory: str | os.PathLike[str]) -> ColmapModel:
    """Read a COLMAP sparse model folder: binary (.bin) if cameras.bin is there, else text.

    Every image's camera must exist; FormatError names the file and the line (text) or the
    byte offset (binary) of any problem.
    """
    root = Path(directory)
    if not root.is_dir():
        raise FormatError(f"{root}: not a directory (expected a COLMAP sparse model folder)")
    if (root / "cameras.bin").exists():
        ext, read = ".bin", (_read_cameras_binary, _read_images_binary, _read_points_binary)
    elif (root / "cameras.txt").exists():
        ext, read = ".txt", (_read_cameras_text, _read_images_text, _read_points_text)
    else:
        raise FormatError(
            f"{root}: no cameras.bin or cameras.txt (is it a COLMAP sparse model, e.g. sparse/0?)"
        )
    files = [root / f"{stem}{ext}" for stem in ("cameras", "images", "points3D")]
    for f in files:
        if not f.is_file():
            raise FormatError(f"{f}: no such file (a COLMAP model has cameras, images, points3D)")
    cameras = read[0](files[0])
    images = read[1](files[1])
    point_ids, points = read[2](files[2])
    for image in images.values():
        if image.camera_id not in cameras:
            raise FormatError(f"{files[1]}: image {image.id}: no camera {image.camera_id}")
    if len(set(point_ids.tolist())) != len(point_ids):
        raise FormatError(f"{files[2]}: a point id is given twice")
    return ColmapModel(root, cameras, images, point_ids, points)


# ---------------------------------------------------------------------------------------------
# stereo views from a model

MIN_SHARED_POINTS = 30
"""A pair must share at least this many 3-D points: fewer and the overlap (what both images
see, so what stereo can measure) is too small to be a view, and the median depth unreliable."""

MIN_DISPARITY_PX = 8.0
"""The shared points' median disparity, focal length x baseline / depth, at least 8 px: a
disparity error of 1 px is then a depth error of at most 1/8 per pixel, which a plane fitted
to thousands of pixels averages down; fewer pixels of parallax and the planes' depths and
tilts are noise (a rig of 0.4 m at 27 m seen at 800 px focal length gives 12 px)."""

MAX_BASELINE_RATIO = 0.4
"""Baseline / depth at most 0.4 (22 deg of convergence): beyond, the two images see a facade
so differently that window-sized correlation windows no longer match (and occlusions grow)."""

MAX_AXIS_ANGLE_DEG = 25.0
"""The two optical axes within 25 deg: rectifying a more convergent pair warps the images
strongly and crops them."""

MAX_FORWARD_DEG = 45.0
"""The baseline within 45 deg of the left camera's image plane: a pair with more forward
motion has its epipole near or inside the image and cannot be rectified sanely (the focal
length of the rectified images blows up)."""

BEST_BASELINE_RATIO = 0.1
"""Among pairs sharing as many points, the one nearest 1:10 is preferred (depth precise,
images still alike)."""


@dataclass(frozen=True)
class StereoPair:
    """A stereo view from two registered images, in COLMAP's world and units.

    left, right : the images (left: the one whose camera sees the other to its right).
    R, T : right from left camera, x_right = R·x_left + T (model units).
    shared : 3-D points both images observe; ratio : baseline / median depth of those points.
    """

    left: ColmapImage
    right: ColmapImage
    R: FloatArray
    T: FloatArray
    shared: int
    ratio: float


@dataclass(frozen=True)
class PairingRule:
    """The thresholds of `stereo_views` (defaults: the module's named constants)."""

    min_shared: int = MIN_SHARED_POINTS
    min_disparity_px: float = MIN_DISPARITY_PX
    max_ratio: float = MAX_BASELINE_RATIO
    max_axis_deg: float = MAX_AXIS_ANGLE_DEG
    max_forward_deg: float = MAX_FORWARD_DEG


def _observed(image: ColmapImage, known: set[int]) -> set[int]:
    return {int(p) for p in image.point_ids if p >= 0 and int(p) in known}


def candidate_pairs(model: ColmapModel, rule: PairingRule | None = None) -> list[StereoPair]:
    """Every pair of images that makes a usable stereo view under `rule`, best first.

    Usable: both images of one size, at least `min_shared` 3-D points in common, a median
    disparity of those points (left focal length x baseline / depth in the left camera) of
    at least `min_disparity_px`, baseline / median depth at most `max_ratio`, optical axes within
    `max_axis_deg`, and the baseline within `max_forward_deg` of the left image plane. Order:
    most shared points first, then the ratio nearest BEST_BASELINE_RATIO, then the names.
    """
    rule = rule or PairingRule()
    known = set(model.point_ids.tolist())
    xyz = dict(zip(model.point_ids.tolist(), model.points, strict=True))
    images = sorted(model.images.values(), key=lambda im: im.name)
    seen = [_observed(im, known) for im in images]
    cos_axis = math.cos(math.radians(rule.max_axis_deg))
    cos_forward = math.cos(math.radians(90.0 - rule.max_forward_deg))
    out = []
    for a in range(len(images)):
        for b in range(a + 1, len(images)):
            shared = seen[a] & seen[b]
            if len(shared) < rule.min_shared:
                continue
            ia, ib = images[a], images[b]
            ca, cb = model.cameras[ia.camera_id], model.cameras[ib.camera_id]
            if (ca.width, ca.height) != (cb.width, cb.height):
                continue
            if float(ia.R[2] @ ib.R[2]) < cos_axis:
                continue
            # the other camera's centre in a's frame: right of a -> a is the left image
            c_b = ia.R @ ib.centre + ia.t
            baseline = float(np.linalg.norm(c_b))
            if baseline <= 0 or abs(c_b[0]) / baseline < cos_forward:
                continue
            left, right = (ia, ib) if c_b[0] > 0 else (ib, ia)
            pts = np.array([xyz[p] for p in shared])
            depth = float(np.median(pts @ left.R[2] + left.t[2]))
            if depth <= 0:
                continue
            ratio = baseline / depth
            focal = float(model.cameras[left.camera_id].opencv()[0][0, 0])
            if focal * ratio < rule.min_disparity_px or ratio > rule.max_ratio:
                continue
            R = right.R @ left.R.T
            T = right.t - R @ left.t
            out.append(StereoPair(left, right, R, T, len(shared), ratio))
    out.sort(
        key=lambda p: (
            -p.shared,
            abs(math.log(p.ratio / BEST_BASELINE_RATIO)),
            p.left.name,
            p.right.name,
        )
    )
    return out


def stereo_views(
    model: ColmapModel, rule: PairingRule | None = None, max_views: int | None = None
) -> list[StereoPair]:
    """Disjoint stereo pairs of `model` (each image in one view at most), in view order.

    Greedy over `candidate_pairs` (most shared points first): a pair is taken when neither
    image is taken yet; at most `max_views`. View order: by the left image's name (so view 00,
    the world frame, is the first such image).
    """
    used: set[int] = set()
    chosen = []
    for pair in candidate_pairs(model, rule):
        if pair.left.id in used or pair.right.id in used:
            continue
        chosen.append(pair)
        used |= {pair.left.id, pair.right.id}
        if max_views is not None and len(chosen) >= max_views:
            break
    return sorted(chosen, key=lambda p: p.left.name)
