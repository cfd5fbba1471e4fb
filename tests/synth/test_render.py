"""Renderer and presets: exact depth, correct labels, determinism, calibration views."""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.errors import GeometryError
from aida_kb.io.scene import read_depth, read_image, read_labels, read_scene
from aida_kb.synth import buildings as bld
from aida_kb.synth.render import GROUND_LABEL
from aida_kb.synth.scenes import preset, render_scene

SMALL = {"image_width": "160", "image_height": "120", "focal_px": "200"}


@pytest.fixture(scope="module")
def house_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("house") / "scene"
    render_scene(preset("house", seed=3, params=SMALL), out)
    return out


def _inside_polygon_2d(px: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule, vectorised over points px (N, 2)."""
    inside = np.zeros(len(px), bool)
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        cond = (a[1] > px[:, 1]) != (b[1] > px[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = a[0] + (px[:, 1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        inside ^= cond & (px[:, 0] < xc)
    return inside


def _brute_force(scene_dir: Path, view: str) -> tuple[np.ndarray, np.ndarray]:
    """Independent ray casting: every pixel against every part polygon (and the ground)."""
    scene = read_scene(scene_dir)
    assert scene.truth is not None
    pose = scene.truth.pose(view)
    K, R, t = (np.array(pose.K), np.array(pose.R), np.array(pose.t))
    W, H = scene.calib.image_size
    ys, xs = np.mgrid[0:H, 0:W]
    rays = np.linalg.inv(K) @ np.vstack([xs.ravel(), ys.ravel(), np.ones(H * W)])
    best = np.full(H * W, np.inf)
    label = np.zeros(H * W, np.int64)
    planes = [(p.label, np.array(p.normal), p.d, np.array(p.polygon)) for p in scene.truth.parts]
    if scene.truth.ground is not None:
        g = scene.truth.ground
        planes.append((g.label, np.array(g.normal), g.d, None))
    for lab, n, d, poly in planes:
        n_c = R @ n
        z = (d + n_c @ t) / (n_c @ rays)
        ok = (z > 0.02) & (z < best)
        if poly is not None:
            pc = poly @ R.T + t
            if np.any(pc[:, 2] <= 0):
                continue
            pp = pc @ K.T
            pp = pp[:, :2] / pp[:, 2:]
            ok &= _inside_polygon_2d(np.stack([xs.ravel(), ys.ravel()], 1).astype(float), pp)
        best[ok] = z[ok]
        label[ok] = lab
    return label.reshape(H, W), best.reshape(H, W)


def test_depth_is_exact_ray_plane_depth(house_dir: Path) -> None:
    scene = read_scene(house_dir)
    assert scene.truth is not None
    for view in scene.views:
        assert view.labels is not None
        assert view.depth_left is not None
        labels = read_labels(view.labels)
        depth = read_depth(view.depth_left)
        pose = scene.truth.pose(view.id)
        K, R, t = np.array(pose.K), np.array(pose.R), np.array(pose.t)
        H, W = labels.shape
        ys, xs = np.mgrid[0:H, 0:W]
        rays = np.linalg.inv(K) @ np.vstack([xs.ravel(), ys.ravel(), np.ones(H * W)])
        planes = {p.label: (np.array(p.normal), p.d) for p in scene.truth.parts}
        assert scene.truth.ground is not None
        planes[scene.truth.ground.label] = (
            np.array(scene.truth.ground.normal),
            scene.truth.ground.d,
        )
        lab = labels.ravel()
        dep = depth.ravel().astype(np.float64)
        assert np.all(np.isnan(dep[lab == 0]))
        assert np.all(np.isfinite(dep[lab != 0]))
        for lb, (n, d) in planes.items():
            sel = lab == lb
            if not sel.any():
                continue
            n_c = R @ n
            z = (d + n_c @ t) / (n_c @ rays[:, sel])
            np.testing.assert_allclose(dep[sel], z, rtol=2e-6)
        # the house is 20-40 m away
        house = (lab > 0) & (lab != GROUND_LABEL)
        assert np.nanmin(dep[house]) > 15
        assert np.nanmax(dep[house]) < 45


def test_labels_match_visible_faces(house_dir: Path) -> None:
    scene = read_scene(house_dir)
    for view in scene.views:
        assert view.labels is not None
        labels = read_labels(view.labels).astype(np.int64)
        ref, ref_depth = _brute_force(house_dir, view.id)
        # the rendered ground is a square of 2 km half size; the truth plane is unbounded
        far = (ref == GROUND_LABEL) & (ref_depth > 1500)
        ref[far] = labels[far]
        # away from face boundaries (one pixel), the rasteriser agrees with brute-force casting
        edges = np.zeros_like(ref, bool)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                edges |= np.roll(np.roll(ref, dy, 0), dx, 1) != ref
        interior = ~edges
        assert interior.sum() > 0.8 * ref.size
        assert np.array_equal(labels[interior], ref[interior])
        # front, a gable wall and the front roof are visible, back faces are not
        seen = set(np.unique(labels).tolist())
        truth = scene.truth
        assert truth is not None
        for role in ("body.front", "body.roof.front"):
            assert truth.part(role).label in seen
        for role in ("body.back", "body.roof.back", "body.floor"):
            assert truth.part(role).label not in seen
        assert 0 in seen
        assert GROUND_LABEL in seen


def test_images_are_textured_and_lit(house_dir: Path) -> None:
    scene = read_scene(house_dir)
    assert scene.truth is not None
    view = scene.views[0]
    assert view.labels is not None
    img = read_image(view.left, grey=True).astype(float)
    labels = read_labels(view.labels)
    means = {}
    for role in ("body.front", "body.left", "body.roof.front"):
        sel = labels == scene.truth.part(role).label
        assert sel.sum() > 50
        means[role] = img[sel].mean()
        # texture for stereo: local contrast well above sensor noise
        lap = cv2.Laplacian(img, cv2.CV_64F)
        assert lap[sel].std() > 6.0
    vals = sorted(means.values())
    assert vals[1] - vals[0] > 5
    assert vals[2] - vals[1] > 5
    right = read_image(view.right, grey=True)
    assert right.shape == img.shape
    assert not np.array_equal(right, img)


def _digest(root: Path) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def test_same_seed_same_bytes(tmp_path: Path) -> None:
    params = {"image_width": "96", "image_height": "64", "focal_px": "120"}
    a = render_scene(preset("turntable", seed=5, views=2, params=params), tmp_path / "a")
    b = render_scene(preset("turntable", seed=5, views=2, params=params), tmp_path / "b")
    c = render_scene(preset("turntable", seed=6, views=2, params=params), tmp_path / "c")
    da, db, dc = _digest(a), _digest(b), _digest(c)
    assert da == db
    assert len(da) == 2 * 4 + 3
    assert da["views/00/left.png"] != dc["views/00/left.png"]


def test_turntable_view_angles(tmp_path: Path) -> None:
    params = {"image_width": "96", "image_height": "64", "focal_px": "120"}
    spec = preset("turntable", params=params)
    out = render_scene(spec, tmp_path / "tt")
    truth = read_scene(out).truth
    assert truth is not None
    assert [v.view for v in truth.views] == ["00", "01", "02", "03"]
    R0 = np.array(truth.pose("00").R)
    assert np.allclose(R0, np.eye(3))
    up = -np.array(truth.ground.normal) if truth.ground else None
    assert up is not None
    for view, angle in zip(("01", "02", "03"), (85.0, 195.0, 265.0), strict=True):
        R = np.array(truth.pose(view).R)
        # relative rotation is a rotation by the turntable angle about the vertical
        rel = R @ R0.T
        got = np.degrees(np.arccos(np.clip((np.trace(rel) - 1) / 2, -1, 1)))
        assert got == pytest.approx(min(angle, 360 - angle), abs=1e-6)
        axis = np.array([rel[2, 1] - rel[1, 2], rel[0, 2] - rel[2, 0], rel[1, 0] - rel[0, 1]])
        assert abs(abs(axis @ up) / np.linalg.norm(axis) - 1) < 1e-6


def test_chessboard_views_are_detected(tmp_path: Path) -> None:
    spec = preset(
        "chessboard",
        views=3,
        params={"image_width": "320", "image_height": "240", "focal_px": "400"},
    )
    out = render_scene(spec, tmp_path / "cb")
    scene = read_scene(out)
    found = 0
    for view in scene.views:
        for path in (view.left, view.right):
            img = read_image(path, grey=True)
            ok, corners = cv2.findChessboardCorners(img, (9, 6))
            found += int(ok)
            if ok:
                assert corners.reshape(-1, 2).shape == (54, 2)
    assert found == 6


def test_generators_give_closed_outward_solids() -> None:
    models = [bld.house(roof=r) for r in ("gable", "hip", "flat", "shed")] + [
        bld.lshape_house(meeting_deg=90.0),
        bld.lshape_house(meeting_deg=135.0),
        bld.oriel_house(),
        bld.reference_box(),
    ]
    for m in models:
        for s in m.solids:
            assert bld.signed_volume(s) > 0
            # every edge is shared by exactly two faces, traversed in opposite directions
            edges: dict[tuple[tuple[float, ...], tuple[float, ...]], int] = {}
            for f in s.faces:
                p = [tuple(np.round(v, 9)) for v in f.polygon]
                for i in range(len(p)):
                    e = (p[i], p[(i + 1) % len(p)])
                    edges[e] = edges.get(e, 0) + 1
            for (a, b), count in edges.items():
                assert count == 1, (m.concept, s.name, a, b)
                assert edges.get((b, a)) == 1, (m.concept, s.name, a, b)
    roles = {f.role for f in bld.house(roof="hip").faces}
    assert {"body.roof.left", "body.roof.right", "body.floor"} <= roles
    roles = {f.role for f in bld.lshape_house(meeting_deg=135.0).faces}
    assert {"body.wings[0].front", "body.wings[0].roof.back"} <= roles


def test_bad_parameters_are_reported() -> None:
    with pytest.raises(GeometryError, match="hip roof needs width > depth"):
        bld.house(width=8, depth=10, roof="hip")
    with pytest.raises(GeometryError, match="unknown key"):
        preset("house", params={"colour": "red"})
    with pytest.raises(GeometryError, match="expected a number"):
        preset("house", params={"width": "wide"})


def test_texture_prefilter_follows_the_footprint() -> None:
    from aida_kb.synth import textures as tx

    tex, texel = tx.texture_set(0)["brick"]
    rng = np.random.default_rng(0)
    u, v = rng.uniform(0, 5, 2000), rng.uniform(0, 5, 2000)
    point = tx.sample(tex, texel, u, v)
    # a footprint of one texel reads the texture itself
    np.testing.assert_allclose(tx.sample(tex, texel, u, v, np.full(2000, texel)), point, atol=1e-6)
    # 25 mm samples (a camera pixel at ~20 m): mortar joints blend into the bricks, so the
    # samples vary less than point samples but keep the texture's mean
    blurred = tx.sample(tex, texel, u, v, np.full(2000, 0.025))
    assert blurred.std(axis=0).max() < 0.8 * point.std(axis=0).max()
    np.testing.assert_allclose(blurred.mean(axis=0), point.mean(axis=0), atol=0.02)
    # a footprint far beyond the tile: the tile's mean colour everywhere
    flat = tx.sample(tex, texel, u, v, np.full(2000, 100.0))
    np.testing.assert_allclose(flat, np.broadcast_to(tex.mean(axis=(0, 1)), flat.shape), atol=0.02)


def test_a_ray_missing_its_samples_plane_takes_the_samples_depth() -> None:
    """With lens distortion each pixel takes the label of its nearest sample of the ideal
    canvas and the exact depth of its own ray on that face's plane; where the ray meets the
    plane behind the camera (the ground at a grazing angle, at its edge) the sample's depth
    stands instead (development seed 63002 rendered depths down to -494,090 m there)."""
    from aida_kb.synth.render import Surface, _labels_along_rays

    ground = Surface(
        label=5,
        role="ground",
        concept="Ground",
        material="grass",
        polygon=np.zeros((3, 3)),
        normal=np.array([0.0, -1.0, 0.0]),  # up, in the camera frame (y down)
        d=-1.5,  # 1.5 m below the camera
        origin=np.zeros(3),
        axis_u=np.array([1.0, 0.0, 0.0]),
        axis_v=np.array([0.0, 0.0, 1.0]),
        length=1.0,
    )
    K = np.array([[100.0, 0.0, 1.0], [0.0, 100.0, 0.5], [0.0, 0.0, 1.0]])
    # two pixels whose nearest samples are ground: one ray above the horizon, one below
    und = np.array([[0.0, -200.0], [1.0, 300.0]])
    labels = np.full((1, 2), 5, dtype=np.int32)
    sampled = np.full((1, 2), 30.0)
    lab, depth = _labels_along_rays(
        [ground], K, np.eye(3), np.zeros(3), und, 2, 1, K, labels, sampled, 1
    )
    assert lab.tolist() == [[5, 5]]
    assert depth[0, 0] == 30.0  # behind the camera along its own ray: the sample's
    assert depth[0, 1] == pytest.approx(1.5 / 2.995)  # in front: exact
