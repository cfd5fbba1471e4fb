"""Benchmark: plane normals of the evidence against the truth, per synthetic preset (not a test).

Each preset is rendered at 640x480 (two views, seed 0) and run through `scene_evidence` with the
manual segmentation (labels.png); for every face that covers at least 2 % of a view's image the
angle between the region's n_init and the true plane normal is measured. Reported per preset:
the largest angle over both views (`<preset>_max_normal_err_deg`) and the face it belongs to,
once with the default pipeline (disparity fit refined by direct image alignment) and once
with the disparity fits alone (`photometric_window = 0`), so that the effect of the refinement
stays visible. Ends with ONE line of JSON.

Run: .venv/bin/python benchmarks/evidence.py
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from aida_kb.io.evidence import Evidence
from aida_kb.io.scene import Scene, read_labels, read_scene
from aida_kb.synth.scenes import preset, render_scene
from aida_kb.vision.evaluate import angle_deg, truth_planes_camera
from aida_kb.vision.evidence import VisionParams, scene_evidence

PRESETS: dict[str, tuple[str, dict[str, str]]] = {
    "house": ("house", {}),
    "flat": ("house", {"roof": "flat"}),
    "hip": ("house", {"roof": "hip"}),
    "shed": ("house", {"roof": "shed"}),
    "lshape": ("lshape", {}),
    "lshape135": ("lshape", {"meeting_deg": "135"}),
    "oriel": ("oriel", {}),
}
MIN_FRACTION = 0.02
LIMIT_DEG = 2.0


def face_errors(scene: Scene, evidence: Evidence) -> list[tuple[float, str, str]]:
    """(angle deg, view id, face role) of every face covering >= MIN_FRACTION of its view;
    a face without a region counts as 180 degrees."""
    assert scene.truth is not None
    roles = {p.label: p.role for p in scene.truth.parts}
    out = []
    for view in evidence.views:
        sv = scene.view(view.id)
        assert sv.labels is not None
        labels = read_labels(sv.labels)
        planes = truth_planes_camera(scene.truth, view.id)
        ids, counts = np.unique(labels, return_counts=True)
        by_label = {r.label: r for r in view.regions if r.label is not None}
        for label, count in zip(ids.tolist(), counts.tolist(), strict=True):
            if label == 0 or count < MIN_FRACTION * labels.size:
                continue
            role = roles.get(label, "ground")
            region = by_label.get(label)
            if region is None:
                out.append((180.0, view.id, role))
                continue
            out.append((angle_deg(np.array(region.n_init), planes[label][0]), view.id, role))
    return out


def main() -> None:
    """Render each preset, build its evidence twice, print per-preset lines and the JSON."""
    summary: dict[str, Any] = {"image": "640x480", "min_face_fraction": MIN_FRACTION}
    worst_all = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for key, (name, params) in PRESETS.items():
            scene_dir = render_scene(preset(name, seed=0, params=params), Path(tmp) / key)
            scene = read_scene(scene_dir)
            start = time.perf_counter()
            evidence, _ = scene_evidence(scene)
            seconds = time.perf_counter() - start
            errors = face_errors(scene, evidence)
            plain, _ = scene_evidence(scene, params=VisionParams(photometric_window=0))
            errors_plain = face_errors(scene, plain)
            worst = max(errors)
            worst_plain = max(errors_plain)
            worst_all = max(worst_all, worst[0])
            summary[f"{key}_max_normal_err_deg"] = round(worst[0], 2)
            summary[f"{key}_worst_face"] = f"{worst[1]}/{worst[2]}"
            summary[f"{key}_max_normal_err_deg_disparity_fit_only"] = round(worst_plain[0], 2)
            summary[f"{key}_faces"] = len(errors)
            summary[f"{key}_evidence_s"] = round(seconds, 2)
            print(
                f"{key}: max {worst[0]:.2f} deg ({worst[1]}/{worst[2]}) over {len(errors)} "
                f"faces; disparity fits alone {worst_plain[0]:.2f} deg; {seconds:.1f} s",
                file=sys.stderr,
            )
    summary["max_normal_err_deg"] = round(worst_all, 2)
    summary["done_when_normals_2deg"] = worst_all <= LIMIT_DEG
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
