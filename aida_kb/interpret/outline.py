"""The slope of a tilted part no region shows, read from the outlines of the walls it rests on.

A roof plane whose slope no region measures (a dark, low-texture roof; a roof the camera
sees edge-on or not at all) still leaves its mark on the walls it meets: a gable wall's
outline rises to the ridge along each rake, a shed's side wall is a trapezoid whose top runs
along the roof. Where the knowledge says that a tilted part meets a part a region shows
(``adjacent``) and that part's region faces across the tilt — its normal square to the
direction the tilted part leans towards, as a gable end wall is to the slopes — the tilted
plane rests on that region's outline (its border's polygons and the image segments along
it, back-projected onto its plane): of the planes tilted by every slope the knowledge
allows (the part's slope attribute), each laid on the outline from outside (the support of
its points, as an inserted part is placed, `hypotheses.support_offset`), the one the
outline touches along the greatest length is the part's slope. A wall in front of the tilt
(the eaves wall) touches every such plane along its top alike and tells nothing; it is not
used.

An outline that shows no slope — one below `ORIENTATION_TOLERANCE_DEG`, level to the
verdict — gives nothing: a tilted part started level is the level part's twin (a gable at 0.5
degrees is a flat roof), and the search could no longer tell the two apart (dev seed 61122, a
flat roof: its gable rival started level from the side wall's level top and cost the same).

The slope found is where the adjustment starts (`unseen.initial_planes`); the adjustment
and the verification decide. The default the knowledge gives (30 degrees when it gives none)
started a shed's top 20 degrees off on dev seed 61112 (true pitch 10.4): its back wall came
out 244 m tall and the shed was rejected, a flat roof taken instead; from its side wall's
trapezoid the top starts at 10.5 degrees and the shed is verified in that view.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.context import Context
from aida_kb.interpret.hypotheses import Frame, PlanarPart, predicted_normal
from aida_kb.interpret.knowledge import Structure
from aida_kb.interpret.observe import intersect_rays_plane
from aida_kb.interpret.verdict.tolerances import ORIENTATION_TOLERANCE_DEG

FloatArray = npt.NDArray[np.float64]

# a region faces across a tilt when its normal lies within this of square to the direction
# the tilted part leans towards (a gable end wall to its slopes: 90 degrees; the eaves wall
# in front of them: 0)
ACROSS_MAX_DEG = 20.0
# the slopes tried, this far apart (degrees): finer than the adjustment needs to start from
# (its edge matching reaches 25 px, `adjust.MATCH_DISTANCES_PX`)
PITCH_STEP_DEG = 0.5
# an outline edge touches a plane when both its ends lie within this many pixels of it,
# converted to metres at the edge's distance: an outline vertex's own scatter (the region's
# border is found to a matching window's few pixels; `support.EDGE_TOLERANCE_PX` is 4)
CONTACT_PX = 5.0
# the slope is taken only when the outline touches its plane along at least this share of
# the walls' outline length more than it touches the plane of the least-touching slope: a
# rake or a trapezoid's top is a large share of its wall's outline; a corner touched by
# every plane (a wall's top seen only at its front end) is not
MIN_CONTACT_GAIN = 0.05
# contact shares this close to the greatest count as equal (rounding of the lengths' sums)
CONTACT_TIE = 1e-9


def outline_pitch(
    ctx: Context,
    structure: Structure,
    leaf: PlanarPart,
    frame: Frame,
    binding: dict[str, str],
    *,
    max_incidence_deg: float | None = None,
) -> float | None:
    """The slope (degrees) of tilted part `leaf`, no region bound to it, from the outlines
    of the regions bound to the parts it meets that face across its tilt (module
    docstring); None when there are none, or their outlines touch no slope clearly more
    than another. ``binding``: region id -> role path. ``max_incidence_deg``: a region
    whose outline the camera sees at more than this between its line of sight and the
    region's normal (a wall seen edge-on) is left out (None: every region counts)."""
    if not leaf.pitched or leaf.direction is None:
        return None
    lean = frame.direction(leaf.direction)
    neighbours = {b for a, b in structure.adjacency if a == leaf.role}
    neighbours |= {a for a, b in structure.adjacency if b == leaf.role}
    sin_across = math.sin(math.radians(ACROSS_MAX_DEG))
    edges: list[FloatArray] = []
    bands: list[FloatArray] = []
    evidence = ctx.evidence
    for rid, role in sorted(binding.items()):
        if role not in neighbours:
            continue
        region = evidence.regions[rid]
        if abs(float(region.normal @ lean)) > sin_across:
            continue
        camera = evidence.cameras[region.view]
        pixels = [s.ends_px for s in evidence.segments_of(rid)]
        polygons = list(evidence.outlines.get(rid, ()))
        pairs = [np.asarray(p, dtype=np.float64).reshape(2, 2) for p in pixels]
        for poly in polygons:
            poly = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
            if len(poly) >= 2:
                pairs.extend(np.stack([poly, np.roll(poly, -1, axis=0)], axis=1))
        if not pairs:
            continue
        ends_px = np.stack(pairs).reshape(-1, 2)
        pts = intersect_rays_plane(camera.centre_m, camera.rays_world(ends_px), region)
        segs = pts.reshape(-1, 2, 3)
        segs = segs[np.all(np.isfinite(segs), axis=(1, 2))]  # rays that miss the plane: out
        if not len(segs):
            continue
        if max_incidence_deg is not None:
            sight = segs.reshape(-1, 3).mean(axis=0) - camera.centre_m
            cos_in = abs(float(region.normal @ sight)) / max(float(np.linalg.norm(sight)), 1e-12)
            if cos_in < math.cos(math.radians(max_incidence_deg)):
                continue
        edges.append(segs)
        focal = float(camera.K[0, 0])
        dist = np.linalg.norm(segs.mean(axis=1) - camera.centre_m, axis=1)
        bands.append(CONTACT_PX * dist / focal)
    if not edges:
        return None
    segs = np.concatenate(edges)
    band = np.concatenate(bands)
    lengths = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
    total = float(lengths.sum())
    if total <= 0:
        return None
    low, high = leaf.slope_range_deg if leaf.slope_range_deg is not None else (0.0, 90.0)
    pitches = np.arange(low, min(high, 89.0) + 1e-9, PITCH_STEP_DEG)
    if len(pitches) < 2:
        return None
    normals = np.stack([predicted_normal(leaf, frame, float(p)) for p in pitches])  # (P, 3)
    heights = np.einsum("pk,eik->pei", normals, segs)  # (P, E, 2): n·x of every edge end
    support = heights.reshape(len(pitches), -1).max(axis=1)  # (P,)
    touching = np.all(heights >= support[:, None, None] - band[None, :, None], axis=2)
    contact = (touching * lengths[None, :]).sum(axis=1) / total  # (P,) share of the outline
    best = float(contact.max())
    if best - float(contact.min()) < MIN_CONTACT_GAIN:
        return None
    # the middle of the slopes touched along the greatest length: within the contact band a
    # few neighbouring slopes touch the same edges
    pitch = float(np.mean(pitches[contact >= best - CONTACT_TIE]))
    if pitch < ORIENTATION_TOLERANCE_DEG:
        return None  # level to the verdict: no evidence of a tilt (module docstring)
    return pitch


