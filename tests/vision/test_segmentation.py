"""Local planes, normals and planar-region segmentation in disparity space."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.vision.segmentation import local_planes, plane_normals, segment_planes


def _two_planes() -> tuple[np.ndarray, np.ndarray]:
    h, w = 120, 160
    vs, us = np.mgrid[0:h, 0:w].astype(np.float64)
    left = 0.05 * us + 0.01 * vs + 4.0
    right = -0.04 * us + 0.0 * vs + 16.0
    truth = np.where(us < 80, 1, 2)
    d = np.where(truth == 1, left, right)
    rng = np.random.default_rng(0)
    d = d + rng.normal(0.0, 0.08, d.shape)
    d[rng.random(d.shape) < 0.05] = np.nan  # dropouts
    return d.astype(np.float32), truth


def test_local_planes_recover_slopes() -> None:
    d, _truth = _two_planes()
    cert = np.ones_like(d)
    planes = local_planes(d, cert, window=15)
    inner = planes[20:-20, 15:60]
    assert np.nanmedian(np.abs(inner[..., 0] - 0.05)) < 0.003
    assert np.nanmedian(np.abs(inner[..., 1] - 0.01)) < 0.003
    normals = plane_normals(planes, 300.0, 80.0, 60.0)
    ok = np.isfinite(normals[..., 0])
    np.testing.assert_allclose(np.linalg.norm(normals[ok], axis=-1), 1.0, atol=1e-5)
    assert np.all(normals[ok][:, 2] < 0)  # facing the camera


def test_segment_planes_finds_both_planes() -> None:
    d, truth = _two_planes()
    cert = np.where(np.isnan(d), 0.0, 0.9).astype(np.float32)
    regions = segment_planes(d, cert, local_planes(d, cert, window=15), min_pixels=300)
    ids = [r for r in np.unique(regions) if r != 0]
    assert len(ids) == 2
    for rid in ids:
        mask = regions == rid
        label = np.bincount(truth[mask]).argmax()
        tmask = truth == label
        iou = (mask & tmask).sum() / (mask | tmask).sum()
        assert iou > 0.9


def test_no_depth_no_regions() -> None:
    d = np.full((50, 60), np.nan, np.float32)
    cert = np.zeros_like(d)
    assert not segment_planes(d, cert, local_planes(d, cert)).any()


def test_coplanar_regions_merge_across_a_window_hole() -> None:
    """Two pieces of one wall 20 m away, 10 px apart across a window, merge; a piece 1 m in
    front (a porch) and a turned piece (a side wall) touching them do not."""
    from aida_kb.vision.merge import merge_coplanar

    regions = np.zeros((60, 200), np.int32)
    regions[:, 0:50] = 3  # wall, left of the window
    regions[:, 60:110] = 5  # wall, right of the window (10 px of hole between)
    regions[:, 110:150] = 7  # porch in front, touching
    regions[:, 150:200] = 9  # side wall, touching the porch
    n = np.array([0.0, 0.0, -1.0])
    a = np.radians(40.0)
    side = np.array([np.sin(a), 0.0, -np.cos(a)])
    ids = np.array([3, 5, 7, 9])
    normals = np.array([n, n, n, side])
    centroids = np.array([[-2.0, 0, 20.0], [1.0, 0, 20.1], [3.0, 0, 19.0], [6.0, 0, 19.5]])
    merged = merge_coplanar(regions, ids, normals, centroids)
    assert set(np.unique(merged).tolist()) == {0, 3, 7, 9}
    assert np.all(merged[:, 60:110] == 3)
    assert np.all(merged[:, 110:150] == 7)
    # without the neighbourhood nothing merges: pieces far apart stay apart
    far = regions.copy()
    far[:, 60:110] = 0
    far[:, 90:110] = 5
    assert set(np.unique(merge_coplanar(far, ids, normals, centroids)).tolist()) == {0, 3, 5, 7, 9}


def test_complete_regions_grows_a_wall_over_dropouts_and_openings() -> None:
    """A wall 20 m away measured on a lace of pixels: its region grows over the dropouts
    between them and the window it encloses (glass 0.4 m behind), not over a pole 2 m in front
    of it, nor over the sky beyond its outline; a second plane's region keeps its pixels."""
    from aida_kb.vision.complete import complete_regions

    H, W, f, B = 120, 200, 200.0, 4.0  # depth noise 0.125 m at 20 m: tolerance 0.375 m
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(us - W / 2) / f, (vs - H / 2) / f, np.ones_like(us)], axis=-1)
    z = np.full((H, W), 20.0)
    wall = (us >= 20) & (us < 180) & (vs >= 20) & (vs < 110)
    window = (us >= 80) & (us < 100) & (vs >= 40) & (vs < 70)
    pole = (us >= 140) & (us < 146) & (vs >= 20) & (vs < 110)
    z[window] = 20.4
    z[pole] = 18.0
    points = (rays * z[..., None]).astype(np.float32)
    measured = wall & ((us.astype(int) // 6 + vs.astype(int) // 6) % 3 != 0)  # 1/3 dropouts
    measured &= ~((us >= 40) & (us < 52))  # a dropout band 12 px wide across the wall
    measured |= pole | window
    points[~measured] = np.nan
    regions = np.zeros((H, W), np.int32)
    regions[wall & measured & ~window & ~pole] = 4
    regions[:10, :10] = 9  # another plane's region, far away
    n = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    out = complete_regions(
        regions,
        points,
        np.array([4, 9]),
        n,
        np.array([-20.0, -5.0]),
        np.array([0.01, 0.01]),
        np.array([20.0, 5.0]),
        f,
        B,
    )
    target = wall & ~pole
    assert np.count_nonzero(out[target] == 4) / np.count_nonzero(target) > 0.97
    assert np.all(out[window] == 4)  # the opening it encloses
    assert not np.any(out[pole] == 4)  # what stands in front stays out
    assert not np.any(out[~wall] == 4)  # nothing beyond the outline
    assert np.all(out[:10, :10] == 9)


def test_complete_regions_claims_no_strip_narrower_than_a_window() -> None:
    """A wall 20 m away (region 4, rows 60-110) and, above it, a strip 8 px wide on its plane
    extended (a tower's corner rising past the eave: windows straddling a silhouette take the
    front's depth) beside a wide patch on the plane: with an 11-px matching window the strip
    stays out and the patch joins; with no window the strip joins too."""
    from aida_kb.vision.complete import complete_regions

    H, W, f, B = 120, 200, 200.0, 4.0
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(us - W / 2) / f, (vs - H / 2) / f, np.ones_like(us)], axis=-1)
    points = (rays * 20.0).astype(np.float32)
    wall = (vs >= 60) & (vs < 110) & (us >= 20) & (us < 180)
    strip = (vs >= 10) & (vs < 60) & (us >= 150) & (us < 158)
    patch = (vs >= 30) & (vs < 60) & (us >= 40) & (us < 100)
    points[~(wall | strip | patch)] = np.nan
    regions = np.where(wall, 4, 0).astype(np.int32)
    args = (np.array([4]), np.array([[0.0, 0.0, -1.0]]), np.array([-20.0]), np.array([0.01]))
    windowed = complete_regions(regions, points, *args, np.array([20.0]), f, B, 11)
    assert not np.any(windowed[strip & (vs < 50)] == 4)
    assert np.all(windowed[patch] == 4)
    plain = complete_regions(regions, points, *args, np.array([20.0]), f, B)
    assert np.all(plain[strip] == 4)


