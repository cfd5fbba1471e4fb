"""Placement of the parts no region shows, from the knowledge (docs/language.md §3.11).

A planar part without evidence is *inserted*: its normal is its predicted orientation in the
instance frame (tilted by the seen tilted planes' mean slope, else by the tilt the knowledge
declares), its offset the support of the points seen on the same structure, moved out by the
knowledge's ``unseen`` placements (`hypotheses.placed_offsets`). A smaller structure is closed
in its whole by the faces `closure.closing_faces` derives from its attachment. A tilted part
inserted facing the camera (a dark roof slope) reaches back to the far edge the reference
image shows of it (`outline.far_edge`: its ridge); that edge is its evidence for the placements
and the support of the parts behind it (the other slope, the back wall mirrored about it).

The main body may not insert a part the reference camera should see (`UnseenError`); a smaller
structure's such parts are returned as *visible*, for `plausibility.unseen` to judge by size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from aida_kb.errors import AidaError
from aida_kb.interpret.closure import ClosingFace, closing_faces
from aida_kb.interpret.context import Context
from aida_kb.interpret.edges import plane_line
from aida_kb.interpret.ground import plane_fitted
from aida_kb.interpret.hypotheses import (
    DEFAULT_PITCH_DEG,
    DOWNWARD,
    HORIZONTAL,
    Frame,
    PlanarPart,
    faces_camera,
    placed_offsets,
    predicted_normal,
    support_offset,
)
from aida_kb.interpret.knowledge import Attribute, Node, Structure
from aida_kb.interpret.observe import RegionView, slope_deg
from aida_kb.interpret.outline import far_edge, outline_pitch
from aida_kb.interpret.verify import PlaneInit
from aida_kb.kb.model import PlacementKind

FloatArray = npt.NDArray[np.float64]
# the directions of the language that face across the forward axis (a wing's gable ends)
ACROSS = ("leftward", "rightward")
Planes = dict[str, tuple[FloatArray, float]]  # role path -> (unit normal (3,), offset m), world

# an inserted part with no seen point to support it starts this far (metres) from the camera
# along its normal: behind the camera's view of the scene, moved by the placements
UNSUPPORTED_OFFSET_M = 10.0


# a tilted part inserted facing the camera, placed by the far edge the reference image shows of
# it: role path -> (unit normal (3,), offset m, the edge's line ends (K, 3)), world, metres
Traced = dict[str, tuple[FloatArray, float, FloatArray]]


def _on_plane(n: FloatArray, d: float, points: FloatArray, fallback: FloatArray) -> FloatArray:
    """A point (3,) on plane n·x = d: the seen `points`' mean ((N, 3); `fallback` (3,) when
    there are none) moved onto it along `n`."""
    centre = points.mean(axis=0) if len(points) else fallback
    out: FloatArray = centre + (d - float(n @ centre)) * n
    return out


class UnseenError(AidaError):
    """An inserted part would be visible: the alternative predicts evidence that is missing."""


@dataclass(frozen=True)
class Initial:
    """The initial planes of one alternative.

    Attributes
    ----------
    planes : the structure's planes (seen ones from their regions, inserted ones from the
        knowledge), then the fixed planes of verified levels
    inserted : role paths of the parts no region shows
    visible : of those, the parts of a smaller structure that would face the camera
    traced : inserted tilted parts whose slope the outlines of the walls they meet show
        (`outline.outline_pitch`): role path -> that slope, degrees
    """

    planes: list[PlaneInit]
    inserted: tuple[str, ...]
    visible: tuple[str, ...]
    traced: dict[str, float] = field(default_factory=dict)


def initial_planes(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    binding: dict[str, str],
    fixed: Planes,
    choices: dict[str, str],
    *,
    seen_by_edges: bool = False,
) -> Initial:
    """The planes an alternative's adjustment starts from (see the module docstring).

    Raises UnseenError when a part of the main body (no ``fixed`` planes) would be inserted
    facing the reference camera, unless ``seen_by_edges``: then it is inserted and returned
    as *visible*, for the caller to judge by the image's segments along its edges (a dark,
    low-texture roof that gives stereo no region, `interpret.support`).
    """
    evidence = ctx.evidence
    seen = {role: evidence.regions[rid] for rid, role in binding.items()}
    pts = [evidence.points_on(rid) for rid in binding]
    points = np.concatenate(pts) if pts else np.zeros((0, 3))
    pitches = [
        slope_deg(seen[leaf.role].normal, ctx.up)
        for leaf in structure.leaves
        if leaf.pitched and leaf.role in seen
    ]
    # an inserted tilted plane starts at the seen tilted planes' mean slope, else at the
    # tilt the knowledge declares (a constant, or its attribute's default)
    pitch = float(np.mean(pitches)) if pitches else None
    planes: list[PlaneInit] = []
    inserted: list[str] = []
    visible: list[str] = []
    # every part's plane first (unit normal, offset m): a part no evidence and no placement
    # of the knowledge puts anywhere may be moved out to the least extent the knowledge allows
    start: dict[str, tuple[FloatArray, float]] = {}
    unplaced: set[str] = set()
    normals: dict[str, FloatArray] = {}
    outlined: dict[str, float] = {}
    for leaf in structure.leaves:
        region = seen.get(leaf.role)
        if region is not None:
            start[leaf.role] = (region.normal, region.offset_m)
            continue
        tilt = leaf.tilt_deg if leaf.tilt_deg is not None else DEFAULT_PITCH_DEG
        # a slope left to the evidence: the outlines of the walls it meets (`outline`)
        traced = (
            outline_pitch(ctx, structure, leaf, frame, binding) if leaf.tilt_deg is None else None
        )
        start_pitch = traced if traced is not None else pitch if pitch is not None else tilt
        if traced is not None:
            outlined[leaf.role] = traced
        normals[leaf.role] = predicted_normal(leaf, frame, start_pitch)

    def place(leaf: PlanarPart, points: FloatArray, edges: Traced) -> None:
        n = normals[leaf.role]
        if len(points):
            d = support_offset(n, points)
        else:
            d = float(n @ evidence.camera.centre_m) - UNSUPPORTED_OFFSET_M
        placements = placed_by_knowledge(
            ctx, structure, leaf, n, frame, seen, fixed, choices, edges
        )
        for placed in placements:
            d = max(d, placed)
        unplaced.discard(leaf.role)
        if not placements:
            unplaced.add(leaf.role)
        start[leaf.role] = (n, d)

    missing = [leaf for leaf in structure.leaves if leaf.role not in seen]
    for leaf in missing:
        place(leaf, points, {})
    # a tilted part inserted facing the camera reaches back to the far edge the reference
    # image shows of it (`outline.far_edge`, a dark roof's ridge): the other inserted parts
    # are placed again with its plane and that edge as its evidence
    edges: Traced = {}
    for leaf in missing:
        n, d = start[leaf.role]
        if not faces_camera(n, _on_plane(n, d, points, evidence.camera.centre_m), evidence.camera):
            continue
        far = far_edge(ctx, leaf, frame, (n, d), points)
        if far is not None:
            edges[leaf.role] = (n, d, far)
    for role, (_, _, far) in edges.items():
        # the far edge bounds the parts behind it: those facing away from where it leans
        lean = frame.direction(next(x.direction for x in missing if x.role == role) or "")
        for leaf in missing:
            if leaf.role not in edges and float(normals[leaf.role] @ lean) < 0:
                place(leaf, np.concatenate([points, far]), edges)
    centre = points.mean(axis=0) if len(points) else evidence.camera.centre_m
    # in a scene up to scale a length in metres is a length in units only at some scale:
    # the largest the seen parts' extents allow gives the least extent in units
    unit_m = 1.0 if evidence.metric else largest_unit_m(ctx, structure, frame, binding)
    if math.isfinite(unit_m):
        start.update(least_extents(ctx, structure, frame, start, unplaced, centre, unit_m))
    for leaf in structure.leaves:
        region = seen.get(leaf.role)
        if region is not None:
            planes.append(PlaneInit(leaf.role, leaf.concept, region.normal, region.offset_m))
            continue
        inserted.append(leaf.role)
        n, d = start[leaf.role]
        on_plane = _on_plane(n, d, points, centre)
        # a face behind another object of the scene (`interpret.scene`) is not seen, rightly
        if faces_camera(n, on_plane, evidence.camera) and not ctx.hidden_by_others(on_plane):
            if fixed or seen_by_edges:
                visible.append(leaf.role)
                planes.append(PlaneInit(leaf.role, leaf.concept, n, d))
                continue
            where = f", oriented at {leaf.orient_span}" if leaf.orient_span is not None else ""
            raise UnseenError(
                f"{leaf.role} ({leaf.concept}{where}) would face camera "
                f"{evidence.camera.view} but no region fits it"
            )
        planes.append(PlaneInit(leaf.role, leaf.concept, n, d))
    for role, (n, d) in sorted(fixed.items()):
        planes.append(PlaneInit(role, "", n, d, fixed=True))
    return Initial(planes, tuple(inserted), tuple(visible), outlined)


# two parts bound the extent of their whole along an axis when their normals lie within this
# of the axis and of each other's opposite (the front and back walls of a body)
EXTENT_AXIS_DEG = 10.0
LENGTH_AXES = ("height", "width", "depth")  # length measures taken along a frame axis


def largest_unit_m(
    ctx: Context, structure: Structure, frame: Frame, binding: dict[str, str]
) -> float:
    """The most metres one length unit of a scene up to scale can stand for (inf: no bound).

    A part's seen points span at least as much as the part: where an attribute measures a
    length of it along a frame axis with an upper bound (``attribute height: length in [2 m,
    30 m] is height(self)``), its seen extent of E units is at most HIGH metres, so a unit is
    at most HIGH / E metres. The least of these over the structure's attributes bounds the
    scale; a length the knowledge requires to be at least LOW metres is then at least
    LOW / that units long (`least_extents`): the least the knowledge allows at any scale the
    seen parts admit (a wall seen 15 units tall is at most 30 m: a unit at most 2 m, a body
    at least 2 m deep at least 1 unit deep). ``binding``: region id -> role path.
    """
    points_of = {role: ctx.evidence.points_on(rid) for rid, role in binding.items()}
    unit_m = math.inf
    for node, attribute, axis in _extent_attributes(ctx, structure, frame):
        if attribute.high is None or attribute.high <= 0:
            continue
        seen = [p for role, p in points_of.items() if _within(role, node.role)]
        if not seen:
            continue
        along = np.concatenate(seen) @ axis
        extent = float(along.max() - along.min())
        if extent > 0:
            unit_m = min(unit_m, attribute.high / extent)
    return unit_m


def _within(role: str, whole: str) -> bool:
    """Whether role path `role` is `whole` or lies below it ('' is the structure's root)."""
    return not whole or role == whole or role.startswith(whole + ".")


def _extent_attributes(
    ctx: Context, structure: Structure, frame: Frame
) -> list[tuple[Node, Attribute, FloatArray]]:
    """(node, attribute, frame axis (3,)) of every attribute of the structure's nodes that
    measures the node's extent along an axis of the frame (``is height(self)`` ...)."""
    axes = {"height": frame.up, "width": frame.right, "depth": frame.front}
    return [
        (node, attribute, axes[attribute.measure])
        for node in structure.nodes
        for attribute in ctx.knowledge.concept(node.concept).attributes.values()
        if attribute.measure in LENGTH_AXES and attribute.measure_args == ("self",)
    ]


def least_extents(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    planes: Planes,
    unplaced: set[str],
    centre: FloatArray,
    unit_m: float = 1.0,
) -> Planes:
    """Inserted parts moved out to the least extent the knowledge gives their whole.

    A part no region shows and no ``unseen`` placement of the knowledge puts anywhere starts
    at the support of the seen points (`support_offset`): a back wall behind a front whose
    roof no view shows lies on the front's own points, a body 0-15 cm deep (Herz-Jesu,
    the castle courtyard), and the solid does not close. Where an attribute of the part's
    whole measures its extent along the axis the part faces (``attribute depth: length in
    [2 m, 60 m] is depth(self)``; height, width, depth along the frame's up, right, front),
    the part is moved out to the range's low end from its opposite part — the least the
    knowledge allows, and nothing more: the verdict names the part as not measured.
    ``planes``: role path -> (unit normal (3,), offset m), every leaf of the structure;
    ``centre``: (3,) a point inside the seen evidence, metres (which side the camera is on);
    ``unit_m``: metres per unit of the scene's lengths (1 in a metric scene; in one up to
    scale the most the seen parts allow, `largest_unit_m`). Returns the moved parts only.
    """
    cos_axis = math.cos(math.radians(EXTENT_AXIS_DEG))
    camera = ctx.evidence.camera.centre_m
    moved: Planes = {}
    for node, attribute, axis in _extent_attributes(ctx, structure, frame):
        if attribute.low is None or attribute.low <= 0:
            continue
        mine = [
            r
            for r in planes
            if _within(r, node.role) and abs(float(planes[r][0] @ axis)) > cos_axis
        ]
        for role in sorted(mine):
            if role not in unplaced or role in moved:
                continue
            n, d = planes[role]
            opposite = [r for r in mine if float(planes[r][0] @ n) < -cos_axis]
            if not opposite:
                continue
            # the opposite part nearest the camera's side bounds the whole there
            d_opp = min(planes[r][1] for r in opposite)
            low = attribute.low / unit_m  # in the scene's units
            if d + d_opp >= low:
                continue
            d_new = low - d_opp
            if float(n @ camera) > d_new:
                continue  # moved out so far the camera would see it: leave it to fail
            moved[role] = (n, d_new)
    return moved


def placed_by_knowledge(
    ctx: Context,
    structure: Structure,
    leaf: PlanarPart,
    normal: FloatArray,
    frame: Frame,
    seen: dict[str, RegionView],
    fixed: Planes,
    choices: dict[str, str],
    traced: Traced | None = None,
) -> list[float]:
    """The offsets the knowledge's ``unseen`` placements give an inserted part
    (`hypotheses.placed_offsets`), from its structure's seen regions and the fixed planes;
    ``traced``: inserted parts placed by the far edge the image shows of them (their planes,
    the edge's ends their evidence: `initial_planes`)."""
    fillers = {**choices, **dict(structure.choices)}
    found = [(p, paths) for p, _, paths in ctx.knowledge.placements(leaf.role, fillers)]
    if not found:
        return []
    edges = traced or {}
    planes = {**fixed, **{r: (g.normal, g.offset_m) for r, g in seen.items()}}
    planes.update({r: (n, d) for r, (n, d, _) in edges.items()})
    centroids = {r: g.centroid_m for r, g in seen.items()}
    centroids.update({r: e[2].mean(axis=0) for r, e in edges.items()})

    def points_of(role: str) -> FloatArray:
        if role in edges:
            return edges[role][2]
        return ctx.evidence.points_on(seen[role].id)

    return placed_offsets(
        found,
        normal,
        frame,
        planes,
        centroids,
        points_of,
        ctx.knowledge.direction,
        reach_front(ctx, structure, frame, seen),
    )


def reach_front(
    ctx: Context, structure: Structure, frame: Frame, seen: dict[str, RegionView]
) -> float | None:
    """Where a ``reach`` of the structure meets its line: a coordinate (metres) along the
    frame's forward axis, at the structure's own ridge (None: no seen points).

    The ridge is the far boundary of the seen forward-tilted parts' points (a wing's front
    roof plane), else the near boundary of the backward-tilted ones; where no region shows a
    tilted part, the middle of the seen walls facing across the forward axis (a gable end
    spans the wing from its front to its back, its apex above the middle), else the far
    boundary of the structure's seen points: a wing whose roof gives stereo no region still
    shows its gable end (held-out 61423: without it the hidden end lay on the gable end, a
    wing of no length, and its roof did not close). A line across the forward axis (a skew
    wing's reach to the body's ridge at 45 degrees) is met where the structure's ridge is:
    the far boundary of a gable end seen alone put a 135-degree wing's hidden end 3.2 m short
    of the body's ridge (dev 72010, 9.6 % of the house's size).
    """

    def along(direction: str, *, pitched: bool) -> FloatArray:
        pts = [
            ctx.evidence.points_on(seen[x.role].id) @ frame.front
            for x in structure.leaves
            if x.pitched == pitched and x.direction == direction and x.role in seen
        ]
        return np.concatenate(pts) if pts else np.zeros(0)

    front = along("forward", pitched=True)
    if len(front) >= 2:
        return float(front.min())
    back = along("backward", pitched=True)
    if len(back) >= 2:
        return float(back.max())
    ends = np.concatenate([along(d, pitched=False) for d in ACROSS])
    if len(ends) >= 2:
        return float(ends.min() + ends.max()) / 2.0
    every = [ctx.evidence.points_on(g.id) @ frame.front for g in seen.values()]
    rest = np.concatenate(every) if every else np.zeros(0)
    return float(rest.min()) if len(rest) >= 2 else None


def ground_of(ctx: Context, known: set[str]) -> str | None:
    """The ground the parts' slopes refer to: the outermost known part facing downward."""
    grounds = [r for r in known if ctx.knowledge.direction(r) == DOWNWARD]
    return min(grounds, key=lambda r: (r.count("."), r)) if grounds else None


def closing_of(
    ctx: Context, structure: Structure, frame: Frame, fixed: Planes
) -> list[ClosingFace]:
    """The faces that close a smaller structure in its whole (`closure.closing_faces`)."""
    return closing_faces(
        structure.root,
        structure.leaves,
        frame,
        fixed,
        ctx.knowledge.attachment(structure.root),
        {r: ctx.knowledge.concept_at(r) for r in fixed},
    )


def mirrored_again(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    planes: Planes,
    binding: dict[str, str],
    choices: dict[str, str],
    inserted: tuple[str, ...],
) -> Planes:
    """Inserted parts a ``mirror REF about edge(A, B)`` places about the far boundary of the
    evidence of an A whose plane fit failed, placed again about the line where the adjusted
    planes of A and B meet: REF's region centroid mirrored about it, along the direction REF
    faces.

    Before the adjustment the line is the far boundary of A's evidence when B is inserted
    (`hypotheses.placed_offsets`): of a roof region whose plane fit failed (it kept under
    `ground.OUTLINE_INLIER_SHARE` of its pixels, `ground.plane_fitted`), its outline
    back-projected onto that plane metres beyond the ridge the adjustment then finds (dev
    73018, a 135-degree wing under a dark roof: its hidden back wall 6.2 m too far back, the
    wall 0.9 m high under a slope reaching down to it, and the right wing rejected for it).
    Nothing measures such a wall, so the adjustment leaves it where it was put. Where A's fit
    held, or B is seen, the placement stands: there the knowledge's other placements and the
    seen points' support (the farthest wins) place the part, and the line the adjustment
    finds for an inserted B is no better (the fixture house_correct, 12 m deep: 9.9 m).
    ``planes``: role path -> (unit normal (3,), offset m), world, every leaf adjusted;
    ``binding``: region id -> role path. Returns the parts placed again (role -> plane).
    """
    seen = {role: ctx.evidence.regions[rid] for rid, role in binding.items()}
    fillers = {**choices, **dict(structure.choices)}
    out: Planes = {}
    for role in inserted:
        if role not in planes:
            continue
        normal = planes[role][0]
        offsets = []
        for p, _, paths in ctx.knowledge.placements(role, fillers):
            if p.kind is not PlacementKind.MIRROR or p.ref is None or p.line is None:
                continue
            ref = seen.get(paths[p.ref])
            a, b = (paths[x] for x in p.line)
            facing = ctx.knowledge.direction(paths[p.ref])
            if ref is None or a not in planes or b not in planes or facing not in HORIZONTAL:
                continue
            if b in seen or a not in seen or plane_fitted(seen[a]):
                continue  # the line was placed by planes, or by a fit's evidence: it stands
            meet = plane_line(*planes[a], *planes[b])
            if meet is None:
                continue
            u = frame.direction(facing)
            c = ref.centroid_m
            offsets.append(float(normal @ (c + 2.0 * float(u @ (meet[0] - c)) * u)))
        if offsets:
            out[role] = (normal, max(offsets))
    return out
