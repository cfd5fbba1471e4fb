"""Benchmark of the whole pipeline on rendered houses (not a test). Prints ONE line of JSON.

For seeds 0, 1, 2 (textures and image noise differ) the `house` preset is rendered, then
reconstructed exactly as `aida-kb reconstruct` does (evidence -> interpretation -> model),
and the model is compared with the ground truth: the largest error of the angles between
adjacent parts (degrees) and of the vertices (percent of the house's size), and the time the
pipeline took per scene (rendering excluded). Run: ``.venv/bin/python benchmarks/reconstruct.py``.
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


def main() -> None:
    """Render, reconstruct and compare each seed; print a line per seed and the JSON summary."""
    kb = compile_path(Path(__file__).resolve().parents[1] / "kb" / "buildings.kb").kb
    assert kb is not None
    angles: list[float] = []
    vertices: list[float] = []
    seconds: list[float] = []
    accepted = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in SEEDS:
            scene = Path(tmp) / f"house{seed}"
            render_scene(preset("house", seed=seed), scene)
            start = time.perf_counter()
            result = reconstruct_scene(kb, scene, Path(tmp) / f"model{seed}")
            seconds.append(time.perf_counter() - start)
            interp = result.interpretation
            truth = read_scene(scene).truth
            if interp.model is None or truth is None:
                print(f"seed {seed}: {interp.message}", file=sys.stderr)
                continue
            accepted += 1
            c = compare_with_truth(interp.model, truth)
            angles.append(c.max_angle_error_deg)
            vertices.append(100.0 * c.max_vertex_error_rel)
            print(
                f"seed {seed}: {interp.message}; max angle error {c.max_angle_error_deg:.3f} deg, "
                f"max vertex error {100.0 * c.max_vertex_error_rel:.2f}% of "
                f"{c.size_m:.1f} m; {seconds[-1]:.1f} s",
                file=sys.stderr,
            )
    print(
        json.dumps(
            {
                "scenes": len(SEEDS),
                "accepted": accepted,
                "max_angle_error_deg": round(max(angles), 4) if angles else None,
                "max_vertex_error_pct": round(max(vertices), 3) if vertices else None,
                "seconds_per_scene": round(sum(seconds) / len(seconds), 2),
            }
        )
    )


if __name__ == "__main__":
    main()
