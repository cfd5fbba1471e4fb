"""The fixed model a view is registered against: planes, edges and what a camera sees of them.

A `RigidModel` is a closed polyhedral model reduced to what registration needs: every part's
plane ``n·x = d`` (world frame, metres, n out of the solid) and every edge where two parts
meet, with its two end points. Edges are found from the parts' polygons (two polygon sides with
the same end points belong to one edge), so any model file with closed polygons will do.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.io.model import ReconstructedModel

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

__all__ = ["RigidModel", "VisibleEdges"]


@dataclass(frozen=True)
class VisibleEdges:
    """The model edges a camera sees, projected.

    index : (E,) indices into the model's edges; a, b : (E, 2) projected end points, pixels
    (clipped to the part in front of the camera); length_px : (E,) projected lengths.
    """

    index: IntArray
    a: FloatArray
    b: FloatArray
    length_px: FloatArray


@dataclass(frozen=True, eq=False)
class RigidModel:
    """Planes and edges of a fixed model (world frame, metres).

    Attributes
    ----------
    names : the P part names (role paths).
    normals : (P, 3) unit normals out of the solid; offsets : (P,) metres.
    edge_ends : (E, 2, 3) the end points of every edge; edge_faces : (E, 2) its two parts.
    vertices : (V, 3) the distinct polygon vertices.
    polygons : the P parts' polygons (K, 3), for occlusion tests.
    """

    names: tuple[str, ...]
    normals: FloatArray
    offsets: FloatArray
    edge_ends: FloatArray
    edge_faces: IntArray
    vertices: FloatArray
    polygons: tuple[FloatArray, ...] = ()

    @classmethod
    def from_polygons(
        cls,
        names: Sequence[str],
        normals: npt.ArrayLike,
        offsets: npt.ArrayLike,
        polygons: Sequence[npt.ArrayLike],
    ) -> RigidModel:
        """A model from P planes and their closed polygons ((K, 3) each, metres).

        Two polygon sides of different parts with the same end points (to 1e-5 of the model's
        size) are one edge between those parts; sides without a partner are no edge.

        Raises
        ------
        GeometryError
            Mismatched sizes, non-finite numbers, or a model with no edge.
        """
        N = np.asarray(normals, dtype=np.float64)
        d = np.asarray(offsets, dtype=np.float64)
        P = len(names)
        if N.shape != (P, 3) or d.shape != (P,) or len(polygons) != P:
            raise GeometryError(
                f"model: {P} names, normals {N.shape}, offsets {d.shape}, "
                f"{len(polygons)} polygons do not agree"
            )
        polys = [np.asarray(p, dtype=np.float64) for p in polygons]
        if any(p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 3 for p in polys):
            raise GeometryError("model: every polygon must have shape (K, 3) with K >= 3")
        if not (np.all(np.isfinite(N)) and np.all(np.isfinite(d))) or not all(
            np.all(np.isfinite(p)) for p in polys
        ):
            raise GeometryError("model: non-finite plane or polygon coordinates")
        N = N / np.linalg.norm(N, axis=1, keepdims=True)
        starts = np.concatenate(polys)
        ends = np.concatenate([np.roll(p, -1, axis=0) for p in polys])
        face = np.repeat(np.arange(P), [p.shape[0] for p in polys])
        size = float(np.max(np.ptp(starts, axis=0)))
        tol = 1e-5 * max(size, 1e-9)
        # side i and side j are one edge when i's start is j's end and i's end is j's start
        same = (np.linalg.norm(starts[:, None] - ends[None, :], axis=2) < tol) & (
            np.linalg.norm(ends[:, None] - starts[None, :], axis=2) < tol
        )
        same |= (np.linalg.norm(starts[:, None] - starts[None, :], axis=2) < tol) & (
            np.linalg.norm(ends[:, None] - ends[None, :], axis=2) < tol
        )
        same &= face[:, None] != face[None, :]
        i, j = np.nonzero(np.triu(same, k=1))
        if i.size == 0:
            raise GeometryError("model: no two parts share an edge (polygons not closed?)")
        edge_ends = np.stack([starts[i], ends[i]], axis=1)
        edge_faces = np.stack([face[i], face[j]], axis=1).astype(np.intp)
        keys = np.round(starts / tol).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        return cls(tuple(names), N, d, edge_ends, edge_faces, starts[np.sort(first)], tuple(polys))

    @classmethod
    def from_model(cls, model: ReconstructedModel) -> RigidModel:
        """The rigid model of a model file's parts (`aida_kb.io.model`)."""
        return cls.from_polygons(
            [p.role for p in model.parts],
            [p.normal for p in model.parts],
            [p.offset_m for p in model.parts],
            [p.polygon for p in model.parts],
        )

    @property
    def n_parts(self) -> int:
        """Number of parts P."""
        return len(self.names)

    @property
    def centroid(self) -> FloatArray:
        """(3,) mean of the distinct vertices, metres."""
        c: FloatArray = self.vertices.mean(axis=0)
        return c

    @property
    def size(self) -> float:
        """The largest extent of the vertices' bounding box, metres."""
        return float(np.max(np.ptp(self.vertices, axis=0)))

    def front_facing(self, centre: FloatArray) -> BoolArray:
        """(P,) True for the parts whose outer side faces a camera at ``centre`` (3,), metres."""
        out: BoolArray = self.normals @ centre - self.offsets > 0.0
        return out

    def _unoccluded(
        self, centre: FloatArray, front: BoolArray, A: FloatArray, B: FloatArray, index: IntArray
    ) -> tuple[FloatArray, FloatArray, IntArray]:
        """The edges (A, B (E, 3)) cut to the stretch no front-facing part hides."""
        K = OCCLUSION_SAMPLES
        s = (np.arange(K) + 0.5) / K
        pts = A[:, None, :] + s[None, :, None] * (B - A)[:, None, :]  # (E, K, 3)
        flat = pts.reshape(-1, 3)
        ray = flat - centre
        hidden = np.zeros(flat.shape[0], dtype=bool)
        own = self.edge_faces[index]  # (E, 2)
        for f in np.flatnonzero(front):  # a dozen parts at most; all samples at once
            n, d = self.normals[f], self.offsets[f]
            denom = ray @ n
            ok = np.abs(denom) > 1e-12
            t = np.where(ok, (d - centre @ n) / np.where(ok, denom, 1.0), -1.0)
            cand = ok & (t > 1e-6) & (t < 1.0 - 1e-6)
            cand &= ~np.repeat(np.any(own == f, axis=1), K)
            if not np.any(cand):
                continue
            sel = np.flatnonzero(cand)
            hit = centre + t[sel, None] * ray[sel]
            hidden[sel[_inside_polygon(hit, self.polygons[f], n)]] = True
        shown = ~hidden.reshape(-1, K)
        keep = shown.mean(axis=1) >= 0.5
        first = np.argmax(shown, axis=1)
        last = K - 1 - np.argmax(shown[:, ::-1], axis=1)
        lo = np.where(first > 0, s[first] - 0.5 / K, 0.0)
        hi = np.where(last < K - 1, s[last] + 0.5 / K, 1.0)
        D = B - A
        return (A + lo[:, None] * D)[keep], (A + hi[:, None] * D)[keep], index[keep]

    def visible_edges(
        self, camera: PinholeCamera, *, min_length_px: float = 8.0, margin_px: float = 0.0
    ) -> VisibleEdges:
        """The edges `camera` can see: at least one of their parts faces it, clipped to z > 0.

        Edges hidden behind parts facing the camera (a non-convex model: a wing, an L-shape) are
        cut to the stretch between their first and last unhidden samples (of
        `OCCLUSION_SAMPLES`), or dropped when fewer than half of the samples show. An edge is
        kept when its projection, clipped to the image shrunk by ``margin_px``, is at least
        ``min_length_px`` long; its end points are the clipped ones.
        """
        front = self.front_facing(camera.centre)
        keep = front[self.edge_faces[:, 0]] | front[self.edge_faces[:, 1]]
        E = self.edge_ends[keep]
        index = np.flatnonzero(keep)
        # clip each edge to the half space z_cam >= z_min in front of the camera
        z = E @ camera.R_cam_world[2] + camera.t_cam_world[2]  # (E, 2)
        z_min = 1e-3 * max(self.size, 1e-9)
        ok = np.any(z > z_min, axis=1)
        E, z, index = E[ok], z[ok], index[ok]
        dz = z[:, 1] - z[:, 0]
        safe = np.where(np.abs(dz) > 0, dz, 1.0)
        s = np.clip((z_min - z[:, 0]) / safe, 0.0, 1.0)
        A = np.where(
            (z[:, 0] < z_min)[:, None], E[:, 0] + s[:, None] * (E[:, 1] - E[:, 0]), E[:, 0]
        )
        B = np.where(
            (z[:, 1] < z_min)[:, None], E[:, 0] + s[:, None] * (E[:, 1] - E[:, 0]), E[:, 1]
        )
        if index.size and self.polygons:
            A, B, index = self._unoccluded(camera.centre, front, A, B, index)
        if index.size == 0:
            empty = np.zeros((0, 2))
            return VisibleEdges(index, empty, empty, np.zeros(0))
        qa = camera.project(A)
        qb = camera.project(B)
        qa, qb, inside = _clip_to_image(qa, qb, camera.width, camera.height, margin_px)
        length = np.linalg.norm(qb - qa, axis=1)
        sel = inside & (length >= min_length_px)
        return VisibleEdges(index[sel], qa[sel], qb[sel], length[sel])


