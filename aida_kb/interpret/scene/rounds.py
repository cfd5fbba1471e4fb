"""The rounds of a scene's search: each finds one object on the evidence the objects found
before leave (the package docstring states the contract and its cost).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.assign import vertical
from aida_kb.interpret.context import Context
from aida_kb.interpret.hypotheses import CONE_WINDOW_DEG, front_region
from aida_kb.interpret.interpreter import SAME_FRAME_COS, TIE_MARGIN, Interpreter, Level, State
from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import EvidenceView, RegionView, view_of
from aida_kb.interpret.result import (
    INSERTED,
    Instance,
    Interpretation,
)
from aida_kb.interpret.run import interpretation_of
from aida_kb.interpret.verdict import (
    DOUBTFUL,
    NOTHING,
    VERIFIED,
    judge,
    with_verdict,
)
from aida_kb.io.evidence import Evidence
from aida_kb.io.model import ModelObject, ReconstructedModel
from aida_kb.io.subset import without_regions

if TYPE_CHECKING:
    from aida_kb.interpret.party import StereoDepth
    from aida_kb.kb.model import KnowledgeBase

from aida_kb.interpret.scene.faces import on_faces
from aida_kb.interpret.scene.members import Members, Preference, members
from aida_kb.interpret.scene.roles import SceneParts
from aida_kb.interpret.scene.shared import alike_doubts

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


def scene_evidence_of(
    kb: KnowledgeBase, evidence: Evidence, goal: str | None, depth: StereoDepth | None = None
) -> Evidence:
    """The evidence a goal is interpreted on: for a goal holding several objects (`members`),
    the reference view's regions split at the party walls it shows (`party.split_terraces`:
    a terrace's touching houses, merged by the segmentation; with the reference view's stereo
    `depth`, each piece on its own plane); for one object, `evidence`."""
    from aida_kb.interpret.party import split_terraces
    from aida_kb.interpret.run import check_goal

    slot = members(Knowledge.from_kb(kb), check_goal(kb, goal))
    return evidence if slot is None else split_terraces(evidence, depth)


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


def _bound(interp: Interpretation) -> set[str]:
    """The region ids an interpretation binds."""
    return {b for inst in interp.instances for b in inst.bindings if b != INSERTED}


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
    scene = SceneParts(
        instances=[Instance(role="", concept=goal, instance_of=goal, parent=None, link="goal")]
    )
    dropped: list[str] = []
    for one, own in found:
        others = set().union(*(o for other, o in found if other is not one))
        verdict = judge(kb, one, without_regions(evidence, others))
        judged = with_verdict(one, verdict)
        if verdict.verdict == NOTHING:
            dropped.append(judged.message)
            continue
        scene.add(
            slot.role,
            slot.concept,
            judged,
            own,
            verdict=DOUBTFUL if verdict.verdict == DOUBTFUL else VERIFIED,
            message=judged.message,
            doubts=verdict.reasons,
            shared=taken.get(id(one), []),
        )
    instances, parts, objects = scene.instances, scene.parts, scene.objects
    trace, residuals = scene.trace, scene.residuals
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


def preferred(
    interpreter: Interpreter, state: State, wanted: frozenset[str]
) -> tuple[State, tuple[str, ...]] | None:
    """The accepted `state` with its body replaced by the cheapest tied body making the
    choices `wanted` (a body `Interpreter.ties` names: the same regions bound in the same
    frame, its cost within `interpreter.TIE_MARGIN`), and the choices given up for them; None
    when no tied body makes them (the evidence of the interpreted view decides against).

    The later levels (wings, oriels) were verified against the accepted body and hold its
    planes fixed: a tied body that lacks one of them (a gable roof for the flat roof a wing
    was fitted under) cannot take its place under them (held-out street 64103, session 20:
    the joined state named a fixed ``body.roof.top`` no level had, and the scene stopped)."""
    if not state.levels or not wanted <= set(interpreter.ties(state)):
        return None
    body = state.levels[0]
    later_own = {p.role for lv in state.levels[1:] for p in lv.verification.planes if not p.fixed}
    held = {
        p.role for lv in state.levels[1:] for p in lv.verification.planes if p.fixed
    } - later_own
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
        if not held <= {p.role for p in level.verification.planes if not p.fixed}:
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
