"""A wall's foot in an image: its measurements lean towards the ground (`interpret.feet`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aida_kb.constraints import Constraint, EdgeData, compile_blocks
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret import joint
from aida_kb.interpret.feet import FOOT_SHADOW_PX, foot_leans, lean_scale, leaning_feet
from aida_kb.register import EdgeObservations
from tests.register.test_register import _box

K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
UP = (0.0, -1.0, 0.0)  # the box stands on its bottom in a y-down world


def _whitened_cost(
    c: Constraint, model_normals: np.ndarray, offsets: np.ndarray, camera: PinholeCamera
) -> float:
    (block,) = compile_blocks([c], len(model_normals), 1)
    r = block.evaluate(model_normals, offsets, [camera])[0][0]
    w = np.asarray(c.sqrt_information) @ r if c.sqrt_information is not None else r / c.sigma
    return float(w @ w)


def test_a_foot_fit_below_the_foot_costs_what_the_shadow_allows_one_above_it_all() -> None:
    # the box's front foot seen from 0.225 m above (10 deg): a fit 1 px below it (towards the
    # ground, where a cast shadow's edge puts it) and one 1 px above it (into the wall)
    model = _box()
    camera = PinholeCamera(K, np.eye(3), np.array([0.0, -0.2, 0.0]), 640, 480)
    ends = camera.project(model.edge_ends.reshape(-1, 3)).reshape(-1, 2, 2)
    names = [tuple(sorted((model.names[a], model.names[b]))) for a, b in model.edge_faces]
    k = names.index(("bottom", "front"))

    def factor(shift_px: float) -> Constraint:
        fit = EdgeObservations(
            model.edge_faces[[k]],
            ends[[k], 0] + [0.0, shift_px],
            ends[[k], 1] + [0.0, shift_px],
            np.array([0.1]),
        )
        (c,) = joint._fitted_edge_factors(model, camera, 0, fit, "00", up=UP)
        return c

    below, above = factor(1.0), factor(-1.0)
    assert below.edge is not None
    assert below.edge.lean != 0
    n = float(np.linalg.norm(ends[k, 1] - ends[k, 0]))
    sd = float(
        joint.fit_point_sigma(
            model,
            camera,
            EdgeObservations(model.edge_faces[[k]], ends[[k], 0], ends[[k], 1], np.array([0.1])),
            UP,
        )[0]
    )
    assert below.edge.lean_scale == pytest.approx(
        float(lean_scale(np.array([sd / math.sqrt(n)]))[0]), rel=1e-9
    )
    cost_below = _whitened_cost(below, model.normals, model.offsets, camera)
    cost_above = _whitened_cost(above, model.normals, model.offsets, camera)
    # above: 1 px over the mean offset's own sd, squared; below: over the shadow's allowance
    assert cost_above == pytest.approx((1.0 / (sd / math.sqrt(n))) ** 2, rel=1e-6)
    assert cost_below == pytest.approx(
        1.0 / ((sd / math.sqrt(n)) ** 2 + FOOT_SHADOW_PX**2), rel=1e-6
    )
    assert cost_below < 1.0 < cost_above
    # without the model's vertical, or on an edge that is no foot, no lean
    (plain,) = joint._fitted_edge_factors(
        model,
        camera,
        0,
        EdgeObservations(model.edge_faces[[k]], ends[[k], 0], ends[[k], 1], np.array([0.1])),
        "00",
    )
    assert plain.edge is not None
    assert plain.edge.lean == 0
    top = names.index(("front", "top"))
    fit = EdgeObservations(model.edge_faces[[top]], ends[[top], 0], ends[[top], 1], np.array([0.1]))
    (eave,) = joint._fitted_edge_factors(model, camera, 0, fit, "00", up=UP)
    assert eave.edge is not None
    assert eave.edge.lean == 0
    assert eave.edge.lean_scale == 1.0


def test_the_wall_side_of_a_foot_line_does_not_depend_on_its_direction() -> None:
    camera = PinholeCamera(K, np.eye(3), np.zeros(3), 640, 480)
    feet = np.array([[0.0, 1.0, 5.0], [0.0, 1.0, 5.0]])
    p = camera.project(feet[:1])[0]
    step = np.array([50.0, 0.0])
    a, b = p - step, p + step
    leans = foot_leans(camera, np.array([a, b]), np.array([b, a]), feet, np.array(UP))
    # the wall rises above the foot: upwards in the image, y down; the line's left normal
    # (-dy, dx) points down for a line running right (a -> b), up for one running left
    assert leans.tolist() == [-1, 1]
    behind = np.array([[0.0, 1.0, -5.0]])
    assert foot_leans(camera, a[None], b[None], behind, np.array(UP)).tolist() == [0]


def test_a_single_view_s_foot_contours_lean_and_its_other_edges_do_not() -> None:
    model = _box()
    camera = PinholeCamera(K, np.eye(3), np.array([0.0, -0.2, 0.0]), 640, 480)
    ends = camera.project(model.edge_ends.reshape(-1, 3)).reshape(-1, 2, 2)
    ground = list(model.names).index("bottom")

    def contour(k: int) -> Constraint:
        a, b = (int(x) for x in model.edge_faces[k])
        p, q = ends[k]
        return Constraint(
            kind="edge",
            parts=(a, b),
            sigma=1.0,
            unit="px",
            measurement=True,
            edge=EdgeData(0, (float(p[0]), float(p[1])), (float(q[0]), float(q[1]))),
        )

    cs = [contour(k) for k in range(len(model.edge_faces))]
    out = leaning_feet(cs, model.normals, model.offsets, ground, [camera])
    feet = [ground in c.parts for c in cs]
    seen = [c.edge is not None and c.edge.lean != 0 for c in out]
    assert sum(feet) == 4
    # the visible feet lean (the back one, behind the box, too: leaning is no visibility test)
    assert all(s for s, f in zip(seen, feet, strict=True) if f)
    assert not any(s for s, f in zip(seen, feet, strict=True) if not f)
    assert all(
        c.edge is not None
        and c.edge.lean_scale == pytest.approx(1.0 / math.hypot(1.0, FOOT_SHADOW_PX))
        for c, f in zip(out, feet, strict=True)
        if f
    )
    assert leaning_feet(cs, model.normals, model.offsets, None, [camera]) == cs
