"""Systematic generation of the main body's hypotheses from the knowledge and the evidence.

A hypothesis of the main body is a *vertical*, an *instance frame* in it, a fully specialised
*structure* (one choice along is-a for every abstract part, `Knowledge.structures`) and a
*binding* of evidence regions to the structure's planar parts. All four are enumerated,
none is guessed:

- **Verticals** (`candidate_ups`): the estimate of the evidence (`observe.estimate_up`); the
  vanishing direction of the reference image's near-vertical segments even where too few
  support it for the estimate (`VP_MIN_SUPPORT` of them, to `VP_MAX_SIGMA_DEG`; within
  `UP_PRIOR_WINDOW_DEG` of the camera's up); the normal of a significant region that may be
  level seen from above, and the cross product of two regions' normals (the vertical if both
  are walls), within `PAIR_WINDOW_DEG` of the estimate or the vanishing direction, or within
  `PRIOR_PAIR_WINDOW_DEG` of the camera's up (an estimate far off: a roof taken for level); each
  refined over the regions vertical under it.
  The latter are ranked by the weight of regions they make vertical or level; the estimate,
  the vanishing direction and the best others, `MAX_VERTICALS` in all, are kept.
- **Frames** (`candidate_frames`): every horizontal direction a significant region faces
  under a vertical (a wall, or a roof plane tilted towards a side) may be any of the four
  horizontal directions of the language (forward, backward, leftward, rightward), so it gives
  four frames; directions within `FRONT_MERGE_DEG` of one already found merge.
- **Bindings** (`best_bindings`): every part's candidates are the significant regions whose
  orientation and slope fit its prediction in the frame (`hypotheses.fits`: the ``orient``
  declaration and the range of the part's slope attribute), then the lighter ones that carry
  at least `MIN_PART_WEIGHT_FRACTION` of the evidence (a side wall seen at a grazing angle,
  whose outline tells a gable wall from a hip's or a shed's) or cover `MIN_PART_AREA_FRACTION`
  of the image's region pixels (a dark roof: little certainty, a plane all the same), or
  none (the part is inserted; whether the camera could miss it is checked before anything is
  solved, `unseen.initial_planes`); the frame's anchor (``frame from PART``)
  is always bound, to a region the frame was taken from: the frame is its evidence's (a
  region too light to be significant may be the anchor, `anchor_regions`). A binding binds
  each region once, puts a part facing upward above the anchor's region (one
  facing downward below it), and leaves a part unbound only when none of its significant
  candidates is free (evidence that fits a part is its evidence; a light one may be clutter
  facing its way: both are tried). Of all consistent bindings the
  `MAX_BINDINGS` that leave the least evidence weight unbound are kept (branch and bound).

Each hypothesis carries the penalty for the evidence it leaves unbound
(`plausibility.unexplained`), plus `OTHER_VERTICAL_PENALTY` in a vertical other than the
estimate, plus `WEAKER_PENALTY` for a structure that asserts less than another of the same
planes (`Knowledge.weaker`): an optimistic estimate of its cost after adjustment, by which the
search (`interpreter`) verifies them, best first. The cost of generation grows with the
number of significant regions R (R² verticals considered, 4R frames per vertical), times the
structures S (the product of the specialisations of the abstract parts), times the bindings
of each (bounded by `MAX_BINDINGS` and `MAX_CANDIDATES`); it is all cheap geometry: only the
verifications of the search solve anything, and their number is bounded there.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.context import MIN_PART_WEIGHT_FRACTION, Context
from aida_kb.interpret.hypotheses import (
    DOWNWARD,
    UPWARD,
    Frame,
    PlanarPart,
    fits,
)
from aida_kb.interpret.knowledge import Structure
from aida_kb.interpret.observe import RegionView
from aida_kb.interpret.plausibility import unexplained
from aida_kb.vision.vanishing import vertical_direction

FloatArray = npt.NDArray[np.float64]

# a candidate vertical lies within this of the camera's up (as `observe.estimate_up` assumes:
# a camera held roughly upright, looking down or up by up to that much)
UP_PRIOR_WINDOW_DEG = 60.0
# a region's normal (taken as level) or the cross product of two regions' normals (taken as
# walls) is a candidate within this of the estimate or the vanishing direction: it corrects
# their error (a few degrees where a wall's fit or the segments' bundle is off); farther,
# nothing says the regions are level or walls (a roof plane and a wall give a direction 30-60
# degrees off, a wall seen from above a "level" one)
PAIR_WINDOW_DEG = 15.0
# ... or within this of the camera's up: a camera held roughly upright looks down or up by up
# to about 20 degrees (issue 14's scenes), plus a wall fit's few degrees. An estimate taken
# from a roof plane believed level (dev seeds 60005: 33 degrees off, 61113: 55) leaves the
# walls' cross product out of both windows above: without this the right vertical was never
# tried. A proposal is only a candidate: ranked by the regions it makes vertical or level
# and judged by the knowledge like any other, at `OTHER_VERTICAL_PENALTY`
PRIOR_PAIR_WINDOW_DEG = 25.0
# two normals closer than this to parallel give no reliable cross product
MIN_PAIR_ANGLE_DEG = 30.0
# verticals closer than this are one (the refinement moves them by less)
UP_MERGE_DEG = 2.0
# a region within this of vertical / level under a candidate vertical counts for it
UP_TOLERANCE_DEG = 10.0
# the verticals kept: the estimate, the vanishing direction and the best others (a wrong
# estimate is usually beaten by one of them: pairs of walls and the ground give few directions)
MAX_VERTICALS = 4
# the vanishing direction of the vertical segments is a candidate when this many support it
# to this 1-sigma (the estimate wants 30: with fewer one wrong bundle can carry it, so here it
# is one candidate among others, judged by the knowledge's fit, not taken as the vertical)
VP_MIN_SUPPORT = 8
VP_MAX_SIGMA_DEG = 1.5
# the heaviest regions whose normals propose verticals (R² pairs)
MAX_UP_REGIONS = 8
# horizontal directions closer than this give one frame (a wall's fit scatters by a few
# degrees; the window of `hypotheses.fits` is 30)
FRONT_MERGE_DEG = 5.0
# a hypothesis in a vertical other than the evidence's estimate costs this much more (in the
# units of `plausibility.unexplained`: an eighth of the evidence left unexplained): another
# vertical must let the knowledge explain clearly more evidence than the estimate does
OTHER_VERTICAL_PENALTY = 0.5
# a structure asserting strictly less than another of the same planes (`Knowledge.weaker`: a
# gable whose slopes may differ, against the symmetric one) costs this much more: it always
# fits at least as well, by the noise of the relations it leaves out, so where both fit the
# one that says more is taken. Far above that noise (a symmetric gable's body costs 1e-4 to
# 5e-4 more than the asymmetric one over the same regions on the symmetric gables of
# tests/fixtures: house_correct, house_occluded, wing_90, oriel), far below what a real
# difference costs the stronger one (the 45/30-degree roof of tests/fixtures: rejected by
# its slopes, normalised cost > 1); one guessed part's worth (`INSERTED_PART_PENALTY`)
WEAKER_PENALTY = 0.05
# a region whose normal is within this of the vertical faces no side
MIN_HORIZONTAL_DEG = 5.0
# regions lighter than significant that may still be an anchor (the heaviest of them)
MAX_LIGHT_ANCHORS = 2
# candidates per part (heaviest first) and bindings per structure and frame kept
MAX_CANDIDATES = 3
MAX_BINDINGS = 4

Binding = dict[str, str]  # region id -> role path
Key = tuple[tuple[int, ...], ...]


@dataclass(frozen=True)
class FrameHypothesis:
    """An instance frame and the regions whose facing direction gave it."""

    frame: Frame
    sources: frozenset[str]  # region ids
    vertical: int  # the index of its vertical among `candidate_ups`


@dataclass(frozen=True)
class BodyHypothesis:
    """One hypothesis of the main body: frame, structure, binding, optimistic cost.

    ``offered``: the regions some part of the structure could have bound in this frame with
    this anchor's region (those it leaves out count against it, `plausibility.misfit`).
    ``unbound``: its parts no region shows (they will be inserted from the knowledge).
    ``prior``: what its vertical costs (`OTHER_VERTICAL_PENALTY`, 0 for the estimate), part
    of ``estimate``.
    """

    frame: FrameHypothesis
    structure: Structure
    binding: Binding
    offered: frozenset[str]
    unbound: int
    estimate: float
    prior: float = 0.0


def _unit(v: FloatArray) -> FloatArray:
    out: FloatArray = v / float(np.linalg.norm(v))
    return out


def _angle_deg(a: FloatArray, b: FloatArray) -> float:
    return math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))


def significant(ctx: Context) -> list[RegionView]:
    """The reference view's significant regions, heaviest first (ties by id)."""
    return sorted((r for r in ctx.regions if ctx.significant(r)), key=lambda r: (-r.weight, r.id))


