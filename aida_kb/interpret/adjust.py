"""One alternative's adjustment: initial planes, segments matched to its edges, two solves.

The alternative's planes start from its regions and the knowledge (`unseen.initial_planes`);
the reference view's segments are matched to the edges of those planes, the problem is built
(`verify.build_verification`) and solved, and the segments are re-matched to the adjusted
planes within a tighter distance and solved again (outliers of the first matching drop out).
The problem of the last solve is returned with its outcome (`Adjusted.verification`): the
accepted interpretation is solved once more as a whole from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.constraints import kind_of
from aida_kb.errors import GeometryError
from aida_kb.interpret.closure import ClosingFace, close, settle_unseen
from aida_kb.interpret.context import Context
from aida_kb.interpret.edges import EdgeMatch, match_segments, plane_line
from aida_kb.interpret.hypotheses import DOWNWARD, UPWARD, Frame
from aida_kb.interpret.knowledge import Structure, join
from aida_kb.interpret.observe import CameraView, SegmentView
from aida_kb.interpret.unseen import Planes, closing_of, ground_of, initial_planes, mirrored_again
from aida_kb.interpret.verify import (
    EdgeEvidence,
    Outcome,
    Verification,
    build_verification,
    orientation_priors,
    outline_priors,
    position_data,
    tilt_constraints,
    verify,
)
from aida_kb.register.match import match_segments as match_finite
from aida_kb.register.model import RigidModel

FloatArray = npt.NDArray[np.float64]

# segments are matched to the initial model within the first distance, then re-matched to
# the adjusted model within the next (outliers of the first matching drop out)
MATCH_DISTANCES_PX = (25.0, 8.0)
# a segment along an edge of an inserted part facing the camera (`_facing_matches`) runs
# within this of the projected edge's direction (the edge is found, not predicted by a region
# border: a tighter angle than `edges.MAX_ANGLE_DEG`)
FACING_ANGLE_DEG = 6.0
# a segment shorter than this does not count as evidence an alternative leaves unexplained
# (short segments are texture and noise as often as edges)
MIN_BORDER_SEGMENT_PX = 8.0
# which side of a segment its bound region lies on is probed this far from its midpoint, on
# either side (outlines are good to a pixel or two; a region's border segment has the region
# on one side only)
SIDE_PROBE_PX = 4.0
# a segment between a region of the structure and one of a verified level lies where their
# planes meet (`_junction`) when, seen through its midpoint, they lie closer than this fraction
# of the distance from the camera (dev 72010, 72015: the valley of a wing's roof running into
# the body's roof 0.004-0.03; a wing's gable end seen against the body's roof behind it 0.10-0.13)
JUNCTION_GAP = 0.05
# a ray through a segment's midpoint whose direction lies within this (cosine times the ray's
# length, unit normals) of a region's plane meets the plane nowhere useful (seen edge-on):
# the segment is then no junction (as `aida_kb.constraints.texture.MIN_INCIDENCE` for patches)
JUNCTION_MIN_INCIDENCE = 1e-9


@dataclass(frozen=True)
class Adjusted:
    """The result of adjusting one alternative.

    Attributes
    ----------
    outcome : the last solve's outcome (planes, residual report, reduced cost)
    verification : the problem of the last solve
    inserted : role paths of the parts no region shows
    loose : fraction of the length of the segments bordering bound regions that no edge of
        the structure explains, in [0, 1]
    visible : inserted parts of a smaller structure that would face the camera (judged by
        their size once closed, `plausibility.unseen`)
    """

    outcome: Outcome
    verification: Verification
    inserted: tuple[str, ...]
    loose: float
    visible: tuple[str, ...]


def adjust(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    binding: dict[str, str],
    fixed: Planes,
    choices: dict[str, str],
    guessed: frozenset[str] = frozenset(),
    verified: frozenset[str] = frozenset(),
    *,
    seen_by_edges: bool = False,
    placed: frozenset[str] | None = None,
) -> Adjusted:
    """Initialise, match segments, adjust twice (re-matching in between).

    ``guessed``: fixed parts of verified levels that were inserted from knowledge, not
    seen. A segment on the edge between such a part and one of this structure explains
    that segment but is not taken as a measurement: its position would measure the guess
    (a wing's foot on the body's inserted floor, seen at a grazing angle, moved the wing's
    seen front wall 1.7 m away from its own stereo evidence).
    ``verified``: the regions verified levels bound. A segment between one of them and a
    region of this structure is where the two meet (a wing's front wall running into the
    body's, its roof into the body's roof): no part's adjacency declares that edge, and the
    level that bound the other region already counted it unexplained; it is not counted
    again in ``loose`` (charged to the wing, the 135-degree L-shape's true wing, binding less
    evidence than the body, paid that junction as a larger fraction of its segments than
    the body taken for the wing did: the arms came out swapped).

    ``seen_by_edges``: an inserted part of the main body may face the camera (it is returned
    in ``visible``, to be judged by the segments along its edges, `unseen.initial_planes`).
    ``placed``: the parts a relation the main body asserts beyond a weaker structure places
    (`Knowledge.beyond_weaker`: a symmetric gable's slopes, judged by their outline after the
    adjustment, `alternative.outline_contradiction`); its other inserted tilted parts hold
    the slope their walls' outlines show (`verify.outline_priors`). None (a smaller part):
    none holds it.

    Raises `unseen.UnseenError` when an inserted part of the main body would face the camera
    (unless ``seen_by_edges``), AidaError when the problem cannot be built or solved.
    """
    evidence = ctx.evidence
    initial = initial_planes(
        ctx, structure, frame, binding, fixed, choices, seen_by_edges=seen_by_edges
    )
    planes = initial.planes
    index = {p.role: i for i, p in enumerate(planes)}
    tilts = tilt_constraints(
        ctx.knowledge,
        [(leaf.role, leaf.concept) for leaf in structure.leaves],
        ground_of(ctx, set(index)),
        index,
    )
    # inserted parts the knowledge orients level keep that orientation (verify.orientation_priors)
    level = {UPWARD: True, DOWNWARD: False}
    tilts += orientation_priors(
        [
            (leaf.role, leaf.concept, level[leaf.direction], leaf.orient_span)
            for leaf in structure.leaves
            if leaf.role in initial.inserted and leaf.direction in level and not leaf.pitched
        ],
        ground_of(ctx, set(index)),
        index,
    )
    # inserted tilted parts no relation places keep the slope their walls' outlines show
    # (verify.outline_priors; with a relation the prior perturbed the seen slope it ties them to)
    tilts += outline_priors(
        {r: slope for r, slope in initial.traced.items() if placed is not None and r not in placed},
        {leaf.role: leaf.concept for leaf in structure.leaves},
        ground_of(ctx, set(index)),
        index,
    )
    positions = {
        role: position_data(evidence.regions[rid], evidence.cameras[evidence.regions[rid].view])
        for rid, role in binding.items()
    }
    fillers = {**choices, **dict(structure.choices)}
    adjacency: dict[str, set[str]] = {}
    # a smaller part also meets the verified part it stands on or out of (an oriel's
    # sides meet the body's front wall): segments along those edges are its evidence too
    closing = closing_of(ctx, structure, frame, fixed)
    pairs = [*structure.adjacency, *((n, c.source) for c in closing for n in c.neighbours)]
    for a, b in pairs:
        adjacency.setdefault(a, set()).add(b)
        adjacency.setdefault(b, set()).add(a)
    adj = {k: frozenset(v) for k, v in adjacency.items()}
    declared = declared_edges(ctx, structure)
    # the structure's own edges: those of one convex solid (`_on_its_side`)
    own = frozenset(_ordered(a, b) for a, b in structure.adjacency)
    current = {p.role: (p.normal, p.offset_m) for p in planes}
    last: tuple[Outcome, Verification] | None = None
    matches: list[EdgeMatch] = []
    outline: list[EdgeEvidence] = []
    facing = frozenset(initial.visible) if seen_by_edges else frozenset()
    for distance_px in MATCH_DISTANCES_PX:
        rematched = _matches(ctx, binding, current, adj, distance_px, own, verified)
        found = _facing_matches(ctx, structure, closing, current, facing, distance_px)
        if last is not None and _same_matches(rematched, matches) and _same(found, outline):
            break
        matches, outline = rematched, found
        verification = build_verification(
            ctx.knowledge,
            ctx.body.role,
            ctx.body.concept,
            planes,
            fillers,
            positions,
            _edge_evidence(ctx, [m for m in matches if not guessed.intersection(m.parts)], binding)
            + outline,
            declared,
            ctx.pinholes,
            tilts,
            metric=ctx.evidence.metric,
            ground=ground_of(ctx, set(index)),
        )
        outcome = verify(verification)
        last = (outcome, verification)
        current = dict(outcome.planes)
        planes = [
            replace(p, normal=current[p.role][0], offset_m=current[p.role][1]) for p in planes
        ]
    assert last is not None
    # the parts mirrored about a line the adjustment moved follow it (`unseen.mirrored_again`)
    again = mirrored_again(
        ctx, structure, frame, last[0].planes, binding, choices, initial.inserted
    )
    if again:
        last = (replace(last[0], planes={**last[0].planes, **again}), last[1])
    last = (_settled(last[0], structure, closing, initial.inserted), last[1])
    matched = {m.segment.id for m in matches}
    bordering = [
        s
        for s in ctx.segments
        if s.length_px >= MIN_BORDER_SEGMENT_PX
        and any(r in binding for r in s.regions)
        and not verified.intersection(s.regions)
    ]
    total = sum(s.length_px for s in bordering)
    loose = sum(s.length_px for s in bordering if s.id not in matched)
    return Adjusted(
        last[0],
        last[1],
        initial.inserted,
        loose / total if total > 0 else 0.0,
        initial.visible,
    )


def _settled(
    outcome: Outcome, structure: Structure, closing: list[ClosingFace], inserted: tuple[str, ...]
) -> Outcome:
    """The outcome with its inserted planes moved to meet the others where more than three
    faces meet (`closure.settle_unseen`; a hip roof's hidden eaves corner)."""
    faces = [(leaf.role, *outcome.planes[leaf.role]) for leaf in structure.leaves]
    faces += [(c.role, c.normal, c.offset_m) for c in closing]
    pairs = [*structure.adjacency, *((c.role, n) for c in closing for n in c.neighbours)]
    offsets = settle_unseen(faces, pairs, inserted)
    if not offsets:
        return outcome
    planes = dict(outcome.planes)
    for role, d in offsets.items():
        planes[role] = (planes[role][0], d)
    return replace(outcome, planes=planes)


def _matches(
    ctx: Context,
    binding: dict[str, str],
    planes: Planes,
    adjacency: dict[str, frozenset[str]],
    max_distance_px: float,
    own: frozenset[tuple[str, str]] = frozenset(),
    met: frozenset[str] = frozenset(),
) -> list[EdgeMatch]:
    """The reference view's segments bordering bound regions, matched to the planes' edges;
    a match of one of the structure's `own` edges whose bound region lies on the other side
    of the segment than its face is dropped (`_on_its_side`).

    A segment between a bound region and one of `met` (the regions of the verified levels this
    structure meets) where their planes meet (`_junction`) is where the two solids run into
    each other: it may be an edge with a verified part (an oriel's side along the body's front
    wall), never one of the structure's `own` edges. Matched to those, the valley where a
    wing's roof runs into the body's roof was taken for the wing's hidden inner gable and
    pulled that end from the body's ridge, where the knowledge puts it, to 1.2 m behind the
    body's front (dev 72015: the wing 3.4 m short, 11.5 % of the house's size). Where the
    planes do not meet, the segment is the structure's outline against the other behind it
    (a wing's gable end against the body's roof): its own edge.
    """
    bordering = [s for s in ctx.segments if any(r in binding for r in s.regions)]
    at_junction = [_junction(ctx, s, binding, met) for s in bordering]
    joins = [s for s, j in zip(bordering, at_junction, strict=True) if j]
    segs = [s for s, j in zip(bordering, at_junction, strict=True) if not j]
    cameras = ctx.evidence.cameras
    found = match_segments(segs, binding, planes, adjacency, cameras, max_distance_px)
    if joins:
        across = {
            a: frozenset(b for b in bs if _ordered(a, b) not in own) for a, bs in adjacency.items()
        }
        found += match_segments(joins, binding, planes, across, cameras, max_distance_px)
        order = {s.id: k for k, s in enumerate(ctx.segments)}
        found.sort(key=lambda m: order[m.segment.id])
    return [
        m for m in found if _ordered(*m.parts) not in own or _on_its_side(ctx, m, binding, planes)
    ]


def _junction(ctx: Context, seg: SegmentView, binding: dict[str, str], met: frozenset[str]) -> bool:
    """Whether `seg` lies between a bound region and an unbound one of `met` whose planes
    (their stereo fits) meet at its midpoint: seen through it, they lie within
    `JUNCTION_GAP` of the distance from the camera of each other."""
    mine = [r for r in seg.regions if r in binding]
    other = [r for r in seg.regions if r in met and r not in binding]
    camera = ctx.evidence.cameras.get(seg.view)
    if not mine or not other or camera is None:
        return False
    ray = camera.rays_world(seg.ends_px.mean(axis=0)[None])[0]
    centre = camera.centre_m
    depths = []
    for rid in (mine[0], other[0]):
        region = ctx.evidence.regions[rid]
        along = float(ray @ region.normal)
        if abs(along) < JUNCTION_MIN_INCIDENCE:
            return False
        depths.append((region.offset_m - float(region.normal @ centre)) / along)
    near, far = depths
    return near > 0 and far > 0 and abs(near - far) <= JUNCTION_GAP * near


def _ordered(a: str, b: str) -> tuple[str, str]:
    return (a, b) if a <= b else (b, a)


def _inside(outlines: tuple[FloatArray, ...], point: FloatArray) -> bool:
    """True if `point` (2,) px lies inside an odd number of the outlines ((K, 2) px each)."""
    count = 0
    for o in outlines:
        if len(o) >= 3:
            contour = np.asarray(o, dtype=np.float32).reshape(-1, 1, 2)
            pt = (float(point[0]), float(point[1]))
            count += cv2.pointPolygonTest(contour, pt, False) > 0
    return count % 2 == 1


def _on_its_side(ctx: Context, m: EdgeMatch, binding: dict[str, str], planes: Planes) -> bool:
    """False when the segment of match `m` has a bound region of one of the edge's two faces
    on the side of it where that face is not: a segment with the front wall above it is no
    eave (the top of an oriel standing out of the wall, 20 px below a low-contrast eave that
    gave no segment, pulled a gable's eave down until its rakes no longer fitted: dev seed
    58000). The face's side is where it lies in the image from the edge of the two planes
    (outward normals: the faces of one convex solid lie on the inner side of each other's
    planes); the region's side is probed `SIDE_PROBE_PX` either side of the segment's
    midpoint in its outlines. True where either side cannot be told."""
    seg = m.segment
    camera = ctx.evidence.cameras.get(seg.view)
    if camera is None:
        return True
    a, b = seg.ends_px
    length = float(np.linalg.norm(b - a))
    if length <= 0:
        return True
    mid = (a + b) / 2
    across = np.array([-(b - a)[1], (b - a)[0]]) / length
    for rid in seg.regions:
        owner = binding.get(rid)
        if owner not in m.parts:
            continue
        other = m.parts[1] if m.parts[0] == owner else m.parts[0]
        outlines = ctx.evidence.outlines.get(rid, ())
        plus = _inside(outlines, mid + SIDE_PROBE_PX * across)
        minus = _inside(outlines, mid - SIDE_PROBE_PX * across)
        if plus == minus:
            continue
        region_side = 1.0 if plus else -1.0
        face_side = _face_side(camera, planes[owner], planes[other], mid, across)
        if face_side is not None and face_side * region_side < 0:
            return False
    return True


def _face_side(
    camera: CameraView,
    owner: tuple[FloatArray, float],
    other: tuple[FloatArray, float],
    mid_px: FloatArray,
    across: FloatArray,
) -> float | None:
    """+1 or -1: the side (along `across`, unit (2,) px) of the image line of the edge of
    planes `owner` and `other` (unit outward normal, offset m; world frame) on which the face
    of `owner` lies, near the pixel `mid_px`; None when the planes are parallel or the edge
    is behind the camera."""
    line = plane_line(owner[0], owner[1], other[0], other[1])
    if line is None:
        return None
    point, direction = line
    R, t = camera.R_cam_world, camera.t_cam_world
    centre = -R.T @ t
    ray = R.T @ np.linalg.solve(camera.K, np.array([mid_px[0], mid_px[1], 1.0]))
    # the point of the edge nearest the ray through the midpoint
    w = point - centre
    b_ = float(ray @ direction)
    denom = float(ray @ ray) - b_ * b_
    if denom <= 1e-12:
        return None
    s_edge = (b_ * float(w @ ray) - float(ray @ ray) * float(w @ direction)) / denom
    x = point + s_edge * direction
    into = np.cross(owner[0], direction)
    if float(into @ other[0]) > 0:
        into = -into
    depth = float((R @ x + t)[2])
    if depth <= 0:
        return None
    step = 0.01 * depth  # a centimetre per metre of distance into the face
    pts = camera.pinhole.project(np.array([x, x + step * into / np.linalg.norm(into)]))
    side = float((pts[1] - pts[0]) @ across)
    return None if side == 0 else math.copysign(1.0, side)


def _edge_evidence(
    ctx: Context, matches: list[EdgeMatch], binding: dict[str, str]
) -> list[EdgeEvidence]:
    """The matched segments as evidence (each with its camera and the part it borders)."""
    out: list[EdgeEvidence] = []
    for m in matches:
        bound = {binding[r] for r in m.segment.regions if r in binding}
        owner = next(p for p in m.parts if p in bound)
        out.append(EdgeEvidence(m.parts, owner, ctx.views.index(m.segment.view), m.segment.ends_px))
    return out


def declared_edges(ctx: Context, structure: Structure) -> set[tuple[str, str]]:
    """Edges a concept measures itself (``measure edge(edge(a, b))``), as sorted pairs."""
    fillers = {n.role: n.concept for n in structure.nodes}
    out: set[tuple[str, str]] = set()
    for node in structure.nodes:
        for spec in ctx.knowledge.concept(node.concept).constraints:
            segment = kind_of(spec.kind).evidence == "segment"
            if not (spec.measurement and segment and len(spec.args) == 2):
                continue
            if not ctx.knowledge.holds(node.role, spec.requires, fillers):
                continue
            a, b = (join(node.role, x) for x in spec.args)
            out.add((a, b) if a <= b else (b, a))
    return out


def _facing_matches(
    ctx: Context,
    structure: Structure,
    closing: list[ClosingFace],
    planes: Planes,
    facing: frozenset[str],
    max_distance_px: float,
) -> list[EdgeEvidence]:
    """The reference image's segments along the edges of inserted parts facing the camera.

    Such a part has no region (a dark, low-texture roof), so no segment borders it in the
    evidence: its outline against the sky or its neighbours is found among all the image's
    segments (`EvidenceView.lines_px`) that border no bound region, matched to its projected
    edges of the closed solid at the current planes (finite edges: a whole line would take
    the horizon for an eave) within ``max_distance_px`` and `FACING_ANGLE_DEG`. Empty when
    there is no such part or the planes do not close.
    """
    if not facing:
        return []
    faces = [(leaf.role, *planes[leaf.role]) for leaf in structure.leaves]
    faces += [(c.role, c.normal, c.offset_m) for c in closing]
    pairs = [*structure.adjacency, *((c.role, n) for c in closing for n in c.neighbours)]
    try:
        polygons = close(faces, pairs)
        names = [role for role, _, _ in faces]
        rigid = RigidModel.from_polygons(
            names,
            [n for _, n, _ in faces],
            [d for _, _, d in faces],
            [polygons[r] for r in names],
        )
    except GeometryError:
        return []
    camera = ctx.evidence.camera
    edges = rigid.visible_edges(camera.pinhole, min_length_px=MIN_BORDER_SEGMENT_PX)
    parts = [(rigid.names[int(a)], rigid.names[int(b)]) for a, b in rigid.edge_faces[edges.index]]
    keep = [i for i, p in enumerate(parts) if facing.intersection(p)]
    lines = ctx.evidence.lines_px.get(camera.view)
    if not keep or lines is None or not len(lines):
        return []
    bordering = {tuple(np.round(s.ends_px, 6).ravel()) for s in ctx.segments}
    free = np.array(
        [
            tuple(np.round(e, 6).ravel()) not in bordering
            and float(np.linalg.norm(e[1] - e[0])) >= MIN_BORDER_SEGMENT_PX
            for e in lines
        ],
        dtype=bool,
    )
    if not free.any():
        return []
    segs = lines[free]
    m = match_finite(
        edges.a[keep],
        edges.b[keep],
        segs[:, 0],
        segs[:, 1],
        max_distance_px=max_distance_px,
        max_angle_rad=math.radians(FACING_ANGLE_DEG),
    )
    view = ctx.views.index(camera.view)
    out: list[EdgeEvidence] = []
    for e, k in zip(m.edge, m.segment, strict=True):
        a, b = parts[keep[int(e)]]
        owner = a if a in facing else b
        out.append(EdgeEvidence((a, b) if a <= b else (b, a), owner, view, segs[int(k)]))
    return out


def _same(a: list[EdgeEvidence], b: list[EdgeEvidence]) -> bool:
    """True if two lists of edge evidence pair the same segments with the same edges."""
    if len(a) != len(b):
        return False
    pairs = zip(a, b, strict=True)
    return all(x.parts == y.parts and np.array_equal(x.ends_px, y.ends_px) for x, y in pairs)


def _same_matches(a: list[EdgeMatch], b: list[EdgeMatch]) -> bool:
    """True if two edge matchings pair the same segments with the same edges."""
    return [(m.segment.id, m.parts) for m in a] == [(m.segment.id, m.parts) for m in b]
