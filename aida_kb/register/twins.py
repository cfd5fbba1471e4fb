"""Choosing between a model's twins by what the images show on its faces.

A symmetric model (a box house turned by a half turn, a square plan by a quarter) projects
the same edges and puts the same regions on its parts at a pose and at its twin: segments and
depth cannot tell them apart, and a model's small asymmetries (a part the knowledge placed a
little off) can make the twin fit the segments better than the true pose (dev seed 60021's
view 01: chamfer cost 0.139 at the twin, 0.221 at the truth). What breaks the symmetry is the
faces' content: the registered views' images carried through the model into the new view at
a candidate pose agree with the new view's image where the pose is right (the same doors,
windows, stains) and not at its twin, which maps the back onto the front or shares no face
with the registered views at all.

`PoseSupport` is that evidence for one pose (the caller measures it, with the images:
`aida_kb.interpret.transfer`); `photometric_choice` takes the pose it confirms among the
refined candidates, `unsupported_twin` names a pose that shares no face with the
registered views while a rival does, and `undecided_rivals` the far poses the images do not
rule out where they confirmed none: the pose taken is then a choice the evidence has not
made, and the result must say so.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from aida_kb.geometry.camera import PinholeCamera

__all__ = [
    "CONFIRM_MARGIN",
    "CONFIRM_NCC",
    "MIN_SHARED_PX",
    "MIN_SHARED_SHARE",
    "RIVAL_COST_RATIO",
    "PhotometricJudge",
    "PoseSupport",
    "photometric_choice",
    "rivals_of",
    "undecided_rivals",
    "unsupported_twin",
]

CONFIRM_NCC = 0.5
"""A pose is confirmed by the images when the registered views' images carried into the view
through the model correlate with its own image at least this well (mean local NCC over the
shared textured pixels). Measured in `reconstruct_views` on dev seeds 60008-60023 (every
rival of every later view): right poses of right models 0.83-0.98 (60010, 60012, 60016,
60019, 60021, 60022); poses a few degrees off, of wrong models, or wrong at most 0.48 (60015's
view 02: 0.48 at a pose 5 degrees off the truth, 0.34 at its quarter-turned twin), most
within 0.25 of 0."""

CONFIRM_MARGIN = 0.2
"""... and leads every rival pose (more than the search's ``span_deg`` from it, sharing faces
with the registered views) by this much NCC: where two poses both correlate, the images do not
decide and the segments' choice stands (the tower of dev seed 60022 carries the same windows
on its four walls: its quarter-turned twins correlate 0.83-0.95 alike)."""

MIN_SHARED_SHARE = 0.1
"""A pose shares faces with the registered views when at least this share of the view's
pixels on the model (at that pose) are textured and seen on the same face by a registered
view: views turned 20-45 degrees from their neighbours share 38-78 % at their true poses (dev
seeds 60009-60022), half-turned twins 0-15 %."""

MIN_SHARED_PX = 400
"""... and at least this many pixels (a 20 x 20 patch): fewer say nothing of the pose."""

RIVAL_COST_RATIO = 2.0
"""Refined candidates whose chamfer cost is at most this many times the best one's are the
rivals the images choose between. A part the knowledge placed a little off (an oriel's sides
no region measures) moves the true pose's edges off theirs: dev seed 60021's true pose cost
1.6 times its twin's. A pose whose edges fit much worse is no rival, whatever its texture."""


@dataclass(frozen=True)
class PoseSupport:
    """What the images say of a candidate pose of a view.

    ncc : the mean local normalised cross-correlation between the view's image and the
    registered views' images carried into it through the model, over the pixels both see on
    the same face and textured in both (nan when there are none); shared_px : how many such
    pixels; model_px : the view's pixels on the model at the pose.
    """

    ncc: float
    shared_px: int
    model_px: int

    @property
    def shares(self) -> bool:
        """The pose shares enough textured faces with the registered views to be judged
        (`MIN_SHARED_SHARE`, `MIN_SHARED_PX`)."""
        need = max(float(MIN_SHARED_PX), MIN_SHARED_SHARE * self.model_px)
        return self.shared_px >= need and math.isfinite(self.ncc)

    @property
    def confirmed(self) -> bool:
        """The images confirm the pose (`CONFIRM_NCC` over shared faces)."""
        return self.shares and self.ncc >= CONFIRM_NCC


