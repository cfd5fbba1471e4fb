"""Check (d): the knowledge's measured attributes lie in their ranges and its fixed orientations
hold, measured on the model."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from aida_kb.interpret.ground import EvidenceGround
from aida_kb.interpret.observe import view_of
from aida_kb.interpret.result import Instance, Interpretation
from aida_kb.interpret.verdict.geometry import FloatArray
from aida_kb.interpret.verdict.tolerances import (
    ORIENTATION_TOLERANCE_DEG,
    RANGE_SLACK_REL,
    SIZE_UNIT,
)
from aida_kb.io.evidence import Evidence
from aida_kb.io.model import ReconstructedModel
from aida_kb.kb.model import AttributeModel, KnowledgeBase, MeasureKind


def _parts_under(
    model: ReconstructedModel, role: str
) -> list[tuple[FloatArray, float, FloatArray]]:
    prefix = role + "."
    return [
        (np.asarray(p.normal, dtype=np.float64), float(p.offset_m), np.asarray(p.polygon))
        for p in model.parts
        if p.role == role or p.role.startswith(prefix) or role == ""
    ]


def _join(role: str, path: str) -> str:
    if path == "self":
        return role
    return f"{role}.{path}" if role else path


def _up(kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel) -> FloatArray | None:
    """The world's up direction from a part the knowledge orients up- or downward."""
    by_role = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    # the outermost composite's up- or downward part (the body's floor before a roof's top)
    for inst in sorted(interp.instances, key=lambda i: (i.role.count("."), i.role != "")):
        concept = kb.concepts.get(inst.concept)
        if concept is None:
            continue
        for part, o in concept.orientations.items():
            n = by_role.get(_join(inst.role, part))
            if n is not None and o.direction in ("upward", "downward"):
                return n if o.direction == "upward" else -n
    return None


def _forward(
    kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel, role: str, up: FloatArray
) -> FloatArray | None:
    """The horizontal direction the frame anchor of the composite at `role` (or a whole) faces."""
    by_role = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    concepts = {i.role: i.concept for i in interp.instances}
    while True:
        concept = kb.concepts.get(concepts.get(role, ""))
        if concept is not None and concept.frame is not None:
            n = by_role.get(_join(role, concept.frame.anchor))
            if n is None:
                return None
            f = n - (n @ up) * up
            norm = float(np.linalg.norm(f))
            return f / norm if norm > 1e-9 else None
        if role == "":
            return None
        role = role.rsplit(".", 1)[0] if "." in role else ""


Ground = Callable[[FloatArray], float | None]
"""A part's corners (K, 3), metres, world frame -> their elevation above the ground the
evidence shows, metres (None: it shows none; `interpret.ground.EvidenceGround.elevation`)."""


def evidence_ground(
    kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel, evidence: Evidence
) -> Ground | None:
    """The ground the reference view (the first: the world frame) shows under the model's
    parts: the surfaces it sees beneath a part (`interpret.ground.lowest_beneath`), the
    object's own regions (bound to its parts, or level on a face of it that faces up) left
    out. The search measures each hypothesis against the ground region's plane as well
    (`interpret.plausibility.attribute_violation`); the refined model is not measured so again
    (`interpret.ground.EvidenceGround`, beneath_only). None without an up direction (no part
    the knowledge orients up- or downward) or when no attribute of the model's concepts is an
    elevation."""
    from aida_kb.interpret.plausibility import on_object  # the search's modules import this one

    measures = (
        a.measure.kind
        for inst in interp.instances
        if (concept := kb.concepts.get(inst.concept)) is not None
        for a in concept.attributes.values()
        if a.measure is not None
    )
    if MeasureKind.ELEVATION not in measures:
        return None  # nothing to measure: the evidence is not read
    up = _up(kb, interp, model)
    if up is None:
        return None
    view = view_of(evidence)
    reference = evidence.views[0].id
    regions = [r for r in view.regions.values() if r.view == reference]
    binding = {b: inst.role for inst in interp.instances for b in inst.bindings if "/" in b}
    planes = {p.role: (np.asarray(p.normal, dtype=np.float64), p.offset_m) for p in model.parts}
    polygons = {p.role: np.asarray(p.polygon, dtype=np.float64) for p in model.parts}
    own = on_object(regions, binding, planes, polygons, up)
    return EvidenceGround(regions, view.points_on, own, up, beneath_only=True).elevation


