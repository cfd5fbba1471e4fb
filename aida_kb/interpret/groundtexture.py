"""The ground's texture between the views: what fixes a later camera's swing about the object.

A later view's camera, registered and adjusted on the model's edges and the views' regions, is
free to swing about the object: a turn about the vertical with a sideways shift of the centre
by the turn times the distance changes the object's image only through its own small depth
(`benchmarks/camera_limits.py`, docs/architecture.md: the cameras are data-limited, 0.06-0.23
deg at one sd against the 0.05 asked). Points at other depths than the object fix the swing:
the ground before and beside it. Seen from the later camera, a ground point 25 m before a
house shifts by 25 m times the swing, a pixel per tenth of a degree at 60 m.

The ground is not a part of the object, and the knowledge need not name it: it is taken as the
plane square to the model's vertical through the model's lowest point (the object stands on
it; a scene where it does not has patches whose texture disagrees, and they are dropped),
reaching `GROUND_REACH` times the model's size around it. Its plane is an unknown of the
adjustment like a part's:

- patches of the first view's left image on the ground, seen again in the first view's right
  image (`texture` factors, `aida_kb.interpret.photometric.texture_factors`), fix the ground's
  plane in the first view's frame — the stereo baseline against ground a few metres to a few
  tens of metres away;
- the same patches seen again in a later view's left image fix that view's camera against it.

The object stands on the ground: its bottom face (`bottom_face`, a house's floor) is held
parallel to the ground's plane (`bottom_on_ground`). The views measure the bottom only by its
foot edges at grazing angles and by its walls standing square to it, the ground's plane by
hundreds of patches: on dev 70035 and 70011 the ground came out 0.004 and 0.11 deg from the
truth's, while the floor was 0.64 and 0.93 deg off with the whole house tilted by as much
(with the tie 0.09 and 0.08 deg).

`ground_adjustment` adds them to the image rounds' problem (`joint_problem`, the model's edges
fitted along the images) and solves coarse to fine over `BLURS_PX`, each level's patches made
at the previous level's solution, their noise measured there, patches beyond their chi-square
quantile dropped. The first view's stereo must see the ground where the model's bottom puts
it (`ground_seen_share`, `GROUND_SEEN_SHARE`): where no ground lies under the object, what
the first view sees below it is the sky, at infinity, and its patches, fitted in the later
views, tilted the "ground" and the bottom held to it (dev 72014: 1.45 and 1.18 deg).

Only the ground's patches are used: the model's own faces' texture fixes a camera against the
model's planes, which are off in the first view's frame by as much as the swing
(benchmarks/texture_cameras.py: dev 67000-67035 textured views 0.062 -> 0.088 deg), while the
ground's fixes it against the first view itself.

Measured through the reconstruction on dev seeds 69002-69032 (session 26; 12 scenes, the
later views of 7 of them seeing 40 ground patches or more): those 11 cameras went from a
median 0.116 deg off to 0.026 (within 0.1 deg 4 -> 9 of 11; 69005 0.28 / 0.43 -> 0.07 / 0.10,
69018 0.17 / 0.12 -> 0.02 / 0.04, 69032 0.11 / 0.12 -> 0.015 / 0.026), 9 of 11 within 2 of
their new deviations (69013 view 02 0.087 deg at 0.026, 69004 0.15 deg at 0.064, which the
verdict still doubts); the camera doubts left 69007, 69013, 69018 and 69032, and the synthetic
house of the --help examples is verified now (its second camera had been fixed only to +-0.11
deg). 69004 got worse (0.055 -> 0.15 deg: 45 patches of ground seen 85 deg from its normal);
69002, 69030 and 69033 see too little ground and keep the image rounds' cameras.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, Origin, TextureImage, compile_blocks
from aida_kb.errors import AidaError, GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rig import Rig
from aida_kb.interpret.joint import (
    JOINT_F_SCALE,
    JOINT_LOSS,
    JointInputs,
    joint_problem,
    part_centres,
)
from aida_kb.interpret.photometric import agreeing_patches, texture_factors, texture_noise_grey
from aida_kb.register import RigidModel
from aida_kb.register.evidence import ViewMeasurements
from aida_kb.solve import SolveResult, build_problem, solve
from aida_kb.solve.problem import Problem
from aida_kb.solve.report import ResidualReport
from aida_kb.solve.solver import TrSolver

FloatArray = npt.NDArray[np.float64]

GROUND_REACH = 3.0
"""The ground's polygon reaches this many times the model's size from the model's centre (in
each direction along the ground): a later view 30-60 deg around the object sees the ground
before it up to about its own size away (a camera's 15-25 deg half field of view at 3-6
times the size), and farther it is hidden or off the images."""

BOTTOM_FACE_DEG = 10.0
"""A model face whose outward normal lies within this of straight down is its bottom, whose
plane starts the ground's (the knowledge's floors stand within a degree of level; the
estimated vertical is up to a few degrees off, `aida_kb.interpret.ground`)."""

GROUND_GRAZING_DEG = 85.0
"""Ground seen farther than this from its normal by a camera carries no patch (judged at each
patch, `photometric.texture_factors`). A camera a few metres above the ground sees it at 70-85
deg (the faces' 70-deg limit, `photometric.TEXTURE_GRAZING_DEG`, would leave every low camera
without ground); beyond 85 deg a 10-pixel patch spans tens of metres of ground. Judged at the
ground polygon's centre (under the object), as it was, a low camera kept none of the ground
it sees well: on dev 73000-73035 the first view saw that centre beyond the limit in 15 of the
24 scenes with later views; judged at each patch its stereo pair keeps 20-272 patches in 12
of them. The later views gain little (73019 view 01 alone, 0 -> 83 patches at the kept model):
they see the first view's near ground off their images or beyond the limit themselves."""

