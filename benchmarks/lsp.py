"""The language server's latency as an editor sees it, through the protocol (a child process).

Run: .venv/bin/python benchmarks/lsp.py
Starts `aida-kb lsp` (wall time to the answer of `initialize`: the server's start), opens
kb/buildings.kb, then times round trips: a change to the diagnostics published for it
(alternately a misspelt concept and its fix), hover, completion after `roof.`, references and
rename of a role. Prints one line of JSON: the CPU time of one analysis (compile and index) and
of the server's imports, start-up (best of STARTS) and the median and worst
of each request over ROUNDS, and the machine's load average (on a busy machine every figure
grows with it; the medians are the ones to trust).
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from lsprotocol import types

from aida_kb.lsp.client import ServerClient
from aida_kb.lsp.convert import uri_of_path

ROOT = Path(__file__).resolve().parents[1]
FILE = ROOT / "kb" / "buildings.kb"
STARTS = 3
ROUNDS = 40


def _position(text: str, needle: str, offset: int) -> types.Position:
    at = text.index(needle) + offset
    line = text.count("\n", 0, at)
    return types.Position(line, at - (text.rfind("\n", 0, at) + 1))


def _timed(run: Callable[[], Any], rounds: int = ROUNDS) -> tuple[float, float]:
    """(median, worst) milliseconds of ``rounds`` calls."""
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        run()
        times.append((time.perf_counter() - start) * 1000)
    return statistics.median(times), max(times)


def _cpu_figures(text: str, uri: str) -> dict[str, float]:
    """CPU time, which the machine's load does not inflate: one analysis (compile + index) of
    the file in this process, and the server's imports in a fresh one."""
    from aida_kb.lsp.analysis import Analysis

    Analysis(uri, text)
    cpu = []
    for _ in range(ROUNDS):
        start = time.process_time()
        Analysis(uri, text)
        cpu.append(time.process_time() - start)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-c", "import aida_kb.lsp.server"], check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    imports = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {
        "analysis_cpu_median_ms": round(statistics.median(cpu) * 1000, 1),
        "server_import_cpu_s": round(imports, 3),
    }


def main() -> None:
    starts = []
    for _ in range(STARTS):
        start = time.perf_counter()
        ServerClient().stop()
        starts.append(time.perf_counter() - start)
    text = FILE.read_text(encoding="utf-8")
    uri = uri_of_path(str(FILE))
    doc = types.TextDocumentIdentifier(uri)
    word = _position(text, "part floor: Floor", len("part floor: "))
    span = types.Range(word, types.Position(word.line, word.character + len("Floor")))
    typo = types.Range(word, types.Position(word.line, word.character + len("Flor")))
    roof = _position(
        text, "eaves: parallel_edges(front, roof.front", len("eaves: parallel_edges(front, ")
    )
    after_dot = types.Position(roof.line, roof.character + len("roof."))
    figures: dict[str, float] = {}
    with ServerClient() as client:
        client.open(uri, text)
        client.diagnostics(uri)
        state = {"typo": False}

        def edit() -> None:
            if state["typo"]:
                version = client.change(uri, "Floor", typo)
            else:
                version = client.change(uri, "Flor", span)
            state["typo"] = not state["typo"]
            client.diagnostics(uri, version)

        requests: dict[str, Callable[[], Any]] = {
            "change_to_diagnostics": edit,
            "hover": lambda: client.request(
                types.TEXT_DOCUMENT_HOVER, types.HoverParams(doc, roof)
            ),
            "completion": lambda: client.request(
                types.TEXT_DOCUMENT_COMPLETION, types.CompletionParams(doc, after_dot)
            ),
            "references": lambda: client.request(
                types.TEXT_DOCUMENT_REFERENCES,
                types.ReferenceParams(
                    context=types.ReferenceContext(include_declaration=True),
                    text_document=doc,
                    position=roof,
                ),
            ),
            "rename": lambda: client.request(
                types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc, roof, "cover")
            ),
        }
        for name, run in requests.items():
            if name != "change_to_diagnostics" and state["typo"]:
                edit()  # the other requests on the clean file
            if name != "change_to_diagnostics":
                assert run(), f"{name} gave nothing"  # timing an empty answer proves nothing
            median, worst = _timed(run)
            figures[f"{name}_median_ms"] = round(median, 1)
            figures[f"{name}_worst_ms"] = round(worst, 1)
    print(
        json.dumps(
            {
                "file": "kb/buildings.kb",
                "rounds": ROUNDS,
                "load_average_1min": round(os.getloadavg()[0], 1),
                **_cpu_figures(text, uri),
                "server_start_best_s": round(min(starts), 3),
                **figures,
            }
        )
    )


if __name__ == "__main__":
    main()
