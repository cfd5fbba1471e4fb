"""benchmarks/evidence.py on random scenes: the figures it reports per kind of face."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from aida_kb.io.scene import read_labels, read_scene
from aida_kb.vision.evidence import scene_evidence
from benchmarks.evidence import (
    GROSS_DEG,
    LOST_COVER,
    coverage_figures,
    face_rows,
    gyration_m,
    kind_figures,
    truth_face_map,
)


def test_gyration_of_a_long_low_wall() -> None:
    """A wall 12 m wide and 3 m high, 30 m in front of a level camera: its pixels spread over
    3/sqrt(12) m vertically and 12/sqrt(12) m horizontally -- the square of its area
    (sqrt(36/12) = 1.73 m) overstates the vertical spread by a factor of 2."""
    f = 800.0
    xs, ys = np.meshgrid(np.arange(-160.0, 160.0) + 0.5, np.arange(-40.0, 40.0) + 0.5)
    rays = np.stack([xs.ravel() / f, ys.ravel() / f, np.ones(xs.size)], axis=1)
    n = np.array([0.0, 0.0, -1.0])  # facing the camera; the wall is z = 30: n·x = -30
    up = np.array([0.0, -1.0, 0.0])
    vertical, horizontal = gyration_m(rays, n, -30.0, up)
    assert math.isclose(vertical, 3.0 / math.sqrt(12.0), rel_tol=1e-3)
    assert math.isclose(horizontal, 12.0 / math.sqrt(12.0), rel_tol=1e-3)


def test_kind_figures_count_failed_fits_apart() -> None:
    """A fit further off than GROSS_DEG counts as failed and stays out of the medians."""
    rows = [
        {"kind": "wall", "angle_deg": a, "tilt_deg": t, "z": 1.0, "z_tilt": 1.0}
        | {"z_tilt_own": 0.5, "aspect": 2.0}
        for a, t in ((0.2, 0.1), (0.4, -0.3), (GROSS_DEG + 5.0, 15.0))
    ]
    wall = kind_figures(rows)["wall"]
    assert wall["regions"] == 3
    assert wall["failed"] == 1
    assert wall["median_deg"] == 0.3
    assert wall["tilt_mean_deg"] == -0.1
    assert wall["median_square_over_vertical"] == 2.0
    assert kind_figures(rows)["roof"] == {"regions": 0, "failed": 0}


def test_truth_face_map_agrees_with_the_rendered_labels(small_house: Path) -> None:
    """The true faces found from the exact depth are the renderer's own labels on the
    labelled pixels (the ground and the faces alike), bar a thin line along the edges."""
    scene = read_scene(small_house)
    view = scene.view("00")
    assert view.labels is not None
    labels = read_labels(view.labels).astype(np.int64)
    faces = truth_face_map(scene, "00")
    on = labels > 0
    assert np.count_nonzero(on) > 0.5 * labels.size
    assert np.mean(faces[on] == labels[on]) > 0.99
    assert np.all(faces[~on & np.isnan(np.load(view.depth_left))] == 0)  # the sky: no face


def test_coverage_rows_of_the_labelled_house(small_house: Path) -> None:
    """With labels.png every face is its own region: covered whole, pure, neither split nor
    merged, its normal within 2 degrees; a wall merged with a roof is counted as merged."""
    scene = read_scene(small_house)
    evidence, products = scene_evidence(scene, views=["00"])
    rows = face_rows(scene, evidence, products)
    assert {r["kind"] for r in rows} >= {"wall", "roof"}
    for r in rows:
        assert r["labelled"]
        assert r["main_cover"] > 0.95, r
        assert r["purity"] > 0.99, r
        assert r["split"] == 0, r
        assert r["merged"] == [], r
        assert r["angle_deg"] < 2.0, r  # the evidence's done-when figure
    figures = coverage_figures(rows)
    assert figures["roof"]["faces"] == sum(r["kind"] == "roof" for r in rows)
    assert figures["roof"]["lost"] == 0
    assert figures["roof"]["merged"] == 0
    merged = [{**rows[0], "kind": "wall", "merged": ["roof"], "main_cover": 0.9}]
    lost = [{**rows[0], "kind": "wall", "main_cover": LOST_COVER / 2}]
    wall = coverage_figures(merged + lost)["wall"]
    assert (wall["faces"], wall["lost"], wall["merged"]) == (2, 1, 1)
    assert wall["merged_with"] == {"roof": 1}