MIN_GROUND_PATCHES = 40
"""A later view's ground patches fix its swing only with at least this many (640 samples):
dev 69004 (45 patches, the ground seen at 5 deg elevation) moved its camera 0.055 -> 0.15 deg
with an sd of 0.063, which the verdict doubts; 73-290 patches fixed the others'."""

GROUND_NEARER_COST = 0.5
"""A first view's stereo patch sees the ground where its plane lies when its cost there is under
this share of its cost at infinity (`ground_seen_share`): the same patch of the left image
looked for in the right image at the plane's disparity and at none."""

GROUND_SEEN_SHARE = 0.5
"""At least this share of the first view's stereo patches must see the ground where the
model's bottom puts it (`ground_seen_share`, at the first blur level, before any later view
pulls it), or the ground's texture is not used: no ground lies there. With no ground under
the object the first view sees the sky below it, at infinity, and the later views' fits of
those patches tilted the "ground" and the bottom held to it (dev 72014: 1.45 and 1.18 deg, its
worst part 0.06 deg without them). Measured at the kept models of dev runs (blur 2 px): no
ground 0.23 (72014) and 0.43 (71031); rendered ground under models of the right kind
0.87-1.00 (72012, 72017, 72027, 71001, 71004, 71006, 71010, 71016, 70011, 70035), Blender's
0.69-0.94 (72100, 72103-72105); models of a wrong kind, whose bottom lies elsewhere, 0.43
(72007) and 0.45 (71020)."""

BLURS_PX = (2.0, 1.0)
"""The Gaussian blurs (sd, pixels) of the coarse-to-fine levels: a camera a few tenths of a
degree off starts a few pixels off on the near ground, within the blurred texture's basin
(the texture prototype's pyramid; `benchmarks/texture_cameras.py`)."""

SOLVES_PER_LEVEL = 2
"""Solves per blur level, the patches beyond their chi-square quantile dropped between them
(occluders, cast shadows that move with nothing, the object's foot)."""

GROUND_TR_SOLVER: TrSolver = "lsmr"
"""The adjustments with the ground's patches solve on the sparse Jacobian: 16 rows a patch, a
thousand patches and more, against 60-100 unknowns; the dense solver's SVD of every step took
minutes a scene (dev 69009: 72 SVDs, 28 s of a 37-s solve on one loaded core)."""

