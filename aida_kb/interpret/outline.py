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
) -> float | None:
    """The slope (degrees) of tilted part `leaf`, no region bound to it, from the outlines
    of the regions bound to the parts it meets that face across its tilt (module
    docstring); None when there are none, or their outlines touch no slope clearly more
    than another. ``binding``: region id -> role path."""
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
