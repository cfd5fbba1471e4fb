"""How far a reconstructed model is from the ground truth of a synthetic scene.

For the demo and the tests only: the pipeline itself never reads ``truth.json``. Parts are
paired by role path; a true face whose namesake faces another way (which eave side of a
right-angled wing is its front is a convention) is paired with the unpaired part of its solid
(the body, ``body.wings[0]``, ...) that faces its way most (within 25 degrees). Angles are
the dihedral angles between parts whose true polygons share an edge (the angle between their
normals); normal errors are the angles between each paired part's normal and its true one;
vertex errors are, for every true vertex, the distance to the nearest vertex of the
reconstructed polygon paired with its face, relative to the size of the true object (the
diagonal of its bounding box). Angles are those at which the planes meet inside the solid
(the knowledge base's convention: a wall corner is 90 degrees, the eaves of a roof pitched at
35 degrees 125, the ridge 110).

`evaluate` judges a whole result (`interpretation.json` with its model) against a scene's
truth: the right outcome (an object found where there is one, nothing where there is none),
the specialisations chosen (truth.json's `concepts`), the normals, the vertices and every
view's camera. It is what `aida-kb evaluate`, `aida-kb demo` and `benchmarks/robustness.py`
report; with the true parts no view shows (`aida_kb.interpret.sight`), named apart, since
no interpretation can measure them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.io.model import ModelPart, ReconstructedModel
from aida_kb.io.scene import PartTruth, SceneTruth

if TYPE_CHECKING:
    from aida_kb.interpret.result import Interpretation

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
    normal_errors_deg: dict[str, float] = field(default_factory=dict)  # true role -> angle
    extra: list[str] = field(default_factory=list)  # model roles paired with no true part
    # true role -> the paired model part's normal deviation (model.json `sd`), degrees; only
    # the parts the adjustment fixes (a finite sd)
    normal_sds_deg: dict[str, float] = field(default_factory=dict)

    @property
    def max_normal_error_deg(self) -> float:
        """The largest angle between a part's normal and its true normal, degrees."""
        return max(self.normal_errors_deg.values(), default=0.0)

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
    normal_errors = {
        t.role: math.degrees(
            math.acos(float(np.clip(np.dot(parts[t.role].normal, t.normal), -1.0, 1.0)))
        )
        for t in true_parts
        if t.role in parts
    }
    normal_sds = {
        role: float(m.sd.normal_deg)
        for role, m in parts.items()
        if m.sd is not None and m.sd.normal_deg is not None and math.isfinite(m.sd.normal_deg)
    }
    paired = {m.role for m in parts.values()}
    extra = [] if roles is not None else [m.role for m in model.parts if m.role not in paired]
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
    return TruthComparison(
        angles,
        worst_angle,
        worst_vertex,
        size,
        missing,
        normal_errors,
        sorted(set(extra)),
        normal_sds,
    )


# ---- a whole result against a scene's truth ---------------------------------------------------
NORMAL_TARGET_DEG = 0.5  # the paper's accuracy: plane normals within half a degree
VERTEX_TARGET = 0.02  # vertices within 2 % of the object's size (bounding-box diagonal)
CAMERA_ANGLE_TARGET_DEG = 0.1  # a registered view's rotation within 0.1 degree (Table 1)
CAMERA_DISTANCE_TARGET = 0.01  # its centre within 1 % of its distance to the object


@dataclass(frozen=True)
class CameraError:
    """One view's camera against the truth: rotation angle (deg) and centre distance (m)."""

    view: str
    angle_deg: float
    centre_m: float
    distance_m: float  # from the true camera centre to the object's centre
    sd_deg: float | None = None  # the adjustment's standard deviation of its rotation
    # (model.json `sd`; None: the first view, not judged, or not fixed)

    @property
    def centre_rel(self) -> float:
        """The centre error as a fraction of the camera's distance to the object."""
        return self.centre_m / self.distance_m if self.distance_m > 0 else math.inf