def test_line_kinds_tell_structural_from_texture() -> None:
    """On a wall 20 m away (region 1) with a recess 0.5 m deep in its middle, beside a side
    wall (region 2): a joint on the flat wall is texture, the recess's edge and the corner
    between the walls are structural, the wall's outline against the sky is structural, and a
    line in the sky is unknown."""
    from aida_kb.vision.linekinds import line_kinds

    H, W, f = 120, 200, 200.0
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(us - W / 2) / f, (vs - H / 2) / f, np.ones_like(us)], axis=-1)
    z = np.full((H, W), 20.0)
    z[40:80, 60:100] = 20.5  # the recess
    points = (rays * z[..., None]).astype(np.float32)
    regions = np.zeros((H, W), np.int32)
    regions[20:, :140] = 1
    regions[20:, 140:] = 2
    points[:20] = np.nan  # the sky
    segments = np.array(
        [
            [20.0, 100.0, 50.0, 100.0],  # a joint on the flat wall
            [60.0, 45.0, 60.0, 75.0],  # the recess's left edge
            [140.0, 30.0, 140.0, 110.0],  # the corner between the walls
            [20.0, 20.0, 120.0, 20.0],  # the wall's top outline
            [20.0, 5.0, 120.0, 5.0],  # in the sky
        ]
    )
    normals = np.array([[0.0, 0.0, -1.0], [-0.6, 0.0, -0.8]])
    kinds = line_kinds(
        segments,
        regions,
        points,
        np.array([1, 2]),
        normals,
        np.array([-20.0, -20.0]),
        np.array([0.2, 0.2]),
        side_px=5.0,
    )
    assert kinds == ["texture", "structural", "structural", "structural", None]


