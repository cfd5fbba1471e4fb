"""Ties the other views decide.

An object's choice along is-a that the interpreted view leaves open (a tie: a gable whose
gable walls no view shows and a shed whose back wall stands under the ridge, as at the end of
a terrace whose other end the second view shows) is re-judged by the other views as
`rejudge` does for a single object, object by object: the scene reconstructed again with
every tied object taking its tied choice (`Preference`), each object scored on every view
but the interpreted one by `object_score`; an object whose tied choice leads by
`rejudge.REJUDGE_MARGIN` per such view takes it, the others keep theirs (and their ties).
When only some lead, the scene is reconstructed once more with those alone, taken when they
still lead.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.party import object_parts
from aida_kb.interpret.result import (
    Interpretation,
    SceneObject,
)
from aida_kb.interpret.verdict import (
    check_view,
    edge_cover,
)
from aida_kb.io.evidence import Evidence, ViewEvidence
from aida_kb.io.model import ReconstructedModel
from aida_kb.io.subset import without_regions

if TYPE_CHECKING:
    from aida_kb.io.scene import Scene
    from aida_kb.kb.model import KnowledgeBase

from aida_kb.interpret.scene.faces import explained_by_others
from aida_kb.interpret.scene.judging import every_view, judge_objects, keeps, matching
from aida_kb.interpret.scene.later import later_view_objects
from aida_kb.interpret.scene.members import Preference
from aida_kb.interpret.scene.roles import object_interpretation
from aida_kb.interpret.scene.shared import confirmed_choices, shared_choices

FloatArray = npt.NDArray[np.float64]


Score = tuple[float, float | None, float | None]  # explained, seen edges, faces holding


def object_score(evidence: Evidence, interp: Interpretation, obj: SceneObject) -> dict[str, Score]:
    """Per view with a camera in `interp`'s model, what it says of object `obj`'s model
    (as `rejudge.score` for a single object): the explained share of the region weight inside
    its projection (the view without the regions the other objects explain), the seen share
    of its visible edges' length (edges between two of its faces; the other objects' faces
    hide what lies behind them), or None without an edge to check, and how well its faces hold
    the regions on them (`inside_faces`), or None without a face to judge."""
    model = interp.model
    if model is None:
        return {}
    sub = object_interpretation(interp, obj.role, obj).model
    assert sub is not None  # a copy of `model`
    own = frozenset(p.role for p in object_parts(model, obj.role))
    rest = without_regions(evidence, explained_by_others(evidence, interp, obj.role))
    out: dict[str, Score] = {}
    for view, whole_view in zip(rest.views, evidence.views, strict=True):
        check = check_view(view, sub)
        if check is None:
            continue
        explained = check.explained_share if check.inside_weight > 0 else 0.0
        out[view.id] = (explained, edge_cover(whole_view, model, own), inside_faces(view, sub))
    return out


def _total(scores: dict[str, Score], views: Sequence[str]) -> float:
    """A score over `views` (as `rejudge.Candidate.total`): explained plus seen edge share,
    plus how well the faces hold the regions on them."""
    out = 0.0
    for v in views:
        explained, edges, inside = scores.get(v, (0.0, None, None))
        out += explained + (edges if edges is not None else 0.0)
        out += inside if inside is not None else 0.0
    return out


# regions are laid over the model's faces on a grid this many pixels wide ...
INSIDE_GRID_PX = 4.0
# ... and a face is judged when the regions on it cover this many cells of the grid (800 px):
# their share outside it is then known to a few per cent
INSIDE_MIN_CELLS = 50


def inside_faces(view: ViewEvidence, model: ReconstructedModel) -> float | None:
    """How well the faces of `model` hold the regions of `view` lying on them, seen from the
    view's camera in `model`: 1 minus the largest share of a face's regions' pixels that falls
    outside the face's projection. A region lies on a face whose plane it lies on
    (`verdict.views`' tolerances) and whose projection holds some of its pixels (on a grid of
    `INSIDE_GRID_PX`); faces whose regions cover fewer than `INSIDE_MIN_CELLS` cells are not
    judged. A model too small for the surfaces it stands on leaves part of them outside — a
    shed whose back wall stands under the ridge, where view 01 sees the gable wall of a gable
    reach back beyond it: half of that region outside the shed's side wall, a tenth outside
    the gable's — which the explained share inside the projection does not see. The largest,
    not the mean: the one face that differs between two alternatives decides, however many
    faces they share. None: no camera in the model for the view, or no face judged."""
    from aida_kb.interpret.verdict.tolerances import (
        DEPTH_TOLERANCE,
        DEPTH_TOLERANCE_MIN_M,
        MIN_WEIGHT_SHARE,
        NORMAL_TOLERANCE_DEG,
    )
    from aida_kb.vision.rectify import undistort_pixels

    camera = next((c for c in model.cameras if c.view == view.id), None)
    regions = [r for r in view.regions if r.w_c > 0]
    if camera is None or not regions or not model.parts:
        return None
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    C = -R.T @ t
    K = np.asarray(view.left.K, dtype=np.float64)
    D = np.asarray(view.left.D, dtype=np.float64)
    total = sum(r.w_c for r in regions)
    shape = (
        math.ceil(view.image_height / INSIDE_GRID_PX),
        math.ceil(view.image_width / INSIDE_GRID_PX),
    )
    # the faces facing the camera, projected onto the grid
    faces: list[tuple[FloatArray, float, npt.NDArray[np.bool_]]] = []
    for part in model.parts:
        n = np.asarray(part.normal, dtype=np.float64)
        poly = np.asarray(part.polygon, dtype=np.float64)
        x_cam = poly @ R.T + t
        if float(n @ C) - part.offset_m <= 0.0 or np.any(x_cam[:, 2] <= 0.0):
            continue
        uv = (x_cam @ K.T)[:, :2] / x_cam[:, 2:3] / INSIDE_GRID_PX
        mask = _cells(uv, shape)
        if mask.any():
            faces.append((n, part.offset_m, mask))
    outlines: dict[int, list[FloatArray]] = {}
    for c in view.contours:
        pts = undistort_pixels(np.asarray(c.points, dtype=np.float64), K, D) / INSIDE_GRID_PX
        outlines.setdefault(c.region, []).append(pts)
    cos_tol = math.cos(math.radians(NORMAL_TOLERANCE_DEG))
    cells = np.zeros(len(faces))  # per face: its regions' cells, and those outside it
    outside = np.zeros(len(faces))
    for r in regions:
        if r.w_c < MIN_WEIGHT_SHARE * total or r.id not in outlines:
            continue
        n_r = np.asarray(r.n_init, dtype=np.float64)
        c_r = np.asarray(r.c_init, dtype=np.float64)
        if view.frame == "camera":  # this view's own left camera -> world
            n_r, c_r = R.T @ n_r, R.T @ (c_r - t)
        tol = max(DEPTH_TOLERANCE * float(np.linalg.norm(c_r - C)), DEPTH_TOLERANCE_MIN_M)
        on = [
            k
            for k, (n, d, _) in enumerate(faces)
            if abs(float(n_r @ n)) >= cos_tol and abs(float(c_r @ n) - d) <= tol
        ]
        if not on:
            continue
        region = np.zeros(shape, dtype=bool)
        for pts in outlines[r.id]:
            region ^= _cells(pts, shape)  # even-odd: a hole inside its outline is cut out
        held = [int((region & faces[k][2]).sum()) for k in on]
        if max(held) == 0:
            continue  # on the plane of a face, but elsewhere: another object's
        k = on[int(np.argmax(held))]
        cells[k] += float(region.sum())
        outside[k] += float(region.sum()) - max(held)
    judged = cells >= INSIDE_MIN_CELLS
    if not judged.any():
        return None
    return 1.0 - float(np.max(outside[judged] / cells[judged]))


def _cells(polygon: FloatArray, shape: tuple[int, int]) -> npt.NDArray[np.bool_]:
    """The cells of a grid (rows, columns) whose centres lie inside `polygon` (K, 2: x, y in
    cells)."""
    from aida_kb.texture.raycast import inside_polygon

    mask = np.zeros(shape, dtype=bool)
    lo = np.clip(np.floor(polygon.min(axis=0)).astype(int), 0, [shape[1], shape[0]])
    hi = np.clip(np.ceil(polygon.max(axis=0)).astype(int) + 1, 0, [shape[1], shape[0]])
    if np.any(hi <= lo):
        return mask
    xs, ys = np.meshgrid(np.arange(lo[0], hi[0]), np.arange(lo[1], hi[1]))
    centres = np.stack([xs.ravel(), ys.ravel()], axis=1) + 0.5
    mask[ys.ravel(), xs.ravel()] = inside_polygon(centres.astype(np.float64), polygon)
    return mask


def _ties(interp: Interpretation) -> dict[str, Preference]:
    """The objects (by role) with ties, each with the tied choices to take instead (the first
    tie of each role)."""
    out: dict[str, Preference] = {}
    for obj in interp.objects:
        first: dict[str, str] = {}
        for tie in obj.ties:
            first.setdefault(tie.split("=", 1)[0], tie)
        if first:
            out[obj.role] = Preference(frozenset(obj.evidence), frozenset(first.values()))
    return out


def _leading(
    evidence: Evidence,
    before: Interpretation,
    after: Interpretation,
    flips: dict[str, Preference],
) -> dict[str, Preference]:
    """The flips whose object in `after` (its tied choice taken) leads its namesake in
    `before` by `rejudge.REJUDGE_MARGIN` per view other than the interpreted one, over the
    views both reconstructions registered (a view one of them left out scores nothing there:
    street5 dev 61031, view 01 left out of the first, gave every tied choice a lead of 1.5 per
    view and took two wrong roofs)."""
    from aida_kb.interpret.rejudge import REJUDGE_MARGIN

    out: dict[str, Preference] = {}
    for obj in before.objects:
        flip = flips.get(obj.role)
        other = None if flip is None else matching(after, flip.regions)
        if flip is None or other is None or other.ties == obj.ties:
            continue
        interpreted = {r.split("/", 1)[0] for r in obj.evidence}
        mine, theirs = object_score(evidence, before, obj), object_score(evidence, after, other)
        views = [v.id for v in evidence.views if v.id not in interpreted]
        views = [v for v in views if v in mine and v in theirs]
        lead = _total(theirs, views) - _total(mine, views)
        if views and lead >= REJUDGE_MARGIN * len(views):
            out[obj.role] = flip
    return out


def reconstruct_objects(
    kb: KnowledgeBase,
    evidence: Evidence,
    *,
    goal: str | None = None,
    source: str = "",
    scene: Scene | None = None,
    progress: Callable[[str], None] | None = None,
) -> Interpretation:
    """`rejudge.rejudged_views` (`multiview.reconstruct_views`, a single object's ties
    re-judged by every view), and for a scene of several objects their ties re-judged by the
    other views object by object (the module docstring), then the ties still open that the knowledge
    decides (`shared_choices`: a touching object's choice): at most three more reconstructions
    of the scene, none when no object has a tie; last, the objects that only the later views
    show (`later_view_objects`)."""
    from aida_kb.interpret.multiview import reconstruct_views  # they build on this module
    from aida_kb.interpret.rejudge import rejudged_views

    first = every_view(
        kb,
        evidence,
        rejudged_views(kb, evidence, goal=goal, source=source, scene=scene, progress=progress),
    )
    flips = _ties(first)
    if not flips:
        return later_view_objects(kb, evidence, first, source=source, progress=progress)

    def again(chosen: dict[str, Preference]) -> Interpretation:
        if progress is not None:
            progress(f"re-judging the ties of {', '.join(chosen)} with every view")
        return reconstruct_views(
            kb,
            evidence,
            goal=goal,
            source=source,
            scene=scene,
            progress=progress,
            prefer=tuple(chosen.values()),
        )

    result, chosen = first, dict[str, Preference]()
    if len(evidence.views) >= 2:
        second = every_view(kb, evidence, again(flips))
        leading = _leading(evidence, first, second, flips) if keeps(first, second) else {}
        if leading and leading != flips:
            second = every_view(kb, evidence, again(leading))
            if not keeps(first, second) or _leading(evidence, first, second, leading) != leading:
                leading = {}
        if leading:
            result, chosen = second, leading
    shared = shared_choices(kb, result)
    if shared:
        wanted = _kept_choices(result, chosen)
        for role, pref in shared.items():
            had = wanted.get(role)
            wanted[role] = (
                pref if had is None else replace(pref, choices=pref.choices | had.choices)
            )
        third = every_view(kb, evidence, again(wanted))
        result = third if keeps(result, third) else result
    confirmed = confirmed_choices(kb, result)
    result = result if confirmed is result else judge_objects(kb, confirmed, evidence)
    return later_view_objects(kb, evidence, result, source=source, progress=progress)


def _kept_choices(interp: Interpretation, chosen: dict[str, Preference]) -> dict[str, Preference]:
    """The preferences `chosen` that made `interp`, each keyed by the role its object has in
    `interp` (a reconstruction may find the objects in another order)."""
    out: dict[str, Preference] = {}
    for pref in chosen.values():
        obj = matching(interp, pref.regions)
        if obj is not None:
            out[obj.role] = pref
    return out
