"""Verifying a hypothesis with the project's solver (`aida_kb.solve`).

A hypothesis is verified by one weighted least-squares problem over the planes of its parts:
seen parts start from their regions' plane fits, inserted ones from the knowledge, and parts
of an already verified level (the main body when a wing or an oriel is tried) are fixed.
Its constraints come from the knowledge base by `aida_kb.solve.constraints_from_kb`: the
internal constraints of every concept the hypothesis instantiates, and the measurements that
tie it to the evidence — the position of each bound region (paper eq. 4) and the edge of each
matched image segment (eq. 5; a concept's own ``measure edge(edge(a, b))`` where it declares
one, else the segment's ``Contour``). Walls also get a soft constraint from their ``tilt``
attribute (`tilt_constraints`).

How the interpreter scales the evidence (`position_data`): a region's plane may move by what
stereo can tell apart, so its shift along the normal is measured as the change of disparity it
causes (``f·B/z²`` pixels per metre at the region's depth z; ``f/z`` across the image when the
baseline is unknown), and its tilt by what that change is at the region's rim against what the
fit resolves there (`tilt_px_per_rad`); the constraint's multiplicity is the region's *mean*
certainty (in 0..1), so that a large region does not outvote the knowledge.

The verdict comes from the solver's residual report: a constraint whose normalised cost
exceeds its threshold rejects the hypothesis (`Outcome.worst_rejected`); the report's reduced
cost (`Outcome.cost`) measures how well the constraints fit together. The fragments of one
model edge seen in one image (a contour broken by texture or occlusion) are judged together:
their rows of the report are pooled (normalised costs and thresholds summed, the residual the
RMS over the fragments), so that one stray fragment does not outweigh the rest of the edge.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, EdgeData, Origin, PositionData, kind_of
from aida_kb.diagnostics.core import Span
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.feet import leaning_feet
from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import FIT_CORRELATED_PX, CameraView, RegionView, fit_sigma_rad
from aida_kb.kb.paths import ROOT, RolePath
from aida_kb.solve import ConstraintResidual, build_problem, constraints_from_kb, solve

FloatArray = npt.NDArray[np.float64]

# A region's tilt where its fit's statistics are unknown (evidence without inlier counts and
# areas, written before they were kept): one degree counts as one pixel.
TILT_PX_PER_RAD = math.degrees(1.0)
# The fit's statistical tilt (`observe.fit_sigma_rad`) understates its error by this factor:
# on the labelled regions of dev seeds 58000-58023, 59000-59023 and streets 62000-62009 (124
# regions on their true faces) the fit was off the truth by 4.3 of its sigmas at the
# 95th percentile (7.5 at most: a 61 m² wall at 59 m, 2.6 deg off, sigma 0.35); twice the
# sigma puts every one of them within 4 (the check's 4 px) and 95 % within 2.
TILT_FIT_SIGMA_FACTOR = 2.0
# ... and is not trusted below this (degrees), however many pixels it has: the old scale (a
# degree, a pixel), so that a large well-measured region (sigma 0.1-0.3 deg) holds its plane
# against the knowledge and the image edges as firmly as before; only fits less certain than
# that are loosened. Biases the statistics do not show remain (unlabelled regions straddling a
# crease: 10 % of them off by more than 6.7 of their sigmas on the dev seeds above).
TILT_FLOOR_DEG = 1.0
TILT_SIGMAS = 5.0  # an attribute range's half-width is taken as this many sigma
MAX_EVALUATIONS = 60  # a hypothesis that needs more is wrong; its residuals will say so
BLAME_EVALUATIONS = 15  # a trial without one constraint starts at the full solution
TOLERANCE = 1e-8  # the solver's ftol, xtol and gtol: far below what the verdicts can tell


@dataclass(frozen=True)
class PlaneInit:
    """A part's plane before adjustment: unit outward normal (3,), offset d (n·x = d), metres.

    Its frame (`aida_kb.solve`) is centred at the foot of the perpendicular from the object's
    centre (`object_centre`): a direction the constraints leave free keeps that point.
    """

    role: str
    concept: str
    normal: FloatArray
    offset_m: float
    fixed: bool = False


BlameGroup = tuple[str, RolePath, tuple[int, ...]]
"""The constraints that stand or fall together when one is left out to find the culprit of a
contradiction: (label, owner, parts) — a knowledge constraint with every instance of its label
and owner (parts ``()``), a measurement per part it measures."""


def blame_group(c: Constraint) -> BlameGroup | None:
    """The blame group of ``c``, or None for measurements through a camera (image segments:
    fragments of evidence, never left out alone)."""
    kind = kind_of(c.kind)
    if kind.uses_camera:
        return None
    o = c.source
    if kind.measurement:
        return (o.label, ROOT, tuple(int(p) for p in c.parts))
    return (o.label, o.owner, ())


@dataclass(frozen=True)
class Outcome:
    """The adjusted planes, the residual of every constraint and the report's reduced cost.

    ``members`` holds, for each row of ``residuals``, the positions of the verification's
    constraints pooled in it (the fragments of one image edge share a row).
    """

    planes: dict[str, tuple[FloatArray, float]]
    residuals: tuple[ConstraintResidual, ...]
    cost: float  # sum of normalised costs over their degrees of freedom
    members: tuple[tuple[int, ...], ...] = ()

    def worst_rejected(self) -> ConstraintResidual | None:
        """The rejected constraint with the highest normalised cost over its threshold."""
        bad = [r for r in self.residuals if r.rejected]
        return max(bad, key=lambda r: r.normalised_cost / r.threshold) if bad else None


@dataclass(frozen=True)
class Verification:
    """One hypothesis' least-squares problem: planes, constraints (each with its origin),
    cameras."""

    planes: tuple[PlaneInit, ...]
    constraints: tuple[Constraint, ...]
    cameras: tuple[PinholeCamera, ...] = ()
    skipped: tuple[str, ...] = field(default=(), compare=False)

    @property
    def roles(self) -> tuple[str, ...]:
        """The parts' role paths, in part order."""
        return tuple(p.role for p in self.planes)

    def without(
        self, drop: Collection[int], start: Mapping[str, tuple[FloatArray, float]] | None = None
    ) -> Verification:
        """The same problem without the constraints at positions ``drop``.

        ``start`` (role path -> (unit normal, offset m)) replaces the initial planes, e.g. by
        the solution of the full problem (a warm start).
        """
        keep = [i for i in range(len(self.constraints)) if i not in drop]
        planes = self.planes
        if start is not None:
            planes = tuple(
                replace(p, normal=start[p.role][0], offset_m=start[p.role][1])
                if p.role in start
                else p
                for p in planes
            )
        return replace(
            self,
            planes=planes,
            constraints=tuple(self.constraints[i] for i in keep),
        )


