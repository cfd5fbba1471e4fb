"""Benchmark: time to render one 640x480 stereo pair of the `house` preset (2x2 supersampling).

Run: .venv/bin/python benchmarks/render.py   (prints ONE line of JSON at the end)
"""

from __future__ import annotations

import json
import time

import numpy as np

from aida_kb.synth.render import Exposure, Lighting, render, surfaces
from aida_kb.synth.scenes import preset


def main() -> None:
    """Time texture generation, then the best of 3 stereo-pair renders."""
    spec = preset("house", seed=0)
    R0, t0 = spec.views_site[0]
    surfs = surfaces(spec.model, R0, t0)
    light = Lighting(
        sun=R0 @ (spec.sun_site / np.linalg.norm(spec.sun_site)), up=R0 @ np.array([0.0, 1.0, 0.0])
    )
    rig = spec.rig
    R, t = np.eye(3), np.zeros(3)
    start = time.perf_counter()
    render(surfs, rig.K1, R, t, rig.image_size, light, seed=0)  # first call builds the textures
    first = time.perf_counter() - start
    best = np.inf
    for _ in range(3):
        start = time.perf_counter()
        render(surfs, rig.K1, R, t, rig.image_size, light, seed=0, exposure=Exposure())
        render(surfs, rig.K2, rig.R @ R, rig.R @ t + rig.T, rig.image_size, light, seed=0)
        best = min(best, time.perf_counter() - start)
    print(
        json.dumps(
            {
                "width": rig.image_size[0],
                "height": rig.image_size[1],
                "supersample": 2,
                "stereo_pair_s": round(best, 3),
                "first_view_with_texture_build_s": round(first, 3),
                "limit_s": 2.0,
            }
        )
    )


if __name__ == "__main__":
    main()
