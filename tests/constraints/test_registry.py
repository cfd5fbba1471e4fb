"""The kind registry: every kind has a sample here, its Jacobians match finite differences by
the planes and the camera pose, and it is documented (the diagnostic-code registry's pattern).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from aida_kb.constraints import (
    KINDS,
    CameraPositionData,
    Constraint,
    EdgeData,
    PositionData,
    TextureData,
    TextureImage,
    compile_blocks,
)
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rig import Rig

ROOT = Path(__file__).resolve().parents[2]
K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])


def _unit(v: np.ndarray) -> np.ndarray:
    out: np.ndarray = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return out


def _scene() -> tuple[np.ndarray, np.ndarray, list[PinholeCamera]]:
    """Six planes of a box-like solid about 20 m in front of two cameras."""
    rng = np.random.default_rng(11)
    base = np.array(
        [[0, 0, -1.0], [-1.0, 0, 0], [1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0], [0, 1.0, 0]]
    )
    n = _unit(base + 0.05 * rng.normal(size=base.shape))
    centre = np.array([0.5, 0.3, 20.0])
    d = n @ centre + 4.0
    cam0 = PinholeCamera(K, np.eye(3), np.zeros(3), 640, 480)
    cam1 = cam0.with_pose(np.array([0.01, -0.05, 0.02, -1.0, 0.2, 0.5]))
    return n, d, [cam0, cam1]


def _texture(cam: PinholeCamera) -> Constraint:
    """A 4 x 4 patch of camera 0's image about its centre on part 0, seen again by camera 1
    in a smooth synthetic image."""
    ys, xs = np.mgrid[0:480, 0:640].astype(np.float64)
    image = 120.0 + 40.0 * np.sin(xs / 9.0) * np.cos(ys / 7.0) + 0.05 * xs
    u, v = np.meshgrid(300.0 + 3.3 * np.arange(4), 220.0 + 2.9 * np.arange(4))
    rays = np.stack([(u.ravel() - 320.0) / 800.0, (v.ravel() - 240.0) / 800.0, np.ones(16)], 1)
    values = 100.0 + 30.0 * np.cos(u.ravel() / 5.0 + v.ravel() / 11.0)
    return Constraint(
        kind="texture",
        parts=(0,),
        sigma=2.0,
        measurement=True,
        texture=TextureData(
            1,
            (0.0, 0.0, 0.0),
            tuple(tuple(float(x) for x in r) for r in rays),  # type: ignore[misc]
            tuple(float(x) for x in values),
            TextureImage(image),
        ),
    )


SAMPLES: dict[str, Callable[[PinholeCamera], Constraint]] = {
    "angle": lambda cam: Constraint(kind="angle", parts=(0, 1), value=1.4, sigma=0.01),
    "parallel": lambda cam: Constraint(kind="parallel", parts=(0, 3), sign=-1, sigma=0.01),
    "coincident": lambda cam: Constraint(
        kind="coincident",
        parts=(0, 3),
        sign=-1,
        sqrt_information=tuple(
            tuple(float(x) for x in row) for row in np.diag([100.0, 100.0, 100.0, 10.0])
        ),
    ),
    "concurrent": lambda cam: Constraint(kind="concurrent", parts=(0, 1, 4, 3), sigma=0.02),
    "parallel_edge": lambda cam: Constraint(kind="parallel_edge", parts=(0, 4, 3, 4), sigma=0.01),
    "symmetry": lambda cam: Constraint(kind="symmetry", parts=(0, 4, 3, 4), sigma=0.01),
    "position": lambda cam: Constraint(
        kind="position",
        parts=(0,),
        sigma=1.0,
        unit="px",
        position=PositionData(
            (0.1 / math.sqrt(1.01), 0.0, -1.0 / math.sqrt(1.01)),
            (0.2, 0.1, 16.5),
            0.8,
            1.0,
            40,
            3.0,
        ),
        measurement=True,
    ),
    "edge": lambda cam: Constraint(
        kind="edge",
        parts=(0, 1),
        sigma=1.0,
        unit="px",
        measurement=True,
        edge=EdgeData(1, (250.0, 180.0), (255.0, 300.0)),
    ),
    "camera_position": lambda cam: Constraint(
        kind="camera_position",
        parts=(0,),
        sqrt_information=((10.0, 0.0, 0.0), (0.0, 50.0, 0.0), (0.0, 0.0, 50.0)),
        measurement=True,
        camera_position=CameraPositionData(
            1,
            tuple(_unit(np.array([0.05, 0.02, -1.0])).tolist()),  # type: ignore[arg-type]
            (0.3, -0.2, 17.0),
        ),
    ),
    "texture": _texture,
}


def test_every_kind_has_a_sample_and_documentation() -> None:
    assert set(SAMPLES) == set(KINDS), "a kind without a Jacobian test here"
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    for name, kind in KINDS.items():
        assert kind.name == name
        assert kind.summary
        assert kind.arity >= 1
        assert kind.residual_size >= kind.dof >= 1
        assert f"`{name}`" in doc, f"kind {name} is not in docs/architecture.md's table"


@pytest.mark.parametrize("name", sorted(KINDS))
def test_jacobians_match_finite_differences(name: str) -> None:
    n, d, cams = _scene()
    c = SAMPLES[name](cams[1])
    (block,) = compile_blocks([c], n.shape[0], len(cams))
    r, J, Jc = block.evaluate(n, d, cams)
    assert r.shape == (1, KINDS[name].block_kind(c).residual_size)
    assert np.all(np.isfinite(r))
    eps = 1e-6
    for a, part in enumerate(c.parts):
        for comp in range(4):
            n_p, n_m, d_p, d_m = n.copy(), n.copy(), d.copy(), d.copy()
            if comp < 3:
                n_p[part, comp] += eps
                n_m[part, comp] -= eps
            else:
                d_p[part] += eps
                d_m[part] -= eps
            num = (block.evaluate(n_p, d_p, cams)[0] - block.evaluate(n_m, d_m, cams)[0]) / (
                2 * eps
            )
            # a plane that occurs twice in a constraint sums its columns
            ana = sum(J[:, :, b, comp] for b, p in enumerate(c.parts) if p == part)
            np.testing.assert_allclose(ana, num, atol=1e-5, rtol=1e-5, err_msg=f"{a}, {comp}")
    if not KINDS[name].uses_camera:
        assert Jc is None
        return
    assert Jc is not None
    pose = cams[1].pose
    for j in range(6):
        step = np.zeros(6)
        step[j] = eps
        plus = [cams[0], cams[1].with_pose(pose + step)]
        minus = [cams[0], cams[1].with_pose(pose - step)]
        num = (block.evaluate(n, d, plus)[0] - block.evaluate(n, d, minus)[0]) / (2 * eps)
        np.testing.assert_allclose(Jc[:, :, j], num, atol=1e-5, rtol=1e-5, err_msg=f"pose {j}")


def test_a_derived_rig_camera_chains_its_pose_jacobian() -> None:
    from aida_kb.solve.problem import Evaluation, build_problem

    n, d, cams = _scene()
    R_rig = np.eye(3)
    rig = Rig(K, R_rig, np.array([-0.4, 0.0, 0.0]), 640, 480)
    right_of_1 = rig.right_of(cams[1])
    p1, p2 = right_of_1.project(np.array([[-4.0, -2.0, 16.5], [-4.0, 2.0, 16.5]]))
    edge = Constraint(
        kind="edge",
        parts=(0, 1),
        sigma=1.0,
        unit="px",
        measurement=True,
        edge=EdgeData(2, tuple(p1), tuple(p2)),  # type: ignore[arg-type]
    )
    problem = build_problem(
        n, d, [edge], cameras=[*cams, cams[0]], free_cameras=[1], derived=[(2, 1, rig)]
    )
    ev = Evaluation(problem, np.zeros(0, dtype=np.intp), free_cameras=np.array([1]))
    x = ev.x_from(np.zeros((6, 3)), problem.cameras)
    f, J = ev.residuals_and_dense_jacobian(x)
    assert J.shape == (2, 6)
    assert np.all(np.isfinite(f))
    eps = 1e-6
    for j in range(6):
        dx = np.zeros(6)
        dx[j] = eps
        num = (ev.residuals(x + dx) - ev.residuals(x - dx)) / (2 * eps)
        np.testing.assert_allclose(J[:, j], num, atol=1e-5, rtol=1e-5)