def tilt_px_per_rad(
    rms_m: FloatArray | float, inliers: FloatArray | float, area_m2: FloatArray | float
) -> FloatArray:
    """Pixels per radian of a region's tilt: one pixel per sigma of what stereo resolves.

    A tilt by theta moves the region's rim (its radius of gyration ``rho = sqrt(area / 12)``
    along each axis) by ``rho·theta`` along the normal: a change of disparity of
    ``(f·B/z²)·rho·theta`` pixels there (of image position, ``(f/z)·rho·theta``, when the
    baseline is unknown). The fit of the region's ``n = inliers / FIT_CORRELATED_PX``
    independent points, scattered by ``rms_m`` about its plane, resolves that change to
    ``(f·B/z²)·rms_m/sqrt(n)``: the tilt counts ``theta·rho·sqrt(n)/rms_m`` of those pixels,
    so ``1 / sigma_fit`` pixels per radian where ``sigma_fit = rms_m / (sqrt(n)·rho)``
    (`observe.fit_sigma_rad`; f, B and z cancel: the scale holds with a baseline or without).
    That sigma is made honest by `TILT_FIT_SIGMA_FACTOR` and floored by `TILT_FLOOR_DEG`:
    ``sigma = hypot(TILT_FIT_SIGMA_FACTOR · sigma_fit, TILT_FLOOR_DEG)``, the scale
    ``1 / sigma`` px/rad. A small region seen edge-on from afar (a few hundred inliers over a
    few m², rms 0.1-0.4 m: sigma 2-10 deg) may then be tilted by several degrees at one
    pixel per sigma; a large one close by is held to a degree per pixel as before.
    A fit of fewer than `FIT_CORRELATED_PX` inliers counts as one point, one of none too (a
    fit that kept none of the original image's pixels: a dark roof's 121 depth pixels, its
    fit 6 degrees off its true face, dev seed 61510, which at a degree a pixel rejected the
    right roof), as the verdict counts it (`verdict.views.normal_tolerance_cos`); where the
    inliers (NaN) or the area (0) are unknown, `TILT_PX_PER_RAD`.

    rms_m : metres; inliers : pixels, NaN unknown; area_m2 : m², 0 unknown (broadcast
    together). Returns px/rad.
    """
    rms, n_px, area = np.broadcast_arrays(
        np.asarray(rms_m, dtype=np.float64),
        np.asarray(inliers, dtype=np.float64),
        np.asarray(area_m2, dtype=np.float64),
    )
    known = np.isfinite(n_px) & (area > 0.0)
    samples = np.maximum(np.where(known, n_px, 0.0) / FIT_CORRELATED_PX, 1.0)
    fit = fit_sigma_rad(rms, samples, np.where(known, area, 1.0))
    sigma = np.hypot(TILT_FIT_SIGMA_FACTOR * fit, math.radians(TILT_FLOOR_DEG))
    return np.where(known, 1.0 / sigma, TILT_PX_PER_RAD)


