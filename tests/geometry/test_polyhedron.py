"""Closed polyhedra from planes and face adjacency: synthetic buildings as ground truth."""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Sequence

import numpy as np
import pytest

from aida_kb.errors import GeometryError
from aida_kb.geometry.polygon import intersect_planes, polygon_centroid
from aida_kb.geometry.polyhedron import CONCURRENT_TOLERANCE, Polyhedron
from aida_kb.geometry.rotation import rotation_from_rvec
from aida_kb.synth import buildings
from aida_kb.synth.buildings import polygon_normal

Faces = dict[str, np.ndarray]


def _adjacency(faces: Faces) -> set[tuple[str, str]]:
    """Pairs of faces sharing an edge of their polygons (each edge exactly twice)."""
    owners: dict[tuple[tuple[float, ...], ...], list[str]] = {}
    for name, P in faces.items():
        for i in range(len(P)):
            a, b = tuple(np.round(P[i], 9)), tuple(np.round(P[(i + 1) % len(P)], 9))
            owners.setdefault(tuple(sorted([a, b])), []).append(name)
    assert all(len(v) == 2 for v in owners.values()), "test solid is not closed"
    return {(v[0], v[1]) for v in owners.values()}


def _planes(faces: Faces) -> tuple[list[str], np.ndarray, np.ndarray]:
    names = list(faces)
    N = np.array([polygon_normal(faces[n]) for n in names])
    d = np.array([N[i] @ faces[n].mean(axis=0) for i, n in enumerate(names)])
    return names, N, d


def _build(faces: Faces) -> Polyhedron:
    names, N, d = _planes(faces)
    return Polyhedron.from_adjacency(names, N, d, _adjacency(faces))


def _same_cycle(got: np.ndarray, want: np.ndarray) -> float:
    """Smallest max-deviation over the cyclic shifts (same direction only)."""
    assert got.shape == want.shape
    return min(float(np.max(np.abs(np.roll(got, r, axis=0) - want))) for r in range(len(want)))


def _volume(faces: Faces) -> float:
    v = 0.0
    for P in faces.values():
        for i in range(1, len(P) - 1):
            v += float(P[0] @ np.cross(P[i], P[i + 1])) / 6.0
    return v


# ---- synthetic buildings as ground truth ---------------------------------------------------

SYNTH = {
    "gable": lambda: buildings.house(roof="gable"),
    "hip": lambda: buildings.house(roof="hip"),
    "flat": lambda: buildings.house(roof="flat"),
    "shed": lambda: buildings.house(roof="shed"),
    "lshape90": lambda: buildings.lshape_house(),
    "lshape135": lambda: buildings.lshape_house(meeting_deg=135.0),
    "oriels": lambda: buildings.oriel_house(),
    "tower": lambda: buildings.tower(),
    "box": lambda: buildings.reference_box(),
}


@pytest.mark.parametrize("preset", sorted(SYNTH))
def test_synth_buildings_rebuilt_from_planes(preset: str) -> None:
    model = SYNTH[preset]()
    # also in the world frame of a camera: an arbitrary rotation and translation
    R = rotation_from_rvec([0.3, -2.0, 0.4])
    for mdl in (model, model.transformed(R, np.array([3.0, -1.5, 25.0]))):
        for solid in mdl.solids:
            truth = {f.role: f.polygon for f in solid.faces}
            poly = _build(truth)
            assert poly.euler_characteristic == 2
            assert poly.is_convex()  # synth solids are convex pieces of a union
            for name, P in poly.polygons().items():
                assert _same_cycle(P, truth[name]) < 1e-9, name
            assert poly.volume() == pytest.approx(buildings.signed_volume(solid), rel=1e-12)
            assert float(np.max(poly.vertex_residuals)) < 1e-9


def test_hip_roof_has_degree_four_eaves_corners() -> None:
    poly = _build({f.role: f.polygon for f in buildings.house(roof="hip").faces})
    degrees = sorted(len(c) for c in poly.vertex_faces)
    assert degrees == [3, 3, 3, 3, 3, 3, 4, 4, 4, 4]
    for corner in (c for c in poly.vertex_faces if len(c) == 4):
        roofs = [poly.names[f] for f in corner if ".roof." in poly.names[f]]
        assert len(roofs) == 2  # two walls and two roof planes meet at each eaves corner