@dataclass(frozen=True)
class Evaluation:
    """A result judged against the truth: correct or not, and the first reason why not.

    expected_object : the truth has the goal object (else nothing must be found).
    outcome : the result's verdict ('verified', 'doubtful' or 'nothing').
    cause : '' when correct, else the first failed check ('nothing found', 'found an
    object where there is none', 'specialisation', 'missing part', 'extra part',
    'normals', 'vertices', 'camera').
    """

    expected_object: bool
    outcome: str
    correct: bool
    cause: str
    specialisations: dict[str, tuple[str, str]]  # role -> (true, chosen) that differ
    comparison: TruthComparison | None
    cameras: list[CameraError]
    doubts: tuple[str, ...] = ()  # the verdict's reasons when the result is doubtful
    # true parts no view shows well enough to measure (`aida_kb.interpret.sight`): no
    # interpretation can place them to the targets; None when unknown (no rendered depth)
    unmeasurable: tuple[str, ...] | None = None

    def summary(self) -> dict[str, object]:
        """The figures as a JSON-ready mapping."""
        c = self.comparison
        return {
            "expected_object": self.expected_object,
            "outcome": self.outcome,
            "correct": self.correct,
            "cause": self.cause,
            "doubts": list(self.doubts),
            "specialisations": {k: list(v) for k, v in self.specialisations.items()},
            "max_normal_error_deg": None if c is None else round(c.max_normal_error_deg, 4),
            "max_vertex_error_pct": None if c is None else round(100 * c.max_vertex_error_rel, 3),
            # every paired part: [normal error, the model's sd of it (None: not fixed)], degrees
            "normals": {}
            if c is None
            else {
                role: [round(e, 4), _rounded(c.normal_sds_deg.get(role))]
                for role, e in c.normal_errors_deg.items()
            },
            "missing": [] if c is None else c.missing,
            "extra": [] if c is None else c.extra,
            "unmeasurable": None if self.unmeasurable is None else list(self.unmeasurable),
            "cameras": [
                {
                    "view": e.view,
                    "angle_deg": round(e.angle_deg, 4),
                    "centre_pct": round(100 * e.centre_rel, 3),
                    "sd_deg": None if e.sd_deg is None else round(e.sd_deg, 4),
                }
                for e in self.cameras
            ],
        }


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 4)


def _in_sds(error: float, sd: float | None) -> str:
    """': 3.1 sd' — an error in the model's own standard deviations ('' without one)."""
    return "" if sd is None or sd <= 0 else f"; the model's sd {sd:.3f} deg: {error / sd:.1f} sd"


def outcome_of(interp: Interpretation) -> str:
    """'verified', 'doubtful' or 'nothing': what the result claims."""
    verdict = getattr(interp, "verdict", None)
    if verdict in ("verified", "doubtful", "nothing"):
        return str(verdict)
    return "verified" if interp.accepted and interp.model is not None else "nothing"


def _camera_errors(model: ReconstructedModel, truth: SceneTruth) -> list[CameraError]:
    """Every true view's camera against the model's camera of that view (missing: inf)."""
    pts = np.array([v for p in truth.parts for v in p.polygon], dtype=np.float64)
    centre = pts.mean(axis=0) if len(pts) else np.zeros(3)
    mine = {c.view: c for c in model.cameras}
    out = []
    for pose in truth.views:
        R_t = np.asarray(pose.R, dtype=np.float64)
        C_t = -R_t.T @ np.asarray(pose.t, dtype=np.float64)
        dist = float(np.linalg.norm(C_t - centre))
        cam = mine.get(pose.view)
        if cam is None:
            out.append(CameraError(pose.view, math.inf, math.inf, dist))
            continue
        R_m = np.asarray(cam.R, dtype=np.float64)
        C_m = -R_m.T @ np.asarray(cam.t, dtype=np.float64)
        cos = (float(np.trace(R_m @ R_t.T)) - 1.0) / 2.0
        angle = math.degrees(math.acos(float(np.clip(cos, -1.0, 1.0))))
        sd = cam.sd.rotation_deg if cam.sd is not None else None
        out.append(CameraError(pose.view, angle, float(np.linalg.norm(C_m - C_t)), dist, sd))
    return out