def position_data(region: RegionView, camera: CameraView) -> PositionData:
    """The evidence of a region's position constraint, scaled as the module docstring says."""
    z = float(camera.pinhole.depth(region.centroid_m[None, :])[0])
    if not z > 0:
        raise SolveError(f"region {region.id} lies behind camera {camera.view}")
    f = float(camera.K[0, 0])
    shift = f * camera.baseline_m / z**2 if camera.baseline_m > 0 else f / z
    certainty = min(1.0, region.weight / max(region.area_px, 1.0))
    return PositionData(
        n_init=_v3(region.normal),
        c_init=_v3(region.centroid_m),
        w_c=float(np.clip(certainty, 1e-6, 1.0)),
        px_per_m=f / z,
        shift_px_per_m=shift,
        tilt_px_per_rad=float(
            tilt_px_per_rad(
                region.rms_m,
                math.nan if region.inliers is None else region.inliers,
                region.area_m2,
            )
        ),
    )


def _v3(a: FloatArray) -> tuple[float, float, float]:
    return (float(a[0]), float(a[1]), float(a[2]))


def _relative(root: RolePath, path: RolePath) -> RolePath:
    """``path`` relative to the role path ``root`` (`ROOT` for the root itself)."""
    try:
        return path.relative_to(root)
    except ValueError as exc:
        raise SolveError(str(exc)) from None


@dataclass(frozen=True)
class EdgeEvidence:
    """A segment matched to the edge of two parts (absolute role paths) in one camera.

    ``contour_of`` is the part whose region the segment borders: the segment is that region's
    contour when no concept declares a measure on this edge.
    """

    parts: tuple[str, str]
    contour_of: str
    camera: int
    ends_px: FloatArray  # (2, 2)