PhotometricJudge = Callable[[PinholeCamera], PoseSupport]
"""The images' support of a candidate camera of the view (world frame)."""


def _gap(a_deg: float, b_deg: float) -> float:
    return abs((a_deg - b_deg + 180.0) % 360.0 - 180.0)


def rivals_of(costs: Sequence[float], angles: Sequence[float], same_deg: float) -> list[int]:
    """Indices of the refined candidates the images choose between: cost within
    `RIVAL_COST_RATIO` of the best, one per pose (candidates within ``same_deg`` of a cheaper
    one's turn are that pose again), cheapest first."""
    best = min(costs)
    order = sorted(range(len(costs)), key=lambda i: costs[i])
    out: list[int] = []
    for i in order:
        if costs[i] > best * RIVAL_COST_RATIO:
            break
        if all(_gap(angles[i], angles[j]) > same_deg for j in out):
            out.append(i)
    return out


def photometric_choice(
    angles: Sequence[float], supports: Sequence[PoseSupport], far_deg: float
) -> int | None:
    """The index of the pose the images confirm, or None when they do not decide.

    The pose with the highest NCC must be `PoseSupport.confirmed` and lead by
    `CONFIRM_MARGIN` every pose more than ``far_deg`` from it that shares faces with the
    registered views (a pose sharing none has no images to speak for it).
    """
    judged = [i for i, s in enumerate(supports) if s.shares]
    if not judged:
        return None
    top = max(judged, key=lambda i: supports[i].ncc)
    if not supports[top].confirmed:
        return None
    for i in judged:
        if _gap(angles[i], angles[top]) > far_deg and (
            supports[top].ncc - supports[i].ncc < CONFIRM_MARGIN
        ):
            return None
    return top


def unsupported_twin(
    angle: float,
    support: PoseSupport,
    angles: Sequence[float],
    supports: Sequence[PoseSupport],
    far_deg: float,
) -> float | None:
    """The turn of a rival that shares faces with the registered views while the pose taken
    (``angle``, ``support``) shares none, more than ``far_deg`` from it; None when there is
    none. A view of a sequence shares faces with the views before it at its true pose; its
    half-turned twin sees their backs: where the segments chose such a pose, the evidence does
    not decide (dev seed 60017's view 02: the segments' best pose shares 0.7 % of its pixels,
    the rivals half a turn from it most of theirs)."""
    if support.shares:
        return None
    for a, s in zip(angles, supports, strict=True):
        if s.shares and _gap(a, angle) > far_deg:
            return a
    return None


def undecided_rivals(
    angle: float,
    support: PoseSupport,
    angles: Sequence[float],
    supports: Sequence[PoseSupport],
    far_deg: float,
) -> tuple[float, ...]:
    """The turns (degrees, as ``angles``) of the rivals more than ``far_deg`` from the pose
    taken (``angle``, ``support``) that the images do not rule out: each shares faces with the
    registered views and its NCC is not `CONFIRM_MARGIN` below the taken pose's (nor below
    `CONFIRM_NCC` when the taken pose shares no faces to be judged on).

    Where `photometric_choice` decided, there are none by its own rule; where it did not, the
    segments' choice stands but is no decision: a square tower with the same windows on its
    four walls correlates 0.97 at its quarter-turned twin and 0.91 at the truth (preset tower
    seed 3, views 80 degrees apart), and its view was verified 90 degrees off."""
    floor = support.ncc - CONFIRM_MARGIN if support.shares else CONFIRM_NCC
    return tuple(
        float(a)
        for a, s in zip(angles, supports, strict=True)
        if s.shares and _gap(a, angle) > far_deg and s.ncc > floor
    )
