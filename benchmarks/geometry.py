"""Geometry benchmark: camera conversion accuracy, projection speed, polyhedron rebuilds.

Run: .venv/bin/python benchmarks/geometry.py
Ends with one line of JSON:
  cahv_round_trip_max_rel   largest relative error of K, R, t over pinhole -> CAHV -> pinhole
                            for 2,000 random cameras (skew included)
  project_jac_100k_ms       project_with_jacobians of 100,000 points (pixels, d/dpoints, d/dpose)
  unproject_100k_ms         unproject of 100,000 pixels
  synth_polygon_max_err_m   largest vertex error of every synthetic building's polygons rebuilt
                            from its planes and face adjacency (all presets, all solids)
  from_adjacency_ms         Polyhedron.from_adjacency of the 9-face hip-roof house
  with_planes_ms            Polyhedron.with_planes (vertices and all checks) of the same house
  vertex_jacobians_ms       Polyhedron.vertex_jacobians of the same house
Times are medians of repeated runs, wall clock, one process.
"""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable

import numpy as np

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.polyhedron import Polyhedron
from aida_kb.synth import buildings


def _median_ms(fn: Callable[[], object], runs: int) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1e3 * statistics.median(times)


def _random_camera(rng: np.random.Generator) -> PinholeCamera:
    fx = rng.uniform(50, 8000)
    K = np.array(
        [
            [fx, rng.uniform(-50, 50), rng.uniform(-500, 3000)],
            [0.0, fx * rng.uniform(0.5, 2), rng.uniform(-500, 3000)],
            [0.0, 0.0, 1.0],
        ]
    )
    axis = rng.normal(size=3)
    rvec = rng.uniform(0, np.pi) * axis / np.linalg.norm(axis)
    pose = np.concatenate([rvec, rng.uniform(-200, 200, size=3)])
    return PinholeCamera.from_pose(K, pose, 1920, 1080)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1.0))


def _faces_and_adjacency(
    polygons: dict[str, np.ndarray],
) -> tuple[list[str], np.ndarray, np.ndarray, set[tuple[str, str]]]:
    names = list(polygons)
    N = np.array([buildings.polygon_normal(polygons[n]) for n in names])
    d = np.array([N[i] @ polygons[n].mean(axis=0) for i, n in enumerate(names)])
    owners: dict[tuple[tuple[float, ...], ...], list[str]] = {}
    for name, P in polygons.items():
        for i in range(len(P)):
            a, b = tuple(np.round(P[i], 9)), tuple(np.round(P[(i + 1) % len(P)], 9))
            owners.setdefault(tuple(sorted([a, b])), []).append(name)
    return names, N, d, {(v[0], v[1]) for v in owners.values()}


def main() -> None:
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(2000):
        cam = _random_camera(rng)
        back = PinholeCamera.from_cahv(cam.to_cahv(), cam.width, cam.height)
        worst = max(
            worst,
            _rel(back.K, cam.K),
            _rel(back.R_cam_world, cam.R_cam_world),
            _rel(back.t_cam_world, cam.t_cam_world),
        )
    cam = _random_camera(rng)
    pixels = rng.uniform([0, 0], [cam.width, cam.height], size=(100_000, 2))
    centre, rays = cam.unproject(pixels)
    points = centre + rays * rng.uniform(1, 50, size=(100_000, 1))
    project_ms = _median_ms(lambda: cam.project_with_jacobians(points), 7)
    unproject_ms = _median_ms(lambda: cam.unproject(pixels), 7)

    models = [buildings.house(roof=r) for r in ("gable", "hip", "flat", "shed")]
    models += [buildings.lshape_house(), buildings.lshape_house(meeting_deg=135.0)]
    models += [buildings.oriel_house(), buildings.reference_box()]
    err = 0.0
    for model in models:
        for solid in model.solids:
            truth = {f.role: f.polygon for f in solid.faces}
            names, N, d, adj = _faces_and_adjacency(truth)
            poly = Polyhedron.from_adjacency(names, N, d, adj)
            for name, P in poly.polygons().items():
                T = truth[name]
                err = max(
                    err, min(float(np.max(np.abs(np.roll(P, r, 0) - T))) for r in range(len(T)))
                )

    house = buildings.house(roof="hip")
    names, N, d, adj = _faces_and_adjacency({f.role: f.polygon for f in house.faces})
    poly = Polyhedron.from_adjacency(names, N, d, adj)
    print(
        json.dumps(
            {
                "cahv_round_trip_max_rel": float(f"{worst:.3g}"),
                "project_jac_100k_ms": round(project_ms, 2),
                "unproject_100k_ms": round(unproject_ms, 2),
                "synth_polygon_max_err_m": float(f"{err:.3g}"),
                "from_adjacency_ms": round(
                    _median_ms(lambda: Polyhedron.from_adjacency(names, N, d, adj), 15), 2
                ),
                "with_planes_ms": round(_median_ms(lambda: poly.with_planes(N, d), 51), 3),
                "vertex_jacobians_ms": round(_median_ms(poly.vertex_jacobians, 51), 3),
            }
        )
    )


if __name__ == "__main__":
    main()