def build_verification(
    knowledge: Knowledge,
    root: str,
    root_concept: str,
    planes: Sequence[PlaneInit],
    fillers: Mapping[str, str],
    positions: Mapping[str, PositionData],
    edges: Sequence[EdgeEvidence],
    declared: Collection[tuple[str, str]],
    cameras: Sequence[PinholeCamera],
    extra: Sequence[Constraint] = (),
    *,
    metric: bool = True,
    ground: str | None = None,
) -> Verification:
    """The verification problem of a hypothesis, its constraints from the knowledge base.

    Parameters
    ----------
    knowledge : the knowledge (its compiled ``kb``).
    root, root_concept : role path and concept of the instance the parts belong to
        (``"body"``, ``"HouseBody"``); every role path below is absolute.
    planes : the parts' initial planes (fixed ones included).
    fillers : role path -> the concept chosen for it along is-a.
    positions : role path of a seen part -> its region's evidence.
    edges : matched segments; those of an edge in ``declared`` (sorted role pairs whose edge a
        concept measures itself) feed that measure, the others their region's contour.
    cameras : the cameras of the edge evidence.
    extra : constraints the interpreter adds (part indices into ``planes``, with origins).
    metric : the scene's lengths are metres (an edge tolerance given as a length becomes
        pixels, `edges_in_pixels`).
    ground : the role path of the part the object stands on (its normal pointing down), or
        None: the measurements of its edges with the other parts are feet, whose lines lean
        towards the ground (`aida_kb.interpret.feet.leaning_feet`).

    Constraints among fixed parts only are left out: they were verified with their level.
    """
    top = RolePath.parse(root)
    index = {RolePath.parse(p.role): i for i, p in enumerate(planes)}
    if len(index) != len(planes):
        raise SolveError("verification: a part appears twice")
    rel = {_relative(top, path): i for path, i in index.items()}
    declared_set = {tuple(sorted(pair)) for pair in declared}
    edge_map: dict[tuple[int, int], list[EdgeData]] = {}
    contours: dict[RolePath, tuple[int, int, EdgeData]] = {}
    counts: dict[RolePath, int] = {}
    for e in edges:
        data = EdgeData(e.camera, (float(e.ends_px[0, 0]), float(e.ends_px[0, 1])), _p2(e.ends_px))
        a, b = index[RolePath.parse(e.parts[0])], index[RolePath.parse(e.parts[1])]
        if tuple(sorted(e.parts)) in declared_set:
            edge_map.setdefault((min(a, b), max(a, b)), []).append(data)
            continue
        part = planes[index[RolePath.parse(e.contour_of)]].concept or knowledge.concept_at(
            e.contour_of
        )
        through = knowledge.contour_path(part)
        if through is None:
            continue  # the knowledge gives this part's evidence no contours to measure
        region = _relative(top, RolePath.parse(e.contour_of)).join(RolePath.parse(through))
        k = counts.get(region, 0)
        counts[region] = k + 1
        contours[region.indexed(k)] = (a, b, data)
    found = constraints_from_kb(
        knowledge.kb,
        root_concept,
        rel,
        fillers={_relative(top, RolePath.parse(r)): c for r, c in fillers.items() if r != root},
        positions={index[RolePath.parse(r)]: p for r, p in positions.items()},
        edges=edge_map,
        contours=contours,
    )
    fixed = {i for i, p in enumerate(planes) if p.fixed}
    out: list[Constraint] = []
    for c in found.constraints:
        if set(c.parts) <= fixed:
            continue
        o = c.source
        out.append(replace(c, label=o.label, origin=replace(o, owner=top.join(o.owner))))
    out += [c for c in extra if not set(c.parts) <= fixed]
    out = with_edge_scatter(edges_in_pixels(out, planes, cameras, metric=metric))
    if ground is not None and RolePath.parse(ground) in index:
        normals = np.array([p.normal for p in planes], dtype=np.float64)
        offsets = np.array([p.offset_m for p in planes], dtype=np.float64)
        out = leaning_feet(out, normals, offsets, index[RolePath.parse(ground)], cameras)
    return Verification(tuple(planes), tuple(out), tuple(cameras), found.skipped)


# Edge tolerances at the object. The knowledge may give an edge measure's tolerance as a length
# (``measure edge(edge(front, roof.front)) +- 0.1 m``): how far the edge a photograph shows may
# lie from where the two planes meet — an eave's overhang, a cornice, a gutter — the same at any
# distance. Where the edge is seen it becomes pixels: sigma_px = sigma_m · f / Z (f the
# camera's focal length, pixels; Z the depth of the segment's middle on the first part's
# starting plane, metres), combined with the image's own noise EDGE_IMAGE_SIGMA_PX as
# sqrt(EDGE_IMAGE_SIGMA_PX² + sigma_px²): a far edge is still found no better than a pixel. The
# threshold stays the same multiple of sigma. In a scene of unknown scale a metre has no size
# in the images: the measure keeps the image's noise alone (threshold likewise).
EDGE_IMAGE_SIGMA_PX = 1.0  # an image edge's own noise, pixels (the knowledge's Contour measure)
LENGTH_UNITS = frozenset({"m"})  # the unit of a length tolerance once compiled (SI)
RAY_PLANE_MIN_COS = 1e-9  # a ray closer to its plane than this meets it nowhere measurable


