"""Objects the first view does not show.

A house hidden behind another in the first view (street 62602: only a strip of its roof
shows there) is found in no round of `interpret_scene`, which looks at the first view alone.
Once the later views are registered, each one's evidence is searched the same way for more
objects: its regions lying on the faces of the objects found so far (`on_faces`, the model
moved into that view's camera frame by its registered pose) count as explained, the rounds of
`find_objects` run on the rest, and an object they find is moved back into the world frame
by the view's pose, joins the scene under the next index of the role, and every object is
judged again on all views (`judge_objects`). Its geometry is that view's own interpretation
(not adjusted jointly with the others); the verdict judges it on every view like the rest.
A view whose registered pose its own stereo does not bear out (`_pose_confirmed`) is not
searched: what it shows would be moved to where that pose puts it.
Cost: one more set of rounds per registered later view, on the regions its objects leave.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import view_of
from aida_kb.interpret.result import (
    Interpretation,
)
from aida_kb.interpret.verdict import (
    DOUBTFUL,
)
from aida_kb.interpret.verdict.judge import confirms
from aida_kb.interpret.verdict.views import check_view
from aida_kb.io.evidence import Evidence, ViewEvidence
from aida_kb.io.model import ModelPart, ReconstructedModel, moved_part

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase

from aida_kb.interpret.scene.faces import on_faces
from aida_kb.interpret.scene.judging import judge_objects
from aida_kb.interpret.scene.members import Members, members
from aida_kb.interpret.scene.roles import SceneParts
from aida_kb.interpret.scene.rounds import MAX_OBJECTS, find_objects

FloatArray = npt.NDArray[np.float64]


def later_view_objects(
    kb: KnowledgeBase,
    evidence: Evidence,
    interp: Interpretation,
    *,
    source: str = "",
    progress: Callable[[str], None] | None = None,
) -> Interpretation:
    """`interp` (a scene of several objects, its later views registered) with the objects the
    later views show and the first does not (the module docstring); `interp` itself when there
    are none, the role is full, or the evidence's first view is not at the world's origin."""
    from aida_kb.interpret.multiview import (  # it builds on this module
        REGISTERED_EXPLAINED_MIN,
        first_view_swapped,
    )

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
    skipped: list[str] = []
    for later in evidence.views[1:]:
        camera = cameras.get(later.id)
        if camera is None or room <= len(added):
            continue
        if not _pose_confirmed(later, model):
            skipped.append(
                f"view {later.id} not searched for more {slot.concept}: at its camera the "
                f"model explains less than {100 * REGISTERED_EXPLAINED_MIN:.0f}% of its "
                "region weight inside its projection (an object found there would stand where "
                "that pose puts it)"
            )
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
    if skipped:
        interp = interp.model_copy(update={"message": f"{interp.message}; " + "; ".join(skipped)})
    if not added:
        return interp
    return judge_objects(kb, _joined(interp, slot, added), evidence)


def _pose_confirmed(view: ViewEvidence, model: ReconstructedModel) -> bool:
    """True if the scene's `model`, at the camera it gave `view`, explains at least
    `multiview.REGISTERED_EXPLAINED_MIN` of the view's region weight inside its projection
    (`verdict.views.check_view`), covering some of its regions and showing an edge
    (`verdict.judge.confirms`), or the view has no region to check by: the view's own stereo
    bears its pose out. The registration keeps a pose no rival turn explains better even where
    it explains little (dev street 66104: view 01 at 0 %, its camera 7 m off); an object found
    in such a view, moved into the world by that pose, stood where nothing is (a 44 m house
    above the terrace)."""
    from aida_kb.interpret.multiview import REGISTERED_EXPLAINED_MIN

    check = check_view(view, model)
    if check is None:
        return True
    return confirms(check, view) and check.explained_share >= REGISTERED_EXPLAINED_MIN


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
    scene = SceneParts(
        list(interp.instances),
        list(interp.model.parts),
        list(interp.trace),
        list(interp.residuals),
        list(interp.objects),
    )
    notes = []
    for one, own, view in added:
        prefix = scene.add(
            slot.role,
            slot.concept,
            one,
            own,
            verdict=DOUBTFUL,
            message=f"{one.message} (found in view {view})",
        )
        notes.append(f"{prefix} found in view {view}, which the first view does not show")
    model = interp.model.model_copy(update={"parts": scene.parts})
    return interp.model_copy(
        update={
            "instances": scene.instances,
            "model": model,
            "trace": scene.trace,
            "residuals": scene.residuals,
            "objects": scene.objects,
            "expanded": interp.expanded + sum(o.expanded for o, _, _ in added),
            "message": f"{interp.message}; " + "; ".join(notes),
        }
    )
