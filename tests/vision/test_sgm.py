"""Semi-global aggregation of NCC costs: the recursion, known shifts, textureless patches."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.errors import VisionError
from aida_kb.testing.pairs import random_texture, warp_right
from aida_kb.vision.sgm import _p2_map, aggregate, sgm_disparity
from aida_kb.vision.stereo import ncc_disparity


def _line_reference(cost: np.ndarray, p1: float, p2: np.ndarray) -> np.ndarray:
    """L_r along one line by the textbook recursion, element by element (the test's oracle).

    cost : (N, D); p2 : (N,) the P2 of the step into each position.
    """
    n, d_count = cost.shape
    out = np.zeros_like(cost, dtype=np.float64)
    out[0] = cost[0]
    for i in range(1, n):
        m = out[i - 1].min()
        for d in range(d_count):
            best = out[i - 1, d]
            if d > 0:
                best = min(best, out[i - 1, d - 1] + p1)
            if d < d_count - 1:
                best = min(best, out[i - 1, d + 1] + p1)
            best = min(best, m + p2[i])
            out[i, d] = cost[i, d] + best - m
    return out


def test_aggregation_is_the_textbook_recursion_in_every_direction() -> None:
    rng = np.random.default_rng(3)
    D, H, W = 5, 4, 6
    cost = rng.uniform(0.0, 2.0, (D, H, W)).astype(np.float32)
    image = rng.uniform(0.0, 255.0, (H, W)).astype(np.float32)
    p1, p2 = 0.1, 1.6
    got = aggregate(cost, image, p1=p1, p2=p2, directions=8)
    want = np.zeros((D, H, W))
    for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1)):
        p2_map = _p2_map(image, p1, p2, dy, dx)
        # the pixels of each scanline in the direction's order
        for y0 in range(H):
            for x0 in range(W):
                if 0 <= y0 - dy < H and 0 <= x0 - dx < W:
                    continue  # not a line's first pixel
                line = []
                y, x = y0, x0
                while 0 <= y < H and 0 <= x < W:
                    line.append((y, x))
                    y, x = y + dy, x + dx
                ys, xs = np.array(line).T
                ref = _line_reference(cost[:, ys, xs].T, p1, p2_map[ys, xs])
                want[:, ys, xs] += ref.T
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)


def test_p2_is_halved_across_an_image_edge_of_p2_edge_grey() -> None:
    image = np.zeros((3, 4), np.float32)
    image[:, 2:] = 8.0  # a step of P2_EDGE_GREY between columns 1 and 2
    p2 = _p2_map(image, 0.1, 1.6, 0, 1)
    np.testing.assert_allclose(p2[:, 2], 0.8)
    np.testing.assert_allclose(p2[:, [1, 3]], 1.6)


def test_a_slanted_textured_plane_is_dense_and_within_half_a_pixel() -> None:
    left = random_texture(96, 192)
    in_right = (6.0 + 0.05 * np.arange(192, dtype=np.float32))[None, :].repeat(96, axis=0)
    right = warp_right(left, in_right)
    # d at the left pixel x = x_r + d(x_r): d = 6 + 0.05 (x - d), so d = (6 + 0.05 x) / 1.05
    truth = in_right / np.float32(1.05)
    res = sgm_disparity(left.astype(np.uint8), right.astype(np.uint8), num_disp=24)
    inner = (slice(8, -8), slice(30, -8))
    has = ~np.isnan(res.disparity[inner])
    assert has.mean() > 0.97
    err = np.abs(res.disparity[inner][has] - truth[inner][has])
    assert np.median(err) < 0.15
    assert np.mean(err > 1.0) < 0.005
    assert np.all((res.certainty >= 0) & (res.certainty <= 1))
    assert np.all(res.certainty[np.isnan(res.disparity)] == 0)


def test_a_textureless_patch_is_filled_where_block_matching_leaves_a_hole() -> None:
    """A flat square inside a textured fronto-parallel plane: block NCC has no window there;
    the aggregation carries the surrounding disparity in, with a low certainty."""
    left = random_texture(120, 200, seed=1)
    left[40:80, 80:120] = 128.0
    right = warp_right(left, np.full(left.shape, 9.0, np.float32))
    patch = (slice(50, 70), slice(90, 110))
    block = ncc_disparity(left.astype(np.uint8), right.astype(np.uint8), num_disp=24, window=11)
    assert np.isnan(block.disparity[patch]).mean() > 0.9
    res = sgm_disparity(left.astype(np.uint8), right.astype(np.uint8), num_disp=24)
    filled = res.disparity[patch]
    assert np.mean(~np.isnan(filled)) > 0.9
    assert np.nanmax(np.abs(filled - 9.0)) < 1.0
    assert np.median(res.certainty[patch]) < 0.1 < np.median(res.certainty[10:30, 10:60])


def test_the_occluded_strip_beside_a_step_gets_no_disparity() -> None:
    left = random_texture(80, 200, seed=2)
    truth = np.full(left.shape, 4.0, np.float32)
    truth[:, 100:] = 14.0  # a nearer surface on the right half occludes a strip of the far one
    right_far = warp_right(left, np.full(left.shape, 4.0, np.float32))
    right_near = warp_right(left, np.full(left.shape, 14.0, np.float32))
    right = right_far.copy()
    right[:, 86:] = right_near[:, 86:]  # right pixels 86.. see the near surface
    res = sgm_disparity(left.astype(np.uint8), right.astype(np.uint8), num_disp=24)
    occluded = res.disparity[10:-10, 92:98]  # left pixels 90..99 have no match
    assert np.isnan(occluded).mean() > 0.6
    seen = res.disparity[10:-10, 110:-10]
    assert np.nanmedian(np.abs(seen - 14.0)) < 0.2


def test_bad_arguments_are_refused() -> None:
    img = np.zeros((40, 60), np.uint8)
    with pytest.raises(VisionError, match="window must be odd"):
        sgm_disparity(img, img, window=4)
    with pytest.raises(VisionError, match="num_disp"):
        sgm_disparity(img, img, num_disp=300)
    with pytest.raises(VisionError, match="differ in size"):
        sgm_disparity(img, img[:, :50])
    with pytest.raises(VisionError, match="P1 <= P2"):
        aggregate(np.zeros((3, 4, 4), np.float32), np.zeros((4, 4), np.float32), p1=2, p2=1)


def test_a_volume_over_the_memory_budget_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AIDA_KB_MEMORY_GB", "0.001")
    img = np.zeros((400, 600), np.uint8)
    with pytest.raises(VisionError, match="memory budget"):
        sgm_disparity(img, img, num_disp=64)
