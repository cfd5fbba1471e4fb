"""Entry point of the ``aida-kb`` (alias ``kb``) command.

Exit codes: 0 success, 1 errors found in the input (or a failed run), 2 usage error or an
unreadable input file, 130 interrupted, 141 the output pipe was closed by its reader.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from aida_kb import __version__
from aida_kb.errors import AidaError, FormatError

# Command modules, in the order `--help` lists them. Each module is aida_kb.cli.<name>
# and must import nothing heavy at module level.
COMMANDS: tuple[str, ...] = (
    "lint",
    "validate",
    "fmt",
    "lsp",
    "explain",
    "graph",
    "compile",
    "schema",
    "demo",
    "synth",
    "scene",
    "calibrate",
    "disparity",
    "evidence",
    "interpret",
    "reconstruct",
    "batch",
    "register",
    "evaluate",
    "test",
    "export",
)

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as a shell reports a writer killed by a closed pipe


def _command_modules() -> list[ModuleType]:
    return [importlib.import_module(f"aida_kb.cli.{name}") for name in COMMANDS]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered command."""
    parser = argparse.ArgumentParser(
        prog="aida-kb",
        description=(
            "aida-kb turns explicit knowledge about buildings (.kb files) and calibrated "
            "stereo images into closed 3-D models."
        ),
        epilog="Run 'aida-kb COMMAND --help' for a command's options and an example.",
    )
    parser.add_argument("--version", action="version", version=f"aida-kb {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in _command_modules():
        module.register(subparsers)
    return parser


def describe_os_error(exc: OSError) -> str:
    """One line for an operating-system error: the file first, then what went wrong."""
    if exc.filename is None:
        return str(exc)
    what = exc.strerror or type(exc).__name__
    if isinstance(exc, FileExistsError):
        what += " (a file is in the way of a directory to create)"
    elif isinstance(exc, NotADirectoryError):
        what += " (a file is where a directory is expected)"
    target = f" -> {exc.filename2}" if exc.filename2 is not None else ""
    return f"{exc.filename}{target}: {what}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    run = getattr(args, "run", None)
    if run is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        code: int = run(args)
    except KeyboardInterrupt:
        print("aida-kb: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except FormatError as exc:
        print(f"aida-kb: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except AidaError as exc:
        print(f"aida-kb: error: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    except BrokenPipeError:  # `aida-kb compile kb.kb | head`: the reader left; end quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as exc:
        print(f"aida-kb: error: {describe_os_error(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # a bug in aida-kb: still no traceback unless asked for
        if os.environ.get("AIDA_KB_DEBUG"):
            raise
        print(
            f"aida-kb: internal error: {type(exc).__name__}: {exc}\n"
            "This is a bug in aida-kb; run again with AIDA_KB_DEBUG=1 for the traceback.",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    return code


if __name__ == "__main__":
    sys.exit(main())
