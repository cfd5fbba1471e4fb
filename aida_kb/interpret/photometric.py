"""Texture factors of a later view: patches of the first view's image on the model's faces,
seen again by the later view's camera (`aida_kb.constraints.kinds.texture`).

`texture_factors` samples the reference image (the first view's left image, its camera fixed)
on a grid of 4 x 4-pixel patches, keeps the patches that lie well inside one model face seen
from both cameras at no more than `TEXTURE_GRAZING_DEG` from its normal (at the patch: a
face's centre may lie where a low camera sees it edge-on while its near part is seen well),
not hidden by another face in the later view, with texture enough to see a shift
(`MIN_PATCH_TEXTURE_GREY`), and makes one ``texture`` constraint per patch.
`texture_noise_grey` measures the residuals' scale.

The reconstruction uses the ground's patches alone (`aida_kb.interpret.groundtexture`: the
ground as one more face, ``only_face``, seen up to `groundtexture.GROUND_GRAZING_DEG`); the model's
own faces' patches are not used: `benchmarks/texture_cameras.py` measures what they do to the
later cameras of kept dev scenes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, Origin, TextureData, TextureImage
from aida_kb.constraints.kinds.texture import PATCH_SAMPLES
from aida_kb.constraints.texture import bilinear
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.polygon import plane_bases
from aida_kb.register import RigidModel
from aida_kb.texture.raycast import Faces, first_hits

FloatArray = npt.NDArray[np.float64]

PATCH_SIDE = 4
"""Samples along a patch's side (`PATCH_SAMPLES` = 4 x 4)."""

SAMPLE_STRIDE_PX = 3
"""Pixels between a patch's samples: a patch spans 10 pixels (the research prototype's
12-pixel patches, /tmp/dense, dev 66000-66035)."""

PATCH_SPACING_PX = 20
"""Pixels between neighbouring patches' first samples: a quarter of the image's area is
sampled. Every 12 pixels (side by side) a view's 750-1400 patches made the adjustment's
dense steps 1.7 s each (an SVD of 24,000 rows; dev 67003 69 s a scene)."""

PATCH_BORDER_PX = 4.0
"""A patch keeps this many pixels off its face's outline in both images: a model edge is a few
pixels off the image's (eaves, the fitted edges' 1-2 px errors), and a sample across it would
compare two surfaces (the prototype's 4-px masks)."""

TEXTURE_GRAZING_DEG = 70.0
"""Patches seen at more than this angle from their face's normal by either camera are left
out: their texture is foreshortened beyond what bilinear sampling follows (the prototype's
cut)."""

MIN_PATCH_TEXTURE_GREY = 0.2
"""A patch whose reference grey levels vary by less than this (standard deviation, in the
blurred image) is left out: flat, its gain is fitted to noise alone. The synthetic scenes'
texture is weak: at blur 2 px the roofs' patches vary by 0.3-0.7 grey, the walls' by 1-10
(median 1.9; dev 67003)."""

EDGE_MARGIN_PX = 2.0
"""A patch's points must project this far inside the later image (the bilinear lookup repeats
the border beyond it)."""

MAD_TO_SD = 1.4826
"""The median absolute deviation of Gaussian noise times this is its standard deviation."""


def model_faces(model: RigidModel) -> Faces:
    """The model's faces for ray casting (`aida_kb.texture.raycast.Faces`), parts' order."""
    u, v = plane_bases(model.normals)
    return Faces(tuple(model.polygons), model.normals, model.offsets, u, v)


def _seen_within(
    normals: FloatArray,
    points: FloatArray,
    cameras: tuple[PinholeCamera, PinholeCamera],
    grazing_deg: float,
) -> npt.NDArray[np.bool_]:
    """(Q,) whether both cameras see each point from the front of its face within
    `grazing_deg` of the face's normal.

    normals : (Q, 3) the unit normal of each point's face; points : (Q, 3) the points, world
    frame, metres.
    """
    limit = math.cos(math.radians(grazing_deg))
    ok = np.ones(points.shape[0], dtype=bool)
    for cam in cameras:
        to_cam = cam.centre[None, :] - points
        dist = np.linalg.norm(to_cam, axis=1)
        cos = np.einsum("qi,qi->q", normals, to_cam) / np.where(dist > 0.0, dist, np.inf)
        ok &= cos >= limit
    return ok


