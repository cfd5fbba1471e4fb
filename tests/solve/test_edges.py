"""Edge constraints in the solver: viewpoint registration (paper §6.2) and joint adjustment."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aida_kb.constraints import Constraint, EdgeData
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.solve.problem import build_problem
from aida_kb.solve.solver import solve
from aida_kb.testing.houses import SyntheticScene, house_row, perturbed

K = np.array([[1000.0, 0.0, 640.0], [0.0, 1000.0, 480.0], [0.0, 0.0, 1.0]])


def _edges(
    scene: SyntheticScene, cam: PinholeCamera, index: int, noise_px: float, seed: int
) -> list[Constraint]:
    """Edge constraints of the body and the wing: each pair of planes meeting at two vertices."""
    rng = np.random.default_rng(seed)
    out = []
    on = np.abs(scene.vertices @ scene.normals.T - scene.offsets) < 1e-6  # (V, P)
    for solid in scene.solids[:2]:
        for a in solid:
            for b in solid:
                both = np.flatnonzero(on[:, a] & on[:, b])
                if a >= b or both.size != 2:
                    continue
                ends = scene.vertices[both]
                if not np.all(cam.in_front(ends)):
                    continue
                p = cam.project(ends) + rng.normal(scale=noise_px, size=(2, 2))
                out.append(
                    Constraint(
                        kind="edge",
                        parts=(int(a), int(b)),
                        sigma=1.0,
                        unit="px",
                        measurement=True,
                        label=f"edge({scene.names[a]}, {scene.names[b]})@{index}",
                        edge=EdgeData(index, (p[0, 0], p[0, 1]), (p[1, 0], p[1, 1])),
                    )
                )
    return out


@pytest.fixture(scope="module")
def scene() -> SyntheticScene:
    return house_row(1, seed=0, evidence_angle_deg=0.03, evidence_offset_m=0.01)


def _cameras() -> tuple[PinholeCamera, PinholeCamera]:
    cam0 = PinholeCamera(K, np.eye(3), np.zeros(3), 1280, 960)
    cam1 = PinholeCamera.from_pose(K, [0.0, -0.35, 0.0, 10.0, -1.0, 3.0], 1280, 960)
    return cam0, cam1


def test_viewpoint_registration_recovers_the_pose(scene: SyntheticScene) -> None:
    cam0, cam1 = _cameras()
    edges = _edges(scene, cam1, 1, noise_px=0.2, seed=1)
    assert len(edges) >= 12
    start = cam1.with_pose(cam1.pose + np.array([0.02, -0.03, 0.01, 0.6, -0.4, 0.5]))
    problem = build_problem(
        scene.normals,
        scene.offsets,
        edges,
        centres=scene.centres,
        fixed_parts=range(len(scene.names)),
        cameras=[cam0, start],
        free_cameras=[1],
    )
    result = solve(problem)
    # the model is held fixed: no part parameter moves, the planes stay as given (to rounding)
    np.testing.assert_array_equal(result.params, 0.0)
    np.testing.assert_allclose(result.normals, scene.normals, rtol=0, atol=1e-12)
    pose = result.cameras[1].pose
    assert np.max(np.abs(pose[:3] - cam1.pose[:3])) < math.radians(0.05)
    assert np.max(np.abs(pose[3:] - cam1.pose[3:])) < 0.05
    assert not result.report.exceeding
    assert result.cameras[0] is cam0


def test_edges_and_positions_adjust_the_house_jointly(scene: SyntheticScene) -> None:
    cam0, cam1 = _cameras()
    edges = _edges(scene, cam0, 0, noise_px=0.2, seed=2) + _edges(scene, cam1, 1, 0.2, seed=3)
    n0, d0 = perturbed(scene, seed=4, angle_deg=1.0, offset_m=0.1)
    problem = build_problem(
        n0,
        d0,
        scene.constraints + tuple(edges),
        centres=scene.centres,
        cameras=[cam0, cam1],
    )
    result = solve(problem)
    assert result.success
    edge_rows = [r for r in result.report.rows if r.kind == "edge"]
    assert len(edge_rows) == len(edges)
    assert max(r.residual for r in edge_rows) < 2.0  # pixels
    assert not result.report.exceeding


def test_edge_constraint_with_an_unknown_camera_is_an_error(scene: SyntheticScene) -> None:
    bad = Constraint(
        kind="edge", parts=(1, 3), sigma=1.0, unit="px", edge=EdgeData(2, (0.0, 0.0), (10.0, 0.0))
    )
    with pytest.raises(SolveError, match="unknown camera index 2"):
        build_problem(scene.normals, scene.offsets, [bad], cameras=list(_cameras()))
