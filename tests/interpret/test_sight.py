"""aida_kb.interpret.sight: what the views of a synthetic scene show of its true parts."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import cv2
import numpy as np

from aida_kb.interpret.evaluate import evaluate, format_evaluation
from aida_kb.interpret.result import read_interpretation
from aida_kb.interpret.sight import SEEN_PX, _view_sight, part_sights, unmeasurable
from aida_kb.io.scene import read_depth, read_scene

LARGE_FACE_PX = 1000  # faces this large in the labels: the estimate is compared with them
PX_AGREEMENT = 0.12  # ... and must agree to 12 % (the depth test's 2 % lets a face's pixels
# just behind a touching one count: 1-8 % more on this scene)


def test_visible_pixels_agree_with_the_rendered_labels(lshape_run: Any) -> None:
    scene = read_scene(lshape_run.scene)
    assert scene.truth is not None
    view = scene.views[0]
    assert view.labels is not None
    assert view.depth_left is not None
    labels = np.asarray(cv2.imread(str(view.labels), cv2.IMREAD_UNCHANGED))
    pose = scene.truth.pose(view.id)
    depth = read_depth(view.depth_left)
    compared = 0
    for part in scene.truth.parts:
        face_px, _ = _view_sight(view, np.array(pose.R), np.array(pose.t), part, depth)
        shown = int((labels == part.label).sum())
        if shown >= LARGE_FACE_PX:
            assert abs(face_px / shown - 1.0) <= PX_AGREEMENT, (part.role, face_px, shown)
            compared += 1
        elif shown == 0:
            assert face_px < SEEN_PX, (part.role, face_px)
    assert compared >= 5


def test_parts_no_view_shows_are_named(lshape_run: Any) -> None:
    scene = read_scene(lshape_run.scene)
    sights = part_sights(scene)
    assert sights is not None
    by_role = {s.role: s for s in sights}
    hidden = unmeasurable(sights)
    assert hidden is not None
    # one view from the front left: the main body's right end and the wing's far walls are
    # turned away, and no edge of theirs shows
    assert "body.right" in hidden
    assert "body.wings[0].left" in hidden
    assert by_role["body.right"].face_px == 0.0
    assert by_role["body.right"].edge_share == 0.0
    # the back wall is hidden too, but the left wall's far outline is its edge: measurable
    assert by_role["body.back"].face_px == 0.0
    assert by_role["body.back"].measurable
    assert by_role["body.front"].face_px > 10 * SEEN_PX
    assert by_role["body.front"].best_view == "00"
    assert not {"body.front", "body.left", "body.roof.front"} & set(hidden)


def test_without_rendered_depth_nothing_is_claimed(lshape_run: Any) -> None:
    scene = read_scene(lshape_run.scene)
    blind = replace(scene, views=tuple(replace(v, depth_left=None) for v in scene.views))
    assert part_sights(blind) is None
    assert unmeasurable(None) is None


def test_a_refused_depth_map_claims_nothing(lshape_run: Any, tmp_path: Any) -> None:
    scene = read_scene(lshape_run.scene)
    view = scene.views[0]
    assert view.depth_left is not None
    depth = read_depth(view.depth_left)
    depth[0, 0] = -1.0  # behind the camera: the format refuses it
    bad = tmp_path / "depth_left.npy"
    np.save(bad, depth)
    assert part_sights(replace(scene, views=(replace(view, depth_left=bad),))) is None


def test_evaluation_reports_the_unmeasurable_parts(lshape_run: Any) -> None:
    scene = read_scene(lshape_run.scene)
    assert scene.truth is not None
    interp = read_interpretation(lshape_run.out / "interpretation.json")
    hidden = unmeasurable(part_sights(scene))
    assert hidden is not None
    result = evaluate(interp, scene.truth, unmeasurable=hidden)
    assert result.summary()["unmeasurable"] == list(hidden)
    assert any(
        "shown by no view" in line and "body.right" in line for line in format_evaluation(result)
    )
    assert evaluate(interp, scene.truth).summary()["unmeasurable"] is None
