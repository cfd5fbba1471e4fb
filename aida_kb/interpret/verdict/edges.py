"""Image segments along the projected model edges (check (c)), which view sees which edge, and how
well image lines of an edge fix a plane through it (check (e))."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.verdict.geometry import FloatArray, IntArray, inside_polygon, project
from aida_kb.interpret.verdict.tolerances import (
    COS_FLUSH,
    EDGE_ANGLE_DEG,
    EDGE_MIN_LENGTH_PX,
    EDGE_SEEN_SHARE,
    EDGE_SIGMA_PX,
    EDGE_STEP_MIN,
    EDGE_STEP_Z,
    EDGE_TOLERANCE_PX,
    FLUSH_OFFSET,
    OUTLINE_PIECE_MIN_PX,
)
from aida_kb.io.evidence import Evidence, LineSegment, ViewEvidence
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel

if TYPE_CHECKING:
    from aida_kb.register.model import RigidModel, VisibleEdges

U8 = npt.NDArray[np.uint8]


def edge_coverage(
    view: ViewEvidence,
    model: ReconstructedModel,
    outlines_of: frozenset[int] = frozenset(),
    image: U8 | None = None,
    occluders: Sequence[ModelPart] = (),
) -> tuple[RigidModel, VisibleEdges, FloatArray] | None:
    """The model edges the view's camera sees (at least EDGE_MIN_LENGTH_PX long) and the
    length of each, pixels, that image segments lie on (within EDGE_TOLERANCE_PX and
    EDGE_ANGLE_DEG; segments undistorted with the view's distortion first). None: no camera
    or no segments. outlines_of: ids of regions whose outlines count as segments too (each
    straight piece of their simplified contours at least OUTLINE_PIECE_MIN_PX long).
    image: the view's left image (8-bit grey, as taken); an edge across which it steps
    steadily (`vision.lines.edge_steps`: at least EDGE_STEP_MIN grey levels at EDGE_STEP_Z
    standard errors) is seen along its whole length, segments or not.
    occluders: the faces of the scene's other objects (roles unlike the model's): they hide
    the model's edges behind them, and an edge where the surface goes on flat into theirs (a
    terrace's front across a party wall, `flush_edges`) is no edge in the image. The model
    returned is then the model with them; only the model's own edges are returned."""
    from aida_kb.register.evidence import camera_of, measurements_of
    from aida_kb.register.match import match_segments
    from aida_kb.register.model import RigidModel, VisibleEdges

    camera = next((c for c in model.cameras if c.view == view.id), None)
    if outlines_of:
        view = view.model_copy(update={"lines": [*view.lines, *_outline_pieces(view, outlines_of)]})
    if camera is None or not view.lines:
        return None
    own = len(model.parts)
    if occluders:
        model = model.model_copy(update={"parts": [*model.parts, *occluders]})
    rigid = RigidModel.from_model(model)
    edges = rigid.visible_edges(camera_of(camera), min_length_px=EDGE_MIN_LENGTH_PX)
    if occluders:
        faces = rigid.edge_faces[edges.index]  # (E, 2), indices into the parts
        keep = (faces < own).all(axis=1) & ~flush_edges(rigid, own, edges.index)
        edges = VisibleEdges(edges.index[keep], edges.a[keep], edges.b[keep], edges.length_px[keep])
    covered = np.zeros(edges.index.size)
    if edges.index.size == 0:
        return rigid, edges, covered
    meas = measurements_of(view)
    matches = match_segments(
        edges.a,
        edges.b,
        meas.p1,
        meas.p2,
        max_distance_px=EDGE_TOLERANCE_PX,
        max_angle_rad=math.radians(EDGE_ANGLE_DEG),
    )
    if matches.size == 0:
        return rigid, edges, _stepped(view, edges, covered, image)
    a, b = edges.a[matches.edge], edges.b[matches.edge]
    length = edges.length_px[matches.edge]
    u = (b - a) / np.maximum(length, 1e-12)[:, None]
    t1 = np.einsum("mk,mk->m", meas.p1[matches.segment] - a, u)
    t2 = np.einsum("mk,mk->m", meas.p2[matches.segment] - a, u)
    lo = np.clip(np.minimum(t1, t2), 0.0, length)
    hi = np.clip(np.maximum(t1, t2), 0.0, length)
    np.add.at(covered, matches.edge, hi - lo)  # pieces of one edge rarely overlap
    return rigid, edges, _stepped(view, edges, np.minimum(covered, edges.length_px), image)


