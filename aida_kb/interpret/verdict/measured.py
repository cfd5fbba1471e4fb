"""Check (e): every part inserted from knowledge (or bound to regions none of which lies on it) is
measured by some evidence."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from aida_kb.interpret.result import INSERTED, Interpretation
from aida_kb.interpret.uncertainty import Uncertainty
from aida_kb.interpret.verdict.edges import line_offset_sd, seen_edges
from aida_kb.interpret.verdict.geometry import (
    FloatArray,
    enclosed_parts,
    inside_polygon,
    model_size,
    outline_points,
)
from aida_kb.interpret.verdict.outcome import ViewCheck
from aida_kb.interpret.verdict.tolerances import (
    CONTESTED_NORMAL_DEG,
    COS_PARALLEL,
    EDGE_SIGMA_PX,
    MEASURED_LINES,
    MEASURING_SHARE,
    OUTLINE_AREA_RATIO,
    OUTLINE_SPAN,
    POSITION_TOLERANCE,
    SIN_SQUARE,
)
from aida_kb.io.evidence import Evidence
from aida_kb.kb.model import KnowledgeBase

if TYPE_CHECKING:
    pass


# The wording of (e)'s reasons for a part no evidence measures; `summary_reasons` says those
# of several parts once
PLACED_BY_KNOWLEDGE = "placed by the knowledge"


BOUND_TO_NOTHING = "bound to no region on it"


NOT_MEASURED = ", not measured"


def _oriented(normal: FloatArray, measured: FloatArray) -> bool:
    """True if a plane of unit `normal` (3,) has its orientation from planes a region
    measures (K, 3): parallel to one, or square to two that are not parallel, within
    EXACT_DEG (a back wall parallel to the front; a floor square to the front and a side)."""
    cos = np.abs(measured @ normal)
    if (cos >= COS_PARALLEL).any():
        return True
    square = measured[cos <= SIN_SQUARE]
    if len(square) < 2:
        return False
    return bool((np.abs(square @ square.T) < COS_PARALLEL).any())


def spread(points: FloatArray, size: float) -> int:
    """0, 1 or 2: points (K, 3) span less than OUTLINE_SPAN of `size` (metres, the face's),
    span it along a line, or over an area (the second principal extent, end to end, at least
    OUTLINE_AREA_RATIO of the first). A few points where outlines cross a plane (a valley
    between two roofs crossing a wing's hidden end) span nothing."""
    if len(points) < 2:
        return 0
    centred = points - points.mean(axis=0)
    axes = np.linalg.svd(centred, full_matrices=False)[2]  # (3, 3) principal directions
    along = centred @ axes[:2].T  # (K, 2)
    extent = along.max(axis=0) - along.min(axis=0)
    if extent[0] < OUTLINE_SPAN * size:
        return 0
    return 2 if extent[1] >= OUTLINE_AREA_RATIO * extent[0] else 1


def contested(kb: KnowledgeBase, interp: Interpretation, role: str) -> str | None:
    """The alternative that orients part `role` otherwise, or None.

    The part's whole (the instance at the role's parent path) was chosen among the
    specialisations of an abstract concept (a roof among gable, hip, flat and shed); when a
    sibling specialisation orients a part of that name another way or has no such part (a
    shed's top is tilted by its pitch, a flat roof's is level), the orientation the
    knowledge gives the part is the choice itself, not evidence for it."""
    if "." not in role:
        return None
    owner, name = role.rsplit(".", 1)
    inst = next((i for i in interp.instances if i.role == owner), None)
    concept = kb.concepts.get(inst.concept) if inst is not None else None
    if concept is None:
        return None
    mine = concept.orientations.get(name)
    if mine is None and name not in concept.parts:
        return None  # not the concept's own part (a wing's floor, attached by its whole)
    key = None if mine is None else (mine.direction, mine.tilt_rad, mine.tilt_from)
    lacking = None  # an alternative without such a part: its planes lie elsewhere
    for parent in concept.parents:
        general = kb.concepts.get(parent)
        for sibling in general.specialisations if general is not None else ():
            other = kb.concepts.get(sibling)
            if other is None or sibling == concept.name or other.abstract:
                continue
            theirs = other.orientations.get(name)
            if theirs is None and name not in other.parts:
                lacking = lacking or sibling
            elif (
                theirs is not None and (theirs.direction, theirs.tilt_rad, theirs.tilt_from) != key
            ):
                return sibling  # the alternative has the part, oriented otherwise
    return lacking


def _owner_concept(interp: Interpretation, role: str) -> str:
    """The concept chosen for the whole that part `role` belongs to ('' when none)."""
    owner = role.rsplit(".", 1)[0]
    return next((i.concept for i in interp.instances if i.role == owner), "")


def unmeasured_roles(
    interp: Interpretation,
    evidence: Evidence,
    checks: tuple[ViewCheck, ...],
    kb: KnowledgeBase | None = None,
    uncertainty: Uncertainty | None = None,
) -> dict[str, str]:
    """The parts whose plane the evidence does not measure, each with its reason (role path
    -> reason, in the order of the model's parts): inserted from
    knowledge, or bound to regions none of which lies on the part (a region bound but left
    off the face by the adjustment measures nothing).

    A plane has three unknowns. A region on the part (in any view) measures all three; so
    do the outlines of regions on the model that reach the part's plane inside its face
    over an area. Otherwise the part needs two measured edges: seen in two views
    (triangulated), or in one view along a neighbour a region measures (the image line
    fixes the edge on that plane). An outline reaching it along a line is the edge it
    shares with the region's part, already counted when seen.
    The knowledge's orientations and placements (a back wall parallel to the front and
    mirrored about the ridge, a roof back as steep as the front, a floor square to the
    walls) fill in the rest, and that is a guess about this scene, not a measurement.
    One measured edge and an orientation the knowledge fixes (parallel or square to parts a
    region measures) measure the part too, unless that orientation is the choice among
    alternatives (`contested`, with `kb`): one edge of a level top — its front eave — lies
    on a shed's sloping top as well, so it cannot tell a flat roof from a shed; for the same
    reason the regions that measure such a part lie within CONTESTED_NORMAL_DEG of it (their
    weighted mean angle; a shed's top 8 degrees off a level face would still pass (b)).
    A part its edges measure must be placed by them to POSITION_TOLERANCE of the model's
    size: each edge, its ends good to EDGE_SIGMA_PX across it in each view that sees it,
    fixes the part's offset to `line_offset_sd` (an edge seen at a grazing angle, or along
    the baseline of the two views that see it, hardly does) — and, with the adjustment's
    `uncertainty`, its offset's standard deviation there, the larger of the two.
    A face inside another solid of the model (`enclosed_parts`: a wing's hidden end reaching
    into the body) is no surface of the object and needs no measurement."""
    model = interp.model
    if model is None:
        return {}
    inserted = {i.role for i in interp.instances if INSERTED in i.bindings}
    bound = {  # parts whose realisation (a con-of region) is bound to evidence
        i.parent
        for i in interp.instances
        if i.link == "con-of" and i.parent is not None and i.bindings and INSERTED not in i.bindings
    }
    by_view = {c.view: c for c in checks}
    pts, tols = [], []
    for view in evidence.views:
        check = by_view.get(view.id)
        if check is not None and check.explained_ids:
            p, t = outline_points(view, check.explained_ids, model)
            pts.append(p)
            tols.append(t)
    points = np.vstack(pts) if pts else np.zeros((0, 3))
    tol = np.concatenate(tols) if tols else np.zeros(0)
    from aida_kb.register.model import RigidModel

    names, edge_faces, seen_by = seen_edges(evidence, model)
    ends = RigidModel.from_model(model).edge_ends  # (E, 2, 3), the edges of `edge_faces`
    normals = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    cameras = {c.view: c for c in model.cameras}
    size = model_size(model)
    on_region = {
        role
        for role in names
        if any(c.explained_on.get(role, 0.0) >= MEASURING_SHARE * c.inside_weight for c in checks)
    }
    measured = np.array(
        [p.normal for p in model.parts if p.role in on_region], dtype=np.float64
    ).reshape(-1, 3)
    enclosed = enclosed_parts(model)  # inside another solid: no surface to measure
    reasons: dict[str, str] = {}
    for part in model.parts:
        if part.role in on_region:
            rival = contested(kb, interp, part.role) if kb is not None else None
            on = [
                (c.turned_on[part.role], c.explained_on[part.role])
                for c in checks
                if part.role in c.turned_on
            ]  # (angle, weight) in each view
            weight = sum(w for _, w in on)
            turned = sum(a * w for a, w in on) / weight if weight > 0 else 0.0
            if rival is not None and turned > CONTESTED_NORMAL_DEG:
                chosen = _owner_concept(interp, part.role)
                reasons[part.role] = (
                    f"{part.role} is oriented by the knowledge of {chosen}, not by its regions: "
                    f"they lie at {turned:.1f} deg to it (at most {CONTESTED_NORMAL_DEG:g}; "
                    f"{rival} orients it otherwise)"
                )
            continue
        if part.role not in inserted | bound or part.role in enclosed:
            continue
        n = np.asarray(part.normal, dtype=np.float64)
        poly = np.asarray(part.polygon, dtype=np.float64)
        near = np.abs(points @ n - part.offset_m) <= tol
        touching = points[near][inside_polygon(points[near], poly, n)] if near.any() else points[:0]
        face_size = float(np.linalg.norm(poly.max(axis=0) - poly.min(axis=0)))
        if spread(touching, face_size) >= 2:
            continue
        me = names.index(part.role) if part.role in names else -1
        lines = 0
        information = 0.0  # 1 / m², of the part's offset from its measured edges
        for k, ((f, g), views) in enumerate(zip(edge_faces, seen_by, strict=True)):
            if me not in (f, g) or not views:
                continue
            other = names[int(g if f == me else f)]
            if len(views) >= 2 or other in on_region:
                lines += 1
                within = normals[other] if other in on_region else None
                sd = line_offset_sd(ends[k], n, within, [cameras[v] for v in sorted(views)])
                information += 1.0 / sd**2 if 0.0 < sd < math.inf else 0.0
        placed = lines >= MEASURED_LINES
        if not placed and lines >= 1 and _oriented(n, measured):
            rival = contested(kb, interp, part.role) if kb is not None else None
            placed = rival is None
            if not placed:
                chosen = _owner_concept(interp, part.role)
                reasons[part.role] = (
                    f"{part.role} is oriented by the knowledge of {chosen}, not measured: no "
                    f"region lies on it and {lines} of its edges are measured, which {rival} "
                    f"would fit as well ({MEASURED_LINES} needed to tell them apart)"
                )
                continue
        if placed:
            sd = 1.0 / math.sqrt(information) if information > 0 else math.inf
            if uncertainty is not None and part.role in uncertainty.parts:
                sd = max(sd, uncertainty.parts[part.role][1])
            if sd > POSITION_TOLERANCE * size:
                placed_to = f"+-{sd:.2f} m" if math.isfinite(sd) else "nothing (left open)"
                reasons[part.role] = (
                    f"{part.role} is placed by {lines} edge{'s' if lines != 1 else ''} only "
                    f"to {placed_to}, more than "
                    f"{100 * POSITION_TOLERANCE:.0f}% of the model's size ({size:.1f} m; an "
                    f"edge's ends good to {EDGE_SIGMA_PX:g} px in the views that see it, or "
                    "the adjustment's covariance)"
                )
            continue
        how = PLACED_BY_KNOWLEDGE if part.role in inserted else BOUND_TO_NOTHING
        reasons[part.role] = (
            f"{part.role} is {how}{NOT_MEASURED}: no region lies on it and "
            f"{lines} of its edges are measured ({MEASURED_LINES} needed: seen in two views, "
            "or in one along a neighbour a region measures)"
        )
    return reasons
