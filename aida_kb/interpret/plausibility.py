"""Plausibility of an adjusted alternative, and the costs the search ranks alternatives by.

An adjusted alternative is plausible when its constraints fit together (reduced cost at most
`MAX_MEAN_COST`, none over its threshold: `alternative`), its planes close a solid with a face
for every part (`closed`), every bound region lies on its part's closed face (`outside`), and
no inserted part is so large in the reference image that the camera could not have missed it
(`unseen`), a smaller part's open face attached against a part of its whole lies within that
part's face (`beyond_whole`: an oriel no larger than the wall it stands out of), and every
measured length attribute of the knowledge (``is height(self)``, ``is distance(a, b)`` ...)
lies in its range in the closed model (`attribute_violation`). Its cost (`misfit`) adds
penalties for evidence it leaves unexplained.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.diagnostics.core import Span
from aida_kb.interpret.closure import ClosingFace, close, inside_face
from aida_kb.interpret.context import Context
from aida_kb.interpret.ground import GROUND_LEVEL_DEG, EvidenceGround
from aida_kb.interpret.hypotheses import Frame
from aida_kb.interpret.knowledge import Structure, join
from aida_kb.interpret.observe import RegionView
from aida_kb.interpret.unseen import Planes, closing_of
from aida_kb.interpret.verify import Outcome

if TYPE_CHECKING:
    from aida_kb.kb.model import AttachmentModel

FloatArray = npt.NDArray[np.float64]

MAX_MEAN_COST = 1.0  # an adjustment whose constraints miss by more than sigma on average fails
UNEXPLAINED_PENALTY = 4.0  # cost of leaving all evidence weight unexplained
SEGMENT_PENALTY = 4.0  # cost of leaving every segment of the bound regions unexplained
# a smaller part's face the camera should see may lack evidence (a grazing side of an oriel,
# its region too small for a plane fit) if its image is below this fraction of its front's
MAX_UNSEEN_SIDE_FRACTION = 0.35
# a region's centroid may lie this fraction of its face's size outside the face
FACE_MARGIN = 0.1
# ... and an unbound region's centroid this fraction of the solid's size inside it (stereo
# noise and planes fitted to a region's edge) before it contradicts the solid
INSIDE_MARGIN = 0.05
COS_LEVEL = math.cos(math.radians(GROUND_LEVEL_DEG))


def unexplained(ctx: Context, used: set[str]) -> float:
    """The penalty for the regions of the reference view not in `used` that are evidence of
    the object (`Context.must_explain`: significant by weight, or large in the image), each by
    its share of the evidence (`Context.share`: weight or pixels, the larger)."""
    left = sum(ctx.share(r) for r in ctx.regions if r.id not in used and ctx.must_explain(r))
    return UNEXPLAINED_PENALTY * left


def misfit(ctx: Context, cost: float, loose: float, left_out: set[str]) -> float:
    """An adjusted alternative's cost: its reduced cost, plus penalties for the fraction of
    segments it leaves unexplained (`loose`) and the regions it could have bound but did not
    (`left_out`, region ids; each by its share of the evidence, `Context.share`)."""
    share = sum(ctx.share(ctx.evidence.regions[r]) for r in left_out)
    return cost + SEGMENT_PENALTY * loose + UNEXPLAINED_PENALTY * share


def closed(
    ctx: Context, structure: Structure, outcome: Outcome, fixed: Planes, frame: Frame
) -> tuple[dict[str, FloatArray], tuple[ClosingFace, ...]]:
    """The closed solid of a structure's planes (`closure`): polygons and closing faces.

    Raises GeometryError (naming the parts) if the planes do not close a solid with a
    face for every part.
    """
    closing = closing_of(ctx, structure, frame, fixed)
    faces = [(leaf.role, *outcome.planes[leaf.role]) for leaf in structure.leaves]
    faces += [(c.role, c.normal, c.offset_m) for c in closing]
    adjacency = list(structure.adjacency)
    adjacency += [(c.role, other) for c in closing for other in c.neighbours]
    return close(faces, adjacency), tuple(closing)


def outside(ctx: Context, binding: dict[str, str], polygons: dict[str, FloatArray]) -> str:
    """Why a bound region does not lie on its part's closed face ('' if all do).

    A region is the visible part of a face: its centroid, projected onto the face's
    plane, must fall inside the face (with a margin of `FACE_MARGIN` of the face's size).
    """
    for rid, role in sorted(binding.items()):
        face = polygons.get(role)
        if face is None or len(face) < 3:
            continue
        centroid = ctx.evidence.regions[rid].centroid_m
        if not inside_face(face, centroid, margin=FACE_MARGIN):
            return f"region {rid} lies outside the face of {role} in the closed model"
    return ""


def hidden_inside(
    ctx: Context,
    planes: Planes,
    ignore: set[str] | frozenset[str],
    size_m: float,
) -> str:
    """Why a seen region contradicts the closed solid ('' if none does).

    A significant region of the reference view that no level binds (`ignore`: the bound
    ones) cannot lie inside the solid: its centroid would be hidden by the solid's faces. The
    solid's planes (`planes`, role path -> (unit outward normal (3,), offset m), world frame)
    bound it; a centroid more than `INSIDE_MARGIN` of the solid's size (`size_m`) behind every
    plane lies inside (for a non-convex solid the test is conservative).
    """
    if not planes:
        return ""
    normals = np.array([n for n, _ in planes.values()], dtype=np.float64)
    offsets = np.array([d for _, d in planes.values()], dtype=np.float64)
    candidates = [r for r in ctx.regions if r.id not in ignore and ctx.significant(r)]
    if not candidates:
        return ""
    centroids = np.array([r.centroid_m for r in candidates], dtype=np.float64)
    depth = centroids @ normals.T - offsets  # (R, F), negative inside each plane
    inside = np.all(depth < -INSIDE_MARGIN * size_m, axis=1)
    for region, hidden in zip(candidates, inside, strict=True):
        if hidden:
            return (
                f"region {region.id} is seen but lies inside the closed model "
                f"({-float(depth[candidates.index(region)].max()):.2g} m behind its faces)"
            )
    return ""


# an open face attached ``against`` a part of its whole (``attach oriels: backward against
# front, ... as back``, docs/language.md 3.12: an oriel's back against the wall it stands out
# of) lies within that part's face in the whole's closed model; its corners may lie outside
# that face by this fraction of the face's size, as a region's centroid may lie outside its own
# face (`FACE_MARGIN`: plane fits and the whole's inserted walls placed by the knowledge move
# the face's edges). Dev 61615 (held out in session 15): a 1.6 m² patch was taken for the
# body's front (22 m²) and the 153 m² front wall for an oriel standing out of it; 61619: an
# oriel reaching past the front's end where the wing stands.
AGAINST_MARGIN = FACE_MARGIN


def beyond_whole(
    attachment: AttachmentModel | None,
    closing: Sequence[ClosingFace],
    polygons: Mapping[str, FloatArray],
    faces: Mapping[str, FloatArray],
) -> str:
    """Why a smaller structure's open face attached ``against`` a part of its whole does not
    lie within that part's face ('' if it does, or the structure attaches otherwise).

    ``attachment``: how the structure attaches to its whole (`Knowledge.attachment`);
    ``closing``: its closing faces (`closed`; each names the whole's part it lies in,
    ``source``); ``polygons``: role path -> its closed faces (K, 3), metres, world; ``faces``:
    role path -> the closed faces of the verified levels (its whole's), same frame. Every
    corner of the open face, projected onto the whole's face, lies inside it with
    `AGAINST_MARGIN` (`closure.inside_face`).
    """
    if attachment is None or attachment.contact != "against":
        return ""
    for face in closing:
        whole = faces.get(face.source)
        own = polygons.get(face.role)
        if whole is None or own is None or len(whole) < 3:
            continue
        out = sum(not inside_face(whole, corner, margin=AGAINST_MARGIN) for corner in own)
        if out:
            return (
                f"{face.role} lies against {face.source}, but {out} of its {len(own)} corners "
                f"lie outside that face in the closed model (by more than "
                f"{100 * AGAINST_MARGIN:.0f}% of its size): it does not stand out of it"
            )
    return ""


def unseen(
    ctx: Context,
    visible: tuple[str, ...],
    polygons: dict[str, FloatArray],
    front: RegionView | None,
) -> str:
    """Why an inserted part the camera should see cannot have been missed ('' if none).

    Its closed face (`polygons`, (N, 3) metres, world), projected into the reference camera,
    must be smaller than `MAX_UNSEEN_SIDE_FRACTION` of the anchor's region `front`.
    """
    camera = ctx.evidence.camera
    for role in visible:
        pixels = camera.pinhole.project(polygons[role])
        x, y = pixels[:, 0], pixels[:, 1]
        area = 0.5 * abs(float(x @ np.roll(y, -1) - y @ np.roll(x, -1)))
        limit = MAX_UNSEEN_SIDE_FRACTION * (front.area_px if front is not None else 0.0)
        if area > limit:
            return (
                f"{role} would face camera {camera.view} ({area:.0f} px, more than "
                f"{limit:.0f}) but no region fits it"
            )
    return ""


# the measures of length an attribute may stand for (docs/language.md §3.10), by the model
LENGTH_MEASURES = ("height", "width", "depth", "distance", "elevation")
# a range is met within this relative slack: `unseen.least_extents` places an unseen part at
# exactly the least extent the knowledge allows, and the closed model measures it a rounding
# error short (development scene 2008: "depth measures 2 m, outside [2 m, 60 m]", every
# hypothesis rejected: nothing found). The verdict allows the same (verdict.RANGE_SLACK_REL).
RANGE_SLACK_REL = 1e-3


@dataclass(frozen=True)
class Violation:
    """A measured attribute of the knowledge outside its range in a closed model."""

    text: str
    label: str  # CONCEPT.ATTRIBUTE
    span: Span | None  # the attribute's declaration


def _faces_under(polygons: dict[str, FloatArray], prefix: str) -> list[FloatArray]:
    """The closed faces (K, 3) of the part at role path `prefix` and of its parts (all: '')."""
    return [
        p for r, p in polygons.items() if not prefix or r == prefix or r.startswith(prefix + ".")
    ]


# a level region is the object's top, not the ground under it, when its centre lies within
# this fraction of the solid's size of an upward-facing face's plane and (by FACE_MARGIN)
# inside that face: a flat roof's region whose 221 stereo points fit its plane 4 deg and
# 0.15 m off (held-out 61713) lies well within it; the ground under a house lies a
# storey's height (a quarter of a house's size and more) below its lowest upward face
ON_TOP_MARGIN = 0.1


def on_object(
    regions: Sequence[RegionView],
    binding: Mapping[str, str],
    planes: Planes,
    polygons: Mapping[str, FloatArray],
    up: FloatArray,
) -> set[str]:
    """Ids of the reference view's regions that are the object's own, not its ground: those
    `binding` binds to its parts (region id -> role path), and the level regions (normal
    within `ground.GROUND_LEVEL_DEG` of `up`) lying on a closed face that faces up
    (`ON_TOP_MARGIN`: a flat roof's region a hypothesis inserts its top under).

    planes : role path -> (unit outward normal (3,), offset m); polygons : role path ->
    closed face (K, 3), metres, world frame; up : (3,) unit vector.
    """
    mine = set(binding)
    tops = [r for r, (n, _) in planes.items() if r in polygons and float(n @ up) >= COS_LEVEL]
    if not tops or not polygons:
        return mine
    corners = np.concatenate(list(polygons.values()))
    size = float(np.max(np.ptp(corners, axis=0)))
    for region in regions:
        if region.id in mine or abs(float(region.normal @ up)) < COS_LEVEL:
            continue
        for role in tops:
            n, d = planes[role]
            near = abs(float(n @ region.centroid_m) - d) <= ON_TOP_MARGIN * size
            if near and inside_face(polygons[role], region.centroid_m, margin=FACE_MARGIN):
                mine.add(region.id)
                break
    return mine


def attribute_violation(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    planes: Planes,
    polygons: dict[str, FloatArray],
    binding: Mapping[str, str] | None = None,
    whole: tuple[Planes, Mapping[str, FloatArray], Iterable[str]] | None = None,
) -> Violation | None:
    """The first attribute of a length measure (height, width, depth, distance, elevation) of
    the structure's instances whose measure in the closed model lies outside its range, or None
    (always None when the evidence's lengths are in unknown units: a scene up to scale).

    `planes` : role path -> (unit normal (3,), offset m), world frame; `polygons` : role path ->
    closed face (K, 3), metres. ``height`` is the extent of the instance's faces along up,
    ``width`` along its frame's right, ``depth`` along its front; ``distance(a, b)`` is the
    distance of a point of plane b from plane a; ``elevation`` the height of the part's lowest
    point above the plane of the ground the reference view shows, under it
    (`aida_kb.interpret.ground`; not taken where it shows none), the object's own regions
    (`on_object`; `binding`: region id -> role path) left out of it. ``whole``: for a
    smaller part, the verified levels' planes, closed faces and bound regions: they are the
    object's too (an oriel's ground is not the body's flat roof where the view shows no
    ground).
    """
    if not ctx.evidence.metric:  # lengths in unknown units: a range in metres does not apply
        return None
    axes = {"height": frame.up, "width": frame.right, "depth": frame.front}
    if whole is not None:
        fixed, fixed_faces, bound = whole
        mine = {**dict.fromkeys(bound, ""), **(binding or {})}
        own = on_object(
            ctx.regions, mine, {**fixed, **planes}, {**fixed_faces, **polygons}, frame.up
        )
    else:
        own = on_object(ctx.regions, binding or {}, planes, polygons, frame.up)
    ground = EvidenceGround(ctx.regions, ctx.evidence.points_on, own, frame.up)
    for node in structure.nodes:
        for attribute in ctx.knowledge.concept(node.concept).attributes.values():
            if attribute.measure not in LENGTH_MEASURES or not attribute.measure_args:
                continue
            if attribute.low is None and attribute.high is None:
                continue
            paths = [join(node.role, a) for a in attribute.measure_args]
            if attribute.measure == "elevation":
                faces = _faces_under(polygons, paths[0])
                if not faces:
                    continue
                taken = ground.elevation(np.concatenate(faces))
                if taken is None:
                    continue  # the view shows no ground: the measure cannot be taken
                value = taken
            elif attribute.measure == "distance":
                a, b = paths[0], paths[-1]
                if a not in planes or b not in planes:
                    continue
                (n_a, d_a), (n_b, d_b) = planes[a], planes[b]
                value = abs(float(n_a @ (np.asarray(n_b) * d_b)) - d_a)
            else:
                faces = _faces_under(polygons, paths[0])
                if not faces:
                    continue
                along = np.concatenate(faces) @ axes[attribute.measure]
                value = float(along.max() - along.min())
            low = attribute.low if attribute.low is not None else -math.inf
            high = attribute.high if attribute.high is not None else math.inf
            slack = RANGE_SLACK_REL * max(
                abs(low) if math.isfinite(low) else 0.0, abs(high) if math.isfinite(high) else 0.0
            )
            if low - slack <= value <= high + slack:
                continue
            where = f" ({attribute.span})" if attribute.span is not None else ""
            label = f"{node.concept}.{attribute.name}"
            return Violation(
                f"attribute {attribute.name} of {node.role or node.concept} ({node.concept}{where})"
                f" measures {value:.3g} m in the closed model, outside its range "
                f"[{low:.3g} m, {high:.3g} m]",
                label,
                attribute.span,
            )
    return None
