"""Benchmark: a scene through COLMAP and back reconstructs as well as the native one. ONE JSON line.

For each seed the `house` preset is rendered (two stereo views, 480x360, focal 600 px) and its
labels are dropped (a COLMAP model has none, so the native scene is segmented by orientation
too). The native scene is reconstructed as `aida-kb reconstruct` does (view 01 registered).
Then `aida_kb.testing.colmap` writes it as a COLMAP model (text; the binary form reads alike,
tests/io/test_colmap.py) in an arbitrary frame (scale 0.37, turned 40 deg, moved), `aida-kb
scene from-colmap` builds a scene with the rig's baseline as the known distance (view 01's
pose is then known), and that scene is reconstructed. Both are compared with the truth
(`aida_kb.interpret.evaluate`): verdict, the largest normal error (deg) and vertex error (%
of the house's size), the camera of view 01 (deg, m off), and the time. A scene known up to
scale only (no known distance) is run for the first seed, to show its summary line and units.

Seed 1 was looked at while the known-pose handling was developed; seeds 3, 4, 5 are held out.
Run: ``nice .venv/bin/python benchmarks/colmap_roundtrip.py [SEED ...]``.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from aida_kb.cli.main import main as cli
from aida_kb.interpret.evaluate import evaluate
from aida_kb.interpret.pipeline import UP_TO_SCALE, reconstruct_scene
from aida_kb.io.scene import read_scene
from aida_kb.kb import compile_path
from aida_kb.synth.scenes import preset, render_scene, rot_y
from aida_kb.testing.colmap import SfmFrame, write_colmap_from_scene

SEEDS = (1, 3, 4, 5)
SIZE = {"image_width": "480", "image_height": "360", "focal_px": "600"}
FRAME = SfmFrame(scale=0.37, Q=tuple(map(tuple, rot_y(0.7))), offset=(3.0, -1.0, 2.0))


def _figures(kb: Any, scene: Path, out: Path, truth: Any) -> dict[str, Any]:
    start = time.perf_counter()
    interp = reconstruct_scene(kb, scene, out).interpretation
    seconds = time.perf_counter() - start
    ev = evaluate(interp, truth)
    c = ev.comparison
    cam = [e for e in ev.cameras if e.view == "01"]
    return {
        "verdict": interp.verdict,
        "normal_deg": None if c is None else round(c.max_normal_error_deg, 3),
        "vertex_pct": None if c is None else round(100 * c.max_vertex_error_rel, 3),
        "view01_deg": round(cam[0].angle_deg, 3) if cam else None,
        "view01_m": round(cam[0].centre_m, 3) if cam else None,
        "units": None if interp.model is None else interp.model.units,
        "says_up_to_scale": UP_TO_SCALE in interp.message,
        "summary": interp.message[:160],
        "s": round(seconds, 1),
    }


def main() -> None:
    """Render, reconstruct natively and through COLMAP; print a line per scene, then JSON."""
    kb = compile_path(Path(__file__).resolve().parents[1] / "kb" / "buildings.kb").kb
    assert kb is not None
    seeds = tuple(int(a) for a in sys.argv[1:]) or SEEDS
    result: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for seed in seeds:
            native = root / f"house{seed}"
            render_scene(preset("house", seed=seed, views=2, params=SIZE), native)
            text = (native / "scene.yaml").read_text()
            lines = [line for line in text.splitlines() if "labels:" not in line]
            (native / "scene.yaml").write_text("\n".join(lines) + "\n")
            truth = read_scene(native).truth
            model, images = write_colmap_from_scene(native, root / f"colmap{seed}", frame=FRAME)
            sfm = root / f"sfm{seed}"
            baseline = read_scene(native).calib.baseline_m
            argv = ["scene", "from-colmap", str(model), "--images", str(images)]
            known = ["--known-distance", "v00_left.png", "v00_right.png", repr(baseline)]
            assert cli([*argv, "-o", str(sfm), *known]) == 0
            row = {
                "native": _figures(kb, native, root / f"out_native{seed}", truth),
                "colmap": _figures(kb, sfm, root / f"out_sfm{seed}", truth),
            }
            if seed == seeds[0]:
                unknown = root / f"sfm_unknown{seed}"
                assert cli([*argv, "-o", str(unknown)]) == 0
                row["colmap_up_to_scale"] = _figures(kb, unknown, root / f"out_u{seed}", truth)
            result[f"house{seed}"] = row
            print(f"house{seed}: {json.dumps(row)}", file=sys.stderr)
    same = [r["native"]["verdict"] == r["colmap"]["verdict"] for r in result.values()]
    result["same_verdict"] = f"{sum(same)}/{len(same)}"
    print(json.dumps(result))


if __name__ == "__main__":
    main()
