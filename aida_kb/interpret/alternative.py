"""One alternative of a structure verified: its region assignments adjusted in turn, the
plausible one of least misfit kept as a verified level, or the reason none is, in the trace.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import numpy.typing as npt

from aida_kb.errors import AidaError, GeometryError
from aida_kb.interpret.adjust import adjust
from aida_kb.interpret.assign import anchor_of, assignments
from aida_kb.interpret.blame import Reason, blame, first_named, over
from aida_kb.interpret.closure import ClosingFace
from aida_kb.interpret.context import Context
from aida_kb.interpret.hypotheses import DOWNWARD, UPWARD, Frame
from aida_kb.interpret.knowledge import Structure
from aida_kb.interpret.observe import RegionView, slope_deg
from aida_kb.interpret.outline import outline_pitch
from aida_kb.interpret.plausibility import (
    MAX_MEAN_COST,
    attribute_violation,
    beyond_whole,
    closed,
    hidden_inside,
    misfit,
    outside,
    unseen,
)
from aida_kb.interpret.support import (
    EdgeSupport,
    edge_support,
    outside_share,
    overflow,
    uncovered,
)
from aida_kb.interpret.trace import Trace
from aida_kb.interpret.unseen import Planes, UnseenError
from aida_kb.interpret.verdict.tolerances import ORIENTATION_TOLERANCE_DEG, SPILL_MAX
from aida_kb.interpret.verify import Outcome, Verification

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Level:
    """A verified level of the interpretation: one structure with its bindings and planes."""

    hid: int
    structure: Structure
    binding: dict[str, str]  # region id -> role path
    inserted: tuple[str, ...]
    outcome: Outcome
    frame: Frame
    polygons: dict[str, FloatArray]  # role path -> closed face polygon (N, 3), world, metres
    closing: tuple[ClosingFace, ...]  # faces of its solid from the levels it belongs to
    verification: Verification  # the problem it was verified by (its last adjustment)
    misfit: float  # adjustment cost plus the penalty for unexplained segments of bound regions
    # the closed solid's edges the reference camera sees and what segments show of them, and
    # the weight of its bound regions lying outside their faces (`support`)
    edges: EdgeSupport = field(default_factory=EdgeSupport.empty)
    overflow: float = 0.0
    # inserted parts of the main body facing the camera, shown by the segments along their
    # edges though no region fits them (`unseen_by_edges`)
    visible: tuple[str, ...] = ()
    # the share of the reference view's region pixels its bound faces cover where no region
    # lies (`support.uncovered`)
    uncovered: float = 0.0


# a part of the main body inserted facing the camera (no region fits it: a dark, low-texture
# roof gives stereo none) is seen when segments lie along at least this share of its visible
# edges' length in the reference image: most of its outline, not the one edge it shares with
# a bound part (a flat roof's eave is the front wall's top edge too)
VISIBLE_SEEN_MIN = 0.6


def unseen_by_edges(ctx: Context, visible: tuple[str, ...], edges: EdgeSupport) -> str:
    """Why an inserted part of the main body facing the camera is not seen ('' if each is):
    segments lie along less than `VISIBLE_SEEN_MIN` of its visible edges' length."""
    for role in visible:
        share = edges.share(frozenset((role,)))
        if share is None or share < VISIBLE_SEEN_MIN:
            shown = "none" if share is None else f"{100 * share:.0f}%"
            return (
                f"{role} would face camera {ctx.evidence.camera.view} but no region fits it, "
                f"and segments show {shown} of its edges' length "
                f"(at least {100 * VISIBLE_SEEN_MIN:.0f}%)"
            )
    return ""


