"""How far a reconstructed model is from the ground truth of a synthetic scene.

For the demo and the tests only: the pipeline itself never reads ``truth.json``. Parts are
paired by role path; a true face whose namesake faces another way (which eave side of a
right-angled wing is its front is a convention) is paired with the unpaired part of its solid
(the body, ``body.wings[0]``, ...) that faces its way most (within 25 degrees). Angles are
the dihedral angles between parts whose true polygons share an edge (the angle between their
normals); vertex errors are, for every true vertex, the distance to the nearest vertex of the
reconstructed polygon paired with its face, relative to the size of the true object (the
diagonal of its bounding box). Angles are those at which the planes meet inside the solid
(the knowledge base's convention: a wall corner is 90 degrees, the eaves of a roof pitched at
35 degrees 125, the ridge 110).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.io.model import ModelPart, ReconstructedModel
from aida_kb.io.scene import PartTruth, SceneTruth

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class AngleError:
    """The angle between two adjacent parts, true and reconstructed, degrees."""

    a: str
    b: str
    truth_deg: float
    model_deg: float

    @property
    def error_deg(self) -> float:
        """|model - truth|, degrees."""
        return abs(self.model_deg - self.truth_deg)


@dataclass(frozen=True)
class TruthComparison:
    """The errors of a model against the truth."""

    angles: list[AngleError]
    max_angle_error_deg: float
    max_vertex_error_m: float
    size_m: float
    missing: list[str]  # true roles with no reconstructed part

    @property
    def max_vertex_error_rel(self) -> float:
        """The largest vertex error as a fraction of the object's size."""
        return self.max_vertex_error_m / self.size_m if self.size_m > 0 else math.inf


def _angle_deg(n1: FloatArray, n2: FloatArray) -> float:
    """The angle at which two planes meet inside the solid: 180 minus the normals' angle."""
    c = float(np.clip(n1 @ n2, -1.0, 1.0))
    return 180.0 - math.degrees(math.acos(c))


def _share_edge(p: FloatArray, q: FloatArray, tol: float) -> bool:
    close = np.linalg.norm(p[:, None, :] - q[None, :, :], axis=2) < tol
    return int(np.count_nonzero(close.any(axis=1))) >= 2


def _solid(role: str) -> str:
    """The solid a part belongs to: ``body.wings[0]`` for its walls and roof, else ``body``."""
    return role.split("]")[0] if "[" in role else role.split(".")[0]


def _paired(model: ReconstructedModel, true_parts: list[PartTruth]) -> dict[str, ModelPart]:
    """True role -> the model part compared with it (see the module docstring).

    A part of the same role more than 25 degrees off is re-paired only if an unpaired part of
    its solid faces the true face's way; else it stays paired by role (its error counts).
    """
    by_role = {p.role: p for p in model.parts}
    close = math.cos(math.radians(25.0))
    out: dict[str, ModelPart] = {}
    off: list[PartTruth] = []
    for t in true_parts:
        m = by_role.get(t.role)
        if m is None:
            continue
        if float(np.dot(m.normal, t.normal)) > close:
            out[t.role] = m
        else:
            off.append(t)
    used = {m.role for m in out.values()}
    for t in off:
        free = [m for m in model.parts if m.role not in used and _solid(m.role) == _solid(t.role)]
        best = max(free, key=lambda m: float(np.dot(m.normal, t.normal)), default=None)
        if best is not None and float(np.dot(best.normal, t.normal)) > close:
            out[t.role] = best
            used.add(best.role)
    for t in off:
        if t.role not in out and t.role not in used:
            out[t.role] = by_role[t.role]
            used.add(t.role)
    return out


def compare_with_truth(
    model: ReconstructedModel, truth: SceneTruth, roles: tuple[str, ...] | None = None
) -> TruthComparison:
    """Compare `model` with `truth` over the true parts (or only those in `roles`)."""
    true_parts = [p for p in truth.parts if roles is None or p.role in roles]
    parts = _paired(model, true_parts)
    all_true = np.array([v for p in true_parts for v in p.polygon], dtype=np.float64)
    size = (
        float(np.linalg.norm(all_true.max(axis=0) - all_true.min(axis=0))) if len(all_true) else 0.0
    )
    missing = [p.role for p in true_parts if p.role not in parts]
    angles: list[AngleError] = []
    worst_vertex = 0.0
    polys = {p.role: np.asarray(p.polygon, dtype=np.float64) for p in true_parts}
    for i, p in enumerate(true_parts):
        if p.role not in parts:
            continue
        mine = parts[p.role]
        mine_poly = np.asarray(mine.polygon, dtype=np.float64)
        dist = np.linalg.norm(polys[p.role][:, None, :] - mine_poly[None, :, :], axis=2)
        worst_vertex = max(worst_vertex, float(dist.min(axis=1).max()))
        for q in true_parts[i + 1 :]:
            if q.role not in parts or not _share_edge(polys[p.role], polys[q.role], 1e-3 * size):
                continue
            truth_deg = _angle_deg(np.asarray(p.normal), np.asarray(q.normal))
            model_deg = _angle_deg(np.asarray(mine.normal), np.asarray(parts[q.role].normal))
            angles.append(AngleError(p.role, q.role, truth_deg, model_deg))
    worst_angle = max((a.error_deg for a in angles), default=0.0)
    return TruthComparison(angles, worst_angle, worst_vertex, size, missing)
