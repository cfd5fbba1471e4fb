"""The outcomes of a verdict and the records it keeps (`Verdict`, one `ViewCheck` per view)."""

from __future__ import annotations

from dataclasses import dataclass, field

from aida_kb.interpret.uncertainty import Uncertainty

VERIFIED, DOUBTFUL, NOTHING = "verified", "doubtful", "nothing"


VERIFIED, DOUBTFUL, NOTHING = "verified", "doubtful", "nothing"


VERIFIED, DOUBTFUL, NOTHING = "verified", "doubtful", "nothing"


@dataclass(frozen=True)
class ViewCheck:
    """How well the model explains one view's regions (weights are certainty sums, eq. 4)
    and segments (`edge_cover`: the share of the visible model edges' projected length that
    image segments lie on; None when no edge is long enough to check)."""

    view: str
    inside_weight: float  # regions inside the model's projection (explained + contradicting)
    explained_weight: float
    contradicting: list[tuple[int, float, str]]  # (region id, weight share, why)
    edge_cover: float | None = None
    explained_on: dict[str, float] = field(default_factory=dict)  # part role -> weight on it
    explained_ids: tuple[int, ...] = ()  # the regions on a model face
    free_ids: tuple[int, ...] = ()  # regions outside the projection or in front of the model
    standing_out_weight: float = 0.0  # regions parallel to a face, standing out of it
    turned_on: dict[str, float] = field(default_factory=dict)  # part role -> the weighted mean
    # angle, degrees, between its face's normal and the normals of the regions on it

    @property
    def explained_share(self) -> float:
        """The share of the weight inside the projection that the model explains."""
        return self.explained_weight / self.inside_weight if self.inside_weight > 0 else 1.0


@dataclass(frozen=True)
class Verdict:
    """The verdict and its reasons (empty when verified); views named as not explained."""

    verdict: str
    reasons: tuple[str, ...]
    views_not_explained: tuple[str, ...]
    checks: tuple[ViewCheck, ...]
    uncertainty: Uncertainty | None = None  # the adjustment's standard deviations
