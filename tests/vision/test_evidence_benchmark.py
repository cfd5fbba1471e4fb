"""benchmarks/evidence.py on random scenes: the figures it reports per kind of face."""

from __future__ import annotations

import math

import numpy as np

from benchmarks.evidence import GROSS_DEG, gyration_m, kind_figures


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