def _patch_pixels(width: int, height: int) -> tuple[FloatArray, FloatArray]:
    """The reference image's patches: samples (Q, 16, 2) and guard points (Q, 8, 2) — the
    corners and side middles of each patch's box grown by `PATCH_BORDER_PX` — pixels."""
    span = SAMPLE_STRIDE_PX * (PATCH_SIDE - 1)
    step = PATCH_SPACING_PX
    lo = PATCH_BORDER_PX + 1.0
    xs = np.arange(lo, width - span - lo, step, dtype=np.float64)
    ys = np.arange(lo, height - span - lo, step, dtype=np.float64)
    corner = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    a = SAMPLE_STRIDE_PX * np.arange(PATCH_SIDE, dtype=np.float64)
    grid = np.stack(np.meshgrid(a, a), axis=-1).reshape(-1, 2)
    b = PATCH_BORDER_PX
    g = np.array([-b, span / 2.0, span + b])
    guard = np.array([[x, y] for y in g for x in g if not (x == g[1] and y == g[1])])
    return corner[:, None, :] + grid[None], corner[:, None, :] + guard[None]


def texture_factors(
    model: RigidModel,
    reference: PinholeCamera,
    reference_image: FloatArray,
    camera: PinholeCamera,
    index: int,
    image: TextureImage,
    sigma_grey: float,
    view: str = "",
    *,
    only_face: int | None = None,
    grazing_deg: float = TEXTURE_GRAZING_DEG,
) -> list[Constraint]:
    """The texture factors of one later view (module docstring).

    Parameters
    ----------
    model : the model (world frame); its faces are the patches' planes.
    reference : the first view's camera (held fixed in the adjustment); reference_image :
        (H, W) its undistorted grey levels (float64), blurred as `image` is.
    camera : the later view's camera at its current pose (visibility is decided there);
        index : its index in the problem.
    image : the later view's undistorted, equally blurred image.
    sigma_grey : each residual's standard deviation, grey levels (`texture_noise_grey`).
    view : the later view's name for the labels.
    only_face : the patches of this face alone (the others hide it); None: every face's.
    grazing_deg : a patch whose middle either camera sees farther than this from its face's
        normal is left out.

    Returns
    -------
    One ``texture`` constraint per kept patch (huber loss), labelled ``texture(PART)@VIEW``.
    """
    faces = model_faces(model)
    seen = list(range(len(model.names))) if only_face is None else [only_face]
    samples, guard = _patch_pixels(reference.width, reference.height)
    Q = samples.shape[0]
    points = np.concatenate([samples, guard], axis=1)  # (Q, 24, 2)
    flat = points.reshape(-1, 2)
    face, depth, rays = first_hits(faces, reference, flat)
    face = face.reshape(Q, -1)
    same = np.all(face == face[:, :1], axis=1) & np.isin(face[:, 0], seen)
    keep = np.flatnonzero(same)
    if keep.size == 0:
        return []
    hits = reference.centre + np.where(np.isfinite(depth), depth, 0.0)[:, None] * rays
    X = hits.reshape(Q, -1, 3)[keep]
    # each patch seen within the grazing limit at its own middle, by both cameras
    middle = X[:, :PATCH_SAMPLES].mean(axis=1)
    near = _seen_within(model.normals[face[keep, 0]], middle, (reference, camera), grazing_deg)
    keep, X = keep[near], X[near]
    if keep.size == 0:
        return []
    # the later view: every point in the image and on the same face there (not hidden)
    Xf = X.reshape(-1, 3)
    in_front = camera.in_front(Xf).reshape(keep.size, -1).all(axis=1)
    keep, X = keep[in_front], X[in_front]
    if keep.size == 0:
        return []
    q = camera.project(X.reshape(-1, 3))
    inside = camera.in_image(q, margin=EDGE_MARGIN_PX).reshape(keep.size, -1).all(axis=1)
    face_k, _, _ = first_hits(faces, camera, q)
    visible = np.all(face_k.reshape(keep.size, -1) == face[keep, :1], axis=1)
    ok = inside & visible
    keep = keep[ok]
    if keep.size == 0:
        return []
    values = bilinear(reference_image, samples[keep].reshape(-1, 2))[0].reshape(keep.size, -1)
    textured = values.std(axis=1) >= MIN_PATCH_TEXTURE_GREY
    keep, values = keep[textured], values[textured]
    ray_rows = rays.reshape(Q, -1, 3)[keep, :PATCH_SAMPLES]
    origin = tuple(float(c) for c in reference.centre)
    out: list[Constraint] = []
    for row, patch in enumerate(keep):
        part = int(face[patch, 0])
        label = f"texture({model.names[part]})@{view}"
        out.append(
            Constraint(
                kind="texture",
                parts=(part,),
                sigma=sigma_grey,
                measurement=True,
                loss="huber",
                label=label,
                texture=TextureData(
                    index,
                    origin,  # type: ignore[arg-type]
                    tuple(tuple(float(x) for x in r) for r in ray_rows[row]),  # type: ignore[misc]
                    tuple(float(x) for x in values[row]),
                    image,
                ),
                origin=Origin(label, "evidence"),
            )
        )
    return out