def _measure(
    kind: MeasureKind,
    args: list[str],
    model: ReconstructedModel,
    up: FloatArray,
    forward: FloatArray | None,
    ground: Ground | None = None,
) -> float | None:
    """The measure's value (radians or metres) on the model, None when it cannot be taken."""
    sets = [_parts_under(model, a) for a in args]
    if any(not s for s in sets):
        return None
    if kind is MeasureKind.ELEVATION:
        # the ground is read from the reference view's evidence (`evidence_ground`); the
        # model alone has none
        if ground is None:
            return None
        return ground(np.vstack([poly for _, _, poly in sets[0]]))
    if kind in (MeasureKind.HEIGHT, MeasureKind.WIDTH, MeasureKind.DEPTH):
        if kind is MeasureKind.HEIGHT:
            axis = up
        elif forward is None:
            return None
        else:
            axis = np.cross(up, forward) if kind is MeasureKind.WIDTH else forward
        pts = np.vstack([poly for _, _, poly in sets[0]]) @ axis
        return float(pts.max() - pts.min())
    if any(len(s) != 1 for s in sets):
        return None  # slope, angle and distance take one plane each
    if kind is MeasureKind.SLOPE:
        return math.acos(float(np.clip(sets[0][0][0] @ up, -1.0, 1.0)))
    (n1, d1, _), (n2, _, poly2) = sets[0][0], sets[1][0]
    if kind is MeasureKind.ANGLE:
        return math.pi - math.acos(float(np.clip(n1 @ n2, -1.0, 1.0)))
    if kind is MeasureKind.DISTANCE:
        return abs(float(poly2.mean(axis=0) @ n1) - d1)
    return None


def check_orientations(
    kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel
) -> list[str]:
    """Every planar part the knowledge orients with a fixed slope (`orient top: upward`,
    `orient front: forward` — vertical —, `tilted by 35 deg`) has that slope on the model
    within ORIENTATION_TOLERANCE_DEG (reasons). Slopes left to an attribute without a
    default are the evidence's and not checked here."""
    up = _up(kb, interp, model)
    if up is None:
        return []
    by_role = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    reasons = []
    for inst in interp.instances:
        concept = kb.concepts.get(inst.concept)
        if concept is None:
            continue
        for part, o in concept.orientations.items():
            n = by_role.get(_join(inst.role, part))
            if n is None or o.tilt_rad is None:
                continue
            slope = math.degrees(math.acos(float(np.clip(n @ up, -1.0, 1.0))))
            if abs(slope - math.degrees(o.tilt_rad)) > ORIENTATION_TOLERANCE_DEG:
                reasons.append(
                    f"{_join(inst.role, part)}: slope {slope:.1f} deg, but {concept.name} "
                    f"orients it {o.direction} at {math.degrees(o.tilt_rad):.0f} deg "
                    f"(within {ORIENTATION_TOLERANCE_DEG:g})"
                )
    return reasons


def measured_attributes(
    kb: KnowledgeBase,
    interp: Interpretation,
    model: ReconstructedModel,
    ground: Ground | None = None,
) -> list[tuple[Instance, AttributeModel, float]]:
    """Every measured attribute (`is slope(self)`, ...) of every instance, measured on the
    model: (instance, attribute, value in SI: radians or metres), in the order of the
    instances and of the concept's attributes. Attributes whose measure cannot be taken
    (no up direction, a part missing from the model, an elevation without `ground`:
    `evidence_ground`) are left out."""
    up = _up(kb, interp, model)
    if up is None:
        return []
    out = []
    for inst in interp.instances:
        concept = kb.concepts.get(inst.concept)
        if concept is None:
            continue
        for attr in concept.attributes.values():
            m = attr.measure
            if m is None:
                continue
            fwd = _forward(kb, interp, model, inst.role, up)
            args = [_join(inst.role, a) for a in m.args]
            value = _measure(m.kind, args, model, up, fwd, ground)
            if value is not None:
                out.append((inst, attr, value))
    return out


def check_attributes(
    kb: KnowledgeBase,
    interp: Interpretation,
    model: ReconstructedModel,
    *,
    unit: str = "",
    metric: bool = True,
    ground: Ground | None = None,
) -> list[str]:
    """Check (d): every measured attribute of every instance inside its range (reasons).
    unit : only the attributes of this unit ('m': the sizes); '' all. metric : False when the
    model's lengths are in unknown units (a scene up to scale): ranges in metres are skipped.
    ground : the evidence's ground, for ``elevation`` (`evidence_ground`; None: not taken)."""
    reasons = []
    for inst, attr, value in measured_attributes(kb, interp, model, ground):
        if unit and attr.unit != unit:
            continue
        if not metric and attr.unit == SIZE_UNIT:
            continue
        if attr.low is None and attr.high is None:
            continue
        low = -math.inf if attr.low is None else attr.low
        high = math.inf if attr.high is None else attr.high
        slack = RANGE_SLACK_REL * max(
            abs(low) if math.isfinite(low) else 0.0, abs(high) if math.isfinite(high) else 0.0
        )
        if not low - slack <= value <= high + slack:
            shown = math.degrees(value) if attr.unit == "rad" else value
            unit = "deg" if attr.unit == "rad" else attr.unit
            lo = math.degrees(low) if attr.unit == "rad" else low
            hi = math.degrees(high) if attr.unit == "rad" else high
            reasons.append(
                f"{inst.role or inst.concept}: {attr.name} = {shown:.3g} {unit} outside "
                f"[{lo:.3g}, {hi:.3g}] ({inst.concept})"
            )
    return reasons