def test_concurrent_moves_non_concurrent_planes_until_every_vertex_lies_on_its_faces() -> None:
    truth = {f.role: f.polygon for f in buildings.tower().faces}
    exact = _build(truth)
    assert exact.concurrent() is exact  # nothing to move
    rng = np.random.default_rng(3)
    N = exact.normals + rng.normal(0.0, 0.01, exact.normals.shape)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    d = exact.offsets + rng.normal(0.0, 0.01, exact.offsets.shape)
    tilted = exact.with_planes(N, d)
    assert float(np.max(tilted.vertex_residuals)) > 0.01  # the apex and eaves corners
    moved = tilted.concurrent()
    tolerance = CONCURRENT_TOLERANCE * moved.size
    assert float(np.max(moved.vertex_residuals)) <= tolerance
    for name, polygon in moved.polygons().items():
        f = moved.names.index(name)
        assert np.max(np.abs(polygon @ moved.normals[f] - moved.offsets[f])) <= tolerance
    # the planes moved by about the residuals, not more
    turned = np.degrees(np.arccos(np.clip(np.sum(moved.normals * N, axis=1), -1.0, 1.0)))
    assert float(np.max(turned)) < 1.5
    assert float(np.max(np.abs(moved.offsets - d))) < 0.1


# ---- non-convex solids -------------------------------------------------------------------


def _extrusion(footprint: Sequence[tuple[float, float]], height: float, prefix: str) -> Faces:
    """A prism over a footprint (x, z) counter-clockwise seen from above (+y), y up."""
    f = np.array(footprint, dtype=float)
    if np.sum(f[:, 0] * np.roll(f[:, 1], -1) - f[:, 1] * np.roll(f[:, 0], -1)) > 0:
        f = f[::-1]  # seen from +y, counter-clockwise means negative (x, z) shoelace
    bottom = np.column_stack([f[:, 0], np.zeros(len(f)), f[:, 1]])
    top = bottom + np.array([0.0, height, 0.0])
    faces: Faces = {f"{prefix}.floor": bottom[::-1], f"{prefix}.roof.top": top}
    for i in range(len(f)):
        j = (i + 1) % len(f)
        faces[f"{prefix}.wall[{i}]"] = np.array([bottom[i], bottom[j], top[j], top[i]])
    return faces


def test_l_shaped_house_is_closed_and_not_convex() -> None:
    faces = _extrusion([(0, 0), (10, 0), (10, 4), (4, 4), (4, 10), (0, 10)], 6.0, "body")
    assert polygon_normal(faces["body.roof.top"])[1] == pytest.approx(1.0)
    poly = _build(faces)
    assert not poly.is_convex()
    assert poly.volume() == pytest.approx(6.0 * (10 * 4 + 4 * 6), rel=1e-13)
    assert poly.euler_characteristic == 2
    assert (len(poly.vertices), poly.edges[0].shape[0]) == (12, 18)
    for name, P in poly.polygons().items():
        assert _same_cycle(P, faces[name]) < 1e-12, name
    top = poly.face_index("body.roof.top")
    np.testing.assert_allclose(poly.face_areas()[top], 64.0)
    np.testing.assert_allclose(poly.face_centroids()[top], [3.875, 6.0, 3.875], atol=1e-14)


def _bay_house(pitch_deg: float = 35.0) -> Faces:
    """A gable house with a full-height oriel (bay) on its front wall, as ONE solid.

    Site frame: x right, y up, z out of the front wall. Body 12 x 10, eaves at 6 m; the bay
    spans x in [-2, 2], stands 1.5 m out and has a flat top at eaves height, so that its top
    and side walls meet the front roof in two corners of four faces.
    """
    h, hr = 6.0, 6.0 + 5.0 * math.tan(math.radians(pitch_deg))

    def p(x: float, y: float, z: float) -> np.ndarray:
        return np.array([x, y, z], dtype=float)

    A, B, C, D = p(-6, 0, -5), p(6, 0, -5), p(6, 0, 5), p(-6, 0, 5)
    E, F, G, H = p(-2, 0, 5), p(2, 0, 5), p(2, 0, 6.5), p(-2, 0, 6.5)

    def up(q: np.ndarray) -> np.ndarray:
        return q + np.array([0.0, h, 0.0])

    RL, RR = p(-6, hr, 0), p(6, hr, 0)
    faces = {
        "body.floor": [A, B, C, F, G, H, E, D],
        "body.back": [A, B, up(B), up(A)],
        "body.left": [A, D, up(D), RL, up(A)],
        "body.right": [B, C, up(C), RR, up(B)],
        "body.front_left": [D, E, up(E), up(D)],
        "body.front_right": [F, C, up(C), up(F)],
        "body.oriels[0].left": [E, H, up(H), up(E)],
        "body.oriels[0].right": [F, G, up(G), up(F)],
        "body.oriels[0].front": [H, G, up(G), up(H)],
        "body.oriels[0].top": [up(E), up(F), up(G), up(H)],
        "body.roof.front": [up(D), up(E), up(F), up(C), RR, RL],
        "body.roof.back": [up(A), up(B), RR, RL],
    }
    outward = {
        "floor": (0, -1, 0),
        "back": (0, 0, -1),
        "left": (-1, 0, 0),
        "right": (1, 0, 0),
        "front_left": (0, 0, 1),
        "front_right": (0, 0, 1),
        "front": (0, 0, 1),
        "top": (0, 1, 0),
    }
    out: Faces = {}
    for name, verts in faces.items():
        P = np.array(verts)
        key = name.split(".")[-1]
        hint = np.array(outward.get(key, (0, 1, 1 if name.endswith("roof.front") else -1)))
        if polygon_normal(P) @ hint < 0:
            P = P[::-1]
        out[name] = P
    return out


