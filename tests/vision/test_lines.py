"""Line segments (subpixel end points, bordering regions) and region contours."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.vision.lines import (
    UNREFINED_SIGMA_PX,
    attach_segments,
    detect_segments,
    edge_steps,
    fit_segments,
    refine_segments,
)
from aida_kb.vision.segmentation import region_contours

CORNERS = np.array([[40.3, 30.6], [150.7, 42.2], [140.2, 110.4], [52.6, 100.9]])


def _inside(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Inside the convex quad CORNERS (counter-clockwise on screen = clockwise in y-down)."""
    ok = np.ones(x.shape, bool)
    for i in range(4):
        (ax, ay), (bx, by) = CORNERS[i], CORNERS[(i + 1) % 4]
        ok &= (bx - ax) * (y - ay) - (by - ay) * (x - ax) >= 0
    return ok


def _quad_image() -> tuple[np.ndarray, np.ndarray]:
    """The quad rendered with 8x8 supersampling (pixel centres at integer coordinates)."""
    h, w, s = 140, 200, 8
    ys, xs = np.mgrid[0 : h * s, 0 : w * s].astype(float)
    cover = _inside((xs + 0.5) / s - 0.5, (ys + 0.5) / s - 0.5).reshape(h, s, w, s).mean((1, 3))
    img = np.round(200.0 - 140.0 * cover).astype(np.uint8)
    regions = np.where(cover >= 0.5, 1, 2).astype(np.int32)
    return img, regions


