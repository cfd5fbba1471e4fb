"""The result of an interpretation, ``interpretation.json`` (pydantic).

An interpretation holds the instances the search created (each with its role path, its
prototype by instance-of, and the evidence it is bound to), the reconstructed model, the
residual report of every constraint the accepted interpretation instantiated (rows of
`aida_kb.solve.ConstraintResidual`, each with its ``.kb`` line), and the trace
of every hypothesis the search created, verified or rejected. Coordinates are world
coordinates (left camera of view 00, OpenCV axes), metres.
"""

from __future__ import annotations

import os
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from aida_kb.diagnostics.core import Span
from aida_kb.io.jsonio import read_json_model, write_json_model
from aida_kb.io.model import FiniteCost, ReconstructedModel
from aida_kb.solve import ConstraintResidual

INSERTED = "inserted"
"""The binding of a part the views cannot see: inserted from the knowledge base."""


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Instance(_Frozen):
    """One instance node: a concept instantiated for a role of the scene object."""

    role: str = Field(description="role path from the scene object; '' for the goal itself")
    concept: str = Field(description="the concept of the instance (after is-a specialisation)")
    instance_of: str = Field(description="the prototype concept in the knowledge base")
    parent: str | None = Field(description="role path of the instance this one is part of")
    link: Literal["goal", "con-of", "part-of"] = Field(description="how it hangs on its parent")
    bindings: list[str] = Field(
        default_factory=list,
        description="evidence ids ('VIEW/REGION') of a planar part, or ['inserted']",
    )


HypothesisStatus = Literal["created", "verified", "rejected"]


class HypothesisTrace(_Frozen):
    """One hypothesis of the search and what became of it."""

    id: int = Field(ge=0)
    parent: int | None = Field(description="the hypothesis it was created under")
    concept: str
    role: str = Field(description="role path of the hypothesised instance")
    status: HypothesisStatus
    step: int = Field(ge=0, description="search step (expansion count) when last changed")
    reason: str = Field(default="", description="why it was rejected or what verified it")
    constraint: str | None = Field(default=None, description="label of the rejecting constraint")
    span: Span | None = Field(
        default=None, description="the rejecting constraint's .kb declaration (None if none)"
    )
    cost: FiniteCost | None = Field(
        default=None, description="the normalised cost of that constraint (residual report)"
    )


class SceneObject(_Frozen):
    """One object of a scene of several (`aida_kb.interpret.scene`), with its own verdict."""

    role: str = Field(description="its role path in the scene object, e.g. 'houses[0]'")
    concept: str = Field(description="its scene-layer concept")
    verdict: Literal["verified", "doubtful"] = Field(description="its own verdict")
    doubts: list[str] = Field(default_factory=list, description="why it is doubtful")
    message: str = Field(description="its one-line summary")
    cost: FiniteCost | None = Field(default=None, description="its search's total cost")
    expanded: int = Field(ge=0, description="hypotheses its search expanded")
    evidence: list[str] = Field(
        default_factory=list, description="the region ids it explains ('VIEW/REGION'), sorted"
    )
    ties: list[str] = Field(
        default_factory=list,
        description="its choices along is-a the evidence does not decide (as Interpretation.ties)",
    )
    shared: list[str] = Field(
        default_factory=list,
        description=(
            "its choices along is-a that the evidence left open and the knowledge decided: a "
            "touching object's ('touching ROLE share PATH', e.g. 'body.roof=GableRoof')"
        ),
    )


class Interpretation(_Frozen):
    """An interpretation of evidence against a knowledge base (``interpretation.json``)."""

    format: Literal["aida-kb/interpretation"] = "aida-kb/interpretation"
    version: Literal[1] = 1
    goal: str = Field(description="the goal concept (a scene-layer concept of the knowledge base)")
    accepted: bool = Field(description="True if the goal hypothesis was verified")
    message: str = Field(description="a one-line summary for people")
    instances: list[Instance] = Field(default_factory=list)
    model: ReconstructedModel | None = None
    residuals: list[ConstraintResidual] = Field(default_factory=list)
    trace: list[HypothesisTrace] = Field(default_factory=list)
    expanded: int = Field(ge=0, description="number of hypotheses the search expanded")
    cost: FiniteCost | None = Field(default=None, description="total normalised cost of the result")
    verdict: Literal["verified", "doubtful", "nothing"] | None = Field(
        default=None, description="aida_kb.interpret.verdict: None where it was not judged"
    )
    doubts: list[str] = Field(default_factory=list, description="why it is doubtful")
    objects: list[SceneObject] = Field(
        default_factory=list,
        description="a goal holding several objects: each object found, with its own verdict",
    )
    ties: list[str] = Field(
        default_factory=list,
        description=(
            "other choices along is-a that explain the same evidence about as well as the "
            "accepted one (aida_kb.interpret.interpreter.TIE_MARGIN), e.g. "
            "'body.roof=ShedRoof': the evidence does not decide between them"
        ),
    )

    def instance(self, role: str) -> Instance:
        """The instance with role path `role` (KeyError if none)."""
        for inst in self.instances:
            if inst.role == role:
                return inst
        raise KeyError(role)

    def rejected(self) -> list[HypothesisTrace]:
        """The rejected hypotheses, in the order of the search."""
        return [h for h in self.trace if h.status == "rejected"]


def read_interpretation(path: str | os.PathLike[str]) -> Interpretation:
    """Load ``interpretation.json``; FormatError names the file and field on bad input."""
    return read_json_model(path, Interpretation)


def write_interpretation(path: str | os.PathLike[str], value: Interpretation) -> None:
    """Write ``interpretation.json`` atomically."""
    write_json_model(path, value)
