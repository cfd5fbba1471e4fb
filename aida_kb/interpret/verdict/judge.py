"""The verdict itself: every check in order, each failure a reason."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.result import INSERTED, Interpretation
from aida_kb.interpret.uncertainty import Uncertainty, adjustment_uncertainty
from aida_kb.interpret.verdict.attributes import (
    check_attributes,
    check_orientations,
    evidence_ground,
)
from aida_kb.interpret.verdict.cameras import camera_doubts
from aida_kb.interpret.verdict.edges import edge_cover
from aida_kb.interpret.verdict.filled import unfilled
from aida_kb.interpret.verdict.measured import unmeasured_roles
from aida_kb.interpret.verdict.normals import loose_normals
from aida_kb.interpret.verdict.outcome import DOUBTFUL, NOTHING, VERIFIED, Verdict, ViewCheck
from aida_kb.interpret.verdict.tolerances import (
    CONTRADICTION_MAX,
    EDGE_COVER_MIN,
    EDGE_MIN_LENGTH_PX,
    EDGE_TOLERANCE_PX,
    EXPLAINED_MIN,
    NEAR_EXPLAINED_MIN,
    SEEN_EDGE_COVER_MIN,
    SIZE_UNIT,
    STANDING_OUT_SHARE_MAX,
)
from aida_kb.interpret.verdict.views import adjoining, check_view, unexplained_near
from aida_kb.io.evidence import Evidence, ViewEvidence
from aida_kb.io.model import ModelPart, ReconstructedModel
from aida_kb.kb.model import KnowledgeBase


def confirms(check: ViewCheck | None, view: ViewEvidence) -> bool:
    """True if `check` (a registered view at the camera the reconstruction gave it) finds the
    model in the view's evidence: the model covers some of its regions and shows an edge (or
    the view has no segments). A camera where it covers no region or shows no edge is
    confirmed by nothing there (a registration 100 degrees off passes every other check for
    want of evidence), and neither is the object. None (no region of the view has a plane):
    its registration, by the view's edges, is all there is to go by."""
    if check is None:
        return True
    return check.inside_weight > 0 and (check.edge_cover is not None or not view.lines)


def unconfirmed(
    evidence: Evidence, model: ReconstructedModel, checks: Sequence[ViewCheck] = ()
) -> str | None:
    """The reason why no other view confirms the model, or None: the evidence has views
    besides the one interpreted (the first) and none of them confirms it — the reconstruction
    registered none (the model's edges matched in no other image), or the model, at the
    cameras it gave them, covers none of their regions or shows none of their edges
    (`confirms`; `checks`: the views' checks, by view id). An object that stands there would
    be found from 20-45 degrees further round; development scenes: 2 of 57 houses seen in
    several views (both doubtful for other reasons), and every object-less scene accepted in
    one view. Dev clutter scene 65033: a tree's crown, view 01 not registered, view 02's camera
    kept where the crown covers none of its regions (doubtful before, now nothing)."""
    first = evidence.views[0].id
    others = list(evidence.views[1:])
    cameras = {c.view for c in model.cameras}
    if not others or first not in cameras:
        return None
    by_view = {c.view: c for c in checks}
    registered = [v for v in others if v.id in cameras]
    if any(confirms(by_view.get(v.id), v) for v in registered):
        return None
    names = ", ".join(v.id for v in others)
    if not registered:
        return (
            f"seen in view {first} alone: none of the other views ({names}) could be "
            "registered to the model (no other view confirms the object)"
        )
    why = [
        f"at view {v.id}'s camera the model covers none of its regions or shows none of its edges"
        if v.id in cameras
        else f"view {v.id} could not be registered"
        for v in others
    ]
    return (
        f"seen in view {first} alone: no other view ({names}) confirms the object "
        f"({'; '.join(why)})"
    )


def _bound_parts(interp: Interpretation) -> set[str]:
    """Roles of the parts bound to evidence: an instance bound to regions, or the whole
    its bound con-of realisation (the region) hangs on."""
    out = set()
    for inst in interp.instances:
        if not inst.bindings or INSERTED in inst.bindings:
            continue
        out.add(inst.parent if inst.link == "con-of" and inst.parent is not None else inst.role)
    return out