def flush_edges(rigid: RigidModel, own: int, index: IntArray) -> npt.NDArray[np.bool_]:
    """(E,) which of the edges `index` (into `rigid`, the model's `RigidModel`) between two of
    its first `own` parts the other parts make flush: one face lies against another object's
    face (a party wall: coplanar, facing the other way) and the other goes on in another
    object's face (coplanar, facing the same way: the terrace's front continues), both of
    those holding the edge's midpoint. Coplanar: normals within COS_FLUSH, offsets within
    FLUSH_OFFSET of the model's size."""
    out = np.zeros(len(index), dtype=bool)
    if len(rigid.names) <= own or not len(index):
        return out
    n, d = rigid.normals, rigid.offsets
    tol = FLUSH_OFFSET * rigid.size
    others = np.arange(own, len(rigid.names))

    def onto(face: int, sign: float, mid: FloatArray) -> bool:
        """Another object's face lies on `face` (sign -1: facing the other way) at `mid`."""
        near = (sign * (n[others] @ n[face]) >= COS_FLUSH) & (
            np.abs(sign * d[others] - d[face]) <= tol
        )
        return any(
            bool(inside_polygon(mid[None, :], rigid.polygons[o], n[o])[0]) for o in others[near]
        )

    for e, k in enumerate(index.tolist()):
        f, g = (int(x) for x in rigid.edge_faces[k])
        mid = rigid.edge_ends[k].mean(axis=0)
        out[e] = (onto(f, -1.0, mid) and onto(g, 1.0, mid)) or (
            onto(g, -1.0, mid) and onto(f, 1.0, mid)
        )
    return out


def _stepped(
    view: ViewEvidence, edges: VisibleEdges, covered: FloatArray, image: U8 | None
) -> FloatArray:
    """`covered` (E,), with the edges the image steps across seen along their whole length."""
    if image is None or edges.index.size == 0:
        return covered
    from aida_kb.vision.lines import edge_steps

    K = np.asarray(view.left.K, dtype=np.float64)
    D = np.asarray(view.left.D, dtype=np.float64)
    step, z = edge_steps(image, np.stack([edges.a, edges.b], axis=1), K, D)
    seen = (np.abs(step) >= EDGE_STEP_MIN) & (np.abs(z) >= EDGE_STEP_Z)
    out: FloatArray = np.where(seen, edges.length_px, covered)
    return out


def _outline_pieces(view: ViewEvidence, regions: frozenset[int]) -> list[LineSegment]:
    """The straight pieces of the outer contours of `regions`, as segments (ids after the
    view's own lines), at least OUTLINE_PIECE_MIN_PX long."""
    out: list[LineSegment] = []
    next_id = max((s.id for s in view.lines), default=0) + 1
    for c in view.contours:
        if c.region not in regions or c.hole:
            continue
        p = np.asarray(c.points, dtype=np.float64)
        q = np.roll(p, -1, axis=0)
        length = np.linalg.norm(q - p, axis=1)
        for a, b, n in zip(
            p[length >= OUTLINE_PIECE_MIN_PX],
            q[length >= OUTLINE_PIECE_MIN_PX],
            length[length >= OUTLINE_PIECE_MIN_PX],
            strict=True,
        ):
            out.append(
                LineSegment(
                    id=next_id,
                    p1=(float(a[0]), float(a[1])),
                    p2=(float(b[0]), float(b[1])),
                    length_px=float(n),
                    contrast=0.0,
                    regions=[c.region],
                )
            )
            next_id += 1
    return out