# a part the knowledge orients level (``orient top: upward``), bound to a region, whose
# adjusted plane slopes more than this is not that part: the verdict doubts such a model for
# the knowledge's orientation at the same figure (`verdict.check_orientations`), and a rival
# that lets the part slope explains the same region without breaking it (dev seed 61120: a
# shed's top sloping 10.6 degrees, bound as a flat roof's top, cost the flat roof exactly what
# it cost the shed, and the result named the flat roof as a rival the evidence could not
# rule out)
LEVEL_TOLERANCE_DEG = ORIENTATION_TOLERANCE_DEG
# an inserted tilted part that a relation of the knowledge places (the symmetry of a gable's
# slopes, which an asymmetric gable does not assert) is rejected when the outline of the walls
# it meets shows a slope this far from the one the relation gave it: the image contradicts
# what the stronger structure asserts of a part it only guessed. On the outline's own
# measure (`outline.outline_pitch`) of the back slopes of 13 dev gables (65013-68029) it lies
# within 4.0 deg of the front's slope; on three asymmetric gables it lies 13.7-16.6 deg from
# it (67013, 68017, 68024), and the randomised asymmetric gables' slopes differ by 8 deg or
# more
OUTLINE_CONTRADICTED_DEG = 8.0
# a wall's outline measures a slope only where the camera sees the wall at most this far from
# square on (between its line of sight and the wall's normal): seen edge-on its outline is a
# few pixels wide, and so its back-projection along the wall is metres off (dev 68011, a
# gable end wall seen at 83 deg: its outline said 55.5 deg for a 37.5 deg slope; 68027 and
# 67014 at 83-85 deg: 3.5 deg off; 68017 and 68024 at 74 and 62 deg: within 2 deg of the truth)
OUTLINE_MAX_INCIDENCE_DEG = 80.0
# nor where more than this share of the wall's region lies outside the wall's face: the region
# is more than that face, and its outline is not the face's (dev 67028, an L-shape: the body's
# end wall and the wing's wall in its plane are one region, 42 % outside the end wall, its
# outline 13 deg off the slopes; the asymmetric gables' end walls lie 0-15 % outside the
# symmetric gable's face: 68017, 68024, 67013). A quarter, as the verdict's spill
# (`verdict.tolerances.SPILL_MAX`)
OUTLINE_OUTSIDE_MAX = SPILL_MAX


def level_violation(
    structure: Structure, binding: dict[str, str], planes: Planes, up: FloatArray
) -> str:
    """Why a part bound to a region (`binding`: region id -> role path) breaks the level
    orientation the knowledge gives it ('' if none does): its plane in `planes` (role path ->
    (unit normal (3,), offset m), world) slopes more than `LEVEL_TOLERANCE_DEG` from facing
    straight up or down (`up` (3,) unit, world)."""
    bound = set(binding.values())
    for leaf in structure.leaves:
        if leaf.role not in bound or leaf.pitched or leaf.direction not in (UPWARD, DOWNWARD):
            continue
        normal = planes[leaf.role][0] / np.linalg.norm(planes[leaf.role][0])
        facing = up if leaf.direction == UPWARD else -up
        slope = math.degrees(math.acos(float(np.clip(normal @ facing, -1.0, 1.0))))
        if slope > LEVEL_TOLERANCE_DEG:
            return (
                f"{leaf.role} ({leaf.concept}) slopes {slope:.1f} deg where its region lies, "
                f"but the knowledge orients it {leaf.direction} (within "
                f"{LEVEL_TOLERANCE_DEG:g} deg)"
            )
    return ""


def outline_contradiction(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    binding: dict[str, str],
    planes: Planes,
    polygons: dict[str, FloatArray],
    inserted: tuple[str, ...],
    placed: frozenset[str],
) -> str:
    """Why an inserted tilted part that a relation of the knowledge places (`placed`: role
    paths, `Knowledge.beyond_weaker`) contradicts the outline of the walls it meets ('' if
    none does): its adjusted plane in `planes` (role path -> (unit normal (3,), offset m),
    world) slopes more than `OUTLINE_CONTRADICTED_DEG` from the slope the outlines of the
    regions bound to its neighbours show (`outline.outline_pitch`, walls seen within
    `OUTLINE_MAX_INCIDENCE_DEG` of square on, regions at most `OUTLINE_OUTSIDE_MAX` outside
    their faces in `polygons`: role path -> (K, 3), metres, world). Only a slope the
    knowledge leaves to the evidence counts: a part tilted by a fixed angle is not measured
    by its outline here."""
    own = {
        rid: role
        for rid, role in binding.items()
        if role not in polygons
        or (share := outside_share(ctx, rid, polygons[role])) is None
        or share <= OUTLINE_OUTSIDE_MAX
    }
    for leaf in structure.leaves:
        if leaf.role not in placed or leaf.role not in inserted or leaf.tilt_deg is not None:
            continue
        traced = outline_pitch(
            ctx, structure, leaf, frame, own, max_incidence_deg=OUTLINE_MAX_INCIDENCE_DEG
        )
        if traced is None:
            continue
        normal = planes[leaf.role][0] / np.linalg.norm(planes[leaf.role][0])
        slope = slope_deg(normal, frame.up)
        if abs(slope - traced) > OUTLINE_CONTRADICTED_DEG:
            return (
                f"{leaf.role} ({leaf.concept}) is inserted at a slope of {slope:.1f} deg, but "
                f"the outlines of the walls it meets show {traced:.1f} deg (at most "
                f"{OUTLINE_CONTRADICTED_DEG:g} deg apart)"
            )
    return ""