BOTTOM_LEVEL_SIGMA_DEG = 0.1
"""The model's bottom face (`bottom_face`: a house's floor, a tower's base) is held parallel
to the ground's plane to this sigma, degrees: the object stands on the ground, whose plane
the first view's stereo pair measures from hundreds of patches, while the views measure the
bottom only by its foot edges at grazing angles and by its walls standing square to it. On
dev 70035 and 70011 (3 views each) the ground's plane came out 0.004 and 0.11 deg from the
truth's, the floor 0.64 and 0.93 deg with the whole house tilted by as much."""

GROUND_NAME = "(ground)"
"""The ground plane's name in the adjustment (no part of the object)."""


@dataclass(frozen=True)
class GroundStep:
    """What `ground_adjustment` leaves: the model's planes and the cameras adjusted with the
    ground's texture, the problem solved (the ground's plane its last part, the first view's
    right camera after the views' cameras) for the deviations, the report of the model's own
    factors (the ground's patches left out), and the patches each later view kept (by camera
    index)."""

    normals: FloatArray
    offsets: FloatArray
    cameras: tuple[PinholeCamera, ...]
    problem: Problem
    report: ResidualReport
    patches: dict[int, int]


def bottom_face(model: RigidModel, up: FloatArray) -> int | None:
    """The model's face that looks down (its outward normal within `BOTTOM_FACE_DEG` of
    ``-up``), the lowest of them along ``up``; None if there is none.

    model : the model (world frame); up : (3,) the model's vertical, pointing up (any length).
    """
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    down = -(model.normals @ up)
    bottoms = np.flatnonzero(down >= math.cos(math.radians(BOTTOM_FACE_DEG)))
    if not bottoms.size:
        return None
    lows = [float((np.asarray(model.polygons[i]) @ up).min()) for i in bottoms]
    return int(bottoms[int(np.argmin(lows))])


