"""Draw the textured model through a camera (ray casting against its faces, atlas lookups)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.io.export import UNSEEN_RGB, Atlas
from aida_kb.io.model import ReconstructedModel
from aida_kb.texture.raycast import Faces, first_hits
from aida_kb.texture.sample import sample_bilinear
from aida_kb.vision.rectify import undistort_pixels

FloatArray = npt.NDArray[np.float64]
U8 = npt.NDArray[np.uint8]

# unseen faces are shaded by how squarely they face the camera, so their shape shows
UNSEEN_SHADE_MIN = 0.55


def _uv_maps(faces: Faces, atlas: Atlas) -> list[FloatArray]:
    """Per face the affine map (3, 2): [u_plane, v_plane, 1] -> atlas (u, v) (OBJ convention)."""
    maps = []
    for f, polygon in enumerate(faces.polygons):
        flat = faces.flat(f, polygon)
        A = np.hstack([flat, np.ones((len(flat), 1))])
        M, *_ = np.linalg.lstsq(A, np.asarray(atlas.uv[f], dtype=np.float64), rcond=None)
        maps.append(M)
    return maps


def render_view(
    model: ReconstructedModel,
    atlas: Atlas | None,
    camera: PinholeCamera,
    *,
    D: npt.ArrayLike | None = None,
    background: U8 | None = None,
) -> tuple[U8, npt.NDArray[np.int64]]:
    """The textured model seen by `camera`: an (H, W, 3) RGB image and the face buffer.

    D : the camera's distortion; the image is then that of the original (distorted) camera,
    pixel for pixel comparable with its photograph. background : (H, W, 3) RGB drawn where no
    face is seen (default black). The face buffer holds the part index per pixel, -1 for none.
    """
    faces = Faces.of(model)
    h, w = camera.height, camera.width
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    pixels = np.stack([xs.ravel(), ys.ravel()], axis=1)
    if D is not None:
        pixels = undistort_pixels(pixels, camera.K, np.asarray(D, dtype=np.float64).ravel())
    face, lam, rays = first_hits(faces, camera, pixels)
    out = np.zeros((h * w, 3), np.float64)
    if background is not None:
        out[:] = np.asarray(background, np.float64).reshape(-1, 3)
    hit = face >= 0
    points = camera.centre + lam[hit, None] * rays[hit]
    fid = face[hit]
    colour = np.zeros((len(points), 3))
    maps = _uv_maps(faces, atlas) if atlas is not None else []
    view_dir = rays[hit] / np.linalg.norm(rays[hit], axis=1, keepdims=True)
    for f in np.unique(fid):
        sel = fid == f
        if atlas is not None and atlas.seen[f]:
            flat = faces.flat(int(f), points[sel])
            uv = np.hstack([flat, np.ones((len(flat), 1))]) @ maps[f]
            ih, iw = atlas.image.shape[:2]
            colour[sel] = sample_bilinear(
                atlas.image, uv[:, 0] * iw - 0.5, (1.0 - uv[:, 1]) * ih - 0.5
            )
        else:
            facing = np.abs(view_dir[sel] @ faces.normals[f])
            shade = UNSEEN_SHADE_MIN + (1.0 - UNSEEN_SHADE_MIN) * facing
            colour[sel] = shade[:, None] * (np.array(UNSEEN_RGB) * 255.0)
    out[hit] = colour
    image = np.clip(np.round(out), 0, 255).astype(np.uint8).reshape(h, w, 3)
    return image, face.reshape(h, w)