def test_fragments_of_one_wall_merge_across_windows_and_a_wing_does_not() -> None:
    """A wall 20 m away, broken by windows (no depth) into five pieces whose own plane fits
    scatter (noise 5 cm on a few hundred points each), merges into one region; a wing's wall
    at 45 degrees touching it, and a porch 1 m in front of it, stay apart."""
    from aida_kb.vision.merge import merge_coplanar

    H, W, f = 120, 400, 500.0
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    x_dir = (u - W / 2) / f
    y_dir = (v - H / 2) / f
    rng = np.random.default_rng(3)
    noise = rng.normal(0.0, 0.05, (H, W))
    z_wall = 20.0 + noise  # a wall square to the optical axis
    # a wing's wall at 45 degrees through the wall's right end (u = 300): z grows with x
    x_end = (300 - W / 2) / f * 20.0
    z_wing = (20.0 - x_end) / (1.0 - x_dir) + noise  # the plane z - x = 20 - x_end
    z = np.where(u < 300, z_wall, z_wing)
    z[(v >= 80) & (u >= 200) & (u < 300)] = 19.0 + noise[(v >= 80) & (u >= 200) & (u < 300)]
    points = np.stack([x_dir * z, y_dir * z, z], axis=-1).astype(np.float32)
    regions = np.zeros((H, W), np.int32)
    for k, left in enumerate(range(0, 300, 60)):  # pieces 40 px wide, 20 px windows between
        regions[:80, left : left + 40] = k + 1
        points[:80, left + 40 : left + 60] = np.nan
    regions[80:, 200:300] = 8  # the porch, 1 m in front
    regions[:, 300:] = 9  # the wing's wall
    ids = np.array([1, 2, 3, 4, 5, 8, 9])
    # the plane fits of small pieces scatter by degrees: turned 5 degrees either way here
    normals, centroids = [], []
    for k, i in enumerate(ids):
        p = points[regions == i].astype(np.float64)
        p = p[np.isfinite(p).all(axis=1)]
        c = p.mean(axis=0)
        n = np.linalg.svd(p - c)[2][2]
        a = np.radians(5.0 if k % 2 else -5.0)
        turn = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
        normals.append(turn @ n)
        centroids.append(c)
    merged = merge_coplanar(
        regions, ids, np.array(normals), np.array(centroids), points=points, focal_px=f
    )
    assert set(np.unique(merged[:80, :300][regions[:80, :300] > 0]).tolist()) == {1}
    assert np.all(merged[80:, 200:300] == 8)
    assert np.all(merged[:, 300:] == 9)
    # by their normals alone (within COPLANAR_DEG) the pieces stay apart
    alone = merge_coplanar(regions, ids, np.array(normals), np.array(centroids))
    assert np.array_equal(alone, regions)


def test_absorb_recesses_takes_a_portal_set_in_the_wall_not_a_side_wall_or_the_sky() -> None:
    """A wall 20 m away with a portal 2 m deep opening onto the ground at its foot: the door's
    region and the embrasure's pixels (no depth, or behind the wall) join the wall; the ground
    in front, a side wall receding from the wall's corner, the sky above (no depth) and a
    chimney 4 m behind the wall's top (deeper than a recess) stay out."""
    from aida_kb.vision.complete import absorb_recesses

    H, W, f = 120, 200, 200.0
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(us - W / 2) / f, (vs - H / 2) / f, np.ones_like(us)], axis=-1)
    z = np.full((H, W), 20.0)
    wall = (us >= 20) & (us < 150) & (vs >= 20) & (vs < 100)
    portal = (us >= 60) & (us < 100) & (vs >= 50) & (vs < 100)
    door = portal & (us >= 66) & (us < 94)
    side = (us >= 150) & (us < 190) & (vs >= 20) & (vs < 100)
    ground = vs >= 100
    chimney = (us >= 30) & (us < 40) & (vs >= 5) & (vs < 20)
    z[door] = 22.0
    z[side] = 20.0 + (us[side] - 150) * 0.2  # recedes 8 m over 40 px
    z[ground] = 20.0 - (vs[ground] - 100) * 0.3  # comes towards the camera
    z[chimney] = 24.0
    points = (rays * z[..., None]).astype(np.float32)
    sky = (vs < 20) & ~chimney
    points[sky | (portal & ~door)] = np.nan  # the embrasure's rims: no depth
    regions = np.zeros((H, W), np.int32)
    regions[wall & ~portal] = 1
    regions[door] = 5
    regions[side] = 2
    regions[ground] = 3
    regions[chimney] = 6
    ids = np.array([1, 2, 3, 5, 6])
    normals = np.array(
        [[0.0, 0.0, -1.0], [-0.98, 0.0, -0.2], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [0, 0, -1.0]]
    )
    offsets = np.array([-20.0, -20.0, -1.0, -22.0, -24.0])
    out = absorb_recesses(
        regions, points, ids, np.full(5, 8, np.int64), normals, offsets, np.full(5, 0.2)
    )
    assert np.all(out[door] == 1)
    # the embrasure (its last pixels at the foot, between the wall and the door on the ground,
    # are where a closing disc no longer fits)
    assert np.count_nonzero(out[portal] == 1) / np.count_nonzero(portal) > 0.97
    assert np.all(out[side] == 2)
    assert np.all(out[ground] == 3)
    assert np.all(out[chimney] == 6)
    assert not np.any(out[sky] == 1)