def _unpitched(binding: dict[str, str], pitched: frozenset[str]) -> dict[str, str] | None:
    """`binding` (region id -> role path) without the regions bound to `pitched` parts, to
    verify again where its planes close no solid; None when it binds none of them or nothing
    else.

    A roof region seen at a grazing angle (a low camera sees a sliver of the roof) or lit
    flat gives its plane a pitch far off its face's: the roof then cuts the walls below their
    eaves or through the floor and no solid closes, while a level top or a shed over the same
    walls, with its top inserted, closes and is taken (dev 67032, a shed seen from below its
    eaves: its top bound to a region pitched 58 deg, 19 deg true, every pitched roof failed
    and a flat roof was accepted). Without those regions the knowledge inserts the slopes and
    the segments place them (`adjust`); the regions left out count against it as any
    evidence an alternative could have bound (`plausibility.misfit`).
    """
    unpitched = {r: role for r, role in binding.items() if role not in pitched}
    if not unpitched or len(unpitched) == len(binding):
        return None
    return unpitched


def verify_alternative(
    ctx: Context,
    trace: Trace,
    structure: Structure,
    frame: Frame,
    parent: int,
    fixed: Planes,
    choices: dict[str, str],
    *,
    forced: dict[str, RegionView],
    exclude: set[str] | frozenset[str] = frozenset(),
    guessed: frozenset[str] = frozenset(),
    junctions: frozenset[str] = frozenset(),
    bindings: list[dict[str, str]] | None = None,
    offered: frozenset[str] | None = None,
    label: str = "",
    seen_by_edges: bool = False,
    faces: dict[str, FloatArray] | None = None,
    placed: frozenset[str] = frozenset(),
) -> Level | None:
    """Verify a structure in `frame` with its anchor bound to `forced`; its level, or None.

    ``fixed``: the planes of verified levels (non-empty for a smaller part, paper §5);
    ``choices``: their is-a choices; ``exclude``: regions they bound; ``junctions``: free
    regions of parts it may meet later (their segments along it are not loose, `adjust`);
    ``guessed``: their inserted parts (`adjust.adjust`). The hypothesis is recorded in
    `trace` under `parent`. ``placed``: the parts a relation of the knowledge places
    beyond a weaker structure (`Knowledge.beyond_weaker`), checked against the walls'
    outlines where they are inserted (`outline_contradiction`).
    ``bindings``: the region assignments to try (None: `assign.assignments` finds them from
    the anchor's region `forced`); ``offered``: the regions the structure could have bound
    (None: those of the bindings); ``label``: how the hypothesis was generated, for the trace.
    ``seen_by_edges``: a part of the main body inserted facing the camera is accepted when
    segments lie along `VISIBLE_SEEN_MIN` of its visible edges' length (`unseen_by_edges`).
    ``faces``: role path -> closed face (K, 3), metres, world, of the verified levels: a
    smaller part's open face attached against one of them lies within it
    (`plausibility.beyond_whole`).
    """
    root = structure.nodes[0]
    what = "; ".join(
        x for x in (structure.describe(), *(f"{k}={r.id}" for k, r in forced.items()), label) if x
    )
    hid = trace.create(root.concept, root.role, parent, f"[{what}]")
    smaller = bool(fixed)  # a part of a verified level (paper §5: smaller parts later)
    options = (
        bindings
        if bindings is not None
        else assignments(ctx, structure, frame, forced, exclude, smaller=smaller)
    )
    if isinstance(options, str):
        trace.reject(hid, f"[{what}] {options}")
        return None
    options = list(options)
    # the parts the knowledge tilts by a pitch (``orient P: ... tilted by T``): the bindings
    # without their regions are tried where a binding's planes close no solid (`_unpitched`)
    pitched = frozenset(leaf.role for leaf in structure.leaves if leaf.pitched)
    best: Level | None = None
    attachment = ctx.knowledge.attachment(structure.root)
    # the regions of the parts this one meets: segments to them are no loose evidence
    met = frozenset(exclude) | junctions
    # why each assignment fell; the trace names the first that a constraint felled (the
    # assignments come heaviest evidence first), else the first. A contradiction's culprit
    # is searched for (`blame`, many solves) only when its reason is the one reported.
    reasons: list[Reason | Callable[[], Reason]] = []
    offered_ids = set(offered) if offered is not None else {rid for b in options for rid in b}
    for binding in options:
        try:
            adjusted = adjust(
                ctx,
                structure,
                frame,
                binding,
                fixed,
                choices,
                guessed,
                met,
                seen_by_edges=seen_by_edges and not smaller,
                placed=None if smaller else placed,
            )
        except UnseenError as exc:
            reasons.append((str(exc), None))
            continue
        except AidaError as exc:
            reasons.append((f"adjustment failed: {exc}", None))
            continue
        outcome = adjusted.outcome
        worst = outcome.worst_rejected()
        if outcome.cost > MAX_MEAN_COST:
            # the constraints together do not fit: name the one to blame, which need not
            # be the first over its threshold (the compromise spreads a contradiction)
            reasons.append(partial(blame, outcome, adjusted.verification, worst))
            continue
        if worst is not None:
            reasons.append((over(worst), worst))
            continue
        try:
            polygons, closing = closed(ctx, structure, outcome, fixed, frame)
        except GeometryError as exc:
            reasons.append((f"its planes do not close a solid: {exc}", None))
            unpitched = None if smaller else _unpitched(binding, pitched)
            if unpitched is not None and unpitched not in options:
                options.append(unpitched)
            continue
        whole = (fixed, faces or {}, exclude) if smaller else None
        violation = attribute_violation(
            ctx, structure, frame, outcome.planes, polygons, binding, whole
        )
        if violation is not None:
            reasons.append((violation.text, violation))
            continue
        tilted = level_violation(structure, binding, outcome.planes, frame.up)
        if tilted:
            reasons.append((tilted, None))
            continue
        against = outline_contradiction(
            ctx, structure, frame, binding, outcome.planes, polygons, adjusted.inserted, placed
        )
        if against:
            reasons.append((against, None))
            continue
        solid = {leaf.role: outcome.planes[leaf.role] for leaf in structure.leaves}
        solid.update({c.role: (c.normal, c.offset_m) for c in closing})
        corners = np.concatenate(list(polygons.values()))
        size = float(np.max(np.ptp(corners, axis=0)))
        edges = edge_support(ctx, solid, polygons)
        why = (
            outside(ctx, binding, polygons)
            or (
                unseen(ctx, adjusted.visible, polygons, anchor_of(forced))
                if smaller
                else unseen_by_edges(ctx, adjusted.visible, edges)
            )
            or hidden_inside(ctx, solid, set(binding) | set(exclude), size)
            or beyond_whole(attachment, closing, polygons, faces or {})
        )
        if why:
            reasons.append((why, None))
            continue
        # evidence an alternative could have bound but leaves out counts against it
        level = Level(
            hid,
            structure,
            binding,
            adjusted.inserted,
            outcome,
            frame,
            polygons,
            closing,
            adjusted.verification,
            misfit(ctx, outcome.cost, adjusted.loose, offered_ids - set(binding)),
            edges,
            overflow(ctx, binding, polygons),
            adjusted.visible,
            uncovered(ctx, binding, polygons),
        )
        if best is None or level.misfit < best.misfit:
            best = level
    if best is None:
        reason = first_named(reasons)
        trace.reject(hid, f"[{what}] {reason[0]}", reason[1])
        return None
    trace.verify(hid, f"[{what}] cost {best.misfit:.3g}")
    return best
