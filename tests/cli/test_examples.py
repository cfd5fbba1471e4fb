"""The examples of every command's --help run, in order, in a copy of the repository's files.

Each command's epilog ends with "examples:" and calls of ``aida-kb``; together they are a
tutorial (one synthesises out/house, the next computes its evidence, ...). Here they run one
after another in a sandbox folder holding copies of kb/ and tests/fixtures/, in the order of
`COMMANDS` (which lists producers before consumers), in-process through `main`, in two chains
that need nothing of each other (`_chain`: the synthetic house's and the rest), each in its own
sandbox. A ``>`` writes the call's standard output to the file; of a pipeline ``a | b`` only
``a`` runs (its output must not be empty). Each call must end with status 0 unless
`EXIT_STATUS` names another with the reason; calls that cannot run here are in `NOT_RUN`, with
the reason — every example is still parsed by the real argument parser. The lists must match
the help texts exactly, so a new example is either run or explained.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import shlex
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from aida_kb.cli.main import COMMANDS, build_parser, main

ROOT = Path(__file__).resolve().parents[2]

NOT_RUN: dict[str, str] = {
    "aida-kb lsp": "serves an editor over stdin/stdout until it closes (tests/lsp drive it)",
    "aida-kb demo": "tests/cli/test_demo.py runs the demo",
    "aida-kb demo --out out/demo --no-net": "tests/cli/test_demo.py runs the demo",
    "aida-kb calibrate photos/ -o calib.yaml --pattern 8x5 --square 0.025": (
        "the user's own chessboard photos"
    ),
    "aida-kb batch --list scenes.txt -o models --workers 4 --memory-limit 3GB": (
        "the user's own list of scenes; tests/batch run lists"
    ),
    "aida-kb batch city -o city-models --scheduler tcp://10.0.0.5:8786": (
        "a running Dask scheduler at that address"
    ),
    "aida-kb batch city -o city-models": (
        "a local Dask cluster of worker processes: tests/batch run the same on threads"
    ),
    "aida-kb scene init --calib calib.txt --images Motorcycle/ -o out/moto": (
        "the user's own Middlebury download"
    ),
    "aida-kb scene init --calib P.txt --pair l.png r.png --unit unknown -o out/p": (
        "the user's own projection matrices and photos"
    ),
    "aida-kb scene from-colmap sparse/0 --images images/ -o out/sfm": (
        "the user's own COLMAP model (tests/io run a COLMAP model written from a scene)"
    ),
    "aida-kb scene from-colmap sparse/0 --images images/ -o out/sfm --known-distance a.jpg "
    "b.jpg 1.2": "the user's own COLMAP model",
    # the same work is done by another test; run here it would add half a minute
    "aida-kb test tests/fixtures --import-path kb": (
        "tests/interpret/test_fixtures.py runs every fixture of tests/fixtures through the "
        "same runner"
    ),
    "aida-kb synth chessboard -o out/board": (
        "tests/vision/test_calibration.py renders and calibrates a smaller chessboard scene"
    ),
    "aida-kb calibrate out/board -o out/calib.yaml": (
        "tests/vision/test_calibration.py renders and calibrates a smaller chessboard scene"
    ),
    "aida-kb synth lshape -o out/l135 --set meeting_deg=135 --chessboard": (
        "renders a calibration set besides the L-shape; tests/synth render both"
    ),
}

EXIT_STATUS: dict[str, tuple[int, str]] = {
    "aida-kb lint --format json kb/examples/broken_syntax.kb": (
        1,
        "the file shows a syntax error on purpose",
    ),
    "aida-kb lsp --check kb/examples/broken_names.kb": (1, "the file has errors on purpose"),
    # the house's second camera is 0.05-0.14 deg off the truth (seeds 0-2) and, its
    # deviation taken honestly (`uncertainty.GROUND_TEXTURE_VARIANCE_INFLATION`), fixed only to
    # +-0.16 deg at 2 sd: the model is right but doubtful, so evaluate's "correct" fails too
    "aida-kb reconstruct kb/buildings.kb out/house -o out/house-model": (
        3,
        "doubtful: the house's second camera is fixed only to +-0.16 deg at 2 sd",
    ),
    "aida-kb evaluate out/house-model out/house": (1, "a doubtful model is not correct"),
    "aida-kb evaluate out/house-model out/house --json": (1, "a doubtful model is not correct"),
}


def _epilogs() -> dict[str, str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {name: sub.choices[name].epilog or "" for name in COMMANDS}


def _examples() -> list[str]:
    """Every example call, in the order of COMMANDS and of each epilog (repeats dropped)."""
    calls: list[str] = []
    for epilog in _epilogs().values():
        tail = epilog.split("examples:", 1)[-1].replace("\\\n", " ")  # continued lines
        for line in tail.splitlines():
            line = " ".join(re.sub(r"\s#.*$", "", line).split())  # no comment
            if line.startswith("aida-kb") and line not in calls:
                calls.append(line)
    return calls


def _words(call: str) -> tuple[list[str], str | None, bool]:
    """(argv after 'aida-kb', file of a '>' redirection, True if piped into something)."""
    words = shlex.split(call)
    piped = "|" in words
    if piped:
        words = words[: words.index("|")]
    target = None
    if ">" in words:
        at = words.index(">")
        target = words[at + 1]
        words = words[:at]
    assert words[0] == "aida-kb"
    return words[1:], target, piped


EXAMPLES = _examples()


def test_the_lists_name_only_examples_that_exist() -> None:
    assert not set(NOT_RUN) - set(EXAMPLES)
    assert not set(EXIT_STATUS) - set(EXAMPLES)


@pytest.mark.parametrize("call", EXAMPLES)
def test_every_example_parses(call: str) -> None:
    argv, _, _ = _words(call)
    parser = build_parser()
    with contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:
            pytest.fail(f"{call!r} does not parse ({exc.code}): {err.getvalue().strip()}")
    assert args.command == argv[0]


@contextlib.contextmanager
def _stdout_to(target: Path | None) -> Iterator[io.StringIO]:
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        yield buffer
    if target is not None:
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(buffer.getvalue())


def _chain(call: str) -> str:
    """The tutorial an example belongs to: "house" for the calls on the synthetic house of
    out/house and what is made of it (its evidence, out/m, out/house-model, exports), "other"
    for the rest (the knowledge's tools, the other presets), which need nothing of it."""
    argv, _, _ = _words(call)
    return "house" if any(w.startswith(("out/house", "out/m")) for w in argv) else "other"


CHAINS = ("house", "other")


def test_every_example_is_in_a_chain_that_runs_it() -> None:
    assert {_chain(c) for c in EXAMPLES} == set(CHAINS)
    # the house chain starts with the call that makes the house
    house = [c for c in EXAMPLES if _chain(c) == "house" and c not in NOT_RUN]
    assert house[0] == "aida-kb synth house -o out/house"


# the two chains run apart (each in its own sandbox), so that the suite's workers share them
@pytest.mark.slow
@pytest.mark.parametrize("chain", CHAINS)
def test_the_examples_run_in_order(
    chain: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    sandbox = tmp_path / "work"
    sandbox.mkdir()
    shutil.copytree(ROOT / "kb", sandbox / "kb")
    shutil.copytree(ROOT / "tests" / "fixtures", sandbox / "tests" / "fixtures")
    monkeypatch.chdir(sandbox)
    monkeypatch.delenv("CI", raising=False)
    failures: list[str] = []
    seconds: dict[str, float] = {}
    for call in EXAMPLES:
        if call in NOT_RUN or _chain(call) != chain:
            continue
        argv, target, piped = _words(call)
        start = time.perf_counter()
        with _stdout_to(sandbox / target if target else None) as out:
            status = main(argv)
        seconds[call] = time.perf_counter() - start
        expected = EXIT_STATUS.get(call, (0, ""))[0]
        if status != expected:
            err = capsys.readouterr().err.strip().splitlines()
            failures.append(f"{call}: exit {status}, expected {expected}: {err[-3:]}")
        if (piped or target) and not out.getvalue().strip():
            failures.append(f"{call}: wrote nothing to its standard output")
    slowest = sorted(seconds.items(), key=lambda item: -item[1])[:5]
    print("slowest examples:", [(call, round(t, 1)) for call, t in slowest])
    assert not failures, "\n".join(failures)