def anchor_regions(ctx: Context, anchors: frozenset[str] = frozenset()) -> list[RegionView]:
    """The regions that may be a frame's anchor: the significant ones, then the
    `MAX_LIGHT_ANCHORS` heaviest of those lighter than that but carrying at least
    `MIN_PART_WEIGHT_FRACTION` of the evidence (a distant or grazing facade); only the
    regions `anchors` names when it names any (a scene's object, `interpret.scene`)."""
    if anchors:
        return sorted((r for r in ctx.regions if r.id in anchors), key=lambda r: (-r.weight, r.id))
    heavy = significant(ctx)
    light = sorted(
        (
            r
            for r in ctx.regions
            if not ctx.significant(r)
            and (ctx.significant(r, MIN_PART_WEIGHT_FRACTION) or ctx.large(r))
        ),
        key=lambda r: (-r.weight, r.id),
    )
    return heavy + light[:MAX_LIGHT_ANCHORS]


def _refined(up: FloatArray, normals: FloatArray, weights: FloatArray) -> FloatArray:
    """`up` (3,) moved to the direction most perpendicular to the regions vertical under it
    (normals (N, 3), weights (N,)) where they span two directions, else `up` itself."""
    tol = math.sin(math.radians(UP_TOLERANCE_DEG))
    vertical = np.abs(normals @ up) < tol
    if int(vertical.sum()) < 2:
        return up
    scatter = (normals[vertical] * weights[vertical, None]).T @ normals[vertical]
    values, vectors = np.linalg.eigh(scatter / weights[vertical].sum())
    if values[1] <= 0.02 * values[2]:
        return up
    refined = vectors[:, 0]
    return _unit(refined if float(refined @ up) > 0 else -refined)


