"""Synthetic constraint problems with ground truth: the paper-sized house and rows of houses.

`paper_house` is a house of 28 surface elements tied by 51 constraints, the size of the
paper's result (§6.1): a hip-roofed main body (floor, four walls, four roof planes), a gable
wing meeting the body's front wall at 135 degrees (floor, four walls, two roof planes) and two
box oriels on the front wall (six faces each); 23 internal constraints (angle, parallel,
parallel-edge, symmetry) and one position constraint per part, from simulated region evidence
(noisy plane fits). `house_row` repeats it along a street, linking neighbours by parallel
fronts. Coordinates: world frame (OpenCV camera at the origin, y down, z forward), metres; the
houses stand about 25 m in front of the camera.

Used by the tests and `benchmarks/solver.py`; not part of the reconstruction itself.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, PositionData
from aida_kb.geometry.polygon import intersect_planes

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

_SITE_TO_WORLD = np.diag([1.0, -1.0, -1.0])  # site: y up, z towards the viewer
_WORLD_SHIFT = np.array([0.0, 6.0, 30.0])


@dataclass(frozen=True)
class SyntheticScene:
    """Ground truth and constraints of a synthetic problem.

    Attributes
    ----------
    names : (P,) role paths of the parts (``h0.body.front`` ...).
    normals : (P, 3) true unit normals; offsets : (P,) true offsets, metres; world frame.
    centres : (P, 3) true part centres (mean of the face's vertices), metres.
    solids : part indices of each convex solid.
    vertex_planes : (V, 3) the three planes meeting at each vertex; vertices : (V, 3) metres.
    constraints : internal constraints followed by the position constraints.
    size : the diagonal of the scene's bounding box, metres.
    """

    names: tuple[str, ...]
    normals: FloatArray
    offsets: FloatArray
    centres: FloatArray
    solids: tuple[tuple[int, ...], ...]
    vertex_planes: IntArray
    vertices: FloatArray
    constraints: tuple[Constraint, ...]
    size: float

    def index(self, name: str) -> int:
        """The index of the part called ``name``."""
        return self.names.index(name)


def _convex_vertices(
    normals: FloatArray, offsets: FloatArray, solid: tuple[int, ...]
) -> tuple[list[tuple[int, int, int]], list[FloatArray]]:
    triples = np.array(list(itertools.combinations(solid, 3)), dtype=np.intp)
    A = normals[triples]
    det = np.abs(np.linalg.det(A))
    ok = det > 1e-6
    triples, det = triples[ok], det[ok]
    pts = intersect_planes(normals[triples], offsets[triples])
    s = np.array(solid, dtype=np.intp)
    inside = np.all(pts @ normals[s].T <= offsets[s] + 1e-7, axis=1)
    triples, det, pts = triples[inside], det[inside], pts[inside]
    best: list[tuple[int, int, int]] = []
    points: list[FloatArray] = []
    for j in np.argsort(-det):
        if any(np.linalg.norm(pts[j] - q) < 1e-6 for q in points):
            continue
        best.append((int(triples[j, 0]), int(triples[j, 1]), int(triples[j, 2])))
        points.append(pts[j])
    return best, points


class _Builder:
    def __init__(self) -> None:
        self.names: list[str] = []
        self.normals: list[FloatArray] = []
        self.points: list[FloatArray] = []
        self.solids: list[tuple[int, ...]] = []
        self.internal: list[Constraint] = []

    def solid(self, shift: FloatArray, faces: list[tuple[str, FloatArray, FloatArray]]) -> None:
        ids = []
        for name, n, p in faces:
            ids.append(len(self.names))
            self.names.append(name)
            nw = _SITE_TO_WORLD @ (n / np.linalg.norm(n))
            self.normals.append(nw)
            self.points.append(_SITE_TO_WORLD @ (p + shift) + _WORLD_SHIFT)
        self.solids.append(tuple(ids))

    def i(self, name: str) -> int:
        return self.names.index(name)

    def add(
        self, kind: str, names: tuple[str, ...], value: float | None = None, sigma_deg: float = 0.05
    ) -> None:
        label = f"{kind}({', '.join(names)})"
        self.internal.append(
            Constraint(
                kind=kind,
                parts=tuple(self.i(n) for n in names),
                value=value,
                sigma=math.radians(sigma_deg),
                unit="rad",
                label=label,
            )
        )


def _add_house(b: _Builder, pre: str, x0: float, wing_deg: float) -> None:
    W, D, H, p = 16.0, 10.0, 9.0, math.radians(35.0)
    cp, sp_ = math.cos(p), math.sin(p)
    shift = np.array([x0, 0.0, 0.0])
    v = np.array
    bd = f"{pre}body"
    b.solid(
        shift,
        [
            (f"{bd}.floor", v([0.0, -1, 0]), v([0.0, 0, 0])),
            (f"{bd}.front", v([0.0, 0, 1]), v([0.0, 0, D / 2])),
            (f"{bd}.back", v([0.0, 0, -1]), v([0.0, 0, -D / 2])),
            (f"{bd}.left", v([-1.0, 0, 0]), v([-W / 2, 0, 0])),
            (f"{bd}.right", v([1.0, 0, 0]), v([W / 2, 0, 0])),
            (f"{bd}.roof.front", v([0.0, cp, sp_]), v([0.0, H, D / 2])),
            (f"{bd}.roof.back", v([0.0, cp, -sp_]), v([0.0, H, -D / 2])),
            (f"{bd}.roof.left", v([-sp_, cp, 0]), v([-W / 2, H, 0])),
            (f"{bd}.roof.right", v([sp_, cp, 0]), v([W / 2, H, 0])),
        ],
    )
    # the wing: its axis turned by (wing_deg - 90) from +z towards +x, from inside the body,
    # so that its front wall's normal makes (180 - wing_deg) with the body's front normal
    turn = math.radians(wing_deg - 90.0)
    axis = v([math.sin(turn), 0.0, math.cos(turn)])
    across = v([math.cos(turn), 0.0, -math.sin(turn)])  # points to the wing's back
    ww, Hw, L = 3.0, 7.0, 12.0
    B = v([W / 2 - D / 2, 0.0, 0.0])
    up = v([0.0, 1.0, 0.0])
    wg = f"{pre}body.wings[0]"
    b.solid(
        shift,
        [
            (f"{wg}.floor", v([0.0, -1, 0]), B),
            (f"{wg}.front", -across, B - ww * across),
            (f"{wg}.back", across, B + ww * across),
            (f"{wg}.left", axis, B + L * axis),
            (f"{wg}.right", -axis, B),
            (f"{wg}.roof.front", cp * up - sp_ * across, B + Hw * up - ww * across),
            (f"{wg}.roof.back", cp * up + sp_ * across, B + Hw * up + ww * across),
        ],
    )
    for k, xc in enumerate((-5.0, -1.0)):
        o = f"{pre}body.oriels[{k}]"
        x_0, x_1, y0, y1, z0, z1 = xc - 1.2, xc + 1.2, 3.0, 7.0, D / 2 - 0.3, D / 2 + 1.2
        b.solid(
            shift,
            [
                (f"{o}.front", v([0.0, 0, 1]), v([xc, y0, z1])),
                (f"{o}.back", v([0.0, 0, -1]), v([xc, y0, z0])),
                (f"{o}.left", v([-1.0, 0, 0]), v([x_0, y0, z0])),
                (f"{o}.right", v([1.0, 0, 0]), v([x_1, y0, z0])),
                (f"{o}.top", v([0.0, 1, 0]), v([xc, y1, z0])),
                (f"{o}.bottom", v([0.0, -1, 0]), v([xc, y0, z0])),
            ],
        )
    right = math.pi / 2
    # body: 9 internal constraints
    b.add("angle", (f"{bd}.front", f"{bd}.left"), right)
    b.add("angle", (f"{bd}.front", f"{bd}.right"), right)
    b.add("angle", (f"{bd}.back", f"{bd}.left"), right)
    b.add("parallel", (f"{bd}.front", f"{bd}.back"))
    b.add("parallel", (f"{bd}.left", f"{bd}.right"))
    b.add("angle", (f"{bd}.front", f"{bd}.floor"), right)
    b.add("symmetry", (f"{bd}.front", f"{bd}.roof.front", f"{bd}.back", f"{bd}.roof.back"))
    b.add("symmetry", (f"{bd}.left", f"{bd}.roof.left", f"{bd}.right", f"{bd}.roof.right"))
    b.add("parallel_edge", (f"{bd}.front", f"{bd}.roof.front", f"{bd}.back", f"{bd}.roof.back"))
    # wing: 6
    b.add("angle", (f"{bd}.front", f"{wg}.front"), math.radians(wing_deg))
    b.add("angle", (f"{wg}.front", f"{wg}.left"), right)
    b.add("parallel", (f"{wg}.front", f"{wg}.back"))
    b.add("parallel", (f"{wg}.floor", f"{bd}.floor"))
    b.add("symmetry", (f"{wg}.front", f"{wg}.roof.front", f"{wg}.back", f"{wg}.roof.back"))
    b.add("parallel_edge", (f"{wg}.front", f"{wg}.roof.front", f"{wg}.back", f"{wg}.roof.back"))
    # oriels: 4 each
    for k in range(2):
        o = f"{pre}body.oriels[{k}]"
        b.add("parallel", (f"{o}.front", f"{bd}.front"))
        b.add("angle", (f"{o}.front", f"{o}.left"), right)
        b.add("parallel", (f"{o}.left", f"{o}.right"))
        b.add("parallel", (f"{o}.top", f"{o}.bottom"))


def _random_tilt(rng: np.random.Generator, n: FloatArray, sigma_rad: float) -> FloatArray:
    """Unit vectors (P, 3): ``n`` rotated by a random small rotation (sigma per axis, rad)."""
    w = rng.normal(scale=sigma_rad, size=n.shape)
    w -= np.einsum("ij,ij->i", w, n)[:, None] * n
    out = n + np.cross(w, n)
    normed: FloatArray = out / np.linalg.norm(out, axis=1, keepdims=True)
    return normed


def house_row(
    n_houses: int = 1,
    *,
    seed: int = 0,
    wing_deg: float = 135.0,
    evidence_angle_deg: float = 0.3,
    evidence_offset_m: float = 0.02,
    position_sigma: float = 0.005,
) -> SyntheticScene:
    """``n_houses`` paper houses (28 parts, 51 constraints each) in a row along the street.

    Parameters
    ----------
    n_houses : number of houses; houses are 40 m apart and neighbours' fronts are tied by a
        parallel constraint (so the problem is one connected system).
    seed : seed of the simulated evidence noise.
    wing_deg : the true angle at which each wing meets its body's front wall (90 or 135).
    evidence_angle_deg, evidence_offset_m : standard deviations of the region plane fits.
    position_sigma : sigma of the position constraints (rad; the shift is weighted so that
        ``evidence_offset_m`` counts as much as ``evidence_angle_deg``).

    Returns
    -------
    SyntheticScene with 28·n parts and 51·n + (n - 1) constraints.
    """
    if n_houses < 1:
        raise ValueError("n_houses must be >= 1")
    b = _Builder()
    for h in range(n_houses):
        _add_house(b, f"h{h}.", 40.0 * h, wing_deg)
        if h:
            b.add("parallel", (f"h{h - 1}.body.front", f"h{h}.body.front"))
    normals = np.array(b.normals)
    offsets = np.einsum("ij,ij->i", normals, np.array(b.points))
    triples: list[tuple[int, int, int]] = []
    verts: list[FloatArray] = []
    centres = np.zeros((len(b.names), 3))
    for solid in b.solids:
        t, pts = _convex_vertices(normals, offsets, solid)
        triples += t
        verts += pts
        arr = np.array(pts)
        for i in solid:
            on = np.abs(arr @ normals[i] - offsets[i]) < 1e-6
            centres[i] = arr[on].mean(axis=0)
    vertices = np.array(verts)
    rng = np.random.default_rng(seed)
    n_init = _random_tilt(rng, normals, math.radians(evidence_angle_deg))
    c_init = centres + rng.normal(scale=evidence_offset_m, size=len(b.names))[:, None] * normals
    w_n = (math.radians(evidence_angle_deg) / evidence_offset_m) ** 2
    visible = np.einsum("ij,ij->i", normals, -centres) > 0
    positions = [
        Constraint(
            kind="position",
            parts=(i,),
            sigma=position_sigma,
            measurement=True,
            label=f"position({name})",
            position=PositionData(
                n_init=(float(n_init[i, 0]), float(n_init[i, 1]), float(n_init[i, 2])),
                c_init=(float(c_init[i, 0]), float(c_init[i, 1]), float(c_init[i, 2])),
                w_c=1.0 if visible[i] else 0.5,
                w_n=w_n,
            ),
        )
        for i, name in enumerate(b.names)
    ]
    size = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    return SyntheticScene(
        names=tuple(b.names),
        normals=normals,
        offsets=offsets,
        centres=centres,
        solids=tuple(b.solids),
        vertex_planes=np.array(triples, dtype=np.intp),
        vertices=vertices,
        constraints=tuple(b.internal) + tuple(positions),
        size=size,
    )


def paper_house(seed: int = 0, wing_deg: float = 135.0) -> SyntheticScene:
    """One house of 28 surface elements and 51 constraints (see `house_row`)."""
    return house_row(1, seed=seed, wing_deg=wing_deg)


def perturbed(
    scene: SyntheticScene, *, seed: int = 1, angle_deg: float = 3.0, offset_m: float = 0.3
) -> tuple[FloatArray, FloatArray]:
    """Initial planes: the true planes tilted (sigma ``angle_deg`` per axis) and shifted.

    Returns normals (P, 3) and offsets (P,), world frame, metres.
    """
    rng = np.random.default_rng(seed)
    n = _random_tilt(rng, scene.normals, math.radians(angle_deg))
    d = np.einsum("ij,ij->i", n, scene.centres) + rng.normal(scale=offset_m, size=n.shape[0])
    return n, d
