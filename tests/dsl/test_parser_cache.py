"""The parser loads no cache another user could plant, and leaves nothing in the temp dir.

Lark's ``cache=True`` unpickles ``$TMPDIR/.lark_*.tmp`` (a predictable name) before checking
anything; a planted pickle then runs code. aida-kb builds its tables from the packaged grammar.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# Builds Lark's cache for aida-kb's grammar and options, then replaces it with a pickle that
# creates a marker file when it is loaded.
PLANT = r"""
import pickle, sys
from pathlib import Path
from lark import Lark
from aida_kb.dsl.parser import grammar_path
tmp, marker = Path(sys.argv[1]), sys.argv[2]
Lark(grammar_path().read_text(encoding="utf-8"), parser="lalr", lexer="contextual",
     maybe_placeholders=True, keep_all_tokens=True, cache=True)
(cache,) = tmp.glob(".lark*")

class Evil:
    def __reduce__(self):
        return (open, (marker, "w"))

first = cache.read_bytes().split(b"\n", 1)[0]
cache.write_bytes(first + b"\n" + pickle.dumps(Evil()))
print(cache)
"""


def test_planted_lark_cache_is_not_unpickled(tmp_path: Path) -> None:
    shared = tmp_path / "shared-tmp"
    shared.mkdir()
    marker = tmp_path / "pwned"
    env = {**os.environ, "TMPDIR": str(shared)}
    planted = subprocess.run(
        [sys.executable, "-c", PLANT, str(shared), str(marker)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    )
    cache = Path(planted.stdout.strip())
    assert cache.is_file()
    assert not marker.exists()  # planting itself loads nothing
    before = sorted(shared.iterdir())

    run = subprocess.run(
        [sys.executable, "-m", "aida_kb", "validate", "kb/buildings.kb"],
        env=env,
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr
    assert not marker.exists(), "the planted pickle was loaded"
    assert sorted(shared.iterdir()) == before  # no cache file written either
