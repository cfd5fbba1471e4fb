"""The interpreter's adjustment: internal constraints pull perturbed planes into shape."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aida_kb.interpret.adjust import adjust
from aida_kb.interpret.interpreter import AttributeSpec
from aida_kb.interpret.knowledge import OwnedSpec
from aida_kb.interpret.observe import CameraView, RegionView
from aida_kb.interpret.problem import PlaneInit, PositionMeasure, Problem


def _spec(
    label: str,
    kind: str,
    args: tuple[str, ...],
    value: float,
    sigma_deg: float,
    reject_deg: float | None = None,
) -> OwnedSpec:
    sigma = math.radians(sigma_deg)
    spec = AttributeSpec(
        label=label,
        kind=kind,
        args=args,
        value=value,
        unit="rad",
        sigma=sigma,
        weight=1.0 / sigma**2,
        reject_above=math.radians(reject_deg) if reject_deg is not None else math.inf,
        measurement=False,
        concept="Test",
    )
    return OwnedSpec(spec, "")


def _turn(n: np.ndarray, deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([c * n[0] + s * n[2], n[1], -s * n[0] + c * n[2]])


CAMERA = CameraView("00", np.diag([800.0, 800.0, 1.0]), np.eye(3), np.zeros(3), 640, 480, 0.4)


def _region(rid: str, normal: np.ndarray, centroid: np.ndarray) -> RegionView:
    return RegionView(rid, "00", normal, np.asarray(centroid, float), 9000.0, 10000.0, 0.01)


def test_perpendicular_walls_meet_the_regions_halfway() -> None:
    front, left = np.array([0.0, 0.0, -1.0]), np.array([-1.0, 0.0, 0.0])
    # the regions say the corner is 92 degrees; the knowledge says 90 +- 1
    seen_front = _turn(front, 1.0)
    seen_left = _turn(left, -1.0)
    planes = (
        PlaneInit("a", "Wall", seen_front, float(seen_front @ [0, 0, 20.0])),
        PlaneInit("b", "Wall", seen_left, float(seen_left @ [-5.0, 0, 22.0])),
    )
    positions = tuple(
        PositionMeasure(p.role, _region(p.role, p.normal, c), CAMERA, _position_spec(), p.role)
        for p, c in zip(planes, ([0, 0, 20.0], [-5.0, 0, 22.0]), strict=True)
    )
    corner = _spec("corner", "angle", ("a", "b"), math.pi / 2, 1.0, 5.0)
    out = adjust(Problem(planes, (corner,), positions, ()))
    n_a, _ = out.planes["a"]
    n_b, _ = out.planes["b"]
    meeting = 180.0 - math.degrees(math.acos(float(n_a @ n_b)))
    # 1 degree of tilt costs 1 px (sigma 1) at each region, 1 degree of corner 1 sigma:
    # the three share the 2 degrees: the corner ends a third of the way, at 90.67
    assert meeting == pytest.approx(90.0 + 2.0 / 3.0, abs=0.05)
    result = {r.label: r for r in out.residuals}
    assert result["corner"].normalised == pytest.approx(2.0 / 3.0, abs=0.05)
    assert not any(r.rejected for r in out.residuals)


def test_a_contradiction_over_the_threshold_is_flagged() -> None:
    n = np.array([0.0, 0.0, -1.0])
    planes = (
        PlaneInit("a", "Wall", n, -20.0, fixed=True),
        PlaneInit("b", "Wall", _turn(n, 40.0), -20.0),
    )
    strict = _spec("parallel", "parallel", ("a", "b"), 0.0, 0.5, 2.0)
    fixed_b = PositionMeasure(
        "b",
        _region("b", _turn(n, 40.0), np.array([3.0, 0.0, 20.0])),
        CAMERA,
        _position_spec(sigma=0.01),
        "b",
    )
    out = adjust(Problem(planes, (strict,), (fixed_b,), ()))
    np.testing.assert_allclose(out.planes["a"][0], n)  # fixed parts do not move
    worst = out.worst_rejected()
    assert worst is not None
    assert worst.label == "parallel"
    assert worst.residual > math.radians(2.0)


def _position_spec(sigma: float = 1.0) -> AttributeSpec:
    return AttributeSpec(
        label="Region#1",
        kind="position",
        args=("self",),
        value=0.0,
        unit="px",
        sigma=sigma,
        weight=1.0 / sigma**2,
        reject_above=4.0,
        measurement=True,
        concept="Region",
    )
