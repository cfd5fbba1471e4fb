"""Parts the knowledge placed, moved onto their outlines (`aida_kb.interpret.silhouette`)."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.photometric import model_faces
from aida_kb.interpret.silhouette import outline_shift, outline_steps, shown_share
from aida_kb.register import RegionMeasurements, RigidModel
from aida_kb.register.evidence import ViewMeasurements
from aida_kb.texture.raycast import first_hits
from tests.interpret.test_photometric import H, K, W, _box

# `_box`: a 10 m cube 30 m ahead, turned 45 deg about the vertical: the camera at the origin
# sees its front and right, and their outlines beside the left and the back
NAMES = ["left", "right", "top", "bottom", "front", "back"]


def _image(model: RigidModel, cam: PinholeCamera) -> np.ndarray:
    """The camera's image of the model: each face one grey, the background lighter."""
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    face, _, _ = first_hits(model_faces(model), cam, np.stack([xs.ravel(), ys.ravel()], axis=1))
    greys = np.array([90.0, 100.0, 110.0, 120.0, 150.0, 130.0])
    out = np.where(face >= 0, greys[np.maximum(face, 0)], 200.0).reshape(H, W)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def test_a_placed_back_moves_onto_its_outline_and_a_right_side_stays() -> None:
    cam = PinholeCamera(K, np.eye(3), np.zeros(3), W, H)
    grey = _image(_box(), cam)
    model = _box(back=5.8)  # the knowledge put the back 0.8 m too far
    movable = np.array([name in ("back", "left") for name in NAMES])
    steps = {NAMES[s.part]: s for s in outline_steps(model, [cam], [grey], movable)}
    assert set(steps) == {"back", "left"}
    # to a pixel or so (15 px a metre here): the shift is taken as one across the edge's
    # middle, the image rounds that follow fit the edge itself
    assert steps["back"].step_m == pytest.approx(-0.8, abs=0.1)
    assert steps["back"].edges == ((0, NAMES.index("right")),)
    assert steps["left"].step_m == pytest.approx(0.0, abs=0.1)
    assert outline_steps(model, [cam], [None], movable) == []  # no image: nothing found


def _steps(*columns: tuple[int, int]) -> np.ndarray:
    """A 200 x 200 grey image, 60 left of x = 100 and 180 right of it, with darker vertical
    stripes (x from, x to) drawn over rows 20-180."""
    img = np.full((200, 200), 60, np.uint8)
    img[:, 100:] = 180
    for x0, x1 in columns:
        img[20:180, x0:x1] = 20
    return img


def test_the_outline_shift_is_the_one_line_running_the_whole_edge() -> None:
    a, b = np.array([90.0, 30.0]), np.array([90.0, 170.0])  # 10 px left of the step
    shift = outline_shift(_steps(), a, b)
    assert shift is not None
    assert abs(shift) == pytest.approx(9.5, abs=0.3)  # the step lies between pixels 99, 100
    # a second line as long, within reach: the outline is not decided
    assert outline_shift(_steps((112, 200)), a, b) is None
    # nothing but noise-free flat grey within reach: nothing found
    assert outline_shift(np.full((200, 200), 60, np.uint8), a, b) is None


def _segments(p1: list[list[float]], p2: list[list[float]]) -> ViewMeasurements:
    none = RegionMeasurements(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
    return ViewMeasurements("00", K, W, H, np.array(p1, float), np.array(p2, float), none)


def test_an_outline_counts_only_where_the_views_segments_show_it() -> None:
    a, b = np.array([100.0, 50.0]), np.array([100.0, 250.0])
    # two segments along it, 1 px off, covering 50-150 and 200-250: three quarters
    view = _segments([[101.0, 50.0], [99.0, 200.0]], [[101.0, 150.0], [99.0, 250.0]])
    assert shown_share(view, a, b) == pytest.approx(0.75, abs=0.03)
    # beyond CORROBORATE_PX, or across it: not shown
    assert shown_share(_segments([[104.0, 50.0]], [[104.0, 250.0]]), a, b) == 0.0
    assert shown_share(_segments([[50.0, 100.0]], [[150.0, 100.0]]), a, b) == 0.0


def test_the_band_keeps_a_line_across_the_faced_part_out() -> None:
    """A stripe 22 px across the edge (a side wall's window column) is out of a band that
    stops at 15 px on its side: the outline 9.5 px away is decided."""
    a, b = np.array([90.0, 30.0]), np.array([90.0, 170.0])  # left normal: towards -x
    assert outline_shift(_steps((112, 200)), a, b) is None
    shift = outline_shift(_steps((112, 200)), a, b, (-15.0, 30.0))
    assert shift == pytest.approx(-9.5, abs=0.3)
