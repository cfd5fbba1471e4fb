"""Every synthetic preset's interpretation.kb as a fixture (not a test). Prints ONE line of JSON.

For each preset of `aida_kb.synth.scenes.PRESETS` (default parameters, seed 0) the scene is
rendered and reconstructed as ``aida-kb reconstruct`` does (with kb/buildings.kb; the tower
with kb/tower.kb); the ``interpretation.kb`` it
writes must lint clean with the knowledge base's folder as import path; then it is put into
the scene's folder as ``expected.kb`` and run through ``aida-kb test`` — the scene is
reconstructed a second time and the result compared with the written expectation
(docs/testing.md). Figures: how many presets were run, how many interpretation files linted
clean, how many passed as fixtures, each preset's verdict and the time of a fixture run.
Run: ``nice -n 10 .venv/bin/python benchmarks/fixture_presets.py [PRESET ...]``.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

from aida_kb.cli.main import main as cli
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.kb import compile_path
from aida_kb.synth.scenes import PRESETS, preset, render_scene

KB_DIR = Path(__file__).resolve().parents[1] / "kb"
KB_OF = {"tower": "tower.kb"}
"""The knowledge base of a preset whose object buildings.kb does not describe."""


def main(argv: list[str]) -> None:
    """Render, reconstruct, lint and run as a fixture each preset; print the JSON summary."""
    names = argv or list(PRESETS)
    kbs = {f: compile_path(KB_DIR / f).kb for f in {"buildings.kb", *KB_OF.values()}}
    lint_clean = passed = 0
    verdicts: dict[str, str | None] = {}
    seconds: dict[str, float] = {}
    failures: dict[str, list[str]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            scene, out = Path(tmp) / name, Path(tmp) / f"out-{name}"
            kb = kbs[KB_OF.get(name, "buildings.kb")]
            assert kb is not None
            render_scene(preset(name, seed=0), scene)
            interp = reconstruct_scene(kb, scene, out).interpretation
            verdicts[name] = interp.verdict
            written = out / "interpretation.kb"
            lint = compile_path(written, search_paths=[str(KB_DIR)])
            clean = not lint.diagnostics
            lint_clean += clean
            # the scene folder and the output folder are siblings: the relative import of
            # the written file holds from the scene folder too
            shutil.copy(written, scene / "expected.kb")
            buffer = io.StringIO()
            start = time.perf_counter()
            with contextlib.redirect_stdout(buffer):
                code = cli(["test", str(scene), "--import-path", str(KB_DIR)])
            seconds[name] = round(time.perf_counter() - start, 1)
            passed += code == 0
            if code != 0 or not clean:
                failures[name] = [d.message for d in lint.diagnostics] + [
                    line.strip() for line in buffer.getvalue().splitlines()[1:-1]
                ]
            print(
                f"{name}: verdict {interp.verdict}, lint {'clean' if clean else 'NOT clean'}, "
                f"fixture exit {code} ({seconds[name]} s)",
                file=sys.stderr,
            )
    print(
        json.dumps(
            {
                "presets": len(names),
                "lint_clean": lint_clean,
                "passed_as_fixture": passed,
                "verdicts": verdicts,
                "fixture_seconds": seconds,
                "failures": failures,
            }
        )
    )


if __name__ == "__main__":
    main(sys.argv[1:])
