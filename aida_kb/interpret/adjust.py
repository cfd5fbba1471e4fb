"""The interpreter's adjustment of one hypothesis: weighted least squares over plane parameters.

Each free part is a plane with a local frame (paper §3): the initial unit normal n0 with two
tangent axes u, v, and the offset d0; its three parameters (a, b, c) give
n = normalise(n0 + a·u + b·v) and d = d0 + c. Fixed parts (a verified higher level) keep
their planes. Residuals, each divided by its sigma (or multiplied by sqrt(weight) when the
knowledge gives a weight only):

- angle (a, b): the angle at which the planes meet (pi minus the angle between their
  normals) minus the value (rad);
- parallel (a, b): the angle between the two planes, 0..90 degrees (rad);
- parallel_edge (a, b, c, d): the angle between edge(a, b) and edge(c, d) (rad);
- symmetry (a, b, c, d): angle(a, b) - angle(c, d) (rad);
- position (eq. 4, px): the plane's distance from the region's centroid c_init, as the
  change of stereo disparity f·B·dist/z² it causes (f·dist/z across the image when the
  baseline B is unknown), and its tilt against n_init, one degree counting as one pixel;
  both scaled by sqrt(mean certainty) so that certain regions hold harder (w_c);
- edge (eq. 5, px): the distances of a segment's two ends from the projected edge line.

A constraint is rejected when its residual after adjustment exceeds `reject_above`, or, when
the knowledge gives no threshold, when its normalised residual exceeds
`DEFAULT_REJECT_SIGMAS`. Normalised residual: |residual| / sigma (RMS over components).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from aida_kb.errors import SolveError
from aida_kb.interpret.problem import Outcome, Problem, Residual

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

DEFAULT_REJECT_SIGMAS = 5.0
TILT_PX_PER_RAD = math.degrees(1.0)  # the position constraint counts 1 degree of tilt as 1 px
PRIOR_SIGMA = 1e3  # a very weak pull of each parameter to its start (removes gauge freedom)
MAX_EVALUATIONS = 60  # a hypothesis that needs more is wrong; its residuals will say so


def _unit(v: FloatArray) -> FloatArray:
    out: FloatArray = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return out


def _angle(n1: FloatArray, n2: FloatArray) -> FloatArray:
    """The angle at which two planes meet inside the solid, pi - angle(n1, n2), row-wise (rad).

    Perpendicular walls meet at pi/2; a wing turned 45 degrees from the front meets it at
    3·pi/4 (the convention of `aida_kb.constraints`).
    """
    cross = np.linalg.norm(np.cross(n1, n2), axis=-1)
    dot = np.sum(n1 * n2, axis=-1)
    out: FloatArray = np.pi - np.arctan2(cross, dot)
    return out


def _misalignment(n1: FloatArray, n2: FloatArray) -> FloatArray:
    """Smooth residual (K, 3) of undirected unit vectors that should be parallel.

    The cross product, signed by the dot product: its length is the sine of the angle
    between the lines (about the angle in radians when small), and unlike the angle itself it
    has no kink at zero.
    """
    sign = np.where(np.sum(n1 * n2, axis=-1) < 0, -1.0, 1.0)
    out: FloatArray = np.cross(n1, n2) * sign[:, None]
    return out


def _magnitude(kind: str, r: FloatArray) -> FloatArray:
    """One number per constraint from its components (K, c): the size the report shows.

    Angles and symmetries: |r|; parallels: the sine of the angle (the cross product's
    length); positions: RMS of the shift and the tilt term; edges: RMS of the two ends.
    """
    if kind in ("parallel", "parallel_edge"):
        out: FloatArray = np.linalg.norm(r, axis=1)
    elif kind == "position":
        tilt = np.linalg.norm(r[:, 1:], axis=1)
        out = np.sqrt((r[:, 0] ** 2 + tilt**2) / 2.0)
    else:
        out = np.sqrt(np.mean(r * r, axis=1))
    return out


@dataclass(frozen=True)
class _Group:
    """Constraints of one kind: plane indices (K, m), values, scales, and their source rows."""

    kind: str
    idx: IntArray
    value: FloatArray
    scale: FloatArray  # 1/sigma (or sqrt(weight))
    rows: list[int]  # index into the residual list


def _sigma_scale(spec: object) -> tuple[float | None, float]:
    """(sigma or None, sqrt(weight)): sigma normalises the report, the weight the adjustment."""
    sigma = getattr(spec, "sigma", None)
    weight = float(getattr(spec, "weight", 1.0))
    if sigma is not None and sigma > 0:
        return float(sigma), math.sqrt(max(weight, 0.0))
    return None, math.sqrt(max(weight, 0.0))


class Adjustment:
    """One weighted least-squares problem built from a `Problem`."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.roles = [p.role for p in problem.planes]
        if len(set(self.roles)) != len(self.roles):
            raise SolveError("adjustment: a part appears twice")
        self.index = {r: i for i, r in enumerate(self.roles)}
        self.n0 = np.array([p.normal for p in problem.planes], dtype=np.float64).reshape(-1, 3)
        self.d0 = np.array([p.offset_m for p in problem.planes], dtype=np.float64)
        if not np.all(np.isfinite(self.n0)) or not np.all(np.isfinite(self.d0)):
            raise SolveError("adjustment: a plane is not finite")
        self.n0 = _unit(self.n0)
        self.free = np.array([not p.fixed for p in problem.planes])
        helper = np.where(np.abs(self.n0[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        self.u = _unit(np.cross(self.n0, helper))
        self.v = np.cross(self.n0, self.u)
        self.labels: list[
            tuple[str, str, str, str, tuple[str, ...], str, float | None, float | None]
        ] = []
        self.groups = self._internal_groups() + self._measure_groups()

    # ---- building ------------------------------------------------------------------------------
    def _row(self, spec: object, owner: str, parts: tuple[str, ...], unit: str) -> int:
        sigma, _ = _sigma_scale(spec)
        self.labels.append(
            (
                str(getattr(spec, "label", "")),
                str(getattr(spec, "kind", "")),
                str(getattr(spec, "concept", "")),
                owner,
                parts,
                unit,
                sigma,
                getattr(spec, "reject_above", None),
            )
        )
        return len(self.labels) - 1

    def _internal_groups(self) -> list[_Group]:
        buckets: dict[str, tuple[list[list[int]], list[float], list[float], list[int]]] = {}
        for owned in self.problem.internal:
            spec = owned.spec
            parts = owned.parts()
            if any(p not in self.index for p in parts):
                continue
            _, scale = _sigma_scale(spec)
            row = self._row(spec, owned.owner, parts, "rad")
            idx, val, sc, rows = buckets.setdefault(spec.kind, ([], [], [], []))
            idx.append([self.index[p] for p in parts])
            val.append(float(spec.value) if spec.value is not None else 0.0)
            sc.append(scale)
            rows.append(row)
        return [
            _Group(kind, np.array(i, dtype=np.int64), np.array(v), np.array(s), r)
            for kind, (i, v, s, r) in buckets.items()
        ]

    def _measure_groups(self) -> list[_Group]:
        groups: list[_Group] = []
        pos = self.problem.positions
        if pos:
            rows = [self._row(m.spec, m.owner, (m.role,), "px") for m in pos]
            scales = [_sigma_scale(m.spec)[1] for m in pos]
            groups.append(
                _Group(
                    "position",
                    np.array([[self.index[m.role]] for m in pos], dtype=np.int64),
                    np.zeros(len(pos)),
                    np.array(scales),
                    rows,
                )
            )
            cams = [m.camera for m in pos]
            self.pos_c = np.array([m.region.centroid_m for m in pos])
            self.pos_n = np.array([m.region.normal for m in pos])
            # the shift in pixels of disparity (f·B·dist/z²) where the baseline is known,
            # else in pixels across the image (f·dist/z)
            self.pos_f = np.array(
                [c.K[0, 0] * (c.baseline_m if c.baseline_m > 0 else 1.0) for c in cams]
            )
            self.pos_zz = np.array([1.0 if c.baseline_m > 0 else 0.0 for c in cams])
            z = np.array(
                [
                    float(c.pinhole.depth(m.region.centroid_m[None, :])[0])
                    for c, m in zip(cams, pos, strict=True)
                ]
            )
            if np.any(z <= 0):
                raise SolveError("adjustment: a region lies behind its camera")
            self.pos_z = z
            certainty = np.array(
                [min(1.0, m.region.weight / max(m.region.area_px, 1.0)) for m in pos]
            )
            self.pos_sqrt_c = np.sqrt(np.clip(certainty, 1e-6, 1.0))
        edges = self.problem.edges
        if edges:
            # one constraint per model edge: its segments (fragments of one image contour)
            # share one row of the report, whose residual is the RMS over all their ends
            by_edge: dict[tuple[str, tuple[str, str]], int] = {}
            rows = []
            for e in edges:
                key = (str(e.spec.label), e.match.parts)
                if key not in by_edge:
                    by_edge[key] = self._row(e.spec, e.owner, e.match.parts, "px")
                rows.append(by_edge[key])
            scales = [_sigma_scale(e.spec)[1] for e in edges]
            groups.append(
                _Group(
                    "edge",
                    np.array(
                        [[self.index[a], self.index[b]] for a, b in (e.match.parts for e in edges)],
                        dtype=np.int64,
                    ),
                    np.zeros(len(edges)),
                    np.array(scales),
                    rows,
                )
            )
            self.edge_P = np.array([e.camera.P for e in edges])
            self.edge_ends = np.array(
                [np.column_stack([e.match.segment.ends_px, np.ones(2)]) for e in edges]
            )
        return groups

    # ---- evaluation ------------------------------------------------------------------------------
    def planes(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Normals (P, 3) and offsets (P,) for the parameter vector x (3 per free plane)."""
        n = self.n0.copy()
        d = self.d0.copy()
        p = x.reshape(-1, 3)
        f = self.free
        n[f] = _unit(self.n0[f] + p[:, :1] * self.u[f] + p[:, 1:2] * self.v[f])
        d[f] = self.d0[f] + p[:, 2]
        return n, d

    def components(self, x: FloatArray) -> list[FloatArray]:
        """Per group, the raw residual components (K, c) in the group's unit."""
        n, d = self.planes(x)
        out: list[FloatArray] = []
        for g in self.groups:
            i = g.idx
            if g.kind == "angle":
                r = (_angle(n[i[:, 0]], n[i[:, 1]]) - g.value)[:, None]
            elif g.kind == "parallel":
                r = _misalignment(n[i[:, 0]], n[i[:, 1]])
            elif g.kind == "parallel_edge":
                e1 = np.cross(n[i[:, 0]], n[i[:, 1]])
                e2 = np.cross(n[i[:, 2]], n[i[:, 3]])
                r = _misalignment(_unit(e1), _unit(e2))
            elif g.kind == "symmetry":
                a1 = _angle(n[i[:, 0]], n[i[:, 1]])
                a2 = _angle(n[i[:, 2]], n[i[:, 3]])
                r = (a1 - a2)[:, None]
            elif g.kind == "position":
                k = i[:, 0]
                dist = np.sum(n[k] * self.pos_c, axis=1) - d[k]
                shift = self.pos_f * dist / self.pos_z ** (1.0 + self.pos_zz)
                tilt = np.cross(n[k], self.pos_n) * TILT_PX_PER_RAD
                r = np.column_stack([shift, tilt])
            elif g.kind == "edge":
                r = self._edge_residuals(n, d, i)
            else:
                raise SolveError(f"adjustment: unknown constraint kind {g.kind!r}")
            out.append(r)
        return out

    def _edge_residuals(self, n: FloatArray, d: FloatArray, i: IntArray) -> FloatArray:
        na, nb = n[i[:, 0]], n[i[:, 1]]
        direction = np.cross(na, nb)
        # a point on each line: the least-norm solution of na·x = da, nb·x = db
        dd = np.sum(direction * direction, axis=1, keepdims=True)
        point = np.cross(d[i[:, 0], None] * nb - d[i[:, 1], None] * na, direction) / np.maximum(
            dd, 1e-18
        )
        x1 = np.einsum("kij,kj->ki", self.edge_P[:, :, :3], point) + self.edge_P[:, :, 3]
        x2 = np.einsum("kij,kj->ki", self.edge_P[:, :, :3], direction)
        line = np.cross(x1, x2)
        line = line / np.maximum(np.hypot(line[:, :1], line[:, 1:2]), 1e-18)
        out: FloatArray = np.einsum("kj,kej->ke", line, self.edge_ends)
        return out

    def weighted(self, x: FloatArray) -> FloatArray:
        """The residual vector the least squares minimises."""
        parts = []
        for g, r in zip(self.groups, self.components(x), strict=True):
            w = g.scale[:, None] * (self.pos_sqrt_c[:, None] if g.kind == "position" else 1.0)
            parts.append((r * w).ravel())
        parts.append(x / PRIOR_SIGMA)
        return np.concatenate(parts)

    def solve(self) -> Outcome:
        """Adjust, then report every constraint's residual."""
        x0 = np.zeros(3 * int(self.free.sum()))
        if x0.size:
            fit = least_squares(self.weighted, x0, method="lm", max_nfev=MAX_EVALUATIONS)
            x = fit.x
        else:
            x = x0
        comps = self.components(x)
        residuals: list[Residual | None] = [None] * len(self.labels)
        sq = 0.0
        count = 0
        for g, r in zip(self.groups, comps, strict=True):
            rms = _magnitude(g.kind, r)
            # rows shared by several items (the fragments of an edge): RMS over the items
            sums: dict[int, list[float]] = {}
            for k, row in enumerate(g.rows):
                sums.setdefault(row, [0.0, 0.0, float(g.scale[k])])
                sums[row][0] += float(rms[k]) ** 2
                sums[row][1] += 1.0
            for row, (total, items, scale) in sums.items():
                label, kind, concept, owner, parts, unit, sigma, reject = self.labels[row]
                value = math.sqrt(total / items)
                normalised = value / sigma if sigma else value * scale
                if reject is not None:
                    rejected = value > float(reject)
                else:
                    rejected = normalised > DEFAULT_REJECT_SIGMAS
                residuals[row] = Residual(
                    label,
                    kind,
                    concept,
                    owner,
                    parts,
                    value,
                    unit,
                    sigma,
                    normalised,
                    reject,
                    rejected,
                )
                sq += normalised * normalised
                count += 1
        n, d = self.planes(x)
        if not (np.all(np.isfinite(n)) and np.all(np.isfinite(d))):
            raise SolveError("adjustment diverged (non-finite planes)")
        planes = {role: (n[i], float(d[i])) for i, role in enumerate(self.roles)}
        final = tuple(r for r in residuals if r is not None)
        return Outcome(planes, final, sq / max(count, 1))


def adjust(problem: Problem) -> Outcome:
    """Solve one verification problem (see the module docstring)."""
    return Adjustment(problem).solve()
