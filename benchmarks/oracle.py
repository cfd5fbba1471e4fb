"""The verdict's evidence checks applied to the TRUE model (not a test).

A check of `aida_kb.interpret.verdict` that fails on the true object, seen by the true
cameras, doubts every right reconstruction of that scene: it can never be `verified`, however
good the interpretation. This script measures how often each check does so. For each kept
robustness scene (``scene-SEED/`` with its ``truth.json`` and ``out-SEED/evidence.json``, as
``benchmarks/robustness.py --keep DIR`` leaves them) it builds the model of the truth — every
true face, every true camera — and runs the checks that judge a model against the evidence
alone (what the interpretation chose plays no part):

- per view (`verdict.views.check_view`, `verdict.edges.edge_cover`): the model covers a
  region, explains at least ``EXPLAINED_MIN`` of the region weight inside its projection,
  its edges are seen along at least ``EDGE_COVER_MIN`` of their length, no region stands out
  of its surface, no region contradicts it beyond ``CONTRADICTION_MAX``;
- in the first view, the edges between the faces its regions lie on are seen along at least
  ``SEEN_EDGE_COVER_MIN`` of their length, as segments or outlines of those regions (the
  interpretation binds those faces to those regions);
- `verdict.views.adjoining` (a large region meeting the model that it does not explain) and
  `verdict.views.unexplained_near` (at least ``NEAR_EXPLAINED_MIN`` of the weight near it);
- `verdict.filled.unfilled` (check (j), "filled"): every face the view sees is there (not
  the surface beyond it), and no region on a face goes on far outside the model.

    .venv/bin/python benchmarks/oracle.py /tmp/rb60/keep [more keep folders ...]

The checks see the scenes' left images, as `aida-kb reconstruct` judges (an edge the image
steps across is seen); ``--no-images`` judges as `aida-kb interpret` does, from the evidence
alone. Prints a line per scene with the checks the truth fails, then ONE line of JSON:
scenes, views, and per check the share of views where the truth fails it.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aida_kb.errors import AidaError
from aida_kb.interpret.verdict.edges import edge_cover
from aida_kb.interpret.verdict.filled import unfilled
from aida_kb.interpret.verdict.tolerances import (
    CONTRADICTION_MAX,
    EDGE_COVER_MIN,
    EXPLAINED_MIN,
    NEAR_EXPLAINED_MIN,
    SEEN_EDGE_COVER_MIN,
    STANDING_OUT_SHARE_MAX,
)
from aida_kb.interpret.verdict.views import adjoining, check_view, unexplained_near
from aida_kb.io.evidence import Evidence, read_evidence
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel
from aida_kb.io.scene import SceneTruth, left_images, read_scene

CHECKS = (
    "covers none",
    "explained",
    "edge cover",
    "standing out",
    "contradicting",
    "adjoining",
    "near explained",
    "seen between bound",
    "filled",
)


def true_model(truth: SceneTruth, evidence: Evidence) -> ReconstructedModel:
    """The truth as a reconstructed model: its faces and every view's true left camera."""
    sizes = {v.id: (v.image_width, v.image_height) for v in evidence.views}
    parts = [
        ModelPart(role=p.role, concept=p.concept, normal=p.normal, offset_m=p.d, polygon=p.polygon)
        for p in truth.parts
    ]
    cameras = [
        ModelCamera(
            view=v.view,
            K=v.K,
            R=v.R,
            t=v.t,
            image_width=sizes[v.view][0],
            image_height=sizes[v.view][1],
        )
        for v in truth.views
        if v.view in sizes
    ]
    return ReconstructedModel(parts=parts, cameras=cameras)


def failed_checks(
    evidence: Evidence,
    model: ReconstructedModel,
    images: Mapping[str, npt.NDArray[np.uint8]] | None = None,
) -> dict[str, list[str]]:
    """Check -> the views (ids) where the model fails it (an empty dict: none failed);
    images: view id -> its left image, as `aida-kb reconstruct` judges with them."""
    out: dict[str, list[str]] = {}
    images = images or {}
    for view in evidence.views:
        image = images.get(view.id)
        check = check_view(view, model, image)
        if check is None:
            continue
        fails = []
        if check.inside_weight <= 0:
            fails.append("covers none")
        if check.explained_share < EXPLAINED_MIN:
            fails.append("explained")
        if check.edge_cover is not None and check.edge_cover < EDGE_COVER_MIN:
            fails.append("edge cover")
        standing = check.standing_out_weight / check.inside_weight if check.inside_weight else 0.0
        if standing > STANDING_OUT_SHARE_MAX:
            fails.append("standing out")
        if check.contradicting and check.contradicting[0][1] > CONTRADICTION_MAX:
            fails.append("contradicting")
        if adjoining(view, model, check):
            fails.append("adjoining")
        share, _ = unexplained_near(view, model, check)
        if share < NEAR_EXPLAINED_MIN:
            fails.append("near explained")
        if unfilled(view, model, check.explained_ids):
            fails.append("filled")
        if view.id == evidence.views[0].id:
            # (c) in the interpreted view: the edges between the parts its regions lie on
            bound = frozenset(role for role, w in check.explained_on.items() if w > 0)
            outlines = frozenset(check.explained_ids)
            seen = edge_cover(view, model, bound, outlines, image) if len(bound) > 1 else None
            if seen is not None and seen < SEEN_EDGE_COVER_MIN:
                fails.append("seen between bound")
        for name in fails:
            out.setdefault(name, []).append(view.id)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("keep", nargs="+", type=Path, help="folders of scene-SEED/, out-SEED/")
    parser.add_argument(
        "--no-images", action="store_true", help="judge without the images (as `interpret` does)"
    )
    args = parser.parse_args(argv)
    fails: Counter[str] = Counter()
    scenes = views = 0
    for keep in args.keep:
        for scene_dir in sorted(keep.glob("scene-*")):
            out_dir = keep / scene_dir.name.replace("scene-", "out-", 1)
            try:
                scene = read_scene(scene_dir)
                evidence = read_evidence(out_dir / "evidence.json")
            except (AidaError, OSError) as exc:
                print(f"{scene_dir}: skipped: {exc}", file=sys.stderr)
                continue
            truth = scene.truth
            if truth is None or not truth.parts:
                continue  # no object: nothing to explain
            try:
                images = None if args.no_images else left_images(scene)
                found = failed_checks(evidence, true_model(truth, evidence), images)
            except AidaError as exc:  # not a closed object (a chessboard): nothing to explain
                print(f"{scene_dir.name}: skipped: {exc}", file=sys.stderr)
                continue
            scenes += 1
            views += len(evidence.views)
            for name, ids in found.items():
                fails[name] += len(ids)
            kind = truth.parameters.get("kind", truth.object)
            shown = "; ".join(f"{k} ({', '.join(v)})" for k, v in found.items()) or "passes"
            print(f"{scene_dir.name} {kind}: {shown}", flush=True)
    result = {
        "scenes": scenes,
        "views": views,
        **{
            f"truth_fails_{k.replace(' ', '_')}": round(fails[k] / max(views, 1), 3) for k in CHECKS
        },
    }
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