def _bound_regions(interp: Interpretation, view: str) -> frozenset[int]:
    """Ids of the regions of `view` the interpretation binds to its parts."""
    out = set()
    for inst in interp.instances:
        for b in inst.bindings:
            head, _, tail = b.partition("/")
            if head == view and tail.isdigit():
                out.add(int(tail))
    return frozenset(out)


def judge(
    kb: KnowledgeBase,
    interp: Interpretation,
    evidence: Evidence,
    *,
    all_views: bool = False,
    uncertainty: Uncertainty | None = None,
    images: Mapping[str, npt.NDArray[np.uint8]] | None = None,
    occluders: Sequence[ModelPart] = (),
) -> Verdict:
    """The verdict on `interp` (see the module docstring). all_views: the result stands for
    every view of the evidence (a reconstruction registers them all), so a view it left
    without a camera is doubted; `aida-kb interpret` uses the world-frame views only.
    uncertainty: the adjustment's, where `interp` is one object of a scene adjusted as a whole
    (`interpret.scene.judge_objects`: the cameras are fixed by every object); None: that of
    `interp` alone. images: view id -> its left image (8-bit grey, as taken), where the scene's
    images are at hand: an edge the image steps across is seen, segment or not (check (c),
    `verdict.edges.edge_coverage`). occluders: where `interp` is one object of a scene, the
    other objects' faces (scene roles): they hide its edges behind them, and a party wall's
    flush edges are no edges in the image (check (c))."""
    images = images or {}
    model = interp.model
    if not interp.accepted or model is None:
        return Verdict(NOTHING, (), (), ())
    if interp.objects:  # a scene of several objects: each was judged alone (interpret.scene)
        return Verdict(interp.verdict or NOTHING, tuple(interp.doubts), (), ())
    reasons: list[str] = []
    if uncertainty is None:
        uncertainty = adjustment_uncertainty(kb, interp, evidence)
    # (a) every constraint of the knowledge (and every prior) under its threshold; the
    # evidence's own factors of a multi-view adjustment (segments, regions: robust, made by
    # code, rule "evidence") are judged by (b) and (c), not one by one — a stray region or
    # segment is an outlier there, not a contradiction of the knowledge
    for r in interp.residuals:
        if r.rejected and r.rule != "evidence":
            reasons.append(
                f"constraint {r.label} ({r.kind}, {', '.join(r.parts)}) over its threshold: "
                f"cost {r.normalised_cost:.3g} of {r.threshold:.3g}"
            )
    # (b), (c) every view's evidence explained
    checks = []
    not_explained = []
    cameras = {c.view for c in model.cameras}
    for view in evidence.views:
        check = check_view(view, model, images.get(view.id), occluders)
        if check is None:
            if view.id in cameras or all_views:
                not_explained.append(view.id)
            if view.id in cameras:  # a camera, but none of its regions has a plane
                reasons.append(f"view {view.id}: no region of it has a plane to check the model by")
            elif all_views:  # left out by the reconstruction: where it was taken from is unknown
                reasons.append(f"view {view.id}: not registered (the model has no camera for it)")
            continue
        checks.append(check)
        problems = []
        # the model, seen by the camera the reconstruction gave this view, covers none of its
        # regions or shows none of its edges: nothing confirms that camera (a registration
        # 100 degrees off lands here; every check below would pass for want of evidence)
        if check.inside_weight <= 0:
            problems.append("covers none of its regions")
        if check.edge_cover is None and view.lines:
            problems.append(f"shows no edge of at least {EDGE_MIN_LENGTH_PX:g} px")
        if check.explained_share < EXPLAINED_MIN:
            problems.append(
                f"explains {100 * check.explained_share:.0f}% of the region weight inside "
                f"its projection (at least {100 * EXPLAINED_MIN:.0f}%)"
            )
        if check.edge_cover is not None and check.edge_cover < EDGE_COVER_MIN:
            problems.append(
                f"edges are seen along {100 * check.edge_cover:.0f}% of their length "
                f"(at least {100 * EDGE_COVER_MIN:.0f}%: segments within {EDGE_TOLERANCE_PX:g} "
                "px, or a steady step across them)"
            )
        if view.id != evidence.views[0].id and check.inside_weight > 0:
            # a registered view: the adjustment fixes its camera to what is asked of it
            problems += camera_doubts(view.id, model, uncertainty)
        standing = check.standing_out_weight / check.inside_weight if check.inside_weight else 0.0
        if standing > STANDING_OUT_SHARE_MAX:
            problems.append(
                f"leaves regions carrying {100 * standing:.0f}% of the weight standing out of "
                f"its surface, parallel to it (at most {100 * STANDING_OUT_SHARE_MAX:.0f}%: a part "
                "the model lacks)"
            )
        worst = check.contradicting[0] if check.contradicting else None
        if worst is not None and worst[1] > CONTRADICTION_MAX:
            problems.append(
                f"region {view.id}/{worst[0]} ({100 * worst[1]:.0f}% of the weight) is {worst[2]}"
            )
        if problems:
            not_explained.append(view.id)
            reasons.append(f"view {view.id}: the model " + "; ".join(problems))
    # (c) in the interpreted view, the edges between parts bound to its evidence are seen
    reference = evidence.views[0]
    bound = _bound_parts(interp)
    outlines = _bound_regions(interp, reference.id)
    seen = (
        edge_cover(
            reference, model, frozenset(bound), outlines, images.get(reference.id), occluders
        )
        if len(bound) > 1
        else None
    )
    if seen is not None and seen < SEEN_EDGE_COVER_MIN:
        reasons.append(
            f"view {reference.id}: the edges between the parts bound to its evidence are seen "
            f"along {100 * seen:.0f}% of their length (at least {100 * SEEN_EDGE_COVER_MIN:.0f}%)"
        )
    # an object whose sizes the knowledge's ranges exclude is not the goal at all (a 0.3 m
    # box, a chessboard on a stand): nothing is found, and the sizes say why
    metric = evidence.units == "m"
    ground = evidence_ground(kb, interp, model, evidence)
    sizes = check_attributes(kb, interp, model, unit=SIZE_UNIT, metric=metric, ground=ground)
    if sizes:
        return Verdict(NOTHING, tuple(sizes), tuple(not_explained), tuple(checks), uncertainty)
    # an object no other view confirms: the scene has other views, and none of them could be
    # registered to the model (its edges are nowhere in those images), or the model covers
    # none of their regions where it put their cameras — what one view took for the object is
    # not there as the model has it (a tree's box-shaped crown taken for a small house)
    alone = unconfirmed(evidence, model, checks) if all_views else None
    if alone is not None:
        return Verdict(NOTHING, (alone,), tuple(not_explained), tuple(checks), uncertainty)
    # (f) no large surface joined to the model that the model does not explain
    by_id = {v.id: v for v in evidence.views}
    for check in checks:
        reasons += adjoining(by_id[check.view], model, check)
    # (g) the surfaces on the model and near it are mostly the model's
    for check in checks:
        share, left = unexplained_near(by_id[check.view], model, check)
        if share < NEAR_EXPLAINED_MIN:
            shown = ", ".join(f"{check.view}/{i}" for i in left[:3])
            reasons.append(
                f"view {check.view}: the model explains {100 * share:.0f}% of the region "
                f"weight on it and near it (at least {100 * NEAR_EXPLAINED_MIN:.0f}%): "
                f"regions {shown} near it are not its surfaces"
            )
    # (j) every face a view sees is there (not the surface behind it), and no region on a
    # face goes on far beyond it (a shed where the view shows a gable's whole end wall)
    for check in checks:
        reasons += unfilled(by_id[check.view], model, check.explained_ids)
    # (e) every part inserted from knowledge is measured by some evidence
    reasons += unmeasured_roles(interp, evidence, tuple(checks), kb, uncertainty).values()
    # (i) every part a region measures has its normal fixed to the accuracy asked of it
    reasons += loose_normals(uncertainty)
    # (d) the knowledge's measured attributes
    reasons += check_attributes(kb, interp, model, metric=metric, ground=ground)
    reasons += check_orientations(kb, interp, model)
    reasons += undecided(interp)
    verdict = DOUBTFUL if reasons else VERIFIED
    return Verdict(verdict, tuple(reasons), tuple(not_explained), tuple(checks), uncertainty)


def undecided(interp: Interpretation) -> list[str]:
    """The choices along is-a the evidence does not decide (`Interpretation.ties`, from the
    interpreter: another specialisation explains the same evidence about as well)."""
    return [
        f"the evidence does not decide {tie.split('=')[0]}: {tie} explains it about as well"
        for tie in interp.ties
    ]
