"""Every command: --help with an example; lint/validate stay light (no numpy, scipy, cv2)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from aida_kb.cli.main import COMMANDS, main

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("numpy", "scipy", "cv2")  # the rule for lint and validate
# Not forbidden by the issue, but each costs 0.1-0.2 s of start-up that validate (< 0.5 s)
# cannot afford: the compiler builds its pydantic model and networkx net only on demand.
SLOW_TO_IMPORT = ("pydantic", "networkx", "rich")


@pytest.mark.parametrize("command", COMMANDS)
def test_help_has_an_example(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert f"aida-kb {command}" in out.split("example", 1)[-1], "the epilog shows a call"


def test_no_command_prints_help_and_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().err


def test_unknown_option_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["lint", "--bogus", "x.kb"])
    assert exit_info.value.code == 2


_PROBE = """
import json, sys
from aida_kb.cli.main import main
code = main(sys.argv[1:])
heavy = sorted(m for m in sys.modules if m.split(".")[0] in {heavy!r})
print(json.dumps({{"code": code, "heavy": heavy}}))
"""


@pytest.mark.parametrize(
    "argv",
    [
        ["lint", "kb/buildings.kb"],
        ["validate", "kb/buildings.kb"],
        ["lint", "--format", "json", "kb/"],
        ["validate", "kb/examples/broken_syntax.kb"],
        ["fmt", "--check", "kb/buildings.kb"],
    ],
)
def test_lint_and_validate_import_no_numpy_scipy_cv2(argv: list[str]) -> None:
    probe = _PROBE.format(heavy=set(HEAVY + SLOW_TO_IMPORT))
    done = subprocess.run(
        [sys.executable, "-c", probe, *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert done.stderr == ""
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["code"] in (0, 1)
    assert result["heavy"] == []


def test_a_closed_output_pipe_ends_quietly() -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "aida_kb", "compile", "kb/buildings.kb"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None
    assert proc.stderr is not None
    proc.stdout.close()  # the reader leaves before the ~70 kB of JSON are written
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait(timeout=60) == 141
    assert err == ""


def test_os_errors_are_one_line_naming_the_file() -> None:
    from aida_kb.cli.main import describe_os_error

    assert describe_os_error(FileExistsError(17, "File exists", "out")) == (
        "out: File exists (a file is in the way of a directory to create)"
    )
    assert describe_os_error(PermissionError(13, "Permission denied", "a", None, "b")) == (
        "a -> b: Permission denied"
    )
    assert describe_os_error(OSError("disk on fire")) == "disk on fire"


def test_an_os_error_in_a_command_is_a_usage_error(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import aida_kb.cli.schema as schema

    def fail(args: object) -> int:
        raise NotADirectoryError(20, "Not a directory", "x/y.json")

    monkeypatch.setattr(schema, "run", fail)
    assert main(["schema"]) == 2
    err = capsys.readouterr().err
    assert (
        err
        == "aida-kb: error: x/y.json: Not a directory (a file is where a directory is expected)\n"
    )
