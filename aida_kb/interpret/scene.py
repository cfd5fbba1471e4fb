"""Several objects per scene: a goal that holds scene objects (``part houses: House [1..*]``).

A scene-layer goal whose part-of role is filled by another scene-layer concept (kb/street.kb:
a street holding one or more houses) is interpreted object by object. Each round runs the
single-object search (`interpreter.Interpreter`) for the member concept on the evidence that
the objects found so far do not explain (`Context.build(..., explained)`): the regions an
accepted object binds, and the regions lying on its faces though unbound (a window band, a
sliver of a side wall), are never bound again, and segments bordering only them measure no
edge. The rounds end when the search finds nothing more, or the role's maximum (or
`MAX_OBJECTS`) is reached. Touching objects need nothing special: a party wall no view sees is
inserted for each of them from its own evidence (the two planes coincide); a region hidden in
part by a nearer object is still one region, bound to the object behind.

Each object is then judged alone (`verdict.judge`) on the evidence without the regions the
others explain: its own verdict, 'verified' or 'doubtful'; one the verdict finds 'nothing'
(its evidence does not support it) is dropped. The scene's result is one `Interpretation`:
the goal, each object's instances, model parts and residuals under its role (``houses[0]``,
``houses[1]`` ...; the order found), the traces one after the other, and `objects` with every
object's verdict; the scene is verified when every object is, doubtful when one is.

An object the first view does not show (hidden behind another) is looked for in each registered
later view once the views are registered (`later_view_objects`).

Cost: round k searches with the regions of k objects removed; each round tries at most
`ANCHORS_PER_ROUND` anchors, and each anchor's search is bounded like one object's: at most
`interpreter.MAX_BODY_VERIFICATIONS` adjustments of the body (of the hypotheses
`generate` enumerates from the anchor's neighbourhood, at most `NEIGHBOUR_HOPS` borders
away, not from the whole view) and `interpreter.MAX_OPTIONAL_EXPANSIONS` for its optional
parts. With N objects there are at most N + 1 rounds (the last finds nothing), so the
adjustments grow linearly with N — at most (N + 1) · `ANCHORS_PER_ROUND` ·
(`MAX_BODY_VERIFICATIONS` + `MAX_OPTIONAL_EXPANSIONS`) — each over the regions of one
neighbourhood; only ranking the anchors and finding the neighbourhoods look at all R regions
of the view each round (O(N · R²) cheap border tests). Never the combinations of objects.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.assign import vertical
from aida_kb.interpret.context import Context
from aida_kb.interpret.hypotheses import CONE_WINDOW_DEG, front_region
from aida_kb.interpret.interpreter import SAME_FRAME_COS, TIE_MARGIN, Interpreter, Level, State
from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import EvidenceView, RegionView, view_of
from aida_kb.interpret.party import extent_m, object_parts, touching_faces
from aida_kb.interpret.result import (
    INSERTED,
    HypothesisTrace,
    Instance,
    Interpretation,
    SceneObject,
)
from aida_kb.interpret.run import interpretation_of
from aida_kb.interpret.uncertainty import Uncertainty, adjustment_uncertainty
from aida_kb.interpret.verdict import (
    DOUBTFUL,
    NOTHING,
    VERIFIED,
    check_view,
    edge_cover,
    judge,
    with_verdict,
)
from aida_kb.io.evidence import Evidence, ViewEvidence
from aida_kb.io.model import ModelObject, ModelPart, ReconstructedModel, moved_part
from aida_kb.io.scene import SceneTruth
from aida_kb.io.subset import without_regions
from aida_kb.solve import ConstraintResidual

if TYPE_CHECKING:
    from aida_kb.io.scene import Scene
    from aida_kb.kb.model import KnowledgeBase

FloatArray = npt.NDArray[np.float64]

# an object's regions are found from its anchor across at most this many region borders (a
# front, its roof, the roof's hips; a side wall, its roof)
NEIGHBOUR_HOPS = 2
# neighbouring regions this close to parallel belong to two objects (coplanar fronts)
PARALLEL_NEIGHBOURS_DEG = 10.0
# two regions border each other along the pixels of their outlines this close to each other
BORDER_PX = 5.0
# ... and meet there in 3-D when their planes, seen along those pixels, lie closer than this
# fraction of the distance from the camera (stereo planes scatter by about 1 %; an occluding
# house stands metres in front of the one behind)
MEET_TOLERANCE = 0.04
# anchors tried per round (the most likely fronts first) before the rounds end
ANCHORS_PER_ROUND = 3
# an unbounded role ([1..*]) stops after this many objects: each round costs one search
MAX_OBJECTS = 12
# a region unbound by an object lies on one of its faces (and is explained by it) when its
# plane's normal (towards the camera, out of the solid) is within this angle of the face's
# outward normal ...
ON_FACE_ANGLE_DEG = 15.0
# ... its centroid within this fraction of the object's size (bounding-box diagonal) of the
# face's plane (stereo planes of small regions scatter by a few per cent) ...
ON_FACE_DISTANCE = 0.03
# ... and inside the face's polygon grown by this fraction of the object's size
ON_FACE_MARGIN = 0.03


@dataclass(frozen=True)
class Members:
    """The role of a scene-layer goal that holds scene objects: role, concept, cardinality."""

    role: str
    concept: str
    min: int
    max: int | None


def members(knowledge: Knowledge, goal: str) -> Members | None:
    """The goal's first part-of role filled by a concept of its own layer (None: there is none,
    the goal is one object)."""
    concept = knowledge.concept(goal)
    for slot in concept.slots:
        if slot.link != "part-of":
            continue
        if knowledge.concept(slot.concept).layer == concept.layer:
            return Members(slot.role, slot.concept, 0 if slot.optional else slot.min, slot.max)
    return None


def object_weight(ctx: Context, ids: set[str] | None = None) -> float:
    """The weight of the reference view's regions (of `ids`; None: all) that are not level
    (within `hypotheses.CONE_WINDOW_DEG` of facing up or down): what walls and roofs can be.
    A region is significant against this weight of its object's neighbourhood, not against the
    whole view, whose ground and other objects grow with the scene (a hip of a house in a
    street of three: 0.7 % of the view's weight, 1.7 % of the three houses', 4.6 % of its
    house's)."""
    cos = math.cos(math.radians(CONE_WINDOW_DEG))
    return sum(
        r.weight
        for r in ctx.regions
        if (ids is None or r.id in ids) and abs(float(r.normal @ ctx.up)) < cos
    )


def _ranked(walls: list[RegionView], ctx: Context, count: int) -> list[RegionView]:
    """Up to `count` significant anchor candidates, the likeliest front first
    (`hypotheses.front_region`: heavy and facing the camera)."""
    left = [w for w in walls if ctx.significant(w)]
    out: list[RegionView] = []
    while left and len(out) < count:
        best = front_region(left, ctx.evidence.camera)
        if best is None:
            break
        out.append(best)
        left = [w for w in left if w.id != best.id]
    return out


def meet(view: EvidenceView, a: str, b: str) -> int:
    """How long the border of regions `a` and `b` is where their planes meet, in outline
    vertices (the vertices of each outline within `BORDER_PX` of the other's; 1 without
    outlines): 0 when the planes seen along those pixels lie on average more than
    `MEET_TOLERANCE` of their distance from the camera apart (one region occludes the other:
    two objects)."""
    oa, ob = view.outlines.get(a, ()), view.outlines.get(b, ())
    border = [p[_near(p, q)] for p in oa for q in ob if len(p) and len(q)] + [
        q[_near(q, p)] for p in oa for q in ob if len(p) and len(q)
    ]
    pixels = np.vstack(border) if border else np.zeros((0, 2))
    if len(pixels) == 0:
        return 1
    camera = view.cameras[view.regions[a].view]
    rays = camera.rays_world(pixels)
    centre = camera.centre_m
    points = []
    for rid in (a, b):
        r = view.regions[rid]
        along = rays @ r.normal
        ok = np.abs(along) > 1e-6
        t = np.where(ok, (r.offset_m - float(r.normal @ centre)) / np.where(ok, along, 1.0), 0.0)
        points.append(centre + t[:, None] * rays)
    gap = np.linalg.norm(points[0] - points[1], axis=1)
    depth = np.maximum(np.linalg.norm(points[0] - centre, axis=1), 1e-6)
    return len(pixels) if float(np.median(gap / depth)) <= MEET_TOLERANCE else 0


def scene_evidence_of(kb: KnowledgeBase, evidence: Evidence, goal: str | None) -> Evidence:
    """The evidence a goal is interpreted on: for a goal holding several objects (`members`),
    the reference view's regions split at the party walls it shows (`party.split_terraces`:
    a terrace's touching houses, merged by the segmentation); for one object, `evidence`."""
    from aida_kb.interpret.party import split_terraces
    from aida_kb.interpret.run import check_goal

    slot = members(Knowledge.from_kb(kb), check_goal(kb, goal))
    return evidence if slot is None else split_terraces(evidence)


def _near(points: FloatArray, polygon: FloatArray) -> npt.NDArray[np.bool_]:
    """Which of the points (N, 2) lie within `BORDER_PX` of the closed polygon (M, 2)."""
    edge = np.roll(polygon, -1, axis=0) - polygon
    length2 = np.maximum(np.sum(edge * edge, axis=1), 1e-12)
    rel = points[:, None, :] - polygon[None, :, :]
    t = np.clip(np.sum(rel * edge[None], axis=2) / length2[None], 0.0, 1.0)
    gap = np.linalg.norm(rel - t[..., None] * edge[None], axis=2).min(axis=1)
    out: npt.NDArray[np.bool_] = gap <= BORDER_PX
    return out


def ground(ctx: Context, anchor: RegionView, rid: str) -> bool:
    """True if region `rid` is level (within `hypotheses.CONE_WINDOW_DEG` of facing up or
    down) and lies below the anchor's centroid: the ground every object stands on."""
    r = ctx.evidence.regions[rid]
    below = float((r.centroid_m - anchor.centroid_m) @ ctx.up) < 0.0
    return below and abs(float(r.normal @ ctx.up)) >= math.cos(math.radians(CONE_WINDOW_DEG))


def neighbourhood(ctx: Context, anchor: RegionView, free: set[str]) -> set[str]:
    """The regions of `free` an object anchored on `anchor` may bind: those reached from it
    across region borders (`EvidenceView.beside`) where their planes meet (`meet`) in at most
    `NEIGHBOUR_HOPS` steps, the longest borders first; never a region facing the way one
    already reached faces (two objects' coplanar fronts or roofs side by side: a convex solid
    shows no two faces facing one way; an oriel's front, parallel to its body's, is lost to
    this) and never a level region below the anchor (the ground, which every object stands
    on)."""
    view = ctx.evidence
    cos_parallel = math.cos(math.radians(PARALLEL_NEIGHBOURS_DEG))

    def allowed(rid: str) -> bool:
        return not ground(ctx, anchor, rid)

    def parallel(a: str, b: str) -> bool:
        return float(view.regions[a].normal @ view.regions[b].normal) >= cos_parallel

    reached = {anchor.id}
    frontier = [anchor.id]
    for _ in range(NEIGHBOUR_HOPS):
        found: dict[str, int] = {}
        for a in frontier:
            for b in sorted(free - reached):
                if not allowed(b) or parallel(a, b) or not view.beside(a, b):
                    continue
                border = meet(view, a, b)
                if border:
                    found[b] = max(found.get(b, 0), border)
        # the longest borders first; a region facing the way one already reached faces is
        # another object's (one convex solid shows no two faces facing one way)
        step: list[str] = []
        for b in sorted(found, key=lambda r: (-found[r], r)):
            if not any(parallel(b, r) for r in reached):
                reached.add(b)
                step.append(b)
        frontier = step
    return reached


def _inside(point: FloatArray, polygon: FloatArray, normal: FloatArray, margin: float) -> bool:
    """True if `point` (3,) projected on the plane of `polygon` (K, 3, convex, any order) lies
    inside it grown by `margin` metres."""
    u = polygon[1] - polygon[0]
    u = u / float(np.linalg.norm(u))
    v = np.cross(normal, u)
    q = np.stack([polygon @ u, polygon @ v], axis=1)
    p = np.array([point @ u, point @ v])
    centre = q.mean(axis=0)
    # a convex polygon: inside all half-planes of its sides, each moved out by the margin
    edges = np.roll(q, -1, axis=0) - q
    outward = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
    outward /= np.linalg.norm(outward, axis=1, keepdims=True) + 1e-12
    flip = np.sign(np.sum((centre - q) * outward, axis=1))
    outward *= -np.where(flip == 0, 1.0, flip)[:, None]
    return bool(np.all(np.sum((p - q) * outward, axis=1) <= margin))


def on_faces(view: EvidenceView, model: ReconstructedModel, candidates: set[str]) -> set[str]:
    """The region ids of `candidates` lying on a face of `model` (see the module constants)."""
    size = extent_m(model.parts)
    return {
        rid
        for rid in sorted(candidates)
        if _on_face(view.regions[rid].normal, view.regions[rid].centroid_m, model.parts, size)
    }


def _on_face(
    normal: FloatArray,
    centroid_m: FloatArray,
    parts: Sequence[ModelPart],
    size_m: float,
) -> bool:
    """True if a region's plane (unit `normal` (3,), `centroid_m` (3,), world frame) lies on one
    of the parts (see the module constants; `size_m` the object's size)."""
    cos = math.cos(math.radians(ON_FACE_ANGLE_DEG))
    for part in parts:
        n = np.asarray(part.normal, dtype=np.float64)
        # facing the face's way: a region facing the other way on its plane is another
        # object's face there (the neighbour's gable wall above a terrace house's roof, on its
        # party wall's plane)
        if float(normal @ n) < cos:
            continue
        if abs(float(n @ centroid_m) - part.offset_m) > ON_FACE_DISTANCE * size_m:
            continue
        poly = np.asarray(part.polygon, dtype=np.float64)
        if _inside(centroid_m, poly, n, ON_FACE_MARGIN * size_m):
            return True
    return False


def _bound(interp: Interpretation) -> set[str]:
    """The region ids an interpretation binds."""
    return {b for inst in interp.instances for b in inst.bindings if b != INSERTED}


def _under(prefix: str, role: str) -> str:
    return prefix if not role else f"{prefix}.{role}"


def _prefixed(
    prefix: str, interp: Interpretation, offset: int
) -> tuple[list[Instance], list[ModelPart], list[HypothesisTrace], list[ConstraintResidual]]:
    """An object's instances, model parts, trace and residuals under its role `prefix` in the
    scene; its hypotheses' ids moved by `offset` (the scene's trace is one list)."""
    instances = [
        inst.model_copy(
            update={
                "role": _under(prefix, inst.role),
                "parent": "" if inst.parent is None else _under(prefix, inst.parent),
                "link": "part-of" if inst.link == "goal" else inst.link,
            }
        )
        for inst in interp.instances
    ]
    model = interp.model
    parts = (
        []
        if model is None
        else [p.model_copy(update={"role": _under(prefix, p.role)}) for p in model.parts]
    )
    trace = [
        h.model_copy(
            update={
                "id": h.id + offset,
                "parent": None if h.parent is None else h.parent + offset,
                "role": _under(prefix, h.role),
            }
        )
        for h in interp.trace
    ]
    residuals = [
        r.model_copy(
            update={
                "owner": _under(prefix, r.owner),
                "parts": tuple(_under(prefix, p) for p in r.parts),
            }
        )
        for r in interp.residuals
    ]
    return instances, parts, trace, residuals


@dataclass(frozen=True)
class Search:
    """The objects `find_objects` found: each accepted interpretation with the regions it
    explains, in the order found; the hypotheses expanded; why the rounds stopped; the choices
    the knowledge decided for an object (by ``id`` of its interpretation)."""

    found: list[tuple[Interpretation, set[str]]]
    expanded: int
    stop: str
    taken: dict[int, list[str]]


def find_objects(
    knowledge: Knowledge,
    view: EvidenceView,
    evidence: Evidence,
    slot: Members,
    limit: int,
    *,
    already: frozenset[str] = frozenset(),
    progress: Callable[[str], None] | None = None,
    prefer: Sequence[Preference] = (),
) -> Search:
    """The rounds of `interpret_scene` (module docstring) on the reference view of `view`:
    at most `limit` objects of the role `slot`, none on the regions `already` explained."""
    found: list[tuple[Interpretation, set[str]]] = []
    explained = set(already)
    expanded = 0
    stop = ""
    reference = {r for r in view.regions if view.regions[r].view == view.reference_view}
    weight = object_weight(Context.build(knowledge, view, slot.concept))
    failed: set[str] = set()  # anchors whose search found nothing
    taken: dict[int, list[str]] = {}  # choices the knowledge decided, by attempt
    while len(found) < limit:
        ctx = Context.build(knowledge, view, slot.concept, frozenset(explained), weight)
        free = {r.id for r in ctx.regions}
        walls = [r for r in vertical(ctx.regions, ctx.up) if r.id not in failed]
        anchors = _ranked(walls, ctx, ANCHORS_PER_ROUND)
        if not anchors:
            stop = stop or "no vertical region left to anchor an object"
            break
        one: Interpretation | None = None
        for anchor in anchors:
            if progress is not None:
                progress(f"{slot.concept} {len(found) + 1}: anchored on region {anchor.id}")
            near = neighbourhood(ctx, anchor, free)
            interpreter = Interpreter(
                knowledge,
                view,
                slot.concept,
                explained=frozenset(reference - near),
                reference_weight=object_weight(ctx, near) or weight,
                anchors=frozenset({anchor.id}),
                foreign=frozenset(r for r in reference - near if not ground(ctx, anchor, r)),
            )
            state, n, goal_id = interpreter.run()
            expanded += n
            pref = next((p for p in prefer if anchor.id in p.regions), None)
            wanted = pref.choices if pref is not None else frozenset()
            swapped = None if state is None or not wanted else preferred(interpreter, state, wanted)
            if swapped is not None:
                state = swapped[0]
            attempt = interpretation_of(interpreter, state, n, goal_id, evidence)
            if swapped is not None and pref is not None:
                attempt = _decided(attempt, wanted, swapped[1], pref.reason)
                taken[id(attempt)] = sorted(wanted) if pref.reason else []
            if attempt.accepted and attempt.model is not None and _bound(attempt) - explained:
                one = attempt
                break
            failed.add(anchor.id)
            stop = attempt.message
        if one is None or one.model is None:
            break
        bound = _bound(one) - explained
        own = bound | on_faces(view, one.model, reference - explained - bound)
        explained |= own
        found.append((one, own))
    return Search(found, expanded, stop, taken)


def interpret_scene(
    kb: KnowledgeBase,
    evidence: Evidence,
    goal: str,
    slot: Members,
    *,
    source: str = "",
    progress: Callable[[str], None] | None = None,
    prefer: Sequence[Preference] = (),
) -> Interpretation:
    """Interpret `evidence` for a goal holding several objects in its role `slot` (see the
    module docstring). The result carries every object with its own verdict in `objects`, and
    the scene's verdict. prefer : choices along is-a that other views decided for objects found
    before (`Preference`, `reconstruct_objects`): an object anchored on one of a preference's
    regions takes the tied body making those choices."""
    knowledge = Knowledge.from_kb(kb)
    view = view_of(evidence, source)
    limit = min(slot.max if slot.max is not None else MAX_OBJECTS, MAX_OBJECTS)
    search = find_objects(knowledge, view, evidence, slot, limit, progress=progress, prefer=prefer)
    found, expanded, stop, taken = search.found, search.expanded, search.stop, search.taken
    # each object judged on the evidence without what the others explain
    objects: list[SceneObject] = []
    instances = [Instance(role="", concept=goal, instance_of=goal, parent=None, link="goal")]
    parts: list[ModelPart] = []
    residuals: list[ConstraintResidual] = []
    trace: list[HypothesisTrace] = []
    dropped: list[str] = []
    for one, own in found:
        others = set().union(*(o for other, o in found if other is not one))
        verdict = judge(kb, one, without_regions(evidence, others))
        judged = with_verdict(one, verdict)
        if verdict.verdict == NOTHING:
            dropped.append(judged.message)
            continue
        prefix = f"{slot.role}[{len(objects)}]"
        inst, faces, steps, rows = _prefixed(prefix, judged, len(trace))
        instances += inst
        parts += faces
        trace += steps
        residuals += rows
        objects.append(
            SceneObject(
                role=prefix,
                concept=slot.concept,
                verdict=DOUBTFUL if verdict.verdict == DOUBTFUL else VERIFIED,
                doubts=list(verdict.reasons),
                message=judged.message,
                cost=judged.cost,
                expanded=judged.expanded,
                evidence=sorted(own),
                ties=list(judged.ties),
                shared=taken.get(id(one), []),
            )
        )
    if parts:  # what touching objects share, judged on the objects' models together
        draft = Interpretation(
            goal=goal,
            accepted=True,
            message="",
            instances=instances,
            model=ReconstructedModel(parts=parts),
            objects=objects,
            expanded=expanded,
        )
        objects = alike_doubts(kb, draft, objects)
    counts = f"{len(objects)} {slot.concept} found in {len(found) + 1} rounds"
    if len(objects) < max(slot.min, 1):
        why = "; ".join(dropped) or stop or "nothing found"
        return Interpretation(
            goal=goal,
            accepted=False,
            message=f"no {goal} in the evidence: {counts} (at least {slot.min} needed): {why}",
            trace=trace,
            expanded=expanded,
        )
    first = found[0][0].model
    assert first is not None
    model = ReconstructedModel(
        parts=parts,
        cameras=first.cameras,
        up=first.up,
        objects=[ModelObject(role=o.role, concept=o.concept, verdict=o.verdict) for o in objects],
    )
    doubtful = [o for o in objects if o.verdict == DOUBTFUL]
    listing = ", ".join(f"{o.role} {o.verdict}" for o in objects)
    return Interpretation(
        goal=goal,
        accepted=True,
        message=(
            f"{goal}: {counts} ({listing}); {expanded} hypotheses expanded; "
            f"no more: {stop or 'the role is full'}"
        ),
        instances=instances,
        model=model,
        residuals=residuals,
        trace=trace,
        expanded=expanded,
        cost=sum(o.cost or 0.0 for o in objects),
        verdict=DOUBTFUL if doubtful else VERIFIED,
        doubts=[f"{o.role}: {d}" for o in doubtful for d in o.doubts],
        objects=objects,
    )


@dataclass(frozen=True)
class Preference:
    """Choices along is-a (``ROLE=CONCEPT``, roles relative to the object) that views other
    than the interpreted one, or the knowledge (`reason`), decided for the object explaining
    `regions` ('VIEW/REGION')."""

    regions: frozenset[str]
    choices: frozenset[str]
    # why, when the knowledge decided them (`shared_choices`; empty: the other views did)
    reason: str = ""


def preferred(
    interpreter: Interpreter, state: State, wanted: frozenset[str]
) -> tuple[State, tuple[str, ...]] | None:
    """The accepted `state` with its body replaced by the cheapest tied body making the
    choices `wanted` (a body `Interpreter.ties` names: the same regions bound in the same
    frame, its cost within `interpreter.TIE_MARGIN`), and the choices given up for them; None
    when no tied body makes them (the evidence of the interpreted view decides against)."""
    if not state.levels or not wanted <= set(interpreter.ties(state)):
        return None
    body = state.levels[0]
    own = next((c for lv, c in interpreter.bodies if lv is body), None)
    if own is None:
        return None
    best: tuple[Level, float, set[str]] | None = None
    for level, cost in interpreter.bodies:
        made = {f"{r}={c}" for r, c in level.structure.choices}
        if level is body or cost > own + TIE_MARGIN or not wanted <= made:
            continue
        if set(level.binding) != set(body.binding):
            continue
        fronts, ups = level.frame.front @ body.frame.front, level.frame.up @ body.frame.up
        if min(float(fronts), float(ups)) < SAME_FRAME_COS:
            continue
        if best is None or cost < best[1]:
            best = (level, cost, made)
    if best is None:
        return None
    level, cost, made = best
    given_up = tuple(sorted({f"{r}={c}" for r, c in body.structure.choices} - made))
    return State((level, *state.levels[1:]), True, state.cost - own + cost), given_up


def _decided(
    attempt: Interpretation, wanted: frozenset[str], given_up: tuple[str, ...], reason: str = ""
) -> Interpretation:
    """`attempt` (its body the tied one making the choices `wanted`) with the choices given up
    no longer named as ties: the other views decided between them, or the knowledge
    (`reason`)."""
    ties = [t for t in attempt.ties if t not in given_up]
    message = attempt.message.replace(
        f"; the evidence does not decide it from {', '.join(attempt.ties)}",
        f"; the evidence does not decide it from {', '.join(ties)}" if ties else "",
    )
    return attempt.model_copy(
        update={
            "ties": ties,
            "message": f"{message}; {reason}"
            if reason
            else f"{message}; the other views decided {', '.join(sorted(wanted))} over "
            f"{', '.join(given_up)} (re-judged by them, interpret.scene.reconstruct_objects)",
        }
    )


def explained_by_others(evidence: Evidence, interp: Interpretation, role: str) -> set[str]:
    """The region ids ('VIEW/REGION') of every view that the scene's objects other than
    `role` explain: in the interpreted view those they bound or lie on their faces (their
    `SceneObject.evidence`), in every other view with a camera in the model those lying on
    their faces (a view in its camera's frame is moved into the world frame by it)."""
    model = interp.model
    out = {r for o in interp.objects if o.role != role for r in o.evidence}
    if model is None:
        return out
    others = [
        (object_parts(model, o.role), extent_m(object_parts(model, o.role)))
        for o in interp.objects
        if o.role != role and object_parts(model, o.role)
    ]
    cameras = {c.view: c for c in model.cameras}
    interpreted = {r.split("/", 1)[0] for o in interp.objects for r in o.evidence}
    for v in evidence.views:
        if v.id in interpreted or v.id not in cameras:
            continue
        R = np.asarray(cameras[v.id].R, dtype=np.float64)
        t = np.asarray(cameras[v.id].t, dtype=np.float64)
        for r in v.regions:
            n = np.asarray(r.n_init, dtype=np.float64)
            c = np.asarray(r.c_init, dtype=np.float64)
            if v.frame == "camera":  # x_cam = R x_world + t
                n, c = R.T @ n, R.T @ (c - t)
            if any(_on_face(n, c, parts, size) for parts, size in others):
                out.add(f"{v.id}/{r.id}")
    return out


def judge_objects(kb: KnowledgeBase, interp: Interpretation, evidence: Evidence) -> Interpretation:
    """`interp` (a scene of several objects) with every object judged again on its model as it
    now is (after a refinement with more views), each on the evidence the others do not
    explain (`explained_by_others`); the scene's verdict from theirs. An object now judged
    'nothing' is kept, doubtful, with that reason (its evidence was found in the first view)."""
    if interp.model is None or not interp.objects:
        return interp
    # the cameras of the later views are fixed by every object's evidence together: judged
    # from one object's alone, a camera 50 degrees round was doubted at +-0.4-1 deg where the
    # scene's adjustment fixes it far better; each object's parts are read from the same
    # adjustment (their deviations with the cameras' correlations)
    whole = adjustment_uncertainty(kb, interp, evidence)
    objects: list[SceneObject] = []
    for obj in interp.objects:
        sub = _sub_interpretation(interp, obj.role, obj)
        sub = sub.model_copy(
            update={
                "goal": obj.concept,
                "residuals": [
                    r.model_copy(
                        update={
                            "owner": _strip(obj.role, r.owner),
                            "parts": tuple(_strip(obj.role, p) for p in r.parts),
                        }
                    )
                    for r in interp.residuals
                    if all(p.startswith(obj.role + ".") for p in r.parts)
                ],
            }
        )
        # all_views: the scene stands for every view of the evidence; a view the
        # reconstruction left without a camera is doubted, an object no other view confirms is
        # not verified (street 62052: view 01 unregistered, a house verified that way)
        verdict = judge(
            kb,
            sub,
            without_regions(evidence, explained_by_others(evidence, interp, obj.role)),
            all_views=True,
            uncertainty=None if whole is None else _object_uncertainty(whole, obj.role),
            occluders=[p for p in interp.model.parts if not p.role.startswith(obj.role + ".")],
        )
        reasons = list(verdict.reasons)
        if verdict.verdict == NOTHING:
            reasons = reasons or ["its model was lost in the refinement"]
        objects.append(
            obj.model_copy(
                update={
                    "verdict": VERIFIED if verdict.verdict == VERIFIED else DOUBTFUL,
                    "doubts": reasons if verdict.verdict != VERIFIED else [],
                }
            )
        )
    objects = alike_doubts(kb, interp, objects)
    doubtful = [o for o in objects if o.verdict == DOUBTFUL]
    model = interp.model.model_copy(
        update={
            "objects": [
                ModelObject(role=o.role, concept=o.concept, verdict=o.verdict) for o in objects
            ]
        }
    )
    return interp.model_copy(
        update={
            "model": model,
            "objects": objects,
            "verdict": DOUBTFUL if doubtful else VERIFIED,
            "doubts": [f"{o.role}: {d}" for o in doubtful for d in o.doubts],
        }
    )


# ---- ties the other views decide ------------------------------------------------------------
# an object's choice along is-a that the interpreted view leaves open (a tie: a gable whose
# gable walls no view shows and a shed whose back wall stands under the ridge, as at the end of
# a terrace whose other end the second view shows) is re-judged by the other views as
# `rejudge` does for a single object, object by object: the scene reconstructed again with
# every tied object taking its tied choice (`Preference`), each object scored on every view
# but the interpreted one by `object_score`; an object whose tied choice leads by
# `rejudge.REJUDGE_MARGIN` per such view takes it, the others keep theirs (and their ties).
# When only some lead, the scene is reconstructed once more with those alone, taken when they
# still lead.


Score = tuple[float, float | None, float | None]  # explained, seen edges, faces holding


def object_score(evidence: Evidence, interp: Interpretation, obj: SceneObject) -> dict[str, Score]:
    """Per view with a camera in `interp`'s model, what it says of object `obj`'s model
    (as `rejudge.score` for a single object): the explained share of the region weight inside
    its projection (the view without the regions the other objects explain), the seen share
    of its visible edges' length (edges between two of its faces; the other objects' faces
    hide what lies behind them), or None without an edge to check, and how well its faces hold
    the regions on them (`inside_faces`), or None without a face to judge."""
    model = interp.model
    if model is None:
        return {}
    sub = _sub_interpretation(interp, obj.role, obj).model
    assert sub is not None  # a copy of `model`
    own = frozenset(p.role for p in object_parts(model, obj.role))
    rest = without_regions(evidence, explained_by_others(evidence, interp, obj.role))
    out: dict[str, Score] = {}
    for view, whole_view in zip(rest.views, evidence.views, strict=True):
        check = check_view(view, sub)
        if check is None:
            continue
        explained = check.explained_share if check.inside_weight > 0 else 0.0
        out[view.id] = (explained, edge_cover(whole_view, model, own), inside_faces(view, sub))
    return out


def _total(scores: dict[str, Score], views: Sequence[str]) -> float:
    """A score over `views` (as `rejudge.Candidate.total`): explained plus seen edge share,
    plus how well the faces hold the regions on them."""
    out = 0.0
    for v in views:
        explained, edges, inside = scores.get(v, (0.0, None, None))
        out += explained + (edges if edges is not None else 0.0)
        out += inside if inside is not None else 0.0
    return out


# regions are laid over the model's faces on a grid this many pixels wide ...
INSIDE_GRID_PX = 4.0
# ... and a face is judged when the regions on it cover this many cells of the grid (800 px):
# their share outside it is then known to a few per cent
INSIDE_MIN_CELLS = 50


def inside_faces(view: ViewEvidence, model: ReconstructedModel) -> float | None:
    """How well the faces of `model` hold the regions of `view` lying on them, seen from the
    view's camera in `model`: 1 minus the largest share of a face's regions' pixels that falls
    outside the face's projection. A region lies on a face whose plane it lies on
    (`verdict.views`' tolerances) and whose projection holds some of its pixels (on a grid of
    `INSIDE_GRID_PX`); faces whose regions cover fewer than `INSIDE_MIN_CELLS` cells are not
    judged. A model too small for the surfaces it stands on leaves part of them outside — a
    shed whose back wall stands under the ridge, where view 01 sees the gable wall of a gable
    reach back beyond it: half of that region outside the shed's side wall, a tenth outside
    the gable's — which the explained share inside the projection does not see. The largest,
    not the mean: the one face that differs between two alternatives decides, however many
    faces they share. None: no camera in the model for the view, or no face judged."""
    from aida_kb.interpret.verdict.tolerances import (
        DEPTH_TOLERANCE,
        DEPTH_TOLERANCE_MIN_M,
        MIN_WEIGHT_SHARE,
        NORMAL_TOLERANCE_DEG,
    )
    from aida_kb.vision.rectify import undistort_pixels

    camera = next((c for c in model.cameras if c.view == view.id), None)
    regions = [r for r in view.regions if r.w_c > 0]
    if camera is None or not regions or not model.parts:
        return None
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    C = -R.T @ t
    K = np.asarray(view.left.K, dtype=np.float64)
    D = np.asarray(view.left.D, dtype=np.float64)
    total = sum(r.w_c for r in regions)
    shape = (
        math.ceil(view.image_height / INSIDE_GRID_PX),
        math.ceil(view.image_width / INSIDE_GRID_PX),
    )
    # the faces facing the camera, projected onto the grid
    faces: list[tuple[FloatArray, float, npt.NDArray[np.bool_]]] = []
    for part in model.parts:
        n = np.asarray(part.normal, dtype=np.float64)
        poly = np.asarray(part.polygon, dtype=np.float64)
        x_cam = poly @ R.T + t
        if float(n @ C) - part.offset_m <= 0.0 or np.any(x_cam[:, 2] <= 0.0):
            continue
        uv = (x_cam @ K.T)[:, :2] / x_cam[:, 2:3] / INSIDE_GRID_PX
        mask = _cells(uv, shape)
        if mask.any():
            faces.append((n, part.offset_m, mask))
    outlines: dict[int, list[FloatArray]] = {}
    for c in view.contours:
        pts = undistort_pixels(np.asarray(c.points, dtype=np.float64), K, D) / INSIDE_GRID_PX
        outlines.setdefault(c.region, []).append(pts)
    cos_tol = math.cos(math.radians(NORMAL_TOLERANCE_DEG))
    cells = np.zeros(len(faces))  # per face: its regions' cells, and those outside it
    outside = np.zeros(len(faces))
    for r in regions:
        if r.w_c < MIN_WEIGHT_SHARE * total or r.id not in outlines:
            continue
        n_r = np.asarray(r.n_init, dtype=np.float64)
        c_r = np.asarray(r.c_init, dtype=np.float64)
        if view.frame == "camera":  # this view's own left camera -> world
            n_r, c_r = R.T @ n_r, R.T @ (c_r - t)
        tol = max(DEPTH_TOLERANCE * float(np.linalg.norm(c_r - C)), DEPTH_TOLERANCE_MIN_M)
        on = [
            k
            for k, (n, d, _) in enumerate(faces)
            if abs(float(n_r @ n)) >= cos_tol and abs(float(c_r @ n) - d) <= tol
        ]
        if not on:
            continue
        region = np.zeros(shape, dtype=bool)
        for pts in outlines[r.id]:
            region ^= _cells(pts, shape)  # even-odd: a hole inside its outline is cut out
        held = [int((region & faces[k][2]).sum()) for k in on]
        if max(held) == 0:
            continue  # on the plane of a face, but elsewhere: another object's
        k = on[int(np.argmax(held))]
        cells[k] += float(region.sum())
        outside[k] += float(region.sum()) - max(held)
    judged = cells >= INSIDE_MIN_CELLS
    if not judged.any():
        return None
    return 1.0 - float(np.max(outside[judged] / cells[judged]))


def _cells(polygon: FloatArray, shape: tuple[int, int]) -> npt.NDArray[np.bool_]:
    """The cells of a grid (rows, columns) whose centres lie inside `polygon` (K, 2: x, y in
    cells)."""
    from aida_kb.texture.raycast import inside_polygon

    mask = np.zeros(shape, dtype=bool)
    lo = np.clip(np.floor(polygon.min(axis=0)).astype(int), 0, [shape[1], shape[0]])
    hi = np.clip(np.ceil(polygon.max(axis=0)).astype(int) + 1, 0, [shape[1], shape[0]])
    if np.any(hi <= lo):
        return mask
    xs, ys = np.meshgrid(np.arange(lo[0], hi[0]), np.arange(lo[1], hi[1]))
    centres = np.stack([xs.ravel(), ys.ravel()], axis=1) + 0.5
    mask[ys.ravel(), xs.ravel()] = inside_polygon(centres.astype(np.float64), polygon)
    return mask


def _ties(interp: Interpretation) -> dict[str, Preference]:
    """The objects (by role) with ties, each with the tied choices to take instead (the first
    tie of each role)."""
    out: dict[str, Preference] = {}
    for obj in interp.objects:
        first: dict[str, str] = {}
        for tie in obj.ties:
            first.setdefault(tie.split("=", 1)[0], tie)
        if first:
            out[obj.role] = Preference(frozenset(obj.evidence), frozenset(first.values()))
    return out


def _matching(interp: Interpretation, regions: frozenset[str]) -> SceneObject | None:
    """The object of `interp` sharing the most regions with `regions` (None: none shares)."""
    best = max(interp.objects, key=lambda o: len(regions & set(o.evidence)), default=None)
    return best if best is not None and regions & set(best.evidence) else None


def _leading(
    evidence: Evidence,
    before: Interpretation,
    after: Interpretation,
    flips: dict[str, Preference],
) -> dict[str, Preference]:
    """The flips whose object in `after` (its tied choice taken) leads its namesake in
    `before` by `rejudge.REJUDGE_MARGIN` per view other than the interpreted one, over the
    views both reconstructions registered (a view one of them left out scores nothing there:
    street5 dev 61031, view 01 left out of the first, gave every tied choice a lead of 1.5 per
    view and took two wrong roofs)."""
    from aida_kb.interpret.rejudge import REJUDGE_MARGIN

    out: dict[str, Preference] = {}
    for obj in before.objects:
        flip = flips.get(obj.role)
        other = None if flip is None else _matching(after, flip.regions)
        if flip is None or other is None or other.ties == obj.ties:
            continue
        interpreted = {r.split("/", 1)[0] for r in obj.evidence}
        mine, theirs = object_score(evidence, before, obj), object_score(evidence, after, other)
        views = [v.id for v in evidence.views if v.id not in interpreted]
        views = [v for v in views if v in mine and v in theirs]
        lead = _total(theirs, views) - _total(mine, views)
        if views and lead >= REJUDGE_MARGIN * len(views):
            out[obj.role] = flip
    return out


def reconstruct_objects(
    kb: KnowledgeBase,
    evidence: Evidence,
    *,
    goal: str | None = None,
    source: str = "",
    scene: Scene | None = None,
    progress: Callable[[str], None] | None = None,
) -> Interpretation:
    """`rejudge.rejudged_views` (`multiview.reconstruct_views`, a single object's ties
    re-judged by every view), and for a scene of several objects their ties re-judged by the
    other views object by object (see above), then the ties still open that the knowledge
    decides (`shared_choices`: a touching object's choice): at most three more reconstructions
    of the scene, none when no object has a tie; last, the objects that only the later views
    show (`later_view_objects`)."""
    from aida_kb.interpret.multiview import reconstruct_views  # they build on this module
    from aida_kb.interpret.rejudge import rejudged_views

    first = _every_view(
        kb,
        evidence,
        rejudged_views(kb, evidence, goal=goal, source=source, scene=scene, progress=progress),
    )
    flips = _ties(first)
    if not flips:
        return later_view_objects(kb, evidence, first, source=source, progress=progress)

    def again(chosen: dict[str, Preference]) -> Interpretation:
        if progress is not None:
            progress(f"re-judging the ties of {', '.join(chosen)} with every view")
        return reconstruct_views(
            kb,
            evidence,
            goal=goal,
            source=source,
            scene=scene,
            progress=progress,
            prefer=tuple(chosen.values()),
        )

    result, chosen = first, dict[str, Preference]()
    if len(evidence.views) >= 2:
        second = _every_view(kb, evidence, again(flips))
        leading = _leading(evidence, first, second, flips) if _keeps(first, second) else {}
        if leading and leading != flips:
            second = _every_view(kb, evidence, again(leading))
            if not _keeps(first, second) or _leading(evidence, first, second, leading) != leading:
                leading = {}
        if leading:
            result, chosen = second, leading
    shared = shared_choices(kb, result)
    if shared:
        wanted = _kept_choices(result, chosen)
        for role, pref in shared.items():
            had = wanted.get(role)
            wanted[role] = (
                pref if had is None else replace(pref, choices=pref.choices | had.choices)
            )
        third = _every_view(kb, evidence, again(wanted))
        result = third if _keeps(result, third) else result
    confirmed = confirmed_choices(kb, result)
    result = result if confirmed is result else judge_objects(kb, confirmed, evidence)
    return later_view_objects(kb, evidence, result, source=source, progress=progress)


# ---- objects the first view does not show -------------------------------------------------
# A house hidden behind another in the first view (street 62602: only a strip of its roof
# shows there) is found in no round of `interpret_scene`, which looks at the first view alone.
# Once the later views are registered, each one's evidence is searched the same way for more
# objects: its regions lying on the faces of the objects found so far (`on_faces`, the model
# moved into that view's camera frame by its registered pose) count as explained, the rounds of
# `find_objects` run on the rest, and an object they find is moved back into the world frame
# by the view's pose, joins the scene under the next index of the role, and every object is
# judged again on all views (`judge_objects`). Its geometry is that view's own interpretation
# (not adjusted jointly with the others); the verdict judges it on every view like the rest.
# Cost: one more set of rounds per registered later view, on the regions its objects leave.


def later_view_objects(
    kb: KnowledgeBase,
    evidence: Evidence,
    interp: Interpretation,
    *,
    source: str = "",
    progress: Callable[[str], None] | None = None,
) -> Interpretation:
    """`interp` (a scene of several objects, its later views registered) with the objects the
    later views show and the first does not (see above); `interp` itself when there are none,
    the role is full, or the evidence's first view is not at the world's origin."""
    from aida_kb.interpret.multiview import first_view_swapped  # it builds on this module

    model = interp.model
    knowledge = Knowledge.from_kb(kb)
    slot = members(knowledge, interp.goal) if interp.accepted else None
    if model is None or not interp.objects or slot is None:
        return interp
    room = min(slot.max if slot.max is not None else MAX_OBJECTS, MAX_OBJECTS)
    room -= len(interp.objects)
    cameras = {c.view: c for c in model.cameras}
    parts = list(model.parts)
    solids = [
        _vertices(p for p in parts if p.role.startswith(o.role + ".")) for o in interp.objects
    ]
    added: list[tuple[Interpretation, set[str], str]] = []  # world-frame result, regions, view
    for later in evidence.views[1:]:
        camera = cameras.get(later.id)
        if camera is None or room <= len(added):
            continue
        swapped = first_view_swapped(evidence, later.id)
        if swapped is None:
            break
        alone = swapped.model_copy(update={"views": swapped.views[:1]})
        R = np.asarray(camera.R, dtype=np.float64)  # x_view = R x_world + t
        t = np.asarray(camera.t, dtype=np.float64)
        view = view_of(alone, source)
        if not view.regions:
            continue
        seen = ReconstructedModel(parts=[moved_part(p, R, t) for p in parts])
        already = frozenset(on_faces(view, seen, set(view.regions)))
        if progress is not None:
            progress(f"looking for more {slot.concept} in view {later.id}")
        search = find_objects(
            knowledge, view, alone, slot, room - len(added), already=already, progress=progress
        )
        for one, own in search.found:
            assert one.model is not None
            back = [moved_part(p, R.T, -R.T @ t) for p in one.model.parts]
            mine = _vertices(back)
            if any(_overlap(mine, theirs) for theirs in solids):
                continue
            moved = one.model_copy(update={"model": one.model.model_copy(update={"parts": back})})
            added.append((moved, own, later.id))
            parts += back
            solids.append(mine)
    if not added:
        return interp
    return judge_objects(kb, _joined(interp, slot, added), evidence)


def _vertices(parts: Iterable[ModelPart]) -> FloatArray:
    """(K, 3) the polygon vertices of `parts`, world frame, metres."""
    return np.concatenate([np.asarray(p.polygon, dtype=np.float64) for p in parts])


def _overlap(a: FloatArray, b: FloatArray) -> bool:
    """True if the convex hull of the vertices `a` (K, 3) holds the centre of `b` (L, 3) or the
    other way round: one object found twice."""
    from scipy.spatial import Delaunay, QhullError

    for hull, centre in ((a, b.mean(axis=0)), (b, a.mean(axis=0))):
        try:
            if int(Delaunay(hull).find_simplex(centre[None, :])[0]) >= 0:
                return True
        except QhullError:  # a flat solid holds no centre
            continue
    return False


def _joined(
    interp: Interpretation, slot: Members, added: list[tuple[Interpretation, set[str], str]]
) -> Interpretation:
    """`interp` with the objects `added` (world-frame results, their regions, the view each
    was found in) under the next indices of the role `slot`, not yet judged."""
    assert interp.model is not None
    instances, parts = list(interp.instances), list(interp.model.parts)
    trace, residuals, objects = list(interp.trace), list(interp.residuals), list(interp.objects)
    notes = []
    for one, own, view in added:
        prefix = f"{slot.role}[{len(objects)}]"
        inst, faces, steps, rows = _prefixed(prefix, one, len(trace))
        instances += inst
        parts += faces
        trace += steps
        residuals += rows
        objects.append(
            SceneObject(
                role=prefix,
                concept=slot.concept,
                verdict=DOUBTFUL,
                message=f"{one.message} (found in view {view})",
                cost=one.cost,
                expanded=one.expanded,
                evidence=sorted(own),
                ties=list(one.ties),
            )
        )
        notes.append(f"{prefix} found in view {view}, which the first view does not show")
    model = interp.model.model_copy(update={"parts": parts})
    return interp.model_copy(
        update={
            "instances": instances,
            "model": model,
            "trace": trace,
            "residuals": residuals,
            "objects": objects,
            "expanded": interp.expanded + sum(o.expanded for o, _, _ in added),
            "message": f"{interp.message}; " + "; ".join(notes),
        }
    )


def _kept_choices(interp: Interpretation, chosen: dict[str, Preference]) -> dict[str, Preference]:
    """The preferences `chosen` that made `interp`, each keyed by the role its object has in
    `interp` (a reconstruction may find the objects in another order)."""
    out: dict[str, Preference] = {}
    for pref in chosen.values():
        obj = _matching(interp, pref.regions)
        if obj is not None:
            out[obj.role] = pref
    return out


# ---- what touching objects share (kb: 'touching ROLE share PATH', docs/language.md 3.14) ----
# Two objects touch where a face of one lies in a face of the other, facing it
# (`party.touching_faces`).


def touching(model: ReconstructedModel, a: str, b: str) -> bool:
    """True if the objects with roles `a` and `b` in `model` touch (`party.touching_faces`)."""
    return bool(touching_faces(model, a, b))


def _shared_paths(kb: KnowledgeBase, interp: Interpretation) -> dict[str, str]:
    """The paths (relative to a member object) that touching members of the goal's part role
    share, each with where the knowledge says so ('FILE:LINE')."""
    concept = kb.concepts.get(interp.goal)
    if concept is None or not interp.objects:
        return {}
    roles = {o.role.split("[", 1)[0] for o in interp.objects}
    return {s.path: f"{s.span.file}:{s.span.line}" for s in concept.shares if s.role in roles}


def _filler(interp: Interpretation, role: str) -> str | None:
    """The concept filling role path `role` in `interp` (None: no instance there)."""
    return next((i.concept for i in interp.instances if i.role == role), None)


def shared_choices(kb: KnowledgeBase, interp: Interpretation) -> dict[str, Preference]:
    """The ties the knowledge decides (``touching houses share body.roof``): an object tied
    at a shared path (``body.roof=GableRoof`` explains its evidence about as well) takes the
    choice of an object touching it whose choice there is decided — by the evidence (no tie
    there), or so by a neighbour of its own (along a terrace). Keyed by role, with the reason
    (`Preference.reason`); an object touching two decided neighbours of different choices
    takes neither."""
    paths = _shared_paths(kb, interp)
    model = interp.model
    if not paths or model is None:
        return {}
    decided: dict[tuple[str, str], str] = {}
    for o in interp.objects:
        for path in paths:
            filler = _filler(interp, f"{o.role}.{path}")
            if filler is not None and not any(t.startswith(path + "=") for t in o.ties):
                decided[(o.role, path)] = filler
    pairs = {
        (a.role, b.role)
        for a in interp.objects
        for b in interp.objects
        if a.role < b.role and touching(model, a.role, b.role)
    }
    near = {
        o.role: sorted({b for a, b in pairs if a == o.role} | {a for a, b in pairs if b == o.role})
        for o in interp.objects
    }
    out: dict[str, Preference] = {}
    grown = True
    while grown:  # along a terrace: a decided neighbour decides the next
        grown = False
        for o in interp.objects:
            for tie in o.ties:
                path, concept = tie.split("=", 1)
                if path not in paths or (o.role, path) in decided:
                    continue
                theirs = {decided[(n, path)] for n in near[o.role] if (n, path) in decided}
                if theirs != {concept}:
                    continue
                source = next(n for n in near[o.role] if decided.get((n, path)) == concept)
                decided[(o.role, path)] = concept
                done = out.get(o.role)
                choices = (done.choices if done is not None else frozenset()) | {tie}
                reason = (
                    f"the knowledge decided {tie}: touching {source} has it "
                    f"(touching objects share {path}, {paths[path]})"
                )
                out[o.role] = Preference(
                    frozenset(o.evidence),
                    choices,
                    f"{done.reason}; {reason}" if done is not None else reason,
                )
                grown = True
    return out


def confirmed_choices(kb: KnowledgeBase, interp: Interpretation) -> Interpretation:
    """`interp` with the ties the knowledge decides for the choice an object already made: an
    object whose touching objects' choices at a shared path are all its own (and one at
    least decided, by the evidence or so) no longer names its other choices there as ties;
    they go to `SceneObject.shared` (judged by `alike_doubts`), the message says why."""
    paths = _shared_paths(kb, interp)
    model = interp.model
    if not paths or model is None:
        return interp
    objects: list[SceneObject] = []
    changed = False
    for o in interp.objects:
        near = [n for n in interp.objects if n.role != o.role and touching(model, o.role, n.role)]
        ties, shared, why = list(o.ties), list(o.shared), []
        for path, where in paths.items():
            mine = _filler(interp, f"{o.role}.{path}")
            open_ = [t for t in ties if t.startswith(path + "=")]
            theirs = {_filler(interp, f"{n.role}.{path}") for n in near}
            settled = [n for n in near if not any(t.startswith(path + "=") for t in n.ties)]
            if mine is None or not open_ or theirs != {mine} or not settled:
                continue
            ties = [t for t in ties if t not in open_]
            shared.append(f"{path}={mine}")
            why.append(
                f"the knowledge decided {path}={mine} over {', '.join(open_)}: touching "
                f"{', '.join(n.role for n in near)} have it (touching objects share {path}, "
                f"{where})"
            )
        if why:
            changed = True
            o = o.model_copy(
                update={"ties": ties, "shared": shared, "message": f"{o.message}; {'; '.join(why)}"}
            )
        objects.append(o)
    if not changed:
        return interp
    return interp.model_copy(update={"objects": objects})


def alike_doubts(
    kb: KnowledgeBase, interp: Interpretation, objects: list[SceneObject]
) -> list[SceneObject]:
    """`objects` (judged, of `interp`'s model) with the doubts of what touching objects share:
    two touching objects filled otherwise at a shared path are both doubtful (the knowledge
    says they are alike), and a choice the knowledge took from a touching object
    (`SceneObject.shared`) stands only on a verified neighbour that made it from its own
    evidence."""
    paths = _shared_paths(kb, interp)
    model = interp.model
    if not paths or model is None:
        return objects
    by_role = {o.role: o for o in objects}
    extra: dict[str, list[str]] = {o.role: [] for o in objects}
    for a in objects:
        for b in objects:
            if a.role == b.role or not touching(model, a.role, b.role):
                continue
            for path, where in paths.items():
                fa, fb = _filler(interp, f"{a.role}.{path}"), _filler(interp, f"{b.role}.{path}")
                if fa is not None and fb is not None and fa != fb:
                    extra[a.role].append(
                        f"{path} is a {fa}, but touching {b.role}'s is a {fb}: the knowledge "
                        f"says touching objects share it ({where})"
                    )
    for o in objects:
        for choice in o.shared:
            path, concept = choice.split("=", 1)
            if not any(
                n.verdict == VERIFIED
                and _filler(interp, f"{n.role}.{path}") == concept
                and choice not in n.shared
                and touching(model, o.role, n.role)
                for n in objects
                if n.role != o.role
            ):
                extra[o.role].append(
                    f"{choice} was taken from a touching object (the evidence leaves it open), "
                    "and no touching object verified on its own evidence has it"
                )
    return [
        by_role[o.role].model_copy(
            update={"verdict": DOUBTFUL, "doubts": [*o.doubts, *extra[o.role]]}
        )
        if extra[o.role]
        else o
        for o in objects
    ]


def _every_view(kb: KnowledgeBase, evidence: Evidence, interp: Interpretation) -> Interpretation:
    """`interp`, its objects judged again on every view (`judge_objects`) where the model has
    no camera for a view of the evidence and an object is verified: a reconstruction that
    returned before judging them so (a refinement skipped) must not leave an object verified
    without the views it left out."""
    if not interp.objects or interp.model is None:
        return interp
    cameras = {c.view for c in interp.model.cameras}
    if all(v.id in cameras for v in evidence.views):
        return interp
    if all(o.verdict != VERIFIED for o in interp.objects):
        return interp
    return judge_objects(kb, interp, evidence)


def _keeps(first: Interpretation, again: Interpretation) -> bool:
    """True if `again` has every object of `first` (one sharing regions with it): a choice
    taken for one object must not lose another."""
    return all(_matching(again, frozenset(o.evidence)) is not None for o in first.objects)


def _object_uncertainty(whole: Uncertainty, role: str) -> Uncertainty:
    """The scene adjustment's deviations as one object's (`role`): its parts and the parts of
    it a region lies on, roles relative to it, and every camera. (The parts a region lies on
    were once left the scene's: every object's verdict then named every other object's parts,
    by their scene roles, as parts whose normal the adjustment leaves open.)"""
    prefix = role + "."
    parts = {_strip(role, r): sd for r, sd in whole.parts.items() if r.startswith(prefix)}
    on_regions = frozenset(_strip(role, r) for r in whole.on_regions if r.startswith(prefix))
    return replace(whole, parts=parts, on_regions=on_regions)


# ---- judging a scene of several objects against its truth (tests and benchmarks) ------------
def _object_of(role: str, members_role: str) -> str | None:
    """The object a role path belongs to ('houses[1]' of 'houses[1].body.front'), or None."""
    head = role.split(".", 1)[0]
    return head if head.startswith(f"{members_role}[") else None


def evaluate_scene(
    interp: Interpretation, truth: SceneTruth, members_role: str
) -> list[dict[str, object]]:
    """Every true object of `truth` against the reconstructed object paired with it.

    Objects are roles ``MEMBERS[K]`` (`members_role`) in the truth's part roles and in the
    result's. A reconstructed object is paired with the true one whose faces its model's
    vertices lie nearest (mean distance to the nearest true vertex); each true object takes
    at most one reconstructed object. Returns one row per true object (its role, the paired
    object or None, `evaluate.evaluate`'s figures of the pair) and one per reconstructed
    object paired with no true one ('invented') or with a true object already taken
    ('twice').
    """
    from aida_kb.interpret.evaluate import evaluate

    true_roles = sorted({o for p in truth.parts if (o := _object_of(p.role, members_role))})
    model = interp.model
    found = [o.role for o in interp.objects]
    verdicts = {o.role: o for o in interp.objects}

    def vertices(
        role: str, parts: list[tuple[str, list[tuple[float, float, float]]]]
    ) -> FloatArray:
        pts = [v for r, poly in parts if _object_of(r, members_role) == role for v in poly]
        return np.asarray(pts, dtype=np.float64).reshape(-1, 3)

    true_parts = [(p.role, p.polygon) for p in truth.parts]
    mine = [] if model is None else [(p.role, p.polygon) for p in model.parts]
    distance = np.full((len(found), len(true_roles)), np.inf)
    for i, f in enumerate(found):
        a = vertices(f, mine)
        for j, t in enumerate(true_roles):
            b = vertices(t, true_parts)
            if len(a) and len(b):
                distance[i, j] = float(
                    np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2).min(axis=1).mean()
                )
    pairs: dict[str, str] = {}  # true -> found
    rows: list[dict[str, object]] = []
    for i in np.argsort(distance.min(axis=1) if len(true_roles) else np.zeros(len(found))):
        f = found[int(i)]
        j = int(np.argmin(distance[i])) if len(true_roles) else -1
        if j < 0 or not np.isfinite(distance[i, j]):
            rows.append({"object": f, "truth": None, "status": "invented"})
            continue
        t = true_roles[j]
        size = vertices(t, true_parts)
        diag = float(np.linalg.norm(size.max(axis=0) - size.min(axis=0)))
        if distance[i, j] > 0.25 * diag:
            rows.append({"object": f, "truth": None, "status": "invented"})
        elif t in pairs:
            rows.append({"object": f, "truth": t, "status": "twice"})
        else:
            pairs[t] = f
    for t in true_roles:
        f_role = pairs.get(t)
        sub_truth = _sub_truth(truth, t)
        if f_role is None or model is None:
            rows.append({"truth": t, "object": None, "status": "missed", "correct": False})
            continue
        sub = _sub_interpretation(interp, f_role, verdicts[f_role])
        result = evaluate(sub, sub_truth, goal=sub.goal)
        rows.append({"truth": t, "object": f_role, "status": "found", **result.summary()})
    return rows