def edge_cover(
    view: ViewEvidence,
    model: ReconstructedModel,
    between: frozenset[str] | None = None,
    outlines_of: frozenset[int] = frozenset(),
    image: U8 | None = None,
    occluders: Sequence[ModelPart] = (),
) -> float | None:
    """The share of the projected length of the model edges the view's camera sees that
    image segments lie on (within EDGE_TOLERANCE_PX and EDGE_ANGLE_DEG); None: no edge to
    check or no camera. Segments are undistorted with the view's distortion first.
    between : only the edges both of whose parts are in this set of roles.
    outlines_of : regions whose outlines count as segments too; image : the view's left image,
    whose steps across an edge show it too; occluders: the scene's other objects' faces
    (`edge_coverage`)."""
    found = edge_coverage(view, model, outlines_of, image, occluders)
    if found is None:
        return None
    rigid, edges, covered = found
    sel: npt.NDArray[np.bool_] = np.ones(edges.index.size, bool)
    if between is not None:
        names = np.array([n in between for n in rigid.names])
        sel = np.asarray(names[rigid.edge_faces[edges.index]].all(axis=1), dtype=bool)
    if not sel.any():
        return None
    return float(covered[sel].sum() / edges.length_px[sel].sum())


def seen_edges(
    evidence: Evidence, model: ReconstructedModel
) -> tuple[tuple[str, ...], IntArray, list[set[str]]]:
    """Which view sees which model edge: image segments lie along at least EDGE_SEEN_SHARE
    of the edge's visible projected length in that view. Returns the part names, the
    edges' two parts (E, 2) (indices into the names; the model's `RigidModel` edges) and,
    per edge, the ids of the views that see it."""
    from aida_kb.register.model import RigidModel

    rigid = RigidModel.from_model(model)
    views: list[set[str]] = [set() for _ in range(len(rigid.edge_faces))]
    for view in evidence.views:
        found = edge_coverage(view, model)
        if found is None:
            continue
        _, edges, covered = found
        for i in edges.index[covered >= EDGE_SEEN_SHARE * edges.length_px]:
            views[int(i)].add(view.id)
    return rigid.names, np.asarray(rigid.edge_faces, dtype=np.int64), views


def line_offset_sd(
    ends: FloatArray, normal: FloatArray, within: FloatArray | None, cameras: list[ModelCamera]
) -> float:
    """How well image lines of a 3-D edge fix a plane through it: the standard deviation,
    metres, of the plane's offset along its unit `normal` (3,), when the edge (ends (2, 3),
    world frame) is seen in `cameras` with its two ends good to EDGE_SIGMA_PX across the
    line. The edge may move square to itself: within the plane of unit normal `within`
    (a neighbour a region measures) or, None, freely (triangulated from the views). inf
    when the views leave a direction unmeasured (one view, no neighbour; a line along the
    baseline)."""
    u = ends[1] - ends[0]
    u = u / max(float(np.linalg.norm(u)), 1e-12)
    if within is not None:
        w = np.cross(within, u)
        basis = (w / max(float(np.linalg.norm(w)), 1e-12))[None, :]
    else:
        a = np.cross(u, [1.0, 0.0, 0.0])
        if np.linalg.norm(a) < 0.1:
            a = np.cross(u, [0.0, 1.0, 0.0])
        a = a / np.linalg.norm(a)
        basis = np.stack([a, np.cross(u, a)])
    info = np.zeros((len(basis), len(basis)))
    h = 1e-3 * max(float(np.linalg.norm(ends[1] - ends[0])), 1e-3)  # metres
    for camera in cameras:
        px = project(camera, ends)  # (2, 2)
        along = px[1] - px[0]
        length = float(np.linalg.norm(along))
        if length < 1e-9:
            continue
        across = np.array([-along[1], along[0]]) / length
        rows = [((project(camera, ends + h * b) - px) @ across) / h for b in basis]  # px / m
        J = np.stack(rows, axis=1)  # (2 ends, k)
        info += J.T @ J / EDGE_SIGMA_PX**2
    if abs(float(np.linalg.det(info))) < 1e-12:
        return math.inf
    cov = np.linalg.inv(info)
    proj = basis @ normal  # (k,): how far the plane moves per metre along each direction
    return math.sqrt(max(float(proj @ cov @ proj), 0.0))