def edges_in_pixels(
    constraints: Sequence[Constraint],
    planes: Sequence[PlaneInit],
    cameras: Sequence[PinholeCamera],
    *,
    metric: bool = True,
) -> list[Constraint]:
    """The edge measurements whose tolerance is a length, in pixels (see EDGE_IMAGE_SIGMA_PX).

    planes : the problem's parts (the constraints' part indices), their starting planes in
    metres; cameras : the problem's cameras (the edges' camera indices); metric : the scene's
    lengths are metres (else the length is not known in pixels). Other constraints unchanged.
    """
    out = list(constraints)
    picked = [
        k
        for k, c in enumerate(constraints)
        if c.edge is not None and c.unit in LENGTH_UNITS and c.sigma is not None
    ]
    if not picked:
        return out
    sigma_m = np.array([float(constraints[k].sigma or 0.0) for k in picked])
    sigma_px = np.full(len(picked), EDGE_IMAGE_SIGMA_PX)
    if metric:
        z = np.full(len(picked), -1.0)
        cam_of = np.array([_edge(constraints[k]).camera for k in picked])
        for ci in np.unique(cam_of):  # per camera (a handful), each camera's edges at once
            at = np.flatnonzero(cam_of == ci)
            z[at] = _depth_on_plane([constraints[picked[i]] for i in at], planes, cameras[ci])
        seen = z > 0
        f = np.array([float(cameras[c].K[0, 0]) for c in cam_of])
        sigma_px[seen] = np.hypot(EDGE_IMAGE_SIGMA_PX, sigma_m[seen] * f[seen] / z[seen])
    for i, k in enumerate(picked):
        c = constraints[k]
        scale = float(sigma_px[i] / sigma_m[i])
        reject = c.reject_above * scale if c.reject_above is not None else None
        out[k] = replace(c, sigma=float(sigma_px[i]), reject_above=reject, unit="px")
    return out


def _edge(c: Constraint) -> EdgeData:
    assert c.edge is not None
    return c.edge


def _depth_on_plane(
    constraints: Sequence[Constraint], planes: Sequence[PlaneInit], camera: PinholeCamera
) -> FloatArray:
    """(M,) metres: the depth in ``camera`` where the ray through the middle of each edge
    constraint's segment meets its first part's starting plane; -1 where it does not (the
    plane behind the camera or along the ray)."""
    ends = np.array([[_edge(c).p1_px, _edge(c).p2_px] for c in constraints], np.float64)
    centre, rays = camera.unproject(ends.mean(axis=1))
    normals = np.array([planes[c.parts[0]].normal for c in constraints], np.float64)
    offsets = np.array([planes[c.parts[0]].offset_m for c in constraints], np.float64)
    along = np.einsum("ij,ij->i", rays, normals)
    ok = np.abs(along) > RAY_PLANE_MIN_COS
    t = np.where(ok, (offsets - normals @ centre) / np.where(ok, along, 1.0), -1.0)
    z = camera.depth(centre[None, :] + t[:, None] * rays)
    out: FloatArray = np.where((t > 0) & (z > 0), z, -1.0)
    return out


PARALLEL_SIGMAS = 3.0  # a fragment parallel to its edge's others: within this many sd


def fragment_scatter_px(ends: Sequence[EdgeData], sigma_px: float = 1.0) -> float:
    """The scatter of one edge's image fragments about their common line, pixels.

    ``ends``: the fragments of one model edge in one image; ``sigma_px``: how well one end
    point of a segment is seen (the knowledge's tolerance of the edge). Their 2·n end points
    are fitted by one straight line (total least squares); the result is the RMS of their
    distances from it over the 2·n - 2 degrees of freedom the line leaves. It is a property of
    the evidence alone — whatever the hypothesis, no model edge can fit the fragments better
    than their own best line. It stands for the relief of a real edge (an eave's overhang, a
    plinth, a cornice: lines parallel to the edge, offset from it) only when every fragment
    is parallel to the others: within PARALLEL_SIGMAS of its own direction's standard
    deviation (sqrt(2)·sigma_px / length, radians) of their length-weighted mean direction.
    A fragment across that (another line near the model's edge: a hip where the hypothesis
    has an eave) is no relief: 0 then, as for a single fragment (nothing to compare).
    """
    if len(ends) < 2:
        return 0.0
    p1 = np.array([e.p1_px for e in ends], dtype=np.float64)
    p2 = np.array([e.p2_px for e in ends], dtype=np.float64)
    delta = p2 - p1
    length = np.hypot(delta[:, 0], delta[:, 1])
    if np.any(length <= 0):
        return 0.0
    angle = np.arctan2(delta[:, 1], delta[:, 0])
    # mean direction of undirected lines: average the doubled angles, weighted by length
    mean = 0.5 * math.atan2(float(length @ np.sin(2 * angle)), float(length @ np.cos(2 * angle)))
    off = np.abs((angle - mean + math.pi / 2) % math.pi - math.pi / 2)
    if np.any(off > PARALLEL_SIGMAS * math.sqrt(2.0) * sigma_px / length):
        return 0.0
    pts = np.concatenate([p1, p2])
    centred = pts - pts.mean(axis=0)
    # the smallest singular value's direction is the line's normal
    smallest = float(np.linalg.svd(centred, compute_uv=False)[-1])
    return smallest / math.sqrt(len(pts) - 2)