def _strip(prefix: str, role: str) -> str:
    return role[len(prefix) + 1 :] if role.startswith(prefix + ".") else ""


def _sub_truth(truth: SceneTruth, role: str) -> SceneTruth:
    """The truth of one object: its parts and concepts, role paths relative to it."""
    parts = [
        p.model_copy(update={"role": _strip(role, p.role)})
        for p in truth.parts
        if p.role.startswith(role + ".")
    ]
    concepts = {_strip(role, r): c for r, c in truth.concepts.items() if r.startswith(role + ".")}
    concept = str(truth.parameters.get(f"{role}.concept", "")) or _MEMBER_CONCEPT
    return truth.model_copy(update={"parts": parts, "concepts": concepts, "object": concept})


_MEMBER_CONCEPT = "member"  # a sub-truth's object when the truth does not name it


def _sub_interpretation(interp: Interpretation, role: str, obj: SceneObject) -> Interpretation:
    """One object of a scene's result as an interpretation of its own, roles relative to it."""
    model = interp.model
    assert model is not None
    parts = [
        p.model_copy(update={"role": _strip(role, p.role)})
        for p in model.parts
        if p.role.startswith(role + ".")
    ]
    instances = [
        i.model_copy(update={"role": _strip(role, i.role)})
        for i in interp.instances
        if i.role.startswith(role + ".") or i.role == role
    ]
    return Interpretation(
        goal=_MEMBER_CONCEPT,
        accepted=True,
        message=obj.message,
        instances=instances,
        model=model.model_copy(update={"parts": parts}),
        expanded=obj.expanded,
        verdict=obj.verdict,
        doubts=obj.doubts,
        ties=obj.ties,
    )