def test_house_with_an_oriel_is_closed_and_not_convex() -> None:
    faces = _bay_house()
    poly = _build(faces)
    assert not poly.is_convex()
    assert poly.volume() == pytest.approx(_volume(faces), rel=1e-12)
    ridge = 5.0 * math.tan(math.radians(35.0))
    assert poly.volume() == pytest.approx(12 * 10 * 6 + 0.5 * 10 * ridge * 12 + 4 * 1.5 * 6)
    for name, P in poly.polygons().items():
        assert _same_cycle(P, faces[name]) < 1e-9, name
    for f, centroid in enumerate(poly.face_centroids()):
        np.testing.assert_allclose(
            centroid, polygon_centroid(poly.polygon(f), poly.normals[f]), atol=1e-12
        )
    four = [c for c in poly.vertex_faces if len(c) == 4]
    assert len(four) == 2  # the bay's top corners on the eaves line
    assert float(np.max(poly.vertex_residuals)) < 1e-12


# ---- rings -----------------------------------------------------------------------------------


def test_from_rings_equals_from_adjacency_and_checks_orientation() -> None:
    faces = _bay_house()
    poly = _build(faces)
    names = list(poly.names)
    rings = {n: [names[g] for g in poly.rings[f]] for f, n in enumerate(names)}
    again = Polyhedron.from_rings(names, poly.normals, poly.offsets, rings)
    np.testing.assert_array_equal(again.vertices, poly.vertices)
    assert again.face_vertices == poly.face_vertices
    mirrored = {n: r[::-1] for n, r in rings.items()}
    with pytest.raises(GeometryError, match="clockwise"):
        Polyhedron.from_rings(names, poly.normals, poly.offsets, mirrored)
    broken = dict(rings)
    broken["body.floor"] = broken["body.floor"][1:]
    with pytest.raises(GeometryError, match="not symmetric"):
        Polyhedron.from_rings(names, poly.normals, poly.offsets, broken)
    with pytest.raises(GeometryError, match="unknown faces: nowhere"):
        Polyhedron.from_rings(names, poly.normals, poly.offsets, {**rings, "nowhere": []})


def test_rings_of_a_torus_are_refused() -> None:
    # K4 (the tetrahedron's adjacency) with every choice of rotations: only the planar ones
    # describe a closed solid; all others must be refused, whatever the planes
    names = ["a", "b", "c", "d"]
    N = np.array([[-1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0], _unit((1.0, 1.0, 1.0))])
    d = np.array([0.0, 0.0, 0.0, 1.0])
    messages = []
    for flips in itertools.product([False, True], repeat=4):
        rings = {}
        for i, n in enumerate(names):
            others = [m for m in names if m != n]
            rings[n] = others[::-1] if flips[i] else others
        try:
            Polyhedron.from_rings(names, N, d, rings)
            messages.append("accepted")
        except GeometryError as err:
            messages.append(str(err))
    assert messages.count("accepted") == 1
    refused = [m for m in messages if m != "accepted"]
    assert all(re.search("Euler|not those of a closed solid|clockwise", m) for m in refused)
    assert any("Euler" in m or "not those" in m for m in refused)  # topology, not geometry