def with_edge_scatter(constraints: Sequence[Constraint]) -> list[Constraint]:
    """The edge measurements with their tolerance widened by the scatter the evidence shows.

    The knowledge's ``measure edge(...) +- 1 px reject above 3 px`` states how well an edge
    is seen in an image of an ideal object. Parallel fragments of one model edge in one
    image that do not lie on one line (`fragment_scatter_px`) show more: a real eave's
    overhang, a plinth, a cornice. Each fragment's sigma
    becomes ``sqrt(sigma² + scatter²)`` and its rejection threshold grows in proportion (the
    same multiple of sigma), so a residual the evidence itself carries does not reject a
    hypothesis, while a model edge off the fragments' common line still does. Castle
    courtyard (Strecha): three fragments of the wall's foot scatter by 3.4 px about their
    line; every hypothesis of that wall was rejected at 3.97 px against 3 px. On rendered
    scenes the fragments scatter by tenths of a pixel: the tolerances barely change; a
    fragment of another line across the edge widens nothing (a wrong hip roof's edge
    collecting a segment 10 degrees off scattered by 4.4 px and passed: the demo house).
    """
    groups: dict[tuple[object, ...], list[int]] = {}
    for k, c in enumerate(constraints):
        if c.edge is not None and c.sigma is not None and c.sqrt_information is None:
            groups.setdefault((c.source.label, c.parts, c.edge.camera), []).append(k)
    out = list(constraints)
    for members in groups.values():
        ends = [e for k in members if (e := constraints[k].edge) is not None]
        sigma_px = constraints[members[0]].sigma
        assert sigma_px is not None
        scatter = fragment_scatter_px(ends, sigma_px)
        if scatter <= 0.0:
            continue
        for k in members:
            c = constraints[k]
            assert c.sigma is not None
            sigma = math.hypot(c.sigma, scatter)
            reject = c.reject_above * sigma / c.sigma if c.reject_above is not None else None
            out[k] = replace(c, sigma=sigma, reject_above=reject)
    return out


def _p2(ends: FloatArray) -> tuple[float, float]:
    return (float(ends[1, 0]), float(ends[1, 1]))


def tilt_constraints(
    knowledge: Knowledge,
    parts: Sequence[tuple[str, str]],
    floor: str | None,
    index: Mapping[str, int],
) -> list[Constraint]:
    """Soft constraints from the parts' slope attributes: the angle to the ground.

    An attribute that measures its part's slope (``attribute tilt: angle in [85 deg, 95 deg] =
    90 deg is slope(self)``, docs/language.md §3.10) says a wall meets the ground at 90 degrees,
    give or take 5: each such part (role path, concept) gets angle(part, floor) == 90 deg,
    rejected outside the range; sigma is the measure's tolerance, else the range's half-width
    taken as `TILT_SIGMAS` sigma (1 degree here). Attributes without a default give none. No
    floor (the ground part), no constraints.
    """
    if floor is None or floor not in index:
        return []
    out: list[Constraint] = []
    for role, concept in parts:
        attr = knowledge.slope_attribute(concept)
        if attr is None or attr.value is None or attr.low is None or attr.high is None:
            continue
        half = (attr.high - attr.low) / 2.0
        if half <= 0 or role not in index:
            continue
        label = f"{concept}.{attr.name}"
        constraint = Constraint(
            kind="angle",
            parts=(index[role], index[floor]),
            value=attr.value,
            sigma=attr.sigma if attr.sigma is not None else half / TILT_SIGMAS,
            reject_above=half,
            unit="rad",
            label=label,
            origin=Origin(label, "attribute", concept, RolePath.parse(role), attr.span),
        )
        out.append(constraint)
    return out


ORIENTATION_PRIOR_SIGMA_RAD = math.radians(1.0)  # an inserted level part: as square as a corner


