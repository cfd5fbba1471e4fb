"""Closed polyhedra from planes and face adjacency (paper §3: polygons from plane intersections).

A `Polyhedron` is a closed, genus-0 solid bounded by named planar faces (``n·x = d``, unit n
out of the solid). Its topology is a *rotation system*: for every face, its neighbours in
cyclic order, counter-clockwise seen from outside (the face's "ring"). Vertex i of face f is
where f meets ring[f][i] and ring[f][i+1]; walking from face to face around that point gives
every face incident to the vertex, so the vertices are shared and every edge belongs to exactly
two faces by construction.

Where the rings come from (`Polyhedron.from_adjacency`): only *which* faces meet along an edge
is known (the knowledge base's adjacency). The face-adjacency graph of a closed genus-0
polyhedron is planar, and when it is 3-connected (every convex polyhedron, by Steinitz's
theorem, and the buildings of this project) its planar embedding is unique up to a mirror
image. So the rings are read from `networkx.check_planarity`'s embedding, and the mirror is
chosen geometrically, by the sign of the enclosed volume computed with the given outward
normals. This needs no initial vertex estimate and no convexity. Adjacency graphs that are not
3-connected admit several arrangements: they are refused with the separating faces named; give
the rings explicitly then (`Polyhedron.from_rings`).

Vertices: a vertex where three faces meet is their exact intersection; where k > 3 faces meet
(the eaves corner of a hip roof) it is the least-squares point of the k planes, exact when
they are concurrent; `vertex_residuals` tells how far they are from it.

Validation (all `GeometryError`, naming the faces): unit, finite normals; every face with
three or more neighbours; each vertex's plane system well conditioned (near-parallel
neighbours, vertices at infinity); every face polygon simple, counter-clockwise about its
outward normal and without zero-length edges; Euler characteristic V - E + F = 2; positive
volume. Not checked: intersections between different faces of a non-convex solid, and faces
with holes or faces that meet along two separate edges (neither can be expressed by a simple
adjacency; model such buildings as a union of solids, as aida_kb.synth does for oriels).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.geometry.polygon import (
    DEFAULT_MAX_CONDITION,
    intersect_planes,
    intersect_planes_with_jacobians,
    plane_bases,
    polygon_area,
    segments_touch,
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

RELATIVE_TOLERANCE = 1e-9
# `Polyhedron.concurrent`: a vertex off its faces' planes by less than this fraction of the
# solid's size is on them (model files check planarity to 1e-4 of a vertex's distance from the
# origin); the planes are refitted at most this many times (a pyramid's apex off by 1 degree
# of tilt converges in a few dozen)
CONCURRENT_TOLERANCE = 1e-9
MAX_CONCURRENT_ROUNDS = 200
"""Edge lengths and polygon clearances below this times the solid's size are degenerate."""


class VertexJacobians(NamedTuple):
    """Derivatives of the vertices of one degree k w.r.t. the planes of their faces.

    vertex_ids : (m,) int array, indices into `Polyhedron.vertices`
    faces : (m, k) int array, the incident faces of each vertex (cyclic order)
    d_vertices_d_normals : (m, 3, k, 3) array, ``d x[j] / d n_faces[p][l]`` at ``[., j, p, l]``
    d_vertices_d_offsets : (m, 3, k) array, ``d x[j] / d d_faces[p]`` at ``[., j, p]``
    """

    vertex_ids: IntArray
    faces: IntArray
    d_vertices_d_normals: FloatArray
    d_vertices_d_offsets: FloatArray


def _planes(
    names: Sequence[str], normals: npt.ArrayLike, offsets: npt.ArrayLike
) -> tuple[tuple[str, ...], FloatArray, FloatArray]:
    nm = tuple(str(n) for n in names)
    if len(set(nm)) != len(nm):
        dup = sorted({n for n in nm if nm.count(n) > 1})
        raise GeometryError(f"face names must be unique, repeated: {', '.join(dup)}")
    N = np.array(normals, dtype=np.float64)
    d = np.array(offsets, dtype=np.float64)
    F = len(nm)
    if N.shape != (F, 3) or d.shape != (F,):
        raise GeometryError(
            f"{F} faces need normals ({F}, 3) and offsets ({F},), got {N.shape} and {d.shape}"
        )
    finite = np.isfinite(N).all(axis=1) & np.isfinite(d)
    if not finite.all():
        raise GeometryError(f"face {nm[int(np.flatnonzero(~finite)[0])]}: non-finite plane")
    length = np.linalg.norm(N, axis=1)
    bad = np.flatnonzero(np.abs(length - 1.0) > 1e-9)
    if bad.size:
        f = int(bad[0])
        raise GeometryError(
            f"face {nm[f]}: normal must be a unit vector, has length {length[f]:.9g}"
        )
    N.setflags(write=False)
    d.setflags(write=False)
    return nm, N, d


