"""What touching objects share (kb: 'touching ROLE share PATH', docs/language.md 3.14).

Two objects touch where a face of one lies in a face of the other, facing it
(`party.touching_faces`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aida_kb.interpret.party import touching_faces
from aida_kb.interpret.result import (
    Interpretation,
    SceneObject,
)
from aida_kb.interpret.verdict import (
    DOUBTFUL,
    VERIFIED,
)
from aida_kb.io.model import ReconstructedModel

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase

from aida_kb.interpret.scene.members import Preference


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