def _score(up: FloatArray, normals: FloatArray, weights: FloatArray) -> float:
    """The weight of the regions vertical or level facing up under `up`."""
    along = normals @ up
    tol = math.sin(math.radians(UP_TOLERANCE_DEG))
    level = along > math.cos(math.radians(UP_TOLERANCE_DEG))
    return float(weights[(np.abs(along) < tol) | level].sum())


def candidate_ups(ctx: Context) -> list[FloatArray]:
    """The verticals (unit (3,), world frame) hypotheses are generated in: the estimate first,
    then the best others (see the module docstring)."""
    regions = significant(ctx)
    estimate = _unit(np.asarray(ctx.up, dtype=np.float64))
    if not regions:
        return [estimate]
    prior = _unit(ctx.evidence.camera.R_cam_world.T @ np.array([0.0, -1.0, 0.0]))
    normals = np.array([r.normal for r in regions], dtype=np.float64)
    weights = np.array([max(r.weight, 1e-12) for r in regions], dtype=np.float64)
    heavy = normals[:MAX_UP_REGIONS]
    vanishing = _vanishing(ctx)
    anchors = [estimate] if vanishing is None else [estimate, vanishing]
    limit = math.cos(math.radians(UP_PRIOR_WINDOW_DEG))
    near = math.cos(math.radians(PAIR_WINDOW_DEG))
    upright = math.cos(math.radians(PRIOR_PAIR_WINDOW_DEG))

    def plausible(direction: FloatArray) -> bool:
        return float(direction @ prior) >= upright or any(
            float(direction @ a) >= near for a in anchors
        )

    # a level region seen from above: its normal (towards the camera) is the vertical
    proposals: list[FloatArray] = [
        _unit(n) for n in heavy if float(n @ prior) >= limit and plausible(_unit(n))
    ]
    min_sin = math.sin(math.radians(MIN_PAIR_ANGLE_DEG))
    for i in range(len(heavy)):
        for j in range(i + 1, len(heavy)):
            cross = np.cross(heavy[i], heavy[j])
            if float(np.linalg.norm(cross)) < min_sin:
                continue
            cross = _unit(cross)
            cross = cross if float(cross @ prior) >= 0 else -cross
            if plausible(cross):
                proposals.append(cross)
    scored: list[tuple[float, float, int, FloatArray]] = []
    for k, p in enumerate(proposals):
        up = _refined(p, normals, weights)
        scored.append((-_score(up, normals, weights), -float(up @ estimate), k, up))
    scored.sort(key=lambda s: (s[0], s[1], s[2]))
    out = [estimate]
    if vanishing is not None and _angle_deg(vanishing, estimate) > UP_MERGE_DEG:
        out.append(vanishing)
    for *_, up in scored:
        if len(out) >= MAX_VERTICALS:
            break
        if all(_angle_deg(up, u) > UP_MERGE_DEG for u in out):
            out.append(up)
    return out