def _rings_from_adjacency(
    names: tuple[str, ...], adjacency: Iterable[tuple[str, str]]
) -> list[list[int]]:
    import networkx as nx

    index = {n: i for i, n in enumerate(names)}
    G: nx.Graph[int] = nx.Graph()
    G.add_nodes_from(range(len(names)))
    for pair in adjacency:
        a, b = pair
        for x in (a, b):
            if x not in index:
                raise GeometryError(f"adjacency names an unknown face {x!r}")
        if a == b:
            raise GeometryError(f"face {a} is listed as adjacent to itself")
        G.add_edge(index[a], index[b])
    if len(names) < 4:
        raise GeometryError(f"a closed polyhedron needs at least 4 faces, got {len(names)}")
    few = [names[f] for f in G.nodes if G.degree(f) < 3]
    if few:
        raise GeometryError(
            f"faces with fewer than 3 neighbours (a polygon needs 3 vertices): {', '.join(few)}"
        )
    if not nx.is_connected(G):
        parts = sorted((sorted(names[f] for f in c) for c in nx.connected_components(G)), key=len)
        raise GeometryError(
            f"the faces form {len(parts)} separate solids; build one polyhedron per solid "
            f"(smallest: {', '.join(parts[0])})"
        )
    planar, embedding = nx.check_planarity(G)
    if not planar:
        raise GeometryError(
            "the face adjacency is not planar: it is not the adjacency of a closed polyhedron "
            "without holes"
        )
    if nx.node_connectivity(G) < 3:
        cut = sorted(names[f] for f in nx.minimum_node_cut(G))
        raise GeometryError(
            "the face adjacency does not fix the faces' arrangement (faces "
            f"{', '.join(cut)} separate it); give the neighbour rings explicitly (from_rings)"
        )
    assert isinstance(embedding, nx.PlanarEmbedding)
    return [list(embedding.neighbors_cw_order(f)) for f in range(len(names))]


class _Topology(NamedTuple):
    rings: tuple[tuple[int, ...], ...]
    face_vertices: tuple[tuple[int, ...], ...]
    vertex_faces: tuple[tuple[int, ...], ...]


def _topology(names: tuple[str, ...], rings: Sequence[Sequence[int]]) -> _Topology:
    """Vertices of a rotation system: walk from face to face around each corner."""
    F = len(names)
    pos: list[dict[int, int]] = []
    for f, ring in enumerate(rings):
        if len(ring) < 3:
            raise GeometryError(
                f"face {names[f]} has {len(ring)} neighbours; a polygon needs at least 3"
            )
        where = {g: i for i, g in enumerate(ring)}
        if len(where) != len(ring) or f in where:
            raise GeometryError(f"face {names[f]}: its ring repeats a face or contains itself")
        pos.append(where)
    for f, ring in enumerate(rings):
        for g in ring:
            if not 0 <= g < F or f not in pos[g]:
                other = names[g] if 0 <= g < F else str(g)
                raise GeometryError(
                    f"faces {names[f]} and {other}: adjacency is not symmetric "
                    f"({other} is in the ring of {names[f]} but not the other way round)"
                )
    corner_vertex: list[list[int]] = [[-1] * len(r) for r in rings]
    vertex_faces: list[tuple[int, ...]] = []
    for f0 in range(F):
        for i0 in range(len(rings[f0])):
            if corner_vertex[f0][i0] >= 0:
                continue
            v = len(vertex_faces)
            cycle: list[int] = []
            f, i = f0, i0
            while corner_vertex[f][i] < 0:
                corner_vertex[f][i] = v
                cycle.append(f)
                g = rings[f][(i + 1) % len(rings[f])]
                f, i = g, pos[g][f]
            if (f, i) != (f0, i0):
                around = ", ".join(names[c] for c in cycle)
                raise GeometryError(f"inconsistent neighbour rings around the vertex of {around}")
            if len(cycle) < 3 or len(set(cycle)) != len(cycle):
                raise GeometryError(
                    f"the corner of faces {', '.join(names[c] for c in cycle)} is not a vertex of "
                    "a polyhedron (fewer than 3 faces, or a face twice): the rings are not those "
                    "of a closed solid"
                )
            vertex_faces.append(tuple(cycle))
    chi = len(vertex_faces) - sum(len(r) for r in rings) // 2 + F
    if chi != 2:
        raise GeometryError(
            f"Euler characteristic V - E + F = {chi}, not 2: the rings are not those of a "
            "closed solid without holes"
        )
    return _Topology(
        tuple(tuple(int(g) for g in r) for r in rings),
        tuple(tuple(c) for c in corner_vertex),
        tuple(vertex_faces),
    )