# The far edge of a tilted part facing the camera that no region shows (a dark, low-texture
# roof slope: stereo gives it no region, the image shows its outline against the sky). Its
# plane starts on the support of the seen points, through the eave along the wall below it;
# how far it reaches back — the ridge, where the slope behind it starts, and so where the
# knowledge mirrors the unseen back wall (``unseen back: mirror front about edge(...)``) — is
# where the reference image's lines, back-projected onto that plane, end. Without it both
# slopes start on the eave, the ridge on the front wall's top, and the solid does not close
# (dev seeds 61318, 61320: a gable under a black roof seen square to its front, rejected for
# a self-intersecting side wall; a flat roof was taken instead).
#
# Its slope is not found so: a line's image fixes it to its ray plane, and on a plane through
# the eave tilted less it lies farther back and spans a little more; in a view square to the
# eaves a few pixels of the line's ends are tens of degrees (dev seed 61320, true 48 degrees:
# the ridge spans the wall's width at 34.5; 61309: at 1.5). The slope stays where it starts
# (the knowledge's, or a seen slope's); the views that see the gable's end measure it.
#
# a line runs along the part's edge with the wall below it (the eave; a ridge is parallel to
# it) when its back-projection lies within this of the frame's direction across the part. A
# line parallel to the eave projects back onto any plane through the eave as a line parallel
# to it, whatever the plane's slope; but the frame's axes come from a region's fitted normal,
# a few degrees off (dev seed 61320: the ridge 6.3 degrees off the frame of a front wall
# fitted 4.8 degrees from vertical)
FAR_EDGE_ANGLE_DEG = 10.0
# a far edge spans at least this share of the seen points' width across the part: a ridge
# runs the length of its roof (a roof tile's line or a chimney's top does not)
FAR_EDGE_MIN_SHARE = 0.5
# each line of a far edge spans at least this share of the seen width: a ridge is one line
# or a few (broken where a chimney stands); the short lines of the texture behind the roof
# (dev seed 61309, a gable seen from above against grass: a row of them, the same distance
# behind, spanned half the width) are not
FAR_EDGE_MIN_PIECE = 0.2
# a line counts when its middle lies across the seen width, with this margin on either side
# (a share of the width); its span counts within that width only. On a plane started at
# another slope than the true one the ridge projects back longer or shorter than it is (dev
# seed 61320: 11.0 m on the 30-degree start over a wall 10.5 m wide)
FAR_EDGE_MARGIN = 0.1


