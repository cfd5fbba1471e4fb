"""The trace of one interpretation run: every hypothesis created, verified or rejected, with
the step of the search it happened in and, for a rejection, the constraint that felled it."""

from __future__ import annotations

from dataclasses import dataclass, field

from aida_kb.interpret.plausibility import Violation
from aida_kb.interpret.result import HypothesisTrace
from aida_kb.solve import ConstraintResidual


@dataclass
class Trace:
    """The hypotheses of one interpretation run, in creation order."""

    entries: list[HypothesisTrace] = field(default_factory=list)
    step: int = 0

    def create(self, concept: str, role: str, parent: int | None, reason: str = "") -> int:
        """Record a new hypothesis; return its id."""
        hid = len(self.entries)
        self.entries.append(
            HypothesisTrace(
                id=hid,
                parent=parent,
                concept=concept,
                role=role,
                status="created",
                step=self.step,
                reason=reason,
            )
        )
        return hid

    def verify(self, hid: int, reason: str = "") -> None:
        """Mark a hypothesis verified."""
        self.entries[hid] = self.entries[hid].model_copy(
            update={"status": "verified", "step": self.step, "reason": reason}
        )

    def reject(
        self, hid: int, reason: str, row: ConstraintResidual | Violation | None = None
    ) -> None:
        """Mark a hypothesis rejected, with the constraint (its report row) that felled it:
        its label, normalised cost and ``.kb`` line; or the attribute whose range it left."""
        if isinstance(row, Violation):
            self.entries[hid] = self.entries[hid].model_copy(
                update={
                    "status": "rejected",
                    "step": self.step,
                    "reason": reason,
                    "constraint": row.label,
                    "cost": None,
                    "span": row.span,
                }
            )
            return
        self.entries[hid] = self.entries[hid].model_copy(
            update={
                "status": "rejected",
                "step": self.step,
                "reason": reason,
                "constraint": None if row is None else row.label,
                "cost": None if row is None else row.normalised_cost,
                "span": None if row is None else row.span,
            }
        )