def ground_plane(
    model: RigidModel, up: FloatArray, bottom: int | None
) -> tuple[FloatArray, float, FloatArray]:
    """The ground under the model: its unit normal, its offset (``n·x = d``, metres) and its
    polygon (4, 3), a square of half side `GROUND_REACH` times the model's size about the
    model's centre, counter-clockwise seen from above (world frame).

    The model's face that looks down (``bottom``, `bottom_face`) gives the plane, turned to
    face up: an estimated vertical is a degree or more off (`aida_kb.interpret.ground`), and a
    ground tilted by that much from the object's own bottom starts its patches pixels off
    where it is near. Without such a face (None), the plane square to ``up`` through the
    model's lowest point.

    model : the model (world frame); up : (3,) the model's vertical, pointing up;
    bottom : the index of its bottom face (`bottom_face`) or None.
    """
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    vertices = np.vstack([np.asarray(p, dtype=np.float64) for p in model.polygons])
    if bottom is not None:
        n, d = -model.normals[bottom], -float(model.offsets[bottom])
    else:
        n, d = up, float((vertices @ up).min())
    centre = vertices.mean(axis=0)
    foot = centre - (float(centre @ n) - d) * n
    a = np.asarray(np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))]), dtype=np.float64)
    a = a / np.linalg.norm(a)
    b = np.cross(n, a)
    half = GROUND_REACH * float(np.ptp(vertices, axis=0).max())
    square = [foot + half * (sa * a + sb * b) for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return n, d, np.array(square)


def _with_ground(model: RigidModel, up: FloatArray, bottom: int | None) -> RigidModel:
    """The model's faces and the ground's (the last; `ground_plane`), for ray casting the
    patches."""
    n, d, polygon = ground_plane(model, up, bottom)
    return RigidModel.from_polygons(
        [*model.names, GROUND_NAME],
        np.vstack([model.normals, n]),
        np.append(model.offsets, d),
        [*model.polygons, polygon],
    )


def bottom_on_ground(bottom: int | None, ground: int) -> list[Constraint]:
    """The prior holding the model's bottom face parallel to the ground's plane, their
    normals opposite (the bottom's faces down, the ground's up), to `BOTTOM_LEVEL_SIGMA_DEG`;
    none without a bottom face.

    bottom : the bottom face's part index (`bottom_face`) or None; ground : the ground
    plane's part index in the adjustment.
    """
    if bottom is None:
        return []
    label = "bottom on the ground"
    return [
        Constraint(
            kind="parallel",
            parts=(bottom, ground),
            sign=-1,
            sigma=math.radians(BOTTOM_LEVEL_SIGMA_DEG),
            unit="rad",
            label=label,
            origin=Origin(label, "prior"),
        )
    ]


def _blurred(image: npt.NDArray[np.uint8], sigma_px: float) -> FloatArray:
    """The image's grey levels (float64) blurred by a Gaussian of ``sigma_px``."""
    import cv2

    return np.asarray(cv2.GaussianBlur(image.astype(np.float64), (0, 0), sigma_px), np.float64)


def ground_adjustment(
    model: RigidModel,
    cameras: Sequence[PinholeCamera],
    views: Sequence[ViewMeasurements],
    free: Sequence[int],
    inputs: JointInputs,
    greys: Sequence[npt.NDArray[np.uint8] | None],
    first_right: tuple[Rig, npt.NDArray[np.uint8]] | None,
) -> GroundStep | str:
    """Adjust the model and the free cameras with the ground's texture (module docstring).

    Parameters
    ----------
    model : the model (world frame) with its vertical in ``inputs.up``.
    cameras : one per view, the first fixed; views : their measurements; free : the indices
        of the free cameras; inputs : the image rounds' measurements (`JointInputs`).
    greys : each view's undistorted left image (8-bit grey) or None.
    first_right : the first view's rig and undistorted right image, or None.

    Returns
    -------
    The adjusted step (`GroundStep`), or why there is none: no vertical, no right image,
    no later view seeing `MIN_GROUND_PATCHES` of the ground, or a failed solve.
    """
    if inputs.up is None or first_right is None or not greys or greys[0] is None:
        return "no vertical, no first right image or no first image"
    up = np.asarray(inputs.up, dtype=np.float64)
    try:
        base = joint_problem(model, cameras, views, free, inputs)
        bottom = bottom_face(model, up)
        faces = _with_ground(model, up, bottom)
    except (SolveError, GeometryError) as exc:
        return str(exc)
    g = len(model.names)  # the ground's plane: the last
    ties = bottom_on_ground(bottom, g)
    rig, right_image = first_right
    normals, offsets = faces.normals, faces.offsets
    now = tuple(base.cameras)
    right = rig.right_of(now[0])
    polygons = list(faces.polygons)
    centres = part_centres(faces)

    def with_patches(
        normals: FloatArray,
        offsets: FloatArray,
        everything: tuple[PinholeCamera, ...],
        extra: list[Constraint],
    ) -> Problem:
        """The image rounds' problem and the patches at the planes and cameras given."""
        return build_problem(
            normals,
            offsets,
            [*base.constraints, *ties, *extra],
            centres=centres,
            names=faces.names,
            cameras=everything,
            free_cameras=base.free_cameras,
            derived=base.derived,
        )

    patches: dict[int, int] = {}
    problem: Problem | None = None
    result: SolveResult | None = None
    try:
        for blur in BLURS_PX:
            current = RigidModel.from_polygons(faces.names, normals, offsets, polygons)
            reference = _blurred(greys[0], blur)
            extra: list[Constraint] = []
            patches = {}
            counts: dict[int, int] = {}
            for k in free:
                image = greys[k]
                if image is None:
                    continue
                tex = texture_factors(
                    current,
                    now[0],
                    reference,
                    now[k],
                    k,
                    TextureImage(_blurred(image, blur)),
                    1.0,
                    views[k].view,
                    only_face=g,
                    grazing_deg=GROUND_GRAZING_DEG,
                )
                counts[k] = len(tex)
                if len(tex) < MIN_GROUND_PATCHES:
                    continue
                sigma = texture_noise_grey(normals, offsets, now, tex)
                if not math.isfinite(sigma) or sigma <= 0.0:
                    continue
                extra += [replace(c, sigma=sigma) for c in tex]
                patches[k] = len(tex)
            if not extra:
                counted = ", ".join(f"{views[k].view}: {n}" for k, n in sorted(counts.items()))
                return f"no later view sees {MIN_GROUND_PATCHES} patches of the ground" + (
                    f" (view {counted})" if counted else ""
                )
            everything = (*now, right)
            stereo = texture_factors(
                current,
                now[0],
                reference,
                right,
                len(now),
                TextureImage(_blurred(right_image, blur)),
                1.0,
                f"{views[0].view} right",
                only_face=g,
                grazing_deg=GROUND_GRAZING_DEG,
            )
            if blur == BLURS_PX[0]:  # the first view's stereo must see the ground there
                seen = ground_seen_share(stereo, normals, offsets, everything, len(now))
                if not seen >= GROUND_SEEN_SHARE:
                    return (
                        f"{seen:.0%} of the first view's patches below the model lie at the "
                        f"ground's depth (at least {GROUND_SEEN_SHARE:.0%}): no ground there"
                    )
            sigma = texture_noise_grey(normals, offsets, everything, stereo)
            if math.isfinite(sigma) and sigma > 0.0:
                extra += [replace(c, sigma=sigma) for c in stereo]
            for _ in range(SOLVES_PER_LEVEL):
                problem = with_patches(normals, offsets, everything, extra)
                result = solve(
                    problem, loss=JOINT_LOSS, f_scale=JOINT_F_SCALE, tr_solver=GROUND_TR_SOLVER
                )
                normals, offsets = result.normals, result.offsets
                everything = tuple(result.cameras)
                extra = agreeing_patches(extra, normals, offsets, everything)
            now = everything[: len(base.cameras)]
        problem = with_patches(normals, offsets, everything, extra)
    except AidaError as exc:
        return str(exc)
    assert result is not None
    own = len(base.constraints)
    report = ResidualReport(rows=result.report.rows[:own], dof=result.report.dof[:own])
    return GroundStep(normals[:g], offsets[:g], now[: len(cameras)], problem, report, patches)


def ground_seen_share(
    stereo: Sequence[Constraint],
    normals: FloatArray,
    offsets: FloatArray,
    cameras: Sequence[PinholeCamera],
    right: int,
) -> float:
    """The share of the first view's stereo patches on the ground that fit its plane clearly
    better than infinity: each patch's cost at the plane under `GROUND_NEARER_COST` times its
    cost seen by the right camera moved onto the first camera's centre (no baseline: every
    point at infinity). 0 without patches.

    stereo : ``texture`` factors of the first view's left image seen by camera ``right``;
    normals (P, 3), offsets (P,) : the planes, world frame; cameras : the problem's cameras,
    the first view's the first.
    """
    if not stereo:
        return 0.0
    cams = list(cameras)
    seen = cams[right]
    cams_far = [*cams]
    cams_far[right] = PinholeCamera(
        seen.K, seen.R_cam_world, -seen.R_cam_world @ cams[0].centre, seen.width, seen.height
    )
    (block,) = compile_blocks(stereo, normals.shape[0], len(cams))
    near = np.sum(block.evaluate(normals, offsets, cams, camera_jacobian=False)[0] ** 2, axis=1)
    far = np.sum(block.evaluate(normals, offsets, cams_far, camera_jacobian=False)[0] ** 2, axis=1)
    return float(np.mean(near < GROUND_NEARER_COST * far))


__all__ = [
    "BLURS_PX",
    "BOTTOM_FACE_DEG",
    "BOTTOM_LEVEL_SIGMA_DEG",
    "GROUND_GRAZING_DEG",
    "GROUND_NAME",
    "GROUND_NEARER_COST",
    "GROUND_REACH",
    "GROUND_SEEN_SHARE",
    "MIN_GROUND_PATCHES",
    "SOLVES_PER_LEVEL",
    "GroundStep",
    "bottom_face",
    "bottom_on_ground",
    "ground_adjustment",
    "ground_plane",
    "ground_seen_share",
]
