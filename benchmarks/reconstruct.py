"""Benchmark of the whole pipeline on rendered houses (not a test). Prints ONE line of JSON.

For seeds 0, 1, 2 (textures and image noise differ) the `house` preset is rendered, then
reconstructed exactly as `aida-kb reconstruct` does (evidence -> interpretation -> model),
and the model is compared with the ground truth: the largest error of the angles between
adjacent parts (degrees) and of the vertices (percent of the house's size), and the time the
pipeline took per scene (rendering excluded). Then the two L-shaped houses of the `lshape`
preset (a wing at 90 degrees, and at 135 with ``meeting_deg=135``; seed 0): how many were
accepted with a wing of the right specialisation (RightWing, SkewWing), and their largest
angle and vertex errors (``null`` when none was). Run:
``.venv/bin/python benchmarks/reconstruct.py``.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from aida_kb.interpret.evaluate import compare_with_truth
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.io.scene import read_scene
from aida_kb.kb import compile_path
from aida_kb.synth.scenes import preset, render_scene

SEEDS = (0, 1, 2)
LSHAPES = (("lshape90", {}, "RightWing"), ("lshape135", {"meeting_deg": "135"}, "SkewWing"))


def _rounded(values: list[float], digits: int) -> float | None:
    return round(max(values), digits) if values else None


def main() -> None:
    """Render, reconstruct and compare each scene; print a line per scene and the JSON summary."""
    kb = compile_path(Path(__file__).resolve().parents[1] / "kb" / "buildings.kb").kb
    assert kb is not None
    angles: list[float] = []
    vertices: list[float] = []
    seconds: list[float] = []
    accepted = 0
    wing_angles: list[float] = []
    wing_vertices: list[float] = []
    wings_right = 0
    with tempfile.TemporaryDirectory() as tmp:
        scenes = [(f"house{s}", "house", s, {}, None) for s in SEEDS]
        scenes += [(name, "lshape", 0, params, wing) for name, params, wing in LSHAPES]
        for name, kind, seed, params, wing in scenes:
            scene = Path(tmp) / name
            render_scene(preset(kind, seed=seed, params=params), scene)
            start = time.perf_counter()
            result = reconstruct_scene(kb, scene, Path(tmp) / f"model-{name}")
            elapsed = time.perf_counter() - start
            interp = result.interpretation
            truth = read_scene(scene).truth
            if interp.model is None or truth is None:
                print(f"{name}: {interp.message}", file=sys.stderr)
                continue
            c = compare_with_truth(interp.model, truth)
            found = ""
            if wing is None:
                seconds.append(elapsed)
                accepted += 1
                angles.append(c.max_angle_error_deg)
                vertices.append(100.0 * c.max_vertex_error_rel)
            else:
                found = next(
                    (i.concept for i in interp.instances if i.role == "body.wings[0]"), "no wing"
                )
                if found == wing:
                    wings_right += 1
                    wing_angles.append(c.max_angle_error_deg)
                    wing_vertices.append(100.0 * c.max_vertex_error_rel)
                found = f" (wing: {found}, truth {wing})"
            print(
                f"{name}: {interp.message}{found}; max angle error {c.max_angle_error_deg:.3f} "
                f"deg, max vertex error {100.0 * c.max_vertex_error_rel:.2f}% of "
                f"{c.size_m:.1f} m; {elapsed:.1f} s",
                file=sys.stderr,
            )
    print(
        json.dumps(
            {
                "scenes": len(SEEDS),
                "accepted": accepted,
                "max_angle_error_deg": _rounded(angles, 4),
                "max_vertex_error_pct": _rounded(vertices, 3),
                "seconds_per_scene": round(sum(seconds) / len(seconds), 2) if seconds else None,
                "lshapes": len(LSHAPES),
                "lshapes_with_right_wing": wings_right,
                "lshape_max_angle_error_deg": _rounded(wing_angles, 4),
                "lshape_max_vertex_error_pct": _rounded(wing_vertices, 3),
            }
        )
    )


if __name__ == "__main__":
    main()