def orientation_priors(
    parts: Sequence[tuple[str, str, bool, Span | None]],
    floor: str | None,
    index: Mapping[str, int],
) -> list[Constraint]:
    """Inserted parts the knowledge orients level hold that orientation (rule ``prior``).

    ``parts``: (role path, concept, faces up (True) or down (False), the ``orient`` line) of
    the inserted parts the knowledge turns upward or downward without a tilt (a flat roof's
    top, an oriel's bottom). No region measures them: their normal is the knowledge's, and
    where the constraints leave a rotation free (a flat top through a measured eave turns
    about it; only its side walls are square to it) the adjustment drifted — a flat roof's
    top came out 27-49 degrees steep (a front-only synthetic house, the castle courtyard),
    which the verdict then doubts for the knowledge's orientation. Each such part gets
    parallel(part, floor), the normals opposite (facing up) or alike (facing down), with sigma
    `ORIENTATION_PRIOR_SIGMA_RAD`. No floor, or the part is the floor: none.
    """
    if floor is None or floor not in index:
        return []
    out: list[Constraint] = []
    for role, concept, up, span in parts:
        if role == floor or role not in index:
            continue
        label = f"{concept} orientation"
        out.append(
            Constraint(
                kind="parallel",
                parts=(index[role], index[floor]),
                sign=-1 if up else 1,
                sigma=ORIENTATION_PRIOR_SIGMA_RAD,
                unit="rad",
                label=label,
                origin=Origin(label, "prior", concept, RolePath.parse(role), span),
            )
        )
    return out


# an inserted tilted part whose slope the outlines of the walls it meets show
# (`outline.outline_pitch`) holds that slope to this sigma: on 13 dev gables (65013-68029) the
# outline's measure of the inserted back slope lies within 4.0 deg of the front's seen slope
# (their true slope), two sigma
OUTLINE_PRIOR_SIGMA_RAD = math.radians(2.0)
# ... and the adjustment is rejected when it moves the part this far from it: the outline
# contradicts it (as `alternative.OUTLINE_CONTRADICTED_DEG` rejects a slope a relation placed
# there; the randomised asymmetric gables' slopes differ by 8 deg or more)
OUTLINE_PRIOR_REJECT_RAD = math.radians(8.0)


def outline_priors(
    traced: Mapping[str, float],
    concepts: Mapping[str, str],
    floor: str | None,
    index: Mapping[str, int],
) -> list[Constraint]:
    """Inserted tilted parts hold the slope the outlines of the walls they meet show (rule
    ``prior``).

    ``traced``: role path -> slope in degrees (`unseen.Initial.traced`); ``concepts``: role
    path -> concept name. No region measures such a part and its slope attribute's range is
    wide: where no segment is matched to its edges the adjustment left its slope free and it
    drifted off the outline it started on (dev 69031, an asymmetric gable's back slope: the
    outline 21.2 deg, the truth 21.2, adjusted to 9.0). Each gets angle(part, floor) at that
    slope with sigma `OUTLINE_PRIOR_SIGMA_RAD`, rejected beyond `OUTLINE_PRIOR_REJECT_RAD`.
    No floor: none.
    """
    if floor is None or floor not in index:
        return []
    out: list[Constraint] = []
    for role, slope in sorted(traced.items()):
        if role == floor or role not in index:
            continue
        concept = concepts.get(role, "")
        label = f"{concept} outline slope"
        out.append(
            Constraint(
                kind="angle",
                parts=(index[role], index[floor]),
                value=math.radians(slope),
                sigma=OUTLINE_PRIOR_SIGMA_RAD,
                reject_above=OUTLINE_PRIOR_REJECT_RAD,
                unit="rad",
                label=label,
                origin=Origin(label, "prior", concept, RolePath.parse(role), None),
            )
        )
    return out


