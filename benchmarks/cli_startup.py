"""Wall time of `aida-kb validate kb/buildings.kb` (target: < 0.5 s), a fresh process each run.

Run: .venv/bin/python benchmarks/cli_startup.py
Prints one line of JSON: {"runs": ..., "validate_median_s": ..., "validate_max_s": ..., ...}.
"""

from __future__ import annotations

import json
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = 15


def _wall(argv: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(argv, cwd=ROOT, capture_output=True, check=False)
    return time.perf_counter() - start


def main() -> None:
    exe = shutil.which("aida-kb", path=str(Path(sys.executable).parent)) or "aida-kb"
    validate = [exe, "validate", "kb/buildings.kb"]
    lint_broken = [exe, "lint", "kb/examples/"]
    _wall(validate)  # warm the file cache and Lark's grammar cache
    times = [_wall(validate) for _ in range(RUNS)]
    broken = [_wall(lint_broken) for _ in range(5)]
    bare = [_wall([sys.executable, "-c", "pass"]) for _ in range(5)]
    print(
        json.dumps(
            {
                "runs": RUNS,
                "validate_median_s": round(statistics.median(times), 4),
                "validate_max_s": round(max(times), 4),
                "lint_examples_median_s": round(statistics.median(broken), 4),
                "python_startup_median_s": round(statistics.median(bare), 4),
            }
        )
    )


if __name__ == "__main__":
    main()