OCCLUSION_SAMPLES = 9


def _inside_polygon(points: FloatArray, polygon: FloatArray, normal: FloatArray) -> BoolArray:
    """(N,) True for points (N, 3) on a polygon's plane that lie inside it (even-odd rule)."""
    k = int(np.argmax(np.abs(normal)))
    axes = [i for i in range(3) if i != k]
    p = points[:, axes]
    q = polygon[:, axes]
    r = np.roll(q, -1, axis=0)
    inside = np.zeros(points.shape[0], dtype=bool)
    for (x1, y1), (x2, y2) in zip(q, r, strict=True):  # the polygon's few sides
        if y2 == y1:  # a side along x crosses no horizontal ray
            continue
        crosses = (y1 > p[:, 1]) != (y2 > p[:, 1])
        x_at = x1 + (p[:, 1] - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (p[:, 0] < x_at)
    return inside


def _clip_to_image(
    a: FloatArray, b: FloatArray, width: int, height: int, margin: float
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Liang-Barsky clipping of N segments to the image rectangle, all at once."""
    lo = np.array([-0.5 + margin, -0.5 + margin])
    hi = np.array([width - 0.5 - margin, height - 0.5 - margin])
    d = b - a
    t0 = np.zeros(a.shape[0])
    t1 = np.ones(a.shape[0])
    ok = np.ones(a.shape[0], dtype=bool)
    for k in range(2):
        for p, q in ((-d[:, k], a[:, k] - lo[k]), (d[:, k], hi[k] - a[:, k])):
            parallel = np.abs(p) < 1e-12
            ok &= ~(parallel & (q < 0))
            r = np.where(parallel, 0.0, q / np.where(parallel, 1.0, p))
            t0 = np.where(~parallel & (p < 0), np.maximum(t0, r), t0)
            t1 = np.where(~parallel & (p > 0), np.minimum(t1, r), t1)
    ok &= t0 < t1
    return a + t0[:, None] * d, a + t1[:, None] * d, ok