def _vanishing(ctx: Context) -> FloatArray | None:
    """The vanishing direction (unit (3,), world frame, pointing up) of the reference image's
    near-vertical segments, or None (`aida_kb.vision.vanishing.vertical_direction`)."""
    camera = ctx.evidence.camera
    segments = ctx.evidence.lines_px.get(camera.view)
    if segments is None or not len(segments):
        return None
    vp = vertical_direction(segments, camera.K, prior_window_deg=UP_PRIOR_WINDOW_DEG)
    if vp is None or vp.sigma_deg > VP_MAX_SIGMA_DEG or vp.support < VP_MIN_SUPPORT:
        return None
    return _unit(camera.R_cam_world.T @ vp.direction)


def candidate_frames(
    ctx: Context, up: FloatArray, vertical: int, anchors: frozenset[str] = frozenset()
) -> list[FrameHypothesis]:
    """The frames under `up` that the facing directions of the regions that may be an anchor
    give (`anchor_regions`; four per direction, one for each horizontal direction of the
    language), heaviest region first."""
    found: list[tuple[FloatArray, set[str]]] = []
    min_sin = math.sin(math.radians(MIN_HORIZONTAL_DEG))
    for r in anchor_regions(ctx, anchors):
        h = r.normal - float(r.normal @ up) * up
        if float(np.linalg.norm(h)) < min_sin:
            continue
        h = _unit(h)
        side = _unit(np.cross(up, h))
        for f in (h, -h, side, -side):
            for direction, sources in found:
                if _angle_deg(direction, f) <= FRONT_MERGE_DEG:
                    sources.add(r.id)
                    break
            else:
                found.append((f, {r.id}))
    return [
        FrameHypothesis(Frame.from_front(f, up), frozenset(sources), vertical)
        for f, sources in found
    ]


def _level_fits(
    leaf: PlanarPart, region: RegionView, anchor: RegionView | None, up: FloatArray
) -> bool:
    """A part facing upward lies above the anchor's region, one facing downward below it (the
    ground is no flat roof, a roof no floor); other parts, or no anchor: True."""
    if anchor is None or leaf.direction not in (UPWARD, DOWNWARD):
        return True
    sign = 1.0 if leaf.direction == UPWARD else -1.0
    return sign * float((region.centroid_m - anchor.centroid_m) @ up) > 0.0


