"""Pose starts from a view's region planes (`aida_kb.register.planes`) and their use."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rotation import rotation_from_rvec
from aida_kb.register import RegionMeasurements, angle_about, register_view, vertical_axis
from aida_kb.register.planes import part_boxes, plane_poses, regions_explained
from aida_kb.testing.segments import simulated_segments
from tests.register.test_register import K, _box, _reference

UP = np.array([0.0, -1.0, 0.0])


def _off_orbit(turn_deg: float, closer: float, rise_m: float) -> PinholeCamera:
    """A camera turned about the box's vertical, `closer` times its distance, `rise_m` higher:
    not on the reference camera's orbit; upright as the reference is."""
    model, ref = _box(), _reference()
    Ra = rotation_from_rvec(UP * math.radians(turn_deg))
    R = ref.R_cam_world @ Ra
    C = model.centroid + closer * (Ra.T @ (ref.centre - model.centroid)) + rise_m * UP
    return PinholeCamera(K, R, -R @ C, 640, 480)


def _regions(cam: PinholeCamera, noise_deg: float, seed: int) -> RegionMeasurements:
    """The planes of the faces `cam` sees, in its frame (normals turned by ~noise_deg)."""
    model = _box()
    parts = np.flatnonzero(model.front_facing(cam.centre))
    centres = np.array([np.mean(model.polygons[i], axis=0) for i in parts])
    n = model.normals[parts] @ cam.R_cam_world.T
    rng = np.random.default_rng(seed)
    n = n + rng.normal(scale=math.radians(noise_deg), size=n.shape)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return RegionMeasurements(n, cam.to_camera(centres), np.full(parts.size, 1e-3))


def _poses(
    cam: PinholeCamera, regions: RegionMeasurements
) -> list[tuple[np.ndarray, np.ndarray, int]]:
    model, ref = _box(), _reference()
    return plane_poses(
        model.normals,
        model.offsets,
        part_boxes(model.polygons),
        model.size,
        regions.normal_cam,
        regions.centre_cam,
        regions.rms_m,
        vertical=(UP, ref.R_cam_world @ UP, float(UP @ ref.centre)),
    )


def test_exact_planes_give_the_pose_in_closed_form() -> None:
    cam = _off_orbit(50.0, 0.7, 0.15)
    regions = _regions(cam, 0.0, 0)
    assert regions.size == 3  # front, right, top
    poses = _poses(cam, regions)
    # the box looks the same turned by half a turn: that pose explains the regions as well
    errors = [
        (np.linalg.norm(R - cam.R_cam_world), np.linalg.norm(t - cam.t_cam_world), n)
        for R, t, n in poses
    ]
    best = min(errors)
    assert best[0] < 1e-9
    assert best[1] < 1e-9
    assert best[2] == 3
    model = _box()
    args = (model.normals, model.offsets, part_boxes(model.polygons), model.size)
    on = regions_explained(*args, cam.R_cam_world, cam.t_cam_world, *_fields(regions))
    assert on == 3
    wrong = _reference()  # the reference pose puts none of these regions on its part
    assert regions_explained(*args, wrong.R_cam_world, wrong.t_cam_world, *_fields(regions)) == 0


def _fields(r: RegionMeasurements) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return r.normal_cam, r.centre_cam, r.rms_m


def test_noisy_planes_give_a_start_near_the_pose() -> None:
    cam = _off_orbit(-35.0, 1.3, -0.1)
    poses = _poses(cam, _regions(cam, 1.5, 4))
    ref = _reference()
    turns = [angle_about(ref, PinholeCamera(K, R, t, 640, 480), UP) for R, t, _ in poses]
    near = min(abs(a - angle_about(ref, cam, UP)) for a in turns)
    assert near < 3.0


@pytest.mark.parametrize("turn_deg", [50.0, -120.0])
def test_a_view_off_the_orbit_registers_from_its_planes(turn_deg: float) -> None:
    model, ref = _box(), _reference()
    cam = _off_orbit(turn_deg, 0.7, 0.15)
    rng = np.random.default_rng(5)
    p1, p2 = simulated_segments(model, cam, rng, noise_px=0.5)
    regions = _regions(cam, 1.0, 6)
    up = vertical_axis(model, ref)
    reg = register_view(model, ref, p1, p2, regions=regions, expected_turn_deg=turn_deg, axis=up)
    dR = reg.camera.R_cam_world @ cam.R_cam_world.T
    angle = math.degrees(math.acos(min(1.0, (np.trace(dR) - 1.0) / 2.0)))
    assert angle < 0.25  # the regions, 1 degree off, pull a little
    distance = float(np.linalg.norm(cam.centre - model.centroid))
    assert float(np.linalg.norm(reg.camera.centre - cam.centre)) < 0.01 * distance