def evaluate(
    interp: Interpretation,
    truth: SceneTruth,
    *,
    goal: str | None = None,
    unmeasurable: tuple[str, ...] | None = None,
) -> Evaluation:
    """Judge `interp` (with its model) against `truth` (see `Evaluation`).

    goal : the concept searched for (default: the interpretation's goal). A truth whose
    object is another concept, or has no parts, expects nothing to be found.
    unmeasurable : the true parts no view shows (`aida_kb.interpret.sight.unmeasurable`;
    None: not known), reported with the result; they change no check.
    """
    goal = goal or interp.goal
    expected = truth.object == goal and bool(truth.parts)
    outcome = outcome_of(interp)
    found = outcome != "nothing" and interp.model is not None
    chosen = {inst.role: inst.concept for inst in interp.instances}
    wrong_kind = {
        role: (concept, chosen.get(role, "-"))
        for role, concept in truth.concepts.items()
        if chosen.get(role) != concept
    }
    model = interp.model
    comparison = (
        compare_with_truth(model, truth) if model is not None and found and expected else None
    )
    cameras = _camera_errors(model, truth) if model is not None and comparison is not None else []
    cause = ""
    if not expected:
        cause = "found an object where there is none" if found else ""
    elif not found:
        cause = "nothing found"
    elif wrong_kind:
        cause = "specialisation"
    elif comparison is not None and comparison.missing:
        cause = "missing part"
    elif comparison is not None and comparison.extra:
        cause = "extra part"
    elif comparison is not None and comparison.max_normal_error_deg > NORMAL_TARGET_DEG:
        cause = "normals"
    elif comparison is not None and comparison.max_vertex_error_rel > VERTEX_TARGET:
        cause = "vertices"
    elif any(
        e.angle_deg > CAMERA_ANGLE_TARGET_DEG or e.centre_rel > CAMERA_DISTANCE_TARGET
        for e in cameras
    ):
        cause = "camera"
    correct = cause == "" and (found == expected) and (outcome == "verified" or not expected)
    if expected and found and cause == "" and outcome != "verified":
        cause = "right but doubtful"
    return Evaluation(
        expected,
        outcome,
        correct,
        cause,
        wrong_kind,
        comparison,
        cameras,
        tuple(interp.doubts),
        unmeasurable if expected else None,
    )


def format_evaluation(result: Evaluation) -> list[str]:
    """The evaluation as lines for people: the verdict, then each figure against its target."""
    word = "correct" if result.correct else f"NOT correct ({result.cause})"
    expected = "an object" if result.expected_object else "nothing"
    lines = [f"{word}: the result is {result.outcome!r}, the truth has {expected}"]
    lines += [f"  doubted: {reason}" for reason in result.doubts]
    for role, (true, chosen) in result.specialisations.items():
        lines.append(f"  specialisation of {role}: chose {chosen}, truth {true}")
    c = result.comparison
    if c is not None:
        if c.missing:
            lines.append(f"  missing parts: {', '.join(c.missing)}")
        if c.extra:
            lines.append(f"  parts not in the truth: {', '.join(c.extra)}")
        worst = max(c.normal_errors_deg.items(), key=lambda kv: kv[1], default=("-", 0.0))
        lines.append(
            f"  largest normal error: {worst[1]:.3f} deg ({worst[0]}; target {NORMAL_TARGET_DEG})"
        )
        for role, off in sorted(c.normal_errors_deg.items(), key=lambda kv: -kv[1]):
            if off > NORMAL_TARGET_DEG:
                sd = c.normal_sds_deg.get(role)
                lines.append(f"    normal of {role}: {off:.3f} deg off{_in_sds(off, sd)}")
        lines.append(
            f"  largest vertex error: {c.max_vertex_error_m:.3f} m = "
            f"{100 * c.max_vertex_error_rel:.2f}% of the object's size {c.size_m:.2f} m "
            f"(target {100 * VERTEX_TARGET:g}%)"
        )
    if result.unmeasurable:
        lines.append(
            "  shown by no view (neither the face nor an edge of it: placed by the knowledge "
            f"alone, whatever the interpretation): {', '.join(result.unmeasurable)}"
        )
    for e in result.cameras:
        lines.append(
            f"  camera of view {e.view}: {e.angle_deg:.3f} deg, {e.centre_m:.3f} m = "
            f"{100 * e.centre_rel:.2f}% of its distance {e.distance_m:.1f} m (targets "
            f"{CAMERA_ANGLE_TARGET_DEG} deg, {100 * CAMERA_DISTANCE_TARGET:g}%"
            f"{_in_sds(e.angle_deg, e.sd_deg)})"
        )
    return lines