def best_bindings(
    ctx: Context,
    structure: Structure,
    frame: FrameHypothesis,
    anchors: frozenset[str] = frozenset(),
) -> list[BodyHypothesis]:
    """The `MAX_BINDINGS` consistent bindings of `structure` in `frame` that leave the least
    evidence weight unbound (see the module docstring), best first."""
    heavy = significant(ctx)
    light = sorted(
        (
            r
            for r in ctx.regions
            if not ctx.significant(r)
            and (ctx.significant(r, MIN_PART_WEIGHT_FRACTION) or ctx.large(r))
        ),
        key=lambda r: (-r.weight, r.id),
    )
    regions = heavy + light
    is_light = {r.id for r in light}
    sources = [r for r in anchor_regions(ctx, anchors) if r.id in frame.sources]
    leaves = structure.leaves
    options: list[list[RegionView | None]] = []
    for leaf in leaves:
        pool = sources if leaf.role == structure.anchor_path else regions
        found: list[RegionView | None] = []
        found += [r for r in pool if fits(leaf, r, frame.frame)][:MAX_CANDIDATES]
        if leaf.role != structure.anchor_path:
            found.append(None)
        if not found:
            return []
        options.append(found)
    # branch and bound over the parts, the anchor first, then fewest options first: keep the
    # best MAX_BINDINGS. A part is left unbound only when none of its significant candidates
    # is free (a light one may be clutter that happens to face its way).
    anchor = next((i for i, leaf in enumerate(leaves) if leaf.role == structure.anchor_path), None)
    order = sorted(range(len(leaves)), key=lambda i: (i != anchor, len(options[i]), i))
    best_rest = [0.0] * (len(order) + 1)
    for k in range(len(order) - 1, -1, -1):
        top = max((r.weight for r in options[order[k]] if r is not None), default=0.0)
        best_rest[k] = best_rest[k + 1] + top
    # a min-heap of the best bindings: (weight, reversed key, key, regions); on equal weight
    # the binding whose region ids sort first is kept
    kept: list[tuple[float, Key, tuple[str, ...], list[RegionView | None]]] = []
    combo: list[RegionView | None] = [None] * len(leaves)
    up = frame.frame.up

    def visit(k: int, weight: float, used: frozenset[str]) -> None:
        if len(kept) >= MAX_BINDINGS and weight + best_rest[k] < kept[0][0] - 1e-12:
            return
        if k == len(order):
            if not used & frame.sources:
                return
            key = tuple("" if r is None else r.id for r in combo)
            entry = (weight, tuple(_neg(x) for x in key), key, list(combo))
            if len(kept) < MAX_BINDINGS:
                heapq.heappush(kept, entry)
            elif entry[:2] > kept[0][:2]:
                heapq.heapreplace(kept, entry)
            return
        i = order[k]
        base = combo[anchor] if anchor is not None else None
        free = [
            r
            for r in options[i]
            if r is not None and r.id not in used and _level_fits(leaves[i], r, base, up)
        ]
        for r in free:
            combo[i] = r
            visit(k + 1, weight + r.weight, used | {r.id})
        if all(r.id in is_light for r in free) and None in options[i]:
            combo[i] = None
            visit(k + 1, weight, used)
        combo[i] = None

    visit(0, 0.0, frozenset())
    out: list[BodyHypothesis] = []
    prior = OTHER_VERTICAL_PENALTY if frame.vertical else 0.0
    for _, _, _, chosen in sorted(kept, key=lambda e: (-e[0], e[2])):
        binding = {r.id: leaf.role for r, leaf in zip(chosen, leaves, strict=True) if r}
        # what it could have bound: its regions, and the candidates of the parts it leaves
        # unbound that are consistent with its anchor's region (the ground fits a flat roof's
        # orientation, but lies below the anchor: not left out). A bound part's other
        # candidates are not left out: a plane has one region (the knowledge's cardinality);
        # a second wall facing the front's way is a wing's or an oriel's, whose level binds
        # it (lshape preset seed 0: charged to the body, the wing's walls made the wing the
        # cheaper body, 38 deg off)
        base = chosen[anchor] if anchor is not None else None
        offered = set(binding) | {
            r.id
            for i, leaf in enumerate(leaves)
            if chosen[i] is None
            for r in options[i]
            if r is not None and _level_fits(leaf, r, base, up)
        }
        out.append(
            BodyHypothesis(
                frame,
                structure,
                binding,
                frozenset(offered),
                sum(1 for r in chosen if r is None),
                unexplained(ctx, set(binding)) + prior,
                prior,
            )
        )
    return out


def _neg(text: str) -> tuple[int, ...]:
    """A key that sorts strings in reverse (for a min-heap that keeps the first ones)."""
    return (*tuple(-ord(c) for c in text), 1)


def body_hypotheses(
    ctx: Context, structures: list[Structure], anchors: frozenset[str] = frozenset()
) -> tuple[list[BodyHypothesis], int, int]:
    """Every generated hypothesis of the main body, best estimate first (ties: in the order
    generated); with the numbers of verticals and frames tried. ``anchors``: the regions the
    frame's anchor may be bound to (none given: any, `anchor_regions`)."""
    out: list[BodyHypothesis] = []
    ups = candidate_ups(ctx)
    frames = 0
    knowledge = ctx.knowledge
    weaker = [any(knowledge.weaker(s, t) for t in structures if t is not s) for s in structures]
    for k, up in enumerate(ups):
        for frame in candidate_frames(ctx, up, k, anchors):
            frames += 1
            for structure, weak in zip(structures, weaker, strict=True):
                found = best_bindings(ctx, structure, frame, anchors)
                if weak:
                    found = [
                        replace(
                            h,
                            estimate=h.estimate + WEAKER_PENALTY,
                            prior=h.prior + WEAKER_PENALTY,
                        )
                        for h in found
                    ]
                out.extend(found)
    ranked = sorted(enumerate(out), key=lambda e: (round(e[1].estimate, 9), e[0]))
    return [h for _, h in ranked], len(ups), frames