def _unit(v: tuple[float, float, float]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


# ---- errors ----------------------------------------------------------------------------------


def _gable() -> tuple[list[str], np.ndarray, np.ndarray, set[tuple[str, str]]]:
    faces = {f.role: f.polygon for f in buildings.house(roof="gable").faces}
    names, N, d = _planes(faces)
    return names, N, d, _adjacency(faces)


def test_adjacency_errors() -> None:
    names, N, d, adj = _gable()
    with pytest.raises(GeometryError, match=r"unknown face 'body\.chimney'"):
        Polyhedron.from_adjacency(names, N, d, [*adj, ("body.front", "body.chimney")])
    few = {p for p in adj if "body.floor" not in p or "body.front" in p or "body.back" in p}
    with pytest.raises(GeometryError, match=r"fewer than 3 neighbours.*body\.floor"):
        Polyhedron.from_adjacency(names, N, d, few)
    with pytest.raises(GeometryError, match="unique"):
        Polyhedron.from_adjacency([*names[:-1], names[0]], N, d, adj)
    with pytest.raises(GeometryError, match="unit vector"):
        Polyhedron.from_adjacency(names, N * 1.01, d, adj)


def test_non_planar_and_ambiguous_adjacency() -> None:
    k33 = [(a, b) for a in "abc" for b in "xyz"]
    N = np.tile(np.eye(3), (2, 1))
    with pytest.raises(GeometryError, match="not planar"):
        Polyhedron.from_adjacency(list("abcxyz"), N, np.zeros(6), k33)
    two_k4 = [("a", "b"), ("a", "c"), ("a", "d"), ("b", "c"), ("b", "d"), ("c", "d")]
    two_k4 += [("a", "e"), ("a", "f"), ("b", "e"), ("b", "f"), ("e", "f")]
    with pytest.raises(GeometryError, match="faces a, b separate it"):
        Polyhedron.from_adjacency(list("abcdef"), N, np.zeros(6), two_k4)
    cubes = [(a, b) for a, b in itertools.combinations("abcd", 2)]
    cubes += [(a, b) for a, b in itertools.combinations("efgh", 2)]
    with pytest.raises(GeometryError, match="2 separate solids"):
        Polyhedron.from_adjacency(
            list("abcdefgh"), np.tile(np.eye(3), (3, 1))[:8], np.zeros(8), cubes
        )


def test_near_parallel_neighbours_are_named() -> None:
    faces = {f.role: f.polygon for f in buildings.house(roof="flat").faces}
    names, N, d = _planes(faces)
    top = names.index("body.roof.top")
    front = names.index("body.front")
    N[top] = _unit(N[front] + [0.0, 1e-8, 0.0])
    with pytest.raises(GeometryError, match=r"degenerate vertex of .*body.front.*parallel"):
        Polyhedron.from_adjacency(names, N, d, _adjacency(faces))


def test_vertex_at_infinity_is_named() -> None:
    faces = {f.role: f.polygon for f in buildings.house(roof="flat").faces}
    names, N, d = _planes(faces)
    # the top turned to face front-left: its normal lies in the plane of front's and left's
    top = names.index("body.roof.top")
    N[top] = _unit(N[names.index("body.front")] + N[names.index("body.left")])
    with pytest.raises(GeometryError, match="infinity"):
        Polyhedron.from_adjacency(names, N, d, _adjacency(faces))


def test_self_intersecting_roof_polygon() -> None:
    # a hip roof whose side planes are pushed past each other: the ridge turns inside out
    faces = {f.role: f.polygon for f in buildings.house(roof="hip").faces}
    names, N, d = _planes(faces)
    for side in ("body.roof.left", "body.roof.right"):
        d[names.index(side)] -= 8.0
    with pytest.raises(GeometryError, match=r"face body\.roof\.(front|back)"):
        Polyhedron.from_adjacency(names, N, d, _adjacency(faces))


def test_self_intersecting_floor_polygon() -> None:
    # the L's inner wall (z = 4) pushed beyond the outer wall z = 0: the footprint crosses itself
    faces = _extrusion([(0, 0), (10, 0), (10, 4), (4, 4), (4, 10), (0, 10)], 6.0, "body")
    poly = _build(faces)
    inner = poly.face_index("body.wall[2]")
    np.testing.assert_allclose([*poly.normals[inner], poly.offsets[inner]], [0, 0, 1, 4])
    d = poly.offsets.copy()
    d[inner] = -2.0
    with pytest.raises(GeometryError, match=r"face body\.floor: its polygon intersects itself"):
        poly.with_planes(poly.normals, d)


def test_inward_normal_is_refused() -> None:
    names, N, d, adj = _gable()
    i = names.index("body.left")
    N[i], d[i] = -N[i], -d[i]
    with pytest.raises(GeometryError, match=r"face body\.left: .*clockwise"):
        Polyhedron.from_adjacency(names, N, d, adj)


# ---- moving planes, Jacobians, measures ------------------------------------------------------


def _perturbed(poly: Polyhedron, scale: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    N = np.array([rotation_from_rvec(rng.normal(scale=scale, size=3)) @ n for n in poly.normals])
    return N, poly.offsets + rng.normal(scale=scale * 5, size=len(poly.offsets))


def test_with_planes_keeps_topology_and_refuses_degenerate_moves() -> None:
    poly = _build({f.role: f.polygon for f in buildings.house(roof="hip").faces})
    N, d = _perturbed(poly, 0.01, 0)
    moved = poly.with_planes(N, d)
    assert moved.face_vertices == poly.face_vertices
    assert 0 < np.max(np.abs(moved.vertices - poly.vertices)) < 1.0
    # the degree-4 eaves corners are no longer concurrent: the residual says by how much
    assert float(np.max(moved.vertex_residuals)) > 1e-4
    for f in range(len(moved.names)):
        P = moved.polygon(f)
        assert np.all(
            np.abs(P @ moved.normals[f] - moved.offsets[f])
            <= moved.vertex_residuals[list(moved.face_vertices[f])] + 1e-12
        )
    d_bad = d.copy()
    d_bad[poly.face_index("body.roof.left")] -= 30.0
    with pytest.raises(GeometryError, match=r"body\.roof"):
        poly.with_planes(N, d_bad)


@pytest.mark.parametrize("preset", ["gable", "hip"])
def test_vertex_jacobians_match_finite_differences(preset: str) -> None:
    poly0 = _build({f.role: f.polygon for f in SYNTH[preset]().faces})
    poly = poly0.with_planes(*_perturbed(poly0, 0.005, 1))
    groups = poly.vertex_jacobians()
    assert sorted(int(i) for g in groups for i in g.vertex_ids) == list(range(len(poly.vertices)))
    h = 1e-6
    N0, d0 = poly.normals, poly.offsets
    for v in range(len(poly.vertices)):
        np.testing.assert_allclose(_vertex(poly, v, N0, d0), poly.vertices[v], atol=1e-12)
    for g in groups:
        for slot in range(g.faces.shape[1]):
            for row, v in enumerate(g.vertex_ids):
                f = int(g.faces[row, slot])
                dp = np.zeros(len(poly.names))
                dp[f] = h
                fd = (_vertex(poly, v, N0, d0 + dp) - _vertex(poly, v, N0, d0 - dp)) / (2 * h)
                np.testing.assert_allclose(g.d_vertices_d_offsets[row, :, slot], fd, atol=1e-7)
                for comp in range(3):
                    # the normal moves off the unit sphere: the plane systems take any normal
                    E = np.zeros_like(N0)
                    E[f, comp] = h
                    fd = (_vertex(poly, v, N0 + E, d0) - _vertex(poly, v, N0 - E, d0)) / (2 * h)
                    np.testing.assert_allclose(
                        g.d_vertices_d_normals[row, :, slot, comp], fd, atol=1e-6
                    )


def _vertex(poly: Polyhedron, v: int, normals: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    faces = list(poly.vertex_faces[v])
    return intersect_planes(normals[faces][None], offsets[faces][None])[0]


def test_measures_of_a_box() -> None:
    faces = {f.role: f.polygon for f in buildings.reference_box(0.4, 0.3, 0.25).faces}
    poly = _build(faces)
    areas = dict(zip(poly.names, poly.face_areas(), strict=True))
    assert areas["box.front"] == pytest.approx(0.4 * 0.25)
    assert areas["box.top"] == pytest.approx(0.4 * 0.3)
    centroids = dict(zip(poly.names, poly.face_centroids(), strict=True))
    np.testing.assert_allclose(centroids["box.top"], [0.0, 0.25, 0.0], atol=1e-15)
    assert poly.volume() == pytest.approx(0.4 * 0.3 * 0.25)
    assert poly.size == pytest.approx(0.4)
    vs, fs = poly.edges
    assert vs.shape == (12, 2)
    assert fs.shape == (12, 2)
    for (a, b), (f, g) in zip(vs, fs, strict=True):
        for face in (f, g):
            assert {int(a), int(b)} <= set(poly.face_vertices[face])
    assert poly.face_index("box.top") == poly.names.index("box.top")
    with pytest.raises(GeometryError, match="no face named"):
        poly.face_index("box.lid")