def _vertex_groups(vertex_faces: tuple[tuple[int, ...], ...]) -> list[tuple[IntArray, IntArray]]:
    degrees = np.array([len(c) for c in vertex_faces], dtype=np.int64)
    groups = []
    for k in np.unique(degrees):
        ids = np.flatnonzero(degrees == k).astype(np.int64)
        faces = np.array([vertex_faces[v] for v in ids], dtype=np.int64).reshape(len(ids), int(k))
        groups.append((ids, faces))
    return groups


def _vertices(
    names: tuple[str, ...],
    normals: FloatArray,
    offsets: FloatArray,
    vertex_faces: tuple[tuple[int, ...], ...],
    max_condition: float,
) -> tuple[FloatArray, FloatArray]:
    V = len(vertex_faces)
    X = np.zeros((V, 3))
    residual = np.zeros(V)
    for ids, faces in _vertex_groups(vertex_faces):
        labels = [[names[f] for f in row] for row in faces]
        pts = intersect_planes(
            normals[faces], offsets[faces], names=labels, max_condition=max_condition
        )
        X[ids] = pts
        residual[ids] = np.max(
            np.abs(offsets[faces] - np.einsum("mkj,mj->mk", normals[faces], pts)), axis=1
        )
    X.setflags(write=False)
    residual.setflags(write=False)
    return X, residual


class _Corners(NamedTuple):
    """Index arrays over all corners of all faces (faces one after another), per topology."""

    vertex: IntArray  # (C,) the vertex at each corner
    face: IntArray  # (C,) the face it belongs to
    next: IntArray  # (C,) the following corner of the same face
    start: IntArray  # (F,) the first corner of each face
    edge_face: IntArray  # (C,) the face across the edge from corner c to corner next[c]
    pair_i: IntArray  # (P,) first edges (by start corner) of non-adjacent edge pairs of a face
    pair_j: IntArray  # (P,) second edges


@lru_cache(maxsize=512)
def _corners(
    rings: tuple[tuple[int, ...], ...], face_vertices: tuple[tuple[int, ...], ...]
) -> _Corners:
    sizes = np.array([len(r) for r in rings], dtype=np.int64)
    start = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    face = np.repeat(np.arange(len(rings), dtype=np.int64), sizes)
    local = np.arange(int(sizes.sum()), dtype=np.int64) - start[face]
    nxt = start[face] + (local + 1) % sizes[face]
    vertex = np.array([v for fv in face_vertices for v in fv], dtype=np.int64)
    edge_face = np.array([r[(i + 1) % len(r)] for r in rings for i in range(len(r))], np.int64)
    pi, pj = [], []
    for f, k in enumerate(sizes.tolist()):
        i, j = np.triu_indices(k, 2)
        keep = ~((i == 0) & (j == k - 1))
        pi.append(start[f] + i[keep])
        pj.append(start[f] + j[keep])
    return _Corners(
        vertex,
        face,
        nxt,
        start,
        edge_face,
        np.concatenate(pi).astype(np.int64),
        np.concatenate(pj).astype(np.int64),
    )