def agreeing_patches(
    patches: list[Constraint],
    normals: FloatArray,
    offsets: FloatArray,
    cameras: Sequence[PinholeCamera],
) -> list[Constraint]:
    """The ``texture`` factors whose whitened cost at the planes (``normals`` (P, 3),
    ``offsets`` (P,), world frame) and cameras given lies within the 99.9 % quantile of their
    chi-square: a window frame, an occluder, a shadow that moves with nothing out."""
    from aida_kb.constraints import CHI2_999, compile_blocks
    from aida_kb.constraints.kinds.texture import TEXTURE

    if not patches:
        return patches
    (block,) = compile_blocks(patches, normals.shape[0], len(cameras))
    r = block.whiten(block.evaluate(normals, offsets, cameras, camera_jacobian=False)[0])
    cost = np.sum(r * r, axis=1)
    return [c for c, z in zip(patches, cost, strict=True) if z <= CHI2_999[TEXTURE.dof]]


def texture_noise_grey(
    normals: FloatArray,
    offsets: FloatArray,
    cameras: tuple[PinholeCamera, ...] | list[PinholeCamera],
    constraints: list[Constraint],
) -> float:
    """The residuals' standard deviation, grey levels: the median absolute residual of the
    ``texture`` constraints at the given planes and cameras, as a Gaussian's (`MAD_TO_SD`),
    corrected for the two components each patch's gain and offset take; NaN without any."""
    from aida_kb.constraints import compile_blocks

    cs = [c for c in constraints if c.kind == "texture"]
    if not cs:
        return math.nan
    (block,) = compile_blocks(cs, normals.shape[0], len(cameras))
    r = block.evaluate(normals, offsets, cameras, camera_jacobian=False)[0]
    scale = MAD_TO_SD * float(np.median(np.abs(r)))
    return scale * math.sqrt(PATCH_SAMPLES / (PATCH_SAMPLES - 2))


MIN_FACE_PATCHES = 10
"""A face carries a view's texture only with at least this many patches (160 samples): fewer
fix its plane's turn too loosely to tell the camera's swing from the face's (the prototype's
failures had one shared face)."""

MIN_FACE_ANGLE_DEG = 30.0
"""Two faces carrying a view's texture must meet at this angle at least: one face, or parallel
ones, leave the camera free to swing about the face's normal with a matching shift (dev 66008,
66017, 66035 view 02: one shared face, the camera went 0.06-0.11 -> 0.12-1.26 deg off)."""


def well_posed(constraints: list[Constraint], normals: FloatArray) -> bool:
    """Whether a view's texture factors fix its camera: at least two faces carry
    `MIN_FACE_PATCHES` patches each and two of those meet at `MIN_FACE_ANGLE_DEG` or more
    (``normals`` (P, 3) the parts' unit normals, world frame)."""
    counts: dict[int, int] = {}
    for c in constraints:
        counts[c.parts[0]] = counts.get(c.parts[0], 0) + 1
    faces = [f for f, n in counts.items() if n >= MIN_FACE_PATCHES]
    if len(faces) < 2:
        return False
    N = normals[faces]
    cosine = np.abs(N @ N.T)
    return bool(np.any(cosine < math.cos(math.radians(MIN_FACE_ANGLE_DEG))))


__all__ = [
    "EDGE_MARGIN_PX",
    "MAD_TO_SD",
    "MIN_FACE_ANGLE_DEG",
    "MIN_FACE_PATCHES",
    "MIN_PATCH_TEXTURE_GREY",
    "PATCH_BORDER_PX",
    "PATCH_SIDE",
    "PATCH_SPACING_PX",
    "SAMPLE_STRIDE_PX",
    "TEXTURE_GRAZING_DEG",
    "agreeing_patches",
    "model_faces",
    "texture_factors",
    "texture_noise_grey",
    "well_posed",
]
