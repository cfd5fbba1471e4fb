"""The texture factor: a patch of the reference image's texture on a plane, seen again by a
camera, gain and offset eliminated (`aida_kb.constraints.texture.texture_kernel`).

Residuals: the patch's `PATCH_SAMPLES` grey levels in the other image less the best gain and
offset of the reference's (N components, N - 2 free), with Jacobians by the patch's plane and
the camera's pose. The reference camera is held fixed: its centre and rays are data.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints.factor import Constraint, TextureData
from aida_kb.constraints.kinds.base import (
    BlockData,
    Evaluated,
    Evidence,
    FloatArray,
    IntArray,
    Kind,
    check_camera,
    vector,
)
from aida_kb.constraints.texture import texture_kernel
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera

PATCH_SAMPLES = 16
"""Sample pixels per patch (a 4 x 4 grid): the residual size of the kind. Enough for the gain
and offset to leave 14 free components, few enough that a patch fits inside a face between its
window frames (4 samples at a 3-pixel stride span 10 pixels)."""


def _data(c: Constraint) -> TextureData:
    assert c.texture is not None
    return c.texture


class Texture(Kind):
    """A patch of the reference image's texture on a plane, seen again through a camera."""

    name: ClassVar[str] = "texture"
    arity: ClassVar[int] = 1
    residual_size: ClassVar[int] = PATCH_SAMPLES
    dof: ClassVar[int] = PATCH_SAMPLES - 2
    measurement: ClassVar[bool] = True
    uses_camera: ClassVar[bool] = True
    evidence: ClassVar[Evidence] = None
    summary: ClassVar[str] = (
        "a patch's grey levels seen again through a camera, less their gain and offset, grey"
    )

    def camera(self, c: Constraint) -> int | None:
        """The camera that sees the patch again."""
        return int(_data(c).camera)

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The patch is there with `PATCH_SAMPLES` finite rays and grey levels, seen by a
        known camera into a 2-D image of at least 2 x 2 pixels."""
        t = c.texture
        if t is None:
            raise SolveError(f"{where}: a texture constraint needs its patch")
        check_camera(where, t.camera, n_cameras)
        vector(where, "origin", t.origin, 3)
        rays = np.asarray(t.rays, dtype=np.float64)
        if rays.shape != (PATCH_SAMPLES, 3) or not np.all(np.isfinite(rays)):
            raise SolveError(f"{where}: rays must be {PATCH_SAMPLES} finite 3-vectors")
        if np.any(np.linalg.norm(rays, axis=1) <= 0.0):
            raise SolveError(f"{where}: a ray has zero length")
        vector(where, "values", t.values, PATCH_SAMPLES)
        img = t.image.pixels
        if img.ndim != 2 or min(img.shape) < 2:
            raise SolveError(f"{where}: the image must be 2-D with at least 2 x 2 pixels")

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``camera`` (M,) int; ``origin`` (M, 3) m; ``rays`` (M, N, 3); ``values`` (M, N)
        grey; ``image`` (M,) object: the `TextureImage` s."""
        ts = [_data(c) for c in cs]
        images = np.empty(len(ts), dtype=object)
        images[:] = [t.image for t in ts]
        return {
            "camera": np.array([t.camera for t in ts], dtype=np.intp),
            "origin": np.array([t.origin for t in ts], dtype=np.float64).reshape(-1, 3),
            "rays": np.array([t.rays for t in ts], dtype=np.float64).reshape(-1, PATCH_SAMPLES, 3),
            "values": np.array([t.values for t in ts], dtype=np.float64).reshape(-1, PATCH_SAMPLES),
            "image": images,
        }

    def evaluate(
        self,
        normals: FloatArray,
        offsets: FloatArray,
        cameras: Sequence[PinholeCamera],
        idx: IntArray,
        data: BlockData,
        *,
        camera_jacobian: bool = True,
    ) -> Evaluated:
        """r (M, N) grey, J (M, N, 1, 4), J_camera (M, N, 6) (None unless
        ``camera_jacobian``)."""
        r, J, Jc = texture_kernel(
            normals,
            offsets,
            idx,
            cameras,
            data["camera"],
            data["origin"],
            data["rays"],
            data["values"],
            list(data["image"]),
        )
        return r, J, (Jc if camera_jacobian else None)


TEXTURE = Texture()
