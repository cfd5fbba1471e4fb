"""A constraint as a factor: its kind, keys, typed measurement, noise model, loss and origin.

A `Constraint` is one residual block of a least-squares problem (Ceres' residual block, GTSAM's
factor):

* **kind** — a name in the kind registry (`aida_kb.constraints.registry.KINDS`), which knows
  the number of planes, the residual size, the degrees of freedom, how to validate, pack and
  evaluate it;
* **keys** — ``parts``, indices of the planes it relates, and for kinds that look through a
  camera, the camera index in the measurement (`EdgeData.camera`,
  `CameraPositionData.camera`);
* **measurement** — per-kind typed data: the target ``value`` of an angle, the ``sign`` of a
  parallel pair, `PositionData` (eq. 4), `EdgeData` (eq. 5), `CameraPositionData` (eq. 4
  measured in a free camera's frame) or `TextureData` (a patch of a reference image's texture
  seen again through a camera);
* **noise model** — ``sigma`` (isotropic, in ``unit``), or an explicit ``weight``, or a square-
  root information matrix ``sqrt_information`` (k x k, whitening the k residual components,
  e.g. a segment's two correlated end-point residuals or metres and radians together);
* **loss** — a robust loss on the whitened block (``None``: the solve's default for
  measurements, none for the knowledge's own constraints), ``loss_scale`` in sigmas;
* **reject_above** — an optional rejection threshold in ``unit``;
* **origin** — where it came from (`Origin`): its label, concept, owning instance, the rule
  that brought it in, and the span of its ``.kb`` line when it has one.

Weighting: the whitened residual of constraint i is ``sqrt(m_i) · S_i · e_i`` where ``e_i`` is
the unweighted residual in the constraint's unit, ``S_i`` the square-root information
(``sqrt(W_i) · I`` for a weight ``W_i`` or ``1/sigma²``) and ``m_i`` its multiplicity (``w_c``,
the summed certainty of the region, for a position constraint; 1 otherwise). Its cost is
``m_i · |S_i e_i|²`` (the paper's eq. 6 term).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from aida_kb.diagnostics.core import Span
from aida_kb.kb.paths import ROOT, RolePath

Rule = Literal["knowledge", "evidence", "attribute", "prior", "code"]
"""Why a constraint exists: a constraint or measure of the knowledge base ("knowledge"), a
measurement the evidence adds with no line of its own ("evidence"), an attribute's range
("attribute"), a prior the program adds (e.g. a first shape's angles, "prior"), or a
constraint built directly in code (tests, benchmarks: "code")."""

Loss = Literal["linear", "soft_l1", "huber"]


@dataclass(frozen=True)
class Origin:
    """Where a constraint came from.

    Attributes
    ----------
    label : its knowledge-base label (``wall_angle``), or a name given by the code.
    rule : why it exists (`Rule`).
    concept : the concept that declared it ('' when no concept did).
    owner : role path of the instance that brought it in (`ROOT` for the goal or none).
    span : the ``.kb`` line it was declared on (None for constraints made by code).
    """

    label: str
    rule: Rule = "code"
    concept: str = ""
    owner: RolePath = ROOT
    span: Span | None = None

    @property
    def where(self) -> str:
        """``file:line:column`` of its ``.kb`` line, or '' when it has none."""
        return str(self.span) if self.span is not None else ""

    def describe(self) -> str:
        """A short phrase for messages: the label, the concept and where it was declared."""
        text = f"'{self.label}'" if self.label else "a constraint"
        if self.concept:
            text += f" of {self.concept}"
        if self.span is not None:
            text += f" ({self.where})"
        elif self.rule != "knowledge":
            text += f" ({self.rule})"
        return text


@dataclass(frozen=True)
class PositionData:
    """Region evidence of a position constraint (paper eq. 4), world frame.

    Attributes
    ----------
    n_init : (3,) unit normal of the region's plane fit, world frame.
    c_init : (3,) metres, world frame: the region's centre of gravity on that plane.
    w_c : summed certainty over the region (the constraint's multiplicity), > 0.
    w_n : relative weight of the centre shift against the normal angle (1/m²), > 0.
    px_per_m : pixels per metre at the region's depth (focal length / depth); needed only when
        the constraint's unit is "px".
    radius_m : the region's radius in metres (a tilt by theta moves its rim by
        ``radius_m · theta``); needed only when the unit is "px".
    shift_px_per_m : unit "px" only: pixels per metre of shift along the normal, in place of
        ``px_per_m`` (e.g. the change of stereo disparity, ``f·B/z²`` per metre of depth).
    tilt_px_per_rad : unit "px" only: pixels per radian of tilt, in place of
        ``px_per_m · radius_m``.
    """

    n_init: tuple[float, float, float]
    c_init: tuple[float, float, float]
    w_c: float = 1.0
    w_n: float = 1.0
    px_per_m: float | None = None
    radius_m: float | None = None
    shift_px_per_m: float | None = None
    tilt_px_per_rad: float | None = None


@dataclass(frozen=True)
class EdgeData:
    """Image evidence of an edge constraint (paper eq. 5).

    Attributes
    ----------
    camera : index of the camera that saw the segment.
    p1_px, p2_px : the segment's end points, pixels (x right, y down).
    lean : 0, or the sign (+1, -1) of the end-point residuals (the model edge's distance from
        the segment's line, `aida_kb.constraints.edge.edge_kernel`) that a one-sided bias of
        the measurement explains: a wall's foot seen as the edge of the shadow the wall casts
        on the ground beside it lies off the true foot towards the ground, never towards the
        wall. Such residuals are multiplied by `lean_scale` before whitening.
    lean_scale : in (0, 1]: that factor (the ratio of the measurement's sigma to its sigma on
        the biased side).
    """

    camera: int
    p1_px: tuple[float, float]
    p2_px: tuple[float, float]
    lean: int = 0
    lean_scale: float = 1.0


@dataclass(frozen=True)
class CameraPositionData:
    """A region's plane measured in the frame of camera ``camera`` (paper eq. 4, registration).

    The region's centre and normal were measured by the stereo pair of that camera, so they
    follow its pose: with the pose ``[rvec, C]`` (``R = R(rvec)`` maps world to camera), the
    centre is ``X = Rᵀ·centre_cam + C`` and the normal ``Rᵀ·normal_cam`` in the world.

    Attributes
    ----------
    camera : index of the camera.
    normal_cam : (3,) unit normal of the region's plane fit, camera frame.
    centre_cam : (3,) metres, camera frame: the region's centre on that plane.
    """

    camera: int
    normal_cam: tuple[float, float, float]
    centre_cam: tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class TextureImage:
    """An image a texture factor looks into (shared by all factors of its camera).

    Attributes
    ----------
    pixels : (H, W) float64 grey levels of the undistorted image of the camera's pinhole model
        (pixel centres at integer coordinates, x right, y down).
    """

    pixels: npt.NDArray[np.float64]


@dataclass(frozen=True)
class TextureData:
    """A patch of a reference image's texture on one plane, seen again by camera ``camera``.

    The patch's N sample pixels of the reference image look along the world-frame rays
    ``rays`` from ``origin`` (the reference camera's centre; that camera is held fixed); each
    ray meets the constraint's plane in a point that camera ``camera`` sees in ``image``.

    Attributes
    ----------
    camera : index of the camera that sees the patch again (its pose may be an unknown).
    origin : (3,) metres, world frame: the reference camera's centre.
    rays : N rows (3,), world frame: the sample pixels' ray directions (any length > 0).
    values : (N,) grey levels of the reference image at the sample pixels.
    image : the image of camera ``camera`` (`TextureImage`).
    """

    camera: int
    origin: tuple[float, float, float]
    rays: tuple[tuple[float, float, float], ...]
    values: tuple[float, ...]
    image: TextureImage


@dataclass(frozen=True)
class Constraint:
    """One constraint (a factor) between parts: see the module docstring.

    Attributes
    ----------
    kind : a kind of the registry (`aida_kb.constraints.registry.KINDS`).
    parts : part indices, the kind's ``arity`` of them.
    value : the target angle (rad) of an "angle" constraint; None for the others.
    sigma : tolerance in `unit`; the weight is ``1/sigma²`` unless `weight` is given.
    weight : explicit weight (overrides sigma for the objective; sigma still normalises).
    sqrt_information : (k, k) whitening matrix of the k residual components, rows as tuples;
        when given it replaces sigma and weight (the report's sigma is then 1, whitened units).
    reject_above : |residual| above this (in `unit`) flags the constraint in the report.
    unit : "rad", "m", "px" or "" (the unit of the residual, sigma and reject_above).
    measurement : True for measurements of the evidence (the default robust loss applies).
    label : a name for reports and messages (the origin's label when not given).
    sign : "parallel" only: +1 the normals face the same way, -1 opposite ways, 0 either.
    position, edge, camera_position, texture : the measurement of the kinds that have one.
    loss, loss_scale : this block's robust loss and its threshold in sigmas (None: the
        solve's default for measurements, linear for the others).
    origin : where the constraint came from (None: made by code, labelled `label`).
    """

    kind: str
    parts: tuple[int, ...]
    value: float | None = None
    sigma: float | None = None
    weight: float | None = None
    reject_above: float | None = None
    unit: str = ""
    measurement: bool = False
    label: str = ""
    position: PositionData | None = None
    edge: EdgeData | None = None
    sign: int = 0
    camera_position: CameraPositionData | None = None
    texture: TextureData | None = None
    sqrt_information: tuple[tuple[float, ...], ...] | None = None
    loss: Loss | None = None
    loss_scale: float | None = None
    origin: Origin | None = None

    @property
    def effective_weight(self) -> float:
        """The weight W: explicit, else ``1/sigma²`` (1 with a square-root information)."""
        if self.sqrt_information is not None:
            return 1.0
        if self.weight is not None:
            return float(self.weight)
        if self.sigma is None:
            return 1.0
        return 1.0 / float(self.sigma) ** 2

    @property
    def effective_sigma(self) -> float:
        """The tolerance that normalises the cost: sigma, else ``1/sqrt(weight)``; 1 in the
        whitened units of a square-root information."""
        if self.sqrt_information is not None:
            return 1.0
        if self.sigma is not None:
            return float(self.sigma)
        return 1.0 / math.sqrt(self.effective_weight)

    @property
    def source(self) -> Origin:
        """The origin, or one made from the label when the constraint has none."""
        return self.origin if self.origin is not None else Origin(self.label or self.kind)
