"""Start-up of `aida-kb validate kb/buildings.kb` (target: < 0.5 s wall), a fresh process each run.

Run: .venv/bin/python benchmarks/cli_startup.py
Prints one line of JSON: wall time (best and median of the runs) and CPU time (user + system,
median) of `validate`, the same for linting the broken examples, and a bare interpreter's wall
time for reference. On a busy machine the best wall time and the CPU time are the figures to
trust: the median wall time then mostly measures waiting for a core.
"""

from __future__ import annotations

import json
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = 15


def _run(argv: list[str]) -> tuple[float, float]:
    """(wall, cpu) seconds of one run of `argv`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(argv, cwd=ROOT, capture_output=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _figures(argv: list[str], runs: int) -> tuple[float, float, float]:
    """(best wall, median wall, median cpu) over `runs` runs."""
    walls, cpus = zip(*(_run(argv) for _ in range(runs)), strict=True)
    return min(walls), statistics.median(walls), statistics.median(cpus)


def main() -> None:
    exe = shutil.which("aida-kb", path=str(Path(sys.executable).parent)) or "aida-kb"
    validate = [exe, "validate", "kb/buildings.kb"]
    _run(validate)  # warm the file cache
    best, median, cpu = _figures(validate, RUNS)
    _, lint_median, lint_cpu = _figures([exe, "lint", "kb/examples/"], 5)
    bare, _, _ = _figures([sys.executable, "-c", "pass"], 5)
    print(
        json.dumps(
            {
                "runs": RUNS,
                "validate_best_s": round(best, 3),
                "validate_median_s": round(median, 3),
                "validate_cpu_s": round(cpu, 3),
                "lint_examples_median_s": round(lint_median, 3),
                "lint_examples_cpu_s": round(lint_cpu, 3),
                "python_startup_best_s": round(bare, 3),
            }
        )
    )


if __name__ == "__main__":
    main()