@dataclass(frozen=True, eq=False)
class Polyhedron:
    """A closed polyhedron: named faces (planes), their neighbour rings and shared vertices.

    Build with `from_adjacency` or `from_rings`; move the planes with `with_planes`.

    Attributes
    ----------
    names : tuple of F str
        Face names (role paths).
    normals : (F, 3) array, unit, out of the solid; offsets : (F,) array, metres
        The planes ``n·x = d`` (world frame).
    rings : tuple of F tuples of int
        Each face's neighbours, counter-clockwise seen from outside.
    face_vertices : tuple of F tuples of int
        Each face's vertices (indices into `vertices`) in the same order: vertex i lies between
        the edges shared with ``rings[f][i]`` and ``rings[f][i+1]``.
    vertex_faces : tuple of V tuples of int
        The faces incident to each vertex, in cyclic order around it.
    vertices : (V, 3) array, metres, world frame
    vertex_residuals : (V,) array, metres
        Largest ``|n·x - d|`` over each vertex's faces (non-zero only where more than three
        faces meet and their planes are not concurrent).
    """

    names: tuple[str, ...]
    normals: FloatArray
    offsets: FloatArray
    rings: tuple[tuple[int, ...], ...]
    face_vertices: tuple[tuple[int, ...], ...]
    vertex_faces: tuple[tuple[int, ...], ...]
    vertices: FloatArray
    vertex_residuals: FloatArray
    max_condition: float = DEFAULT_MAX_CONDITION

    # ---- construction -------------------------------------------------------------------

    @classmethod
    def from_adjacency(
        cls,
        names: Sequence[str],
        normals: npt.ArrayLike,
        offsets: npt.ArrayLike,
        adjacency: Iterable[tuple[str, str]],
        *,
        max_condition: float = DEFAULT_MAX_CONDITION,
    ) -> Polyhedron:
        """A polyhedron from its planes and which faces meet along an edge.

        Parameters
        ----------
        names : sequence of F str
            Unique face names (role paths such as ``body.roof.front``).
        normals : (F, 3) array, unit, pointing out of the solid
        offsets : (F,) array, metres (``n·x = d``, world frame)
        adjacency : iterable of (str, str)
            Unordered pairs of faces sharing an edge (each pair once or twice, either order).
        max_condition : float
            Largest accepted condition number of a vertex's plane system.

        Raises
        ------
        GeometryError
            Naming the faces: see the module's list of checks.
        """
        nm, N, d = _planes(names, normals, offsets)
        rings = _rings_from_adjacency(nm, adjacency)
        topo = _topology(nm, rings)
        X, res = _vertices(nm, N, d, topo.vertex_faces, max_condition)
        # the embedding's mirror image is as planar as itself: keep the one enclosing a
        # positive volume with the given outward normals
        volume = sum(
            polygon_area(X[list(fv)], N[f]) * d[f] for f, fv in enumerate(topo.face_vertices)
        )
        if volume < 0:
            topo = _topology(nm, [r[::-1] for r in rings])
            X, res = _vertices(nm, N, d, topo.vertex_faces, max_condition)
        return cls._checked(nm, N, d, topo, X, res, max_condition)

    @classmethod
    def from_rings(
        cls,
        names: Sequence[str],
        normals: npt.ArrayLike,
        offsets: npt.ArrayLike,
        rings: Mapping[str, Sequence[str]],
        *,
        max_condition: float = DEFAULT_MAX_CONDITION,
    ) -> Polyhedron:
        """A polyhedron from its planes and each face's neighbours in cyclic order.

        Parameters
        ----------
        names, normals, offsets, max_condition
            As in `from_adjacency`.
        rings : mapping face name -> sequence of neighbour names
            Counter-clockwise seen from outside, starting anywhere.

        Raises
        ------
        GeometryError
            Rings that are not symmetric, not consistently oriented or not of a genus-0 solid
            (Euler characteristic), and the geometric checks of the module.
        """
        nm, N, d = _planes(names, normals, offsets)
        index = {n: i for i, n in enumerate(nm)}
        missing = [n for n in nm if n not in rings]
        unknown = sorted(({g for r in rings.values() for g in r} | set(rings)) - set(nm))
        if missing or unknown:
            raise GeometryError(
                f"rings: faces without a ring: {', '.join(missing) or '-'}; "
                f"unknown faces: {', '.join(unknown) or '-'}"
            )
        topo = _topology(nm, [[index[g] for g in rings[n]] for n in nm])
        X, res = _vertices(nm, N, d, topo.vertex_faces, max_condition)
        return cls._checked(nm, N, d, topo, X, res, max_condition)

    @classmethod
    def _checked(
        cls,
        names: tuple[str, ...],
        N: FloatArray,
        d: FloatArray,
        topo: _Topology,
        X: FloatArray,
        res: FloatArray,
        max_condition: float,
    ) -> Polyhedron:
        poly = cls(
            names, N, d, topo.rings, topo.face_vertices, topo.vertex_faces, X, res, max_condition
        )
        poly._validate()
        return poly

    def with_planes(self, normals: npt.ArrayLike, offsets: npt.ArrayLike) -> Polyhedron:
        """The same topology with moved planes: vertices recomputed, all checks run again.

        Parameters
        ----------
        normals : (F, 3) array, unit; offsets : (F,) array, metres
            In the order of `names`.
        """
        nm, N, d = _planes(self.names, normals, offsets)
        X, res = _vertices(nm, N, d, self.vertex_faces, self.max_condition)
        topo = _Topology(self.rings, self.face_vertices, self.vertex_faces)
        return self._checked(nm, N, d, topo, X, res, self.max_condition)

    def concurrent(self) -> Polyhedron:
        """The same solid with its planes moved until every vertex lies on all its faces.

        Where more than three planes meet (the eaves corner of a hip roof, a pyramid's apex)
        the vertex is their least-squares point, off each plane by its residual, and the faces
        are not planar. Alternating projections — each face's plane refitted to its vertices
        (least squares, same outward side), the vertices recomputed — lower the sum of squared
        vertex-plane distances at every step, to zero for a consistent solid; the planes move
        by about the residuals. Stops when every residual is below `CONCURRENT_TOLERANCE` of
        the solid's size or after `MAX_CONCURRENT_ROUNDS`. A solid whose residuals are already
        below that is returned as it is.
        """
        solid = self
        tolerance = CONCURRENT_TOLERANCE * max(self.size, 1e-300)
        for _ in range(MAX_CONCURRENT_ROUNDS):
            if float(solid.vertex_residuals.max(initial=0.0)) <= tolerance:
                break
            normals = np.empty_like(solid.normals)
            offsets = np.empty_like(solid.offsets)
            for f, vertices in enumerate(solid.face_vertices):
                points = solid.vertices[list(vertices)]
                centre = points.mean(axis=0)
                n = np.linalg.svd(points - centre)[2][-1]
                n = n if float(n @ solid.normals[f]) >= 0 else -n
                normals[f], offsets[f] = n, float(n @ centre)
            solid = solid.with_planes(normals, offsets)
        return solid

    # ---- checks -------------------------------------------------------------------------

    @property
    def size(self) -> float:
        """The largest extent of the vertices' bounding box, metres."""
        return float(np.max(np.ptp(self.vertices, axis=0)))

    def _validate(self) -> None:
        c = _corners(self.rings, self.face_vertices)
        size = self.size
        tol = RELATIVE_TOLERANCE * max(size, 1e-300)
        P = self.vertices[c.vertex]
        Q = P[c.next]
        lengths = np.linalg.norm(Q - P, axis=1)
        short = np.flatnonzero(lengths <= tol)
        if short.size:
            e = int(short[0])
            raise GeometryError(
                f"face {self.names[c.face[e]]}: its edge with {self.names[c.edge_face[e]]} has "
                f"zero length ({lengths[e]:.3g} m); the faces around it do not form a polygon"
            )
        u, v = plane_bases(self.normals)
        p2 = np.stack([np.einsum("cj,cj->c", P, u[c.face]), np.einsum("cj,cj->c", P, v[c.face])], 1)
        i, j = c.pair_i, c.pair_j
        hits = np.flatnonzero(segments_touch(p2[i], p2[c.next[i]], p2[j], p2[c.next[j]], tol))
        if hits.size:
            e1, e2 = int(i[hits[0]]), int(j[hits[0]])
            a, b = self.names[c.edge_face[e1]], self.names[c.edge_face[e2]]
            raise GeometryError(
                f"face {self.names[c.face[e1]]}: its polygon intersects itself (its edges with "
                f"{a} and {b} cross)"
            )
        areas = self._areas(P, Q, c)
        flat = np.flatnonzero(~(areas > tol * size))
        if flat.size:
            f = int(flat[0])
            around = ", ".join(self.names[g] for g in self.rings[f])
            raise GeometryError(
                f"face {self.names[f]}: its polygon (neighbours {around}) runs clockwise about "
                f"its normal (area {areas[f]:.6g} m²): the planes cross over, or the normal "
                "points into the solid"
            )
        volume = float(areas @ self.offsets) / 3.0
        if not volume > 0:
            raise GeometryError(f"the solid encloses a non-positive volume ({volume:.6g} m³)")

    def _areas(self, P: FloatArray, Q: FloatArray, c: _Corners) -> FloatArray:
        twice = np.einsum("cj,cj->c", np.cross(P, Q), self.normals[c.face])
        areas: FloatArray = 0.5 * np.add.reduceat(twice, c.start)
        return areas

    # ---- topology -----------------------------------------------------------------------

    def face_index(self, face: str | int) -> int:
        """Index of a face given by name or index."""
        if isinstance(face, int):
            if not 0 <= face < len(self.names):
                raise GeometryError(f"no face {face}: the polyhedron has {len(self.names)} faces")
            return face
        try:
            return self.names.index(face)
        except ValueError:
            raise GeometryError(f"no face named {face!r}") from None

    @property
    def edges(self) -> tuple[IntArray, IntArray]:
        """Edges as (vertex pairs (E, 2), face pairs (E, 2)); the first face is the lower index.

        The vertex pair runs counter-clockwise along the first face.
        """
        c = _corners(self.rings, self.face_vertices)
        keep = c.face < c.edge_face
        vs = np.stack([c.vertex[keep], c.vertex[c.next[keep]]], axis=1)
        return vs, np.stack([c.face[keep], c.edge_face[keep]], axis=1)

    @property
    def euler_characteristic(self) -> int:
        """V - E + F (2 for a closed polyhedron without holes)."""
        E = sum(len(r) for r in self.rings) // 2
        return len(self.vertex_faces) - E + len(self.names)

    # ---- geometry -----------------------------------------------------------------------

    def polygon(self, face: str | int) -> FloatArray:
        """A face's polygon (K, 3), metres, counter-clockwise seen from outside."""
        f = self.face_index(face)
        return np.array(self.vertices[list(self.face_vertices[f])])

    def polygons(self) -> dict[str, FloatArray]:
        """Every face's polygon (K, 3), by name, in the order of `names`."""
        return {n: self.polygon(f) for f, n in enumerate(self.names)}

    def face_areas(self) -> FloatArray:
        """(F,) areas, m²."""
        c = _corners(self.rings, self.face_vertices)
        P = self.vertices[c.vertex]
        return self._areas(P, P[c.next], c)

    def face_centroids(self) -> FloatArray:
        """(F, 3) area centroids of the faces, metres."""
        c = _corners(self.rings, self.face_vertices)
        P = self.vertices[c.vertex]
        counts = np.diff(np.append(c.start, len(c.face)))
        o = np.add.reduceat(P, c.start, axis=0) / counts[:, None]
        a = P - o[c.face]
        b = a[c.next]
        w = np.einsum("cj,cj->c", np.cross(a, b), self.normals[c.face])
        total = np.add.reduceat(w, c.start)
        centroids: FloatArray = o + np.add.reduceat(w[:, None] * (a + b), c.start, axis=0) / (
            3.0 * total[:, None]
        )
        return centroids

    def volume(self) -> float:
        """Enclosed volume, m³ (divergence theorem: sum of area times offset over 3)."""
        return float(self.face_areas() @ self.offsets) / 3.0

    def is_convex(self, tol: float | None = None) -> bool:
        """True if no vertex lies outside any face's plane by more than `tol` metres.

        `tol` defaults to ``RELATIVE_TOLERANCE * size``.
        """
        t = RELATIVE_TOLERANCE * self.size if tol is None else tol
        if not np.isfinite(t):
            raise GeometryError(f"tolerance must be a finite number of metres, got {t}")
        return bool(np.all(self.vertices @ self.normals.T - self.offsets <= t))

    def vertex_jacobians(self) -> list[VertexJacobians]:
        """Derivatives of every vertex w.r.t. the planes of its faces, grouped by degree.

        Returns
        -------
        list of VertexJacobians
            One entry per vertex degree k present (3 first); see `VertexJacobians`.
        """
        out = []
        for ids, faces in _vertex_groups(self.vertex_faces):
            labels = [[self.names[f] for f in row] for row in faces]
            jac = intersect_planes_with_jacobians(
                self.normals[faces],
                self.offsets[faces],
                names=labels,
                max_condition=self.max_condition,
            )
            out.append(VertexJacobians(ids, faces, jac.d_points_d_normals, jac.d_points_d_offsets))
        return out