def test_extend_to_border_takes_the_strip_only_the_left_camera_sees() -> None:
    """A wall 20 m away whose leftmost 30 px the right camera cannot see (no depth): its region
    goes on to the border on the rows where stereo measured the wall next to the strip, not
    beside the recess of a porch (its region's pixels there lie 1 m behind the plane), not in
    the sky above the wall, and not across another region's pixels."""
    from aida_kb.vision.complete import extend_to_border

    H, W, f = 100, 160, 200.0
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(us - W / 2) / f, (vs - H / 2) / f, np.ones_like(us)], axis=-1)
    z = np.full((H, W), 20.0)
    porch = (vs >= 60) & (us < 70)
    z[porch] = 21.0
    points = (rays * z[..., None]).astype(np.float32)
    strip = us < 30
    sky = vs < 10
    points[strip | sky] = np.nan
    regions = np.zeros((H, W), np.int32)
    regions[~strip & ~sky] = 1  # the wall, its porch absorbed (`absorb_recesses`)
    regions[20:30, :30] = 2  # a sign on the wall, its own region
    unseen = np.zeros((1, H, W), bool)
    unseen[0, :, :30] = True
    out = extend_to_border(
        regions,
        unseen,
        points,
        ids=np.array([1]),
        normals=np.array([[0.0, 0.0, -1.0]]),
        offsets=np.array([-20.0]),
        tolerances=np.array([0.2]),
    )
    assert np.all(out[10:20, :30] == 1)
    assert np.all(out[30:60, :30] == 1)
    assert np.all(out[20:30, :30] == 2)
    assert not np.any(out[60:, :30] == 1)  # beside the porch: the wall is not seen going on
    assert not np.any(out[:10] == 1)


def _dark_roof() -> tuple[
    npt.NDArray[np.bool_], npt.NDArray[np.uint8], npt.NDArray[np.int32], npt.NDArray[np.uint8]
]:
    """A dark roof (a trapezoid with verges at 45 deg, columns 10-190 of a 120 x 200 image)
    between the bright sky and a wall region (1, rows 70 and below): the roof's mask, the
    image, the regions and the roof's outline ring (5 px wide)."""
    H, W = 120, 200
    v, u = np.mgrid[0:H, 0:W]
    roof = (v >= 30) & (v < 70) & (u >= 40 + (70 - v)) & (u < 160 - (70 - v))
    image = np.full((H, W), 200, np.uint8)  # sky
    image[roof] = 40
    image[v >= 70] = 120  # the wall
    regions = np.where(v >= 70, 1, 0).astype(np.int32)
    roof_u8 = roof.astype(np.uint8)
    ring = cv2.dilate(roof_u8, np.ones((5, 5), np.uint8)) - cv2.erode(roof_u8, np.ones((5, 5)))
    return roof, image, regions, np.asarray(ring, np.uint8)


