"""A COLMAP sparse model written from a synthetic scene (tests and benchmarks of from-colmap).

`write_colmap_from_scene` turns a rendered scene directory (with truth.json) into what COLMAP
would have produced from its images: one camera per distinct intrinsics, every left and right
image registered with its true pose, and 3-D points sampled on the true parts with their
tracks, all in an arbitrary world frame and scale (structure from motion knows neither), in
the text or the binary format of COLMAP's documentation. The images are copied beside it.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.io.colmap import CAMERA_MODELS, COLMAP_PIXEL_OFFSET, rotation_to_quaternion
from aida_kb.io.scene import read_depth, read_scene

FloatArray = npt.NDArray[np.float64]

POINTS_PER_PART = 60
"""3-D points sampled on each true part (a grid clipped to its polygon)."""

DEPTH_AGREEMENT = 0.02
"""A point counts as seen by a left image where its depth is within 2 % of the rendered depth
(else something is in front of it)."""


@dataclass(frozen=True)
class SfmFrame:
    """The arbitrary frame of the written model: x_model = scale·(Q·x_world) + offset."""

    scale: float = 1.0
    Q: tuple[tuple[float, float, float], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class _Image:
    name: str
    camera: int
    R: FloatArray
    t: FloatArray
    xy: list[tuple[float, float, int]]


def _polygon_samples(polygon: FloatArray, normal: FloatArray, n: int) -> FloatArray:
    """About `n` points (k, 3) on a grid inside the planar `polygon` (V, 3)."""
    u = polygon[1] - polygon[0]
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    uv = np.column_stack([(polygon - polygon[0]) @ u, (polygon - polygon[0]) @ v])
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    side = int(np.ceil(np.sqrt(n * 2)))
    gu, gv = np.meshgrid(
        np.linspace(lo[0], hi[0], side + 2)[1:-1], np.linspace(lo[1], hi[1], side + 2)[1:-1]
    )
    grid = np.column_stack([gu.ravel(), gv.ravel()])
    inside = np.array(
        [
            cv2.pointPolygonTest(uv.astype(np.float32), (float(a), float(b)), False) > 0
            for a, b in grid
        ]
    )
    pts = grid[inside]
    out: FloatArray = polygon[0] + pts[:, :1] * u + pts[:, 1:] * v
    return out


def write_colmap_from_scene(
    scene_dir: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    frame: SfmFrame | None = None,
    fmt: Literal["text", "binary"] = "text",
) -> tuple[Path, Path]:
    """Write scene_dir's views as a COLMAP model; returns (model folder, images folder).

    Images are named ``vNN_left.png`` / ``vNN_right.png``. A point is observed by a left
    image where it lies in front, inside the image, on a face turned to the camera and not
    hidden (depth_left agrees to DEPTH_AGREEMENT); by a right image where it is observed by
    its view's left image and projects inside the right one.
    """
    fr = frame or SfmFrame()
    scene = read_scene(scene_dir)
    truth = scene.truth
    if truth is None:
        raise ValueError(f"{scene_dir}: no truth.json (a synthetic scene is needed)")
    root = Path(out)
    model_dir, images_dir = root / "sparse", root / "images"
    model_dir.mkdir(parents=True, exist_ok=True)
    images_dir.mkdir(parents=True, exist_ok=True)
    Q = np.array(fr.Q, dtype=np.float64)
    c = np.array(fr.offset, dtype=np.float64)
    # points on the true parts, world frame, with their faces' normals
    samples = [
        (_polygon_samples(np.array(p.polygon), np.array(p.normal), POINTS_PER_PART), p.normal)
        for p in truth.parts
    ]
    world = np.concatenate([pts for pts, _ in samples])
    normals = np.concatenate([np.tile(n, (len(pts), 1)) for pts, n in samples])
    cameras: dict[tuple[float, ...], int] = {}
    cam_rows: list[tuple[int, str, int, int, list[float]]] = []
    images: list[_Image] = []
    tracks: dict[int, list[tuple[int, int]]] = {}

    def camera_id(K: FloatArray, D: FloatArray, size: tuple[int, int]) -> int:
        key = (*K.ravel().round(9), *D.ravel().round(12), *size)
        if key not in cameras:
            cameras[key] = len(cameras) + 1
            fx, fy = K[0, 0], K[1, 1]
            cx, cy = K[0, 2] + COLMAP_PIXEL_OFFSET, K[1, 2] + COLMAP_PIXEL_OFFSET
            if not np.any(D):
                cam_rows.append((cameras[key], "PINHOLE", *size, [fx, fy, cx, cy]))
            else:
                d = list(np.resize(np.append(D, np.zeros(8)), 8))
                cam_rows.append((cameras[key], "FULL_OPENCV", *size, [fx, fy, cx, cy, *d]))
        return cameras[key]

    for view in scene.views:
        pose = truth.pose(view.id)
        rig = view.rig
        R_l, t_l = np.array(pose.R), np.array(pose.t)
        R_r, t_r = rig.R @ R_l, rig.R @ t_l + rig.T
        depth = read_depth(view.depth_left) if view.depth_left is not None else None
        seen_left = None
        for side, K, D, R, t, src in (
            ("left", rig.K1, rig.D1, R_l, t_l, view.left),
            ("right", rig.K2, rig.D2, R_r, t_r, view.right),
        ):
            name = f"v{view.id}_{side}{src.suffix}"
            (images_dir / name).write_bytes(src.read_bytes())
            cam = camera_id(K, D, rig.image_size)
            cam_pts = world @ R.T + t
            centre = -R.T @ t
            px, _ = cv2.projectPoints(world, cv2.Rodrigues(R)[0], t, K, D)
            px = px.reshape(-1, 2)
            w, h = rig.image_size
            ok = (cam_pts[:, 2] > 0) & (px[:, 0] >= 0) & (px[:, 0] <= w - 1)
            ok &= (px[:, 1] >= 0) & (px[:, 1] <= h - 1)
            ok &= np.einsum("ij,ij->i", normals, centre - world) > 0
            if side == "left":
                if depth is not None:
                    ix = np.clip(np.round(px).astype(int), 0, [w - 1, h - 1])
                    d = depth[ix[:, 1], ix[:, 0]]
                    ok &= np.isfinite(d) & (
                        np.abs(d - cam_pts[:, 2]) <= DEPTH_AGREEMENT * cam_pts[:, 2]
                    )
                seen_left = ok
            else:
                assert seen_left is not None
                ok &= seen_left
            # into the model frame: R' = R Q^T, t' = s t - R' c
            R_m = R @ Q.T
            t_m = fr.scale * t - R_m @ c
            image = _Image(name, cam, R_m, t_m, [])
            iid = len(images) + 1
            for k in np.flatnonzero(ok):
                tracks.setdefault(int(k) + 1, []).append((iid, len(image.xy)))
                image.xy.append(
                    (
                        float(px[k, 0]) + COLMAP_PIXEL_OFFSET,
                        float(px[k, 1]) + COLMAP_PIXEL_OFFSET,
                        int(k) + 1,
                    )
                )
            images.append(image)
    model_pts = fr.scale * (world @ Q.T) + c
    # points seen by fewer than two images are not in a structure-from-motion model
    kept = {pid: tr for pid, tr in tracks.items() if len(tr) >= 2}
    for image in images:
        image.xy = [(x, y, pid if pid in kept else -1) for x, y, pid in image.xy]
    if fmt == "text":
        _write_text(model_dir, cam_rows, images, kept, model_pts)
    else:
        _write_binary(model_dir, cam_rows, images, kept, model_pts)
    return model_dir, images_dir


def _write_text(
    folder: Path,
    cams: list[tuple[int, str, int, int, list[float]]],
    images: list[_Image],
    tracks: dict[int, list[tuple[int, int]]],
    pts: FloatArray,
) -> None:
    lines = [
        "# Camera list with one line of data per camera:",
        "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]",
    ]
    lines += [
        f"{cid} {model} {w} {h} " + " ".join(repr(float(p)) for p in params)
        for cid, model, w, h, params in cams
    ]
    (folder / "cameras.txt").write_text("\n".join(lines) + "\n")
    lines = ["# Image list with two lines of data per image:"]
    for iid, im in enumerate(images, start=1):
        q = rotation_to_quaternion(im.R)
        lines.append(
            f"{iid} " + " ".join(repr(float(v)) for v in (*q, *im.t)) + f" {im.camera} {im.name}"
        )
        lines.append(" ".join(f"{x!r} {y!r} {pid}" for x, y, pid in im.xy))
    (folder / "images.txt").write_text("\n".join(lines) + "\n")
    lines = ["# 3D point list with one line of data per point:"]
    for pid, track in sorted(tracks.items()):
        p = [float(v) for v in pts[pid - 1]]
        lines.append(
            f"{pid} {p[0]!r} {p[1]!r} {p[2]!r} 128 128 128 0.5 "
            + " ".join(f"{i} {k}" for i, k in track)
        )
    (folder / "points3D.txt").write_text("\n".join(lines) + "\n")


def _write_binary(
    folder: Path,
    cams: list[tuple[int, str, int, int, list[float]]],
    images: list[_Image],
    tracks: dict[int, list[tuple[int, int]]],
    pts: FloatArray,
) -> None:
    data = bytearray(struct.pack("<Q", len(cams)))
    for cid, model, w, h, params in cams:
        data += struct.pack("<iiQQ", cid, CAMERA_MODELS[model][0], w, h)
        data += struct.pack(f"<{len(params)}d", *params)
    (folder / "cameras.bin").write_bytes(bytes(data))
    data = bytearray(struct.pack("<Q", len(images)))
    for iid, im in enumerate(images, start=1):
        q = rotation_to_quaternion(im.R)
        data += struct.pack("<idddddddi", iid, *q, *im.t, im.camera)
        data += im.name.encode() + b"\0"
        data += struct.pack("<Q", len(im.xy))
        for x, y, pid in im.xy:
            data += struct.pack("<ddq", x, y, pid)
    (folder / "images.bin").write_bytes(bytes(data))
    data = bytearray(struct.pack("<Q", len(tracks)))
    for pid, track in sorted(tracks.items()):
        data += struct.pack("<QdddBBBd", pid, *pts[pid - 1], 128, 128, 128, 0.5)
        data += struct.pack("<Q", len(track))
        for i, k in track:
            data += struct.pack("<ii", i, k)
    (folder / "points3D.bin").write_bytes(bytes(data))
