"""Role paths of one object within a scene's result: an object's parts, instances, trace and
residuals moved under its role (``houses[1].body.front``), and back (roles relative to it).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace

from aida_kb.interpret.result import (
    HypothesisTrace,
    Instance,
    Interpretation,
    SceneObject,
)
from aida_kb.interpret.uncertainty import Uncertainty
from aida_kb.io.model import ModelPart
from aida_kb.io.scene import SceneTruth
from aida_kb.solve import ConstraintResidual


def under(prefix: str, role: str) -> str:
    """Role path `role` of an object as a role of the scene, the object being `prefix`."""
    return prefix if not role else f"{prefix}.{role}"


def prefixed(
    prefix: str, interp: Interpretation, offset: int
) -> tuple[list[Instance], list[ModelPart], list[HypothesisTrace], list[ConstraintResidual]]:
    """An object's instances, model parts, trace and residuals under its role `prefix` in the
    scene; its hypotheses' ids moved by `offset` (the scene's trace is one list)."""
    instances = [
        inst.model_copy(
            update={
                "role": under(prefix, inst.role),
                "parent": "" if inst.parent is None else under(prefix, inst.parent),
                "link": "part-of" if inst.link == "goal" else inst.link,
            }
        )
        for inst in interp.instances
    ]
    model = interp.model
    parts = (
        []
        if model is None
        else [p.model_copy(update={"role": under(prefix, p.role)}) for p in model.parts]
    )
    trace = [
        h.model_copy(
            update={
                "id": h.id + offset,
                "parent": None if h.parent is None else h.parent + offset,
                "role": under(prefix, h.role),
            }
        )
        for h in interp.trace
    ]
    residuals = [
        r.model_copy(
            update={
                "owner": under(prefix, r.owner),
                "parts": tuple(under(prefix, p) for p in r.parts),
            }
        )
        for r in interp.residuals
    ]
    return instances, parts, trace, residuals


def object_uncertainty(whole: Uncertainty, role: str) -> Uncertainty:
    """The scene adjustment's deviations as one object's (`role`): its parts and the parts of
    it a region lies on, roles relative to it, and every camera. (The parts a region lies on
    were once left the scene's: every object's verdict then named every other object's parts,
    by their scene roles, as parts whose normal the adjustment leaves open.)"""
    prefix = role + "."
    parts = {relative_role(role, r): sd for r, sd in whole.parts.items() if r.startswith(prefix)}
    on_regions = frozenset(relative_role(role, r) for r in whole.on_regions if r.startswith(prefix))
    return replace(whole, parts=parts, on_regions=on_regions)


# ---- judging a scene of several objects against its truth (tests and benchmarks) ------------
def object_of(role: str, members_role: str) -> str | None:
    """The object a role path belongs to ('houses[1]' of 'houses[1].body.front'), or None."""
    head = role.split(".", 1)[0]
    return head if head.startswith(f"{members_role}[") else None


def relative_role(prefix: str, role: str) -> str:
    return role[len(prefix) + 1 :] if role.startswith(prefix + ".") else ""


def object_truth(truth: SceneTruth, role: str) -> SceneTruth:
    """The truth of one object: its parts and concepts, role paths relative to it."""
    parts = [
        p.model_copy(update={"role": relative_role(role, p.role)})
        for p in truth.parts
        if p.role.startswith(role + ".")
    ]
    concepts = {
        relative_role(role, r): c for r, c in truth.concepts.items() if r.startswith(role + ".")
    }
    concept = str(truth.parameters.get(f"{role}.concept", "")) or MEMBER_CONCEPT
    return truth.model_copy(update={"parts": parts, "concepts": concepts, "object": concept})


MEMBER_CONCEPT = "member"  # a sub-truth's object when the truth does not name it


def object_interpretation(interp: Interpretation, role: str, obj: SceneObject) -> Interpretation:
    """One object of a scene's result as an interpretation of its own, roles relative to it."""
    model = interp.model
    assert model is not None
    parts = [
        p.model_copy(update={"role": relative_role(role, p.role)})
        for p in model.parts
        if p.role.startswith(role + ".")
    ]
    instances = [
        i.model_copy(update={"role": relative_role(role, i.role)})
        for i in interp.instances
        if i.role.startswith(role + ".") or i.role == role
    ]
    return Interpretation(
        goal=MEMBER_CONCEPT,
        accepted=True,
        message=obj.message,
        instances=instances,
        model=model.model_copy(update={"parts": parts}),
        expanded=obj.expanded,
        verdict=obj.verdict,
        doubts=obj.doubts,
        ties=obj.ties,
    )


@dataclass
class SceneParts:
    """A scene's result built object by object: each object's instances, model parts, trace
    and residuals under its role (`prefixed`), and the objects."""

    instances: list[Instance] = field(default_factory=list)
    parts: list[ModelPart] = field(default_factory=list)
    trace: list[HypothesisTrace] = field(default_factory=list)
    residuals: list[ConstraintResidual] = field(default_factory=list)
    objects: list[SceneObject] = field(default_factory=list)

    def add(
        self,
        role: str,
        concept: str,
        one: Interpretation,
        evidence: Iterable[str],
        *,
        verdict: str,
        message: str,
        doubts: Sequence[str] = (),
        shared: Sequence[str] = (),
    ) -> str:
        """Add the object `one` (its own result, roles relative to it) under the next index of
        the scene role `role`; returns its role in the scene (``houses[2]``)."""
        prefix = f"{role}[{len(self.objects)}]"
        inst, faces, steps, rows = prefixed(prefix, one, len(self.trace))
        self.instances += inst
        self.parts += faces
        self.trace += steps
        self.residuals += rows
        self.objects.append(
            SceneObject(
                role=prefix,
                concept=concept,
                verdict=verdict,
                doubts=list(doubts),
                message=message,
                cost=one.cost,
                expanded=one.expanded,
                evidence=sorted(evidence),
                ties=list(one.ties),
                shared=list(shared),
            )
        )
        return prefix