def far_edge(
    ctx: Context,
    leaf: PlanarPart,
    frame: Frame,
    plane: tuple[FloatArray, float],
    points: FloatArray,
) -> FloatArray | None:
    """The far edge of tilted part `leaf`, inserted facing the camera on `plane` ((unit
    normal (3,), offset m), world: its predicted orientation laid on the seen points, through
    the eave), that the reference image's lines show: their ends (K, 3), world, metres, back-
    projected onto the plane; None when no line behind the seen `points` ((N, 3), world,
    metres) runs parallel to their edge and, with others as far behind, spans
    `FAR_EDGE_MIN_SHARE` of their width. The far edge is the farthest such group along the
    direction the part leans towards (see the comment above `FAR_EDGE_ANGLE_DEG`).
    """
    if not leaf.pitched or leaf.direction is None or not len(points):
        return None
    camera = ctx.evidence.camera
    lines = ctx.evidence.lines_px.get(camera.view)
    if lines is None or not len(lines):
        return None
    lean = frame.direction(leaf.direction)
    across = np.cross(frame.up, lean)
    across /= np.linalg.norm(across)
    side = points @ across
    lo, hi = float(side.min()), float(side.max())
    width = hi - lo
    if width <= 0:
        return None
    normal, offset = plane
    centre = camera.centre_m
    rays = camera.rays_world(np.asarray(lines, dtype=np.float64).reshape(-1, 2)).reshape(-1, 2, 3)
    denom = rays @ normal
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (offset - float(normal @ centre)) / denom
    lam = np.where((np.abs(denom) > 1e-9) & (lam > 0), lam, np.nan)
    ends = centre + lam[..., None] * rays  # (L, 2, 3); NaN where a ray misses the plane
    hit = np.all(np.isfinite(ends), axis=(1, 2))
    direction = ends[:, 1] - ends[:, 0]
    length = np.linalg.norm(direction, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        along = np.abs(direction @ across) / length
        behind = float((points @ lean).max()) - (ends @ lean).mean(axis=1)  # (L,)
    dist = np.linalg.norm(ends.mean(axis=1) - centre, axis=1)
    band = CONTACT_PX * dist / float(camera.K[0, 0])  # an edge's few pixels, in metres
    spans = np.sort(ends @ across, axis=1)  # (L, 2)
    middle = spans.mean(axis=1)
    clipped = np.clip(spans, lo, hi)
    margin = FAR_EDGE_MARGIN * width
    # along the eave, behind the seen points by more than an edge's pixels (not the eave
    # itself), across their width, each a piece of a long line
    keep = hit & (length > 0) & (along >= math.cos(math.radians(FAR_EDGE_ANGLE_DEG)))
    keep &= (behind > band) & (middle >= lo - margin) & (middle <= hi + margin)
    keep &= clipped[:, 1] - clipped[:, 0] >= FAR_EDGE_MIN_PIECE * width
    for i in np.flatnonzero(keep)[np.argsort(-behind[keep])]:
        group = keep & (np.abs(behind - behind[i]) <= band[i])
        if _covered(clipped[group]) >= FAR_EDGE_MIN_SHARE * width:
            out: FloatArray = ends[group].reshape(-1, 3)
            return out
    return None


def _covered(spans: FloatArray) -> float:
    """The length (m) of the union of intervals `spans` ((K, 2), each low <= high)."""
    total, end = 0.0, -math.inf
    for a, b in spans[np.argsort(spans[:, 0])]:
        if b <= end:
            continue
        total += float(b) - max(float(a), end)
        end = float(b)
    return total