def _distance_to_line(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = (b - a) / np.linalg.norm(b - a)
    q = p - a
    return float(abs(q[0] * t[1] - q[1] * t[0]))


def test_lsd_finds_the_four_edges_with_subpixel_accuracy() -> None:
    img, regions = _quad_image()
    segs = detect_segments(img, min_length_px=30)
    assert 4 <= len(segs) <= 8
    edges = [(CORNERS[i], CORNERS[(i + 1) % 4]) for i in range(4)]
    found = set()
    for seg in segs:
        p1, p2 = seg[:2], seg[2:]
        mid = (p1 + p2) / 2
        dists = [_distance_to_line(mid, a, b) for a, b in edges]
        k = int(np.argmin(dists))
        assert dists[k] < 0.2, f"segment {seg} is {dists[k]:.2f} px off the nearest edge"
        a, b = edges[k]
        assert max(_distance_to_line(p1, a, b), _distance_to_line(p2, a, b)) < 0.4
        found.add(k)
    assert found == {0, 1, 2, 3}
    attached = attach_segments(segs, img, regions)
    for s in attached:
        assert s.regions == [1, 2]
        assert {s.left_region, s.right_region} == {1, 2}
        assert s.contrast > 100
        assert s.length_px >= 30


def _textured_quad(seed: int) -> np.ndarray:
    """The quad filled with a coarse random texture (3 px blocks, dark to bright) on a mid-grey
    background, 8x8 supersampled: its edges change polarity along their length."""
    h, w, s = 140, 200, 8
    ys, xs = np.mgrid[0 : h * s, 0 : w * s].astype(float)
    cover = _inside((xs + 0.5) / s - 0.5, (ys + 0.5) / s - 0.5).reshape(h, s, w, s).mean((1, 3))
    rng = np.random.default_rng(seed)
    blocks = rng.uniform(30.0, 150.0, size=(h // 3 + 1, w // 3 + 1))
    texture = np.kron(blocks, np.ones((3, 3)))[:h, :w]
    return np.round(cover * texture + (1.0 - cover) * 170.0).astype(np.uint8)


def _offsets(segs: np.ndarray) -> np.ndarray:
    """Each segment's mean distance (px) from the quad edge nearest its middle."""
    edges = [(CORNERS[i], CORNERS[(i + 1) % 4]) for i in range(4)]
    out = []
    for seg in segs:
        p1, p2 = seg[:2], seg[2:]
        d = [_distance_to_line((p1 + p2) / 2, a, b) for a, b in edges]
        a, b = edges[int(np.argmin(d))]
        out.append((_distance_to_line(p1, a, b) + _distance_to_line(p2, a, b)) / 2)
    return np.array(out)


def test_refinement_moves_segments_onto_textured_edges() -> None:
    raw, refined = [], []
    for seed in range(3):
        img = _textured_quad(seed)
        lsd = detect_segments(img, min_length_px=15, refine=False)
        on_edge = _offsets(lsd) < 2.0  # the quad's edges, not the texture's
        raw.append(_offsets(lsd[on_edge]))
        refined.append(_offsets(refine_segments(img, lsd[on_edge])))
    before, after = np.median(np.concatenate(raw)), np.median(np.concatenate(refined))
    assert after < 0.25
    assert after < 0.6 * before
    # a clean edge: within a few hundredths
    img, _ = _quad_image()
    segs = detect_segments(img, min_length_px=30)
    assert float(_offsets(segs).max()) > 0.1  # LSD alone
    assert float(_offsets(detect_segments(img, min_length_px=30, refine=True)).max()) < 0.05


def test_edge_fit_sigma_tells_clean_from_textured_edges() -> None:
    img, _ = _quad_image()
    clean = fit_segments(img, detect_segments(img, min_length_px=30))
    assert np.all(clean.support > 30)
    assert float(clean.sigma_px.max()) < 0.1  # a clean edge's points: hundredths of a pixel
    textured = _textured_quad(0)
    lsd = detect_segments(textured, min_length_px=15)
    fits = fit_segments(textured, lsd[_offsets(lsd) < 2.0])
    refined = fits.support > 0
    assert np.median(fits.sigma_px[refined]) > 1.3 * float(clean.sigma_px.max())
    assert float(fits.sigma_px[refined].max()) > 0.3  # edge points on a texture scatter
    # a segment on no edge is kept as detected, with the unrefined sigma
    flat = np.full((40, 60), 120, np.uint8)
    kept = fit_segments(flat, np.array([[10.0, 20.0, 50.0, 20.0]]))
    np.testing.assert_array_equal(kept.segments, [[10.0, 20.0, 50.0, 20.0]])
    assert kept.sigma_px.tolist() == [UNREFINED_SIGMA_PX]
    assert kept.support.tolist() == [0]


def test_left_and_right_follow_the_direction() -> None:
    img = np.zeros((60, 80), np.uint8)
    img[30:, :] = 200
    regions = np.where(np.arange(60)[:, None] < 30, 5, 7) * np.ones((1, 80), np.int32)
    seg = np.array([[10.0, 29.5, 70.0, 29.5]])
    (s,) = attach_segments(seg, img, regions)
    assert (s.left_region, s.right_region) == (5, 7)  # pointing right: left is up
    (r,) = attach_segments(seg[:, [2, 3, 0, 1]], img, regions)
    assert (r.left_region, r.right_region) == (7, 5)
    assert detect_segments(np.full((50, 50), 90, np.uint8)).shape == (0, 4)


def test_region_contours_with_a_hole() -> None:
    regions = np.zeros((100, 120), np.int32)
    regions[10:90, 20:100] = 3
    regions[40:60, 50:70] = 0
    found = region_contours(regions)
    outer = [p for rid, hole, p in found if rid == 3 and not hole]
    holes = [p for rid, hole, p in found if rid == 3 and hole]
    assert len(outer) == 1
    assert len(holes) == 1
    assert sorted(map(tuple, outer[0].astype(int).tolist())) == [
        (20, 10),
        (20, 89),
        (99, 10),
        (99, 89),
    ]
    assert len(holes[0]) == 4


def test_a_faint_steady_step_along_a_line_stands_out_of_texture() -> None:
    # two faces 4 grey levels apart under texture of sd 8: no segment need be found there,
    # but along 200 px the step is many standard errors; a line across one face shows none
    rng = np.random.default_rng(3)
    img = 120.0 + rng.normal(0.0, 8.0, (200, 300))
    img[:, 150:] += 4.0
    grey = np.clip(img, 0, 255).astype(np.uint8)
    ends = np.array([[[150.0, 0.0], [150.0, 199.0]], [[75.0, 0.0], [75.0, 199.0]]])
    step, z = edge_steps(grey, ends - [[0.5, 0.0], [0.0, 0.0]])
    assert abs(step[0]) == pytest.approx(4.0, abs=1.5)
    assert abs(z[0]) > 5.0
    assert abs(z[1]) < 3.0