def verify(
    v: Verification,
    max_evaluations: int = MAX_EVALUATIONS,
    levels: Sequence[Sequence[int]] | None = None,
) -> Outcome:
    """Adjust the free planes (`aida_kb.solve.solve`) and report every constraint.

    ``max_evaluations`` caps the solver's residual evaluations (per level); ``levels`` (part
    indices) solves hierarchically, each level fixed before the next (`solve`'s levels).

    Raises
    ------
    SolveError
        Degenerate planes or a diverged adjustment.
    """
    normals = np.array([p.normal for p in v.planes], dtype=np.float64).reshape(-1, 3)
    offsets = np.array([p.offset_m for p in v.planes], dtype=np.float64)
    centre = object_centre(v.constraints)
    problem = build_problem(
        normals,
        offsets,
        v.constraints,
        centres=None if centre is None else np.tile(centre, (len(v.planes), 1)),
        fixed_parts=[i for i, p in enumerate(v.planes) if p.fixed],
        names=v.roles,
        cameras=v.cameras,
    )
    result = solve(problem, max_iterations=max_evaluations, tolerance=TOLERANCE, levels=levels)
    if not (np.all(np.isfinite(result.normals)) and np.all(np.isfinite(result.offsets))):
        raise SolveError("adjustment diverged (non-finite planes)")
    roles = v.roles
    pools: dict[tuple[object, ...], list[int]] = {}
    for k, c in enumerate(v.constraints):
        key: tuple[object, ...] = (k,)
        if c.edge is not None:  # the fragments of one model edge in one image
            key = (c.source.label, c.parts, c.edge.camera)
        pools.setdefault(key, []).append(k)
    rows = result.report.rows
    residuals = []
    for members in pools.values():
        first = rows[members[0]]
        if len(members) == 1:
            residuals.append(first)
            continue
        normalised = sum(rows[k].normalised_cost for k in members)
        threshold = sum(rows[k].threshold for k in members)
        residuals.append(
            first.model_copy(
                update={
                    "residual": math.sqrt(
                        sum(rows[k].residual ** 2 for k in members) / len(members)
                    ),
                    "cost": sum(rows[k].cost for k in members),
                    "normalised_cost": normalised,
                    "threshold": threshold,
                    "rejected": normalised > threshold,
                    "fragments": len(members),
                }
            )
        )
    planes = {
        role: (result.normals[i].copy(), float(result.offsets[i])) for i, role in enumerate(roles)
    }
    pooled = tuple(tuple(m) for m in pools.values())
    return Outcome(planes, tuple(residuals), result.report.reduced_cost, pooled)


def object_centre(constraints: Sequence[Constraint]) -> FloatArray | None:
    """(3,) metres, world frame: the certainty-weighted mean of the region centres that the
    position constraints measure (the seen part of the object), or None without any.

    Every plane of a verification turns about the foot of the perpendicular from this point
    (`aida_kb.solve.build_problem`'s ``centres``). About the foot from the world origin (the
    reference camera, tens of metres away) a plane that nothing measures but the knowledge's
    angles swings with them: a floor turned 1.5 degrees by its walls rose 1.2 m at the house
    (dev seed 61309; the ground rule then rejected the house). About the object it stays
    where it was put, and rotation and offset are no longer correlated through the distance.
    """
    data = [c.position for c in constraints if c.position is not None]
    if not data:
        return None
    w = np.array([max(d.w_c, 0.0) for d in data], dtype=np.float64)
    c = np.array([d.c_init for d in data], dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(c)) or w.sum() <= 0.0:
        return None
    return np.asarray((w[:, None] * c).sum(axis=0) / w.sum(), dtype=np.float64)


def verify_levels(levels: Sequence[Verification]) -> Outcome:
    """An accepted interpretation solved as a whole, level by level (paper §5).

    ``levels`` are the verified levels' problems in order (the main body first; each later
    one holds the earlier levels' parts as fixed planes). They are joined into one problem
    whose parts are every level's own parts, started where each level's verification started,
    and solved with `aida_kb.solve.solve`'s ``levels``: the main parts first, then fixed while
    the smaller parts are adjusted against them. The outcome reports every constraint of the
    interpretation at once.
    """
    if not levels:
        raise SolveError("verify_levels: no level to solve")
    planes: list[PlaneInit] = []
    index: dict[str, int] = {}
    members: list[list[int]] = []
    for v in levels:
        own = []
        for p in v.planes:
            if p.fixed:
                if p.role not in index:
                    raise SolveError(
                        f"verify_levels: {p.role} is fixed but no earlier level has it"
                    )
                continue
            index[p.role] = len(planes)
            own.append(len(planes))
            planes.append(p)
        members.append(own)
    constraints: list[Constraint] = []
    for v in levels:
        for c in v.constraints:
            constraints.append(replace(c, parts=tuple(index[v.planes[i].role] for i in c.parts)))
    joint = Verification(tuple(planes), tuple(constraints), levels[0].cameras)
    return verify(joint, levels=members)
