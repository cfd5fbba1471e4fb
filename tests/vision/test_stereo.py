"""NCC stereo: known shifts, slanted planes, occlusions, flat images, a rendered house."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from aida_kb.errors import VisionError
from aida_kb.io.scene import read_image, read_labels, read_scene
from aida_kb.testing.pairs import random_texture, warp_right
from aida_kb.vision.evaluate import score_disparity, truth_disparity
from aida_kb.vision.rectify import stereo_rectification
from aida_kb.vision.stereo import QUANTISATION_SD, image_noise_sd, ncc_disparity


@pytest.mark.parametrize("exact", [False, True])
def test_constant_subpixel_shift(exact: bool) -> None:
    left = random_texture(96, 160)
    right = warp_right(left, np.full(left.shape, 7.3, np.float32))
    res = ncc_disparity(left.astype(np.uint8), right.astype(np.uint8), num_disp=16, exact=exact)
    inner = res.disparity[10:-10, 20:-10]
    assert np.mean(~np.isnan(inner)) > 0.97
    assert np.nanmedian(np.abs(inner - 7.3)) < 0.1
    assert np.mean(np.abs(inner[~np.isnan(inner)] - 7.3) > 0.5) < 0.005
    assert np.median(res.certainty[10:-10, 20:-10]) > 0.5
    assert res.certainty.min() >= 0.0
    assert res.certainty.max() <= 1.0
    assert np.all(res.certainty[np.isnan(res.disparity)] == 0.0)


def test_slanted_plane_subpixel() -> None:
    h, w = 96, 200
    left = random_texture(h, w, seed=1)
    slope = 8.0 / (w - 1)
    xs = np.arange(w, dtype=np.float32)
    right = warp_right(left, np.tile(4.0 + slope * xs, (h, 1)))  # d as a function of x_right
    # at the left pixel x_l = x_r + d: d = 4 + slope·(x_l - d)
    truth = np.tile((4.0 + slope * xs) / (1.0 + slope), (h, 1))
    res = ncc_disparity(left, right, num_disp=16, window=9)
    err = np.abs(res.disparity - truth)[10:-10, 20:-10]
    assert np.nanmedian(err) < 0.15
    assert np.mean(err[~np.isnan(err)] > 1.0) < 0.01


def test_occlusion_is_dropped_by_left_right_check() -> None:
    # a fronto-parallel square at disparity 12 in front of a background at disparity 3
    h, w = 100, 160
    back, front = random_texture(h, w + 40, seed=2), random_texture(h, w + 40, seed=3)
    disp = np.full((h, w), 3.0, np.float32)
    disp[30:70, 60:110] = 12.0
    left = np.where(disp == 12.0, front[:, :w], back[:, :w]).astype(np.float32)
    # render the right image exactly: right(x) = surface seen at x + d
    right = np.empty_like(left)
    xs = np.arange(w)
    for y in range(h):  # test data only: per-row assembly of a two-layer scene
        right[y] = back[y, xs + 3]
        in_front = (xs + 12 >= 60) & (xs + 12 < 110) & (y >= 30) & (y < 70)
        right[y, in_front] = front[y, xs[in_front] + 12]
    res = ncc_disparity(left, right, num_disp=16, window=7)
    occluded = res.disparity[
        35:65, 49:57
    ]  # background visible left of the square, hidden on the right
    assert np.mean(np.isnan(occluded)) > 0.6
    good = ~np.isnan(res.disparity)
    assert np.mean(np.abs(res.disparity[good] - disp[good]) > 1.0) < 0.03


def test_flat_image_has_no_disparity() -> None:
    flat = np.full((60, 90), 120, np.uint8)
    res = ncc_disparity(flat, flat, num_disp=8)
    assert np.all(np.isnan(res.disparity))
    assert np.all(res.certainty == 0.0)
    assert res.density == 0.0


def test_workers_and_bands_give_identical_results() -> None:
    left = random_texture(130, 120, seed=4)
    right = warp_right(left, np.full(left.shape, 5.0, np.float32))
    a = ncc_disparity(left, right, num_disp=12, workers=1)
    b = ncc_disparity(left, right, num_disp=12, workers=3)
    np.testing.assert_array_equal(a.disparity, b.disparity)
    np.testing.assert_array_equal(a.certainty, b.certainty)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"window": 8}, "odd"),
        ({"num_disp": 2}, "num_disp"),
        ({"min_disp": -1}, "min_disp"),
        ({"num_disp": 300}, "num_disp"),
    ],
)
def test_bad_parameters(kwargs: dict[str, int], message: str) -> None:
    img = np.zeros((40, 60), np.uint8)
    with pytest.raises(VisionError, match=message):
        ncc_disparity(img, img, **kwargs)


def test_bad_images() -> None:
    with pytest.raises(VisionError, match="differ in size"):
        ncc_disparity(np.zeros((40, 60), np.uint8), np.zeros((40, 61), np.uint8))
    with pytest.raises(VisionError, match="NaN"):
        ncc_disparity(np.full((40, 60), np.nan), np.zeros((40, 60)))
    with pytest.raises(VisionError, match="too small"):
        ncc_disparity(np.zeros((40, 20), np.uint8), np.zeros((40, 20), np.uint8), min_disp=15)


@pytest.mark.parametrize("window", [41, 99999])
def test_a_window_larger_than_the_image_is_named_as_the_problem(window: int) -> None:
    img = np.zeros((40, 60), np.uint8)
    with pytest.raises(VisionError, match=rf"window {window} does not fit the 60x40 image"):
        ncc_disparity(img, img, window=window)


def test_rendered_house_against_truth(small_house: Path) -> None:
    scene = read_scene(small_house)
    assert scene.truth is not None
    view = scene.views[0]
    assert view.labels is not None
    rect = stereo_rectification(scene.calib)
    left, right = rect.rectify(read_image(view.left, grey=True), read_image(view.right, grey=True))
    truth = truth_disparity(scene.truth, view.id, read_labels(view.labels), rect)
    res = ncc_disparity(left, right, num_disp=16)
    full = score_disparity(res.disparity, truth)
    assert full.density > 0.85
    assert full.bad2 < 0.05
    # the most certain half is far better than the rest
    known = ~np.isnan(truth) & ~np.isnan(res.disparity)
    top = known & (res.certainty >= np.median(res.certainty[known]))
    best = score_disparity(np.where(top, res.disparity, np.nan).astype(np.float32), truth)
    assert best.bad1 < 0.03
    assert best.bad2 < 0.01
    assert best.mean_abs_px < 0.25


def test_adaptive_range_agrees_with_the_full_search(small_house: Path) -> None:
    scene = read_scene(small_house)
    assert scene.truth is not None
    view = scene.views[0]
    assert view.labels is not None
    rect = stereo_rectification(scene.calib)
    left, right = rect.rectify(read_image(view.left, grey=True), read_image(view.right, grey=True))
    full = ncc_disparity(left, right, num_disp=32, window=11, adaptive_range=False)
    fast = ncc_disparity(left, right, num_disp=32, window=11, adaptive_range=True)
    both = ~np.isnan(full.disparity) & ~np.isnan(fast.disparity)
    assert both.sum() > 0.9 * np.count_nonzero(~np.isnan(full.disparity))
    differ = both & (np.abs(full.disparity - fast.disparity) > 1.0)
    assert differ.sum() < 0.02 * both.sum()
    truth = truth_disparity(scene.truth, view.id, read_labels(view.labels), rect)
    s_fast, s_full = score_disparity(fast.disparity, truth), score_disparity(full.disparity, truth)
    assert s_fast.density >= s_full.density - 0.01
    assert s_fast.bad2 <= s_full.bad2 + 0.005
    # where they differ, the restricted search is right more often than the full one
    err_full = np.abs(full.disparity - truth)[differ & ~np.isnan(truth)]
    err_fast = np.abs(fast.disparity - truth)[differ & ~np.isnan(truth)]
    assert np.mean(err_fast < 1.0) > np.mean(err_full < 1.0)


@pytest.mark.parametrize("sigma", [0.5, 1.0, 2.0, 4.0])
def test_image_noise_sd_finds_the_noise_under_texture_edges_and_clipping(sigma: float) -> None:
    rng = np.random.default_rng(7)
    H, W = 240, 320
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    img = 60.0 + 0.2 * u + 0.1 * v  # a smooth ramp: the mask cancels it
    img[:, 160:] += 40.0 * (np.sin(u[:, 160:] / 1.5) > 0)  # a stripe texture on a third
    img[100:, :] += 30.0  # a step edge
    img += rng.normal(0.0, sigma, img.shape)
    img[:40, :80] = 255.0  # a blown-out sky: no noise left there
    img = np.clip(img, 0.0, 255.0)
    assert image_noise_sd(img) == pytest.approx(sigma, rel=0.12)


def test_image_noise_sd_of_a_clean_image_is_the_rounding() -> None:
    flat = np.full((50, 60), 128.0)
    assert image_noise_sd(flat) == pytest.approx(QUANTISATION_SD)
    ramp = np.round(np.mgrid[0:50, 0:60][1] * 0.37)
    assert image_noise_sd(ramp) == pytest.approx(QUANTISATION_SD, abs=0.1)


def test_certainty_follows_the_texture_against_the_noise() -> None:
    """Faint texture in a clean pair is as certain as strong texture in a noisy one: the
    gradient factor counts the texture in noise sds (GRADIENT_SNR)."""
    rng = np.random.default_rng(3)
    blurred = np.asarray(cv2.GaussianBlur(rng.normal(0.0, 1.0, (120, 200)), (0, 0), 1.2))
    base = blurred / blurred.std()

    def pair(texture: float, noise: float) -> tuple[npt.NDArray[np.float64], ...]:
        tex = 128.0 + texture * base
        left = tex[:, :-8] + rng.normal(0.0, noise, (120, 192))
        right = tex[:, 8:] + rng.normal(0.0, noise, (120, 192))
        return np.round(left), np.round(right)

    faint = ncc_disparity(*pair(3.0, 0.3), num_disp=16, window=11)
    strong = ncc_disparity(*pair(30.0, 3.0), num_disp=16, window=11)
    inner = (slice(20, -20), slice(30, -30))
    assert np.nanmedian(faint.disparity[inner]) == pytest.approx(8.0, abs=0.1)
    c_faint = float(np.median(faint.certainty[inner]))
    c_strong = float(np.median(strong.certainty[inner]))
    assert c_faint > 0.3
    assert c_faint == pytest.approx(c_strong, abs=0.15)
