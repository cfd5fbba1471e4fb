"""The lint path stays light: no numpy, scipy, cv2, networkx, and not even pydantic."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ["numpy", "scipy", "cv2", "networkx", "pydantic"]

SCRIPT = f"""
import sys
from aida_kb.kb import compile_path
result = compile_path("kb/buildings.kb")
assert result.ok, result.diagnostics
print(",".join(m for m in {HEAVY!r} if m in sys.modules))
result.kb
print(",".join(m for m in {HEAVY!r} if m in sys.modules))
"""


def test_linting_imports_nothing_heavy_and_the_model_only_pydantic() -> None:
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert out[0] == ""
    assert out[1] == "pydantic"