def test_outlined_patches_take_a_dark_face_measured_on_its_outline_not_the_sky() -> None:
    """A dark roof between the bright sky and a wall region: its outline has certain depth
    along the verges and the eave (not along the ridge, a row: no disparity there for any
    matcher), so it is a patch; the sky, cut by the image's border, is not. Without depth
    along the verges the roof is no patch either."""
    from aida_kb.vision.outline import OUTLINE_REACH_PX, outlined_patches

    roof, image, regions, ring = _dark_roof()
    v = np.mgrid[0 : roof.shape[0], 0 : roof.shape[1]][0]
    certainty = np.where((ring > 0) & (v > 33), 0.5, 0.0).astype(np.float32)  # not the ridge
    certainty[v >= 70] = 0.5
    patches, certain, edges = outlined_patches(regions, image, certainty, min_pixels=200)
    assert int(patches.max()) == 1
    inside = cv2.erode(roof.astype(np.uint8), np.ones((2 * OUTLINE_REACH_PX + 1,) * 2, np.uint8))
    assert np.all(patches[inside > 0] == 1)
    assert np.all(patches[v < 20] == 0)  # the sky
    assert np.array_equal(certain, certainty >= 0.1)
    assert edges[50, 40 + 20 - 1 : 40 + 20 + 2].any()  # the left verge
    without = np.where(v >= 70, 0.5, 0.0).astype(np.float32)
    assert int(outlined_patches(regions, image, without, min_pixels=200)[0].max()) == 0


def test_outlined_patches_excuse_the_half_occluded_left_verge_only() -> None:
    """The right camera sees the far field beside the roof's left verge hidden behind the
    roof: no certain depth there, yet the roof is a patch on its right verge and its eave. The
    right verge (its background seen by both cameras) without depth is no excuse: no patch."""
    from aida_kb.vision.outline import outlined_patches

    roof, image, regions, ring = _dark_roof()
    v, u = np.mgrid[0 : roof.shape[0], 0 : roof.shape[1]]
    measured = (ring > 0) & (v > 33)
    certainty = np.where(v >= 70, 0.5, 0.0).astype(np.float32)
    left = measured & (u < 100)  # the left verge's ring
    right = measured & (u >= 100)
    no_left = np.where(right, 0.5, certainty).astype(np.float32)
    assert int(outlined_patches(regions, image, no_left, min_pixels=200)[0].max()) == 1
    no_right = np.where(left, 0.5, certainty).astype(np.float32)
    assert int(outlined_patches(regions, image, no_right, min_pixels=200)[0].max()) == 0


def test_outlined_patches_count_a_neighbours_depth_only_at_an_edge() -> None:
    """The roof's right verge borders a region (2) of its own grey with certain depth all
    over: no edge parts them, and only a region's depth right at an edge is fitted to the
    roof's plane, so that depth does not measure the roof's outline (61935: a patch of far
    ground and a striped wall, held by the near ground's region, was fitted as the wall). Where
    the neighbour is lighter (an edge between them) its depth at the edge measures it."""
    from aida_kb.vision.outline import outlined_patches

    roof, image, regions, ring = _dark_roof()
    v, u = np.mgrid[0 : roof.shape[0], 0 : roof.shape[1]]
    beside = (v >= 30) & (v < 70) & (u >= 160 - (70 - v)) & (u < 190)
    regions = np.where(beside, 2, regions).astype(np.int32)
    certainty = np.where((ring > 0) & (v > 33) & (u < 100), 0.5, 0.0).astype(np.float32)
    certainty[(v >= 70) | beside] = 0.5
    same = np.where(beside, 40, image).astype(np.uint8)
    assert int(outlined_patches(regions, same, certainty, min_pixels=200)[0].max()) == 0
    lighter = np.where(beside, 120, image).astype(np.uint8)
    assert int(outlined_patches(regions, lighter, certainty, min_pixels=200)[0].max()) == 1


def test_an_outline_on_one_line_fixes_no_tilt() -> None:
    """Points along two verges 20 m long, 8 m apart, fix a roof plane's tilt to rms /
    (sqrt(n/81) · g), g = 4 m their spread across the verges;
    points along one verge (a line) fix none."""
    import math

    from aida_kb.vision.regions import outline_tilt_rad

    s = np.linspace(0.0, 20.0, 50)
    n = np.array([0.0, 0.6, -0.8])
    along = np.array([0.0, 0.8, 0.6])  # the verge's direction on the plane
    across = np.cross(n, along)
    left = np.outer(s, along)
    right = left + 8.0 * across
    both = np.vstack([left, right]) + np.array([0.0, 0.0, 30.0])
    tilt = outline_tilt_rad(both, n, 0.05, 100, 11)
    assert math.isclose(tilt, 0.05 / (math.sqrt(100 / 81) * 4.0), rel_tol=1e-6)
    assert outline_tilt_rad(left + np.array([0.0, 0.0, 30.0]), n, 0.05, 100, 11) > 1e3
