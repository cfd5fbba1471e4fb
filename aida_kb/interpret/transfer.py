"""The registered views' images carried into a new view through the model, at a candidate pose.

`ImageTransfer` is the `aida_kb.register.twins.PhotometricJudge` of a view: for a candidate
camera it casts a ray through every pixel of the view onto the model (`texture.raycast`), takes
the point each ray meets into every registered view that sees the same face there (its face
buffer: the model hides what lies behind it), samples that view's image, and compares the
result with the view's own image by local normalised cross-correlation (windows of
`NCC_WINDOW_PX`, both images smoothed by `BLUR_SIGMA_PX`, only where both are textured). At the
true pose a face's doors, windows and stains land on themselves; at a symmetric twin they land
on another face's, or the view shares no face with the registered ones.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.polygon import plane_bases
from aida_kb.register.model import RigidModel
from aida_kb.register.twins import PoseSupport
from aida_kb.texture.raycast import Faces, face_buffer, first_hits

FloatArray = npt.NDArray[np.float64]
GreyImage = npt.NDArray[np.uint8]

__all__ = ["BLUR_SIGMA_PX", "MIN_TEXTURE_GREY", "NCC_WINDOW_PX", "ImageTransfer"]

BLUR_SIGMA_PX = 1.5
"""Both images are smoothed by a Gaussian of this standard deviation (pixels) before they are
compared: a candidate refined to the segments of a model a little off lies a pixel or two from
the true pose, which sharp texture would not forgive (windows and doors still correlate)."""

NCC_WINDOW_PX = 9
"""Side of the square window of the local NCC, pixels (odd): large enough to hold a window's
frame or a stain's border, small enough to stay on one face."""

MIN_TEXTURE_GREY = 2.0
"""A window counts only where both images vary by at least this standard deviation (grey
levels, after smoothing): a blank wall correlates with anything as noise does."""

MIN_DEPTH_M = 1e-6
"""A point nearer than this to a camera's plane (metres) is not in front of it."""


def _faces(model: RigidModel) -> Faces:
    """The model's parts as faces for ray casting (no texture axes needed: any in-plane
    basis)."""
    if not model.polygons:
        raise GeometryError("image transfer: the model has no polygons")
    u, v = plane_bases(model.normals)
    return Faces(model.polygons, model.normals, model.offsets, u, v)


def _smooth(grey: GreyImage) -> npt.NDArray[np.float32]:
    import cv2

    blurred = cv2.GaussianBlur(grey.astype(np.float32), (0, 0), BLUR_SIGMA_PX)
    return np.asarray(blurred, dtype=np.float32)


class ImageTransfer:
    """The images' support of candidate poses of one view (`__call__`).

    model : the fixed model (world frame); cameras : the registered views' pinhole cameras;
    images : their images (8-bit grey, each in its camera's undistorted pixels; None: left
    out); image : the new view's own image, in the pixels of the cameras it is called with.
    """

    def __init__(
        self,
        model: RigidModel,
        cameras: Sequence[PinholeCamera],
        images: Sequence[GreyImage | None],
        image: GreyImage,
    ) -> None:
        self._faces = _faces(model)
        self._own = _smooth(image)
        self._refs: list[tuple[PinholeCamera, npt.NDArray[np.int64], npt.NDArray[np.float32]]] = []
        for cam, grey in zip(cameras, images, strict=True):
            if grey is None or grey.shape != (cam.height, cam.width):
                continue
            buffer, _ = face_buffer(self._faces, cam)
            self._refs.append((cam, buffer, _smooth(grey)))

    def __call__(self, camera: PinholeCamera) -> PoseSupport:
        """The support of `camera` (the new view's, world frame): `PoseSupport` with the mean
        local NCC of the view's image against the registered views' images carried into it,
        over the pixels a registered view sees on the same face and both images texture."""
        import cv2

        h, w = self._own.shape
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
        pixels = np.stack([xs.ravel(), ys.ravel()], axis=1)
        face, depth, rays = first_hits(self._faces, camera, pixels, grid=True)
        hit = np.nonzero(face >= 0)[0]
        model_px = int(hit.size)
        if model_px == 0:
            return PoseSupport(float("nan"), 0, 0)
        points = camera.centre + depth[hit, None] * rays[hit]  # (N, 3) world
        total, count = 0.0, 0
        shared = np.zeros((h, w), dtype=bool)  # pixels some registered view shares
        for cam, buffer, grey in self._refs:
            local = points @ cam.R_cam_world.T + cam.t_cam_world
            front = local[:, 2] > MIN_DEPTH_M
            uv = local[:, :2] / np.where(front, local[:, 2], 1.0)[:, None]
            uv = uv @ cam.K[:2, :2].T + cam.K[:2, 2]
            col, row = np.rint(uv[:, 0]).astype(np.int64), np.rint(uv[:, 1]).astype(np.int64)
            inside = front & (col >= 0) & (col < cam.width) & (row >= 0) & (row < cam.height)
            same = np.zeros(hit.size, dtype=bool)
            same[inside] = buffer[row[inside], col[inside]] == face[hit[inside]]
            if not np.any(same):
                continue
            map_x = np.full(h * w, -1.0, dtype=np.float32)
            map_y = np.full(h * w, -1.0, dtype=np.float32)
            map_x[hit[same]] = uv[same, 0]
            map_y[hit[same]] = uv[same, 1]
            maps = (map_x.reshape(h, w), map_y.reshape(h, w))
            carried = np.asarray(cv2.remap(grey, *maps, cv2.INTER_LINEAR), dtype=np.float32)
            mask = np.zeros(h * w, dtype=np.uint8)
            mask[hit[same]] = 1
            s, used = _local_ncc(self._own, carried, mask.reshape(h, w))
            total += s
            count += int(np.count_nonzero(used))
            shared |= used
        ncc = total / count if count else float("nan")
        return PoseSupport(ncc, int(np.count_nonzero(shared)), model_px)


def _local_ncc(
    a: npt.NDArray[np.float32], b: npt.NDArray[np.float32], mask: npt.NDArray[np.uint8]
) -> tuple[float, npt.NDArray[np.bool_]]:
    """The sum of the local NCC of images a and b (H, W) over the pixels whose whole window
    lies in `mask` and is textured in both (`MIN_TEXTURE_GREY`), and those pixels (H, W)."""
    import cv2

    k = NCC_WINDOW_PX
    whole = cv2.erode(mask, np.ones((k, k), np.uint8)) > 0
    if not np.any(whole):
        return 0.0, whole

    def mean(x: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        return np.asarray(cv2.boxFilter(x, -1, (k, k), normalize=True), dtype=np.float32)

    ma, mb = mean(a), mean(b)
    va = mean(a * a) - ma * ma
    vb = mean(b * b) - mb * mb
    cab = mean(a * b) - ma * mb
    floor = np.float32(MIN_TEXTURE_GREY**2)
    use: npt.NDArray[np.bool_] = whole & (va >= floor) & (vb >= floor)
    if not np.any(use):
        return 0.0, use
    ncc = cab[use] / np.sqrt(va[use] * vb[use])
    return float(np.sum(ncc, dtype=np.float64)), use
