"""Shared by the knowledge-base commands: finding .kb files, compiling them, printing results.

Cheap to import: the compiler is imported inside `check`, rich inside the commands that use it.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aida_kb.errors import FormatError

if TYPE_CHECKING:
    from aida_kb.kb import CompileResult
    from aida_kb.kb.project import Project

EXIT_OK = 0
EXIT_ERRORS = 1
EXIT_USAGE = 2


def packaged_kb(name: str = "buildings.kb") -> Path:
    """A file of the shipped knowledge: the installed wheel's ``_data/kb``, else ``kb/``.

    Parameters
    ----------
    name : str
        Path relative to the ``kb`` directory, e.g. ``"buildings.kb"``.
    """
    from importlib import resources  # here: lint and validate never need it

    packaged = resources.files("aida_kb").joinpath("_data", "kb", name)
    if packaged.is_file():
        return Path(str(packaged))
    source = Path(__file__).resolve().parents[2] / "kb" / name
    if source.is_file():
        return source
    raise FormatError(f"the shipped knowledge base {name!r} is missing from this installation")


def display_path(path: Path) -> str:
    """`path` relative to the working directory when it lies below it, else as given."""
    try:
        return os.path.relpath(os.path.realpath(path)) if _below_cwd(path) else str(path)
    except ValueError:  # another drive (Windows)
        return str(path)


def _below_cwd(path: Path) -> bool:
    cwd = os.path.realpath(os.getcwd())
    return os.path.commonpath([cwd, os.path.realpath(path)]) == cwd


def collect_kb_files(
    paths: Sequence[str], command: str | None = None, *, force_exclude: bool = False
) -> tuple[list[Path], list[str]]:
    """Expand the command line's paths: files as given, directories recursively to ``*.kb``.

    Hidden directories (``.venv``, ``.git``) are skipped, and so is what the directory's
    project (``aida-kb.toml``, `aida_kb.kb.project`) excludes for `command` (``lint``,
    ``validate``, ``fmt``; None: nothing) — unless the named directory is itself excluded.
    With `force_exclude`, a named file the project excludes is left out too (pre-commit
    hooks name every changed file).
    Returns the files (no duplicates, in command-line order, each directory's files sorted)
    and one message per path that does not exist or holds no ``.kb`` file. `FormatError` for
    a project file that cannot be read.
    """
    from aida_kb.kb.project import find_project

    files: list[Path] = []
    problems: list[str] = []
    seen: set[str] = set()

    def add(p: Path) -> None:
        key = os.path.realpath(p)  # never raises, not even on a symlink loop
        if key not in seen:
            seen.add(key)
            files.append(p)

    for raw in paths:
        p = Path(raw)
        if p.is_dir():
            found: list[Path] = []
            project = find_project(p) if command else None
            if project is not None and project.excluded(p, command or ""):
                project = None  # the named folder is excluded: naming it asks for it

            def keep(q: Path, project: Project | None = project) -> bool:
                return project is None or not project.excluded(q, command or "")

            for root, dirs, names in os.walk(p):
                dirs[:] = sorted(d for d in dirs if not d.startswith(".") and keep(Path(root) / d))
                found.extend(
                    Path(root) / n for n in names if n.endswith(".kb") and keep(Path(root) / n)
                )
            if not found:
                problems.append(f"{raw}: no .kb files in this directory")
            for f in sorted(found):
                add(f)
        elif p.exists():
            if not (force_exclude and command and find_project(p).excluded(p, command)):
                add(p)
        else:
            problems.append(f"{raw}: no such file or directory")
    return files, problems


def read_source(path: Path) -> str:
    """The text of a .kb file; `FormatError` naming the file when it cannot be read as UTF-8."""
    from aida_kb.limits import MAX_KB_BYTES, read_text_limited

    try:
        return read_text_limited(path, MAX_KB_BYTES)
    except UnicodeDecodeError as exc:
        raise FormatError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise FormatError(f"{path}: cannot read: {exc.strerror or exc}") from None


def add_force_exclude_option(parser: Any) -> None:
    """``--force-exclude``: the project's exclusions apply to files named on the command line."""
    parser.add_argument(
        "--force-exclude",
        action="store_true",
        help="leave out a named file that the project file (aida-kb.toml) excludes, as a "
        "folder walk would (for pre-commit hooks, which name every changed file)",
    )


def add_import_path_option(parser: Any) -> None:
    """``--import-path DIR`` (repeatable): a folder imports may also resolve into."""
    parser.add_argument(
        "--import-path",
        action="append",
        default=[],
        metavar="DIR",
        help="also resolve imports in DIR, and allow them there (default: only the root "
        "file's folder; docs/language.md §2.2)",
    )


def check(path: Path, import_paths: Sequence[str] = (), *, library: bool = False) -> CompileResult:
    """Read and compile one .kb file (its imports included); `FormatError` if it is unreadable.

    The root file is read here first, so that an unreadable file named on the command line is
    a usage error (exit status 2); an unreadable *import* is a diagnostic of the result.
    ``library`` accepts a file without layers (docs/language.md §2.3).
    """
    from aida_kb.kb import compile_path

    name = display_path(path)
    read_source(path)
    return compile_path(name, search_paths=import_paths, library=library)


def use_color(stream: Any, choice: str = "auto") -> bool:
    """Colour on a terminal (``auto``) unless NO_COLOR is set; ``always``/``never`` force it."""
    if choice == "always":
        return True
    if choice == "never" or os.environ.get("NO_COLOR"):
        return False
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def print_error(message: str) -> None:
    """One error line on stderr, prefixed like every aida-kb error."""
    print(f"aida-kb: error: {message}", file=sys.stderr)


def compile_or_report(path: Path, import_paths: Sequence[str] = ()) -> Any:
    """Compile `path`; print its diagnostics to stderr; the KnowledgeBase, or None on errors."""
    from aida_kb.diagnostics.core import Diagnostic
    from aida_kb.diagnostics.render import render_summary, render_text

    result = check(path, import_paths)
    if result.diagnostics:
        diags = sorted(result.diagnostics, key=Diagnostic.sort_key)
        color = use_color(sys.stderr)
        print(render_text(diags, result.sources, color=color) + "\n", file=sys.stderr)
        print(render_summary(diags, 1, color=color), file=sys.stderr)
    if not result.ok:
        return None
    return result.kb


def check_output_file(output: str | None, inputs: Iterable[str | os.PathLike[str]]) -> None:
    """Refuse (FormatError) an ``-o`` file that is one of `inputs`; stdout (None, ``-``) passes."""
    if output is None or output == "-":
        return
    from aida_kb.io.atomic import check_outputs

    check_outputs([output], inputs)


def write_output(
    output: str | None, text: str, inputs: Iterable[str | os.PathLike[str]] = ()
) -> None:
    """`text` to stdout (`output` None or ``-``) or to the file `output`, written atomically.

    `inputs` are the files the command read (the .kb file and its imports): writing over one
    of them is refused.
    """
    if output is None or output == "-":
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    from aida_kb.io.atomic import write_text_atomic

    check_output_file(output, inputs)
    write_text_atomic(output, text)
