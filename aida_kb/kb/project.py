"""A project of .kb files: the folder of an ``aida-kb.toml`` and what it leaves out.

docs/language.md §2.3 is the reference. A project file looks like this::

    # kb/aida-kb.toml
    [project]
    exclude = []                              # left out by every command walking the folder
    [lint]
    exclude = ["examples"]                    # left out by lint and validate
    [fmt]
    exclude = ["examples/broken_syntax.kb"]   # left out by fmt

An entry is a path relative to the project folder, or a glob (``*`` and ``?``) matched against
such a path; a folder leaves out everything below it. Exclusions apply to the files found by
walking a folder given on the command line, never to a file named there, nor below a folder
that was named although it is excluded (naming it asks for it).

Cheap to import (``tomllib`` and ``fnmatch`` only): `lint` and `validate` use it.
"""

from __future__ import annotations

import fnmatch
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from aida_kb.errors import FormatError

__all__ = ["PROJECT_FILE", "Project", "find_project"]

#: The name of the project file.
PROJECT_FILE = "aida-kb.toml"
#: The commands whose own table may exclude more (``[lint]`` also serves ``validate``).
_TABLES = ("project", "lint", "fmt")
_COMMAND_TABLE = {"lint": "lint", "validate": "lint", "fmt": "fmt"}


@dataclass(frozen=True)
class Project:
    """A project: its folder, and the exclusions per table (``project``, ``lint``, ``fmt``)."""

    folder: Path
    file: Path | None
    exclude: dict[str, tuple[str, ...]]

    def patterns(self, command: str) -> tuple[str, ...]:
        """The exclusions that apply to `command` (``lint``, ``validate``, ``fmt``)."""
        table = _COMMAND_TABLE.get(command)
        extra = self.exclude.get(table, ()) if table else ()
        return (*self.exclude.get("project", ()), *extra)

    def relative(self, path: Path) -> str | None:
        """`path` relative to the project folder (``/``-separated); None when outside it."""
        real, folder = os.path.realpath(path), os.path.realpath(self.folder)
        if os.path.commonpath([real, folder]) != folder:
            return None
        return Path(os.path.relpath(real, folder)).as_posix()

    def excluded(self, path: Path, command: str) -> bool:
        """True when `path` or a folder above it (inside the project) is excluded."""
        rel = self.relative(path)
        if rel is None or rel == ".":
            return False
        parts = rel.split("/")
        prefixes = ["/".join(parts[: i + 1]) for i in range(len(parts))]
        return any(
            fnmatch.fnmatchcase(prefix, pattern.strip("/"))
            for pattern in self.patterns(command)
            for prefix in prefixes
        )


def _read(file: Path) -> Project:
    try:
        data = tomllib.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"{file}: cannot read the project file: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise FormatError(f"{file}: not a valid project file: {exc}") from None
    exclude: dict[str, tuple[str, ...]] = {}
    for key, table in data.items():
        if key not in _TABLES or not isinstance(table, dict):
            raise FormatError(
                f"{file}: unknown table [{key}] (the tables are {', '.join(_TABLES)})"
            )
        for option, value in table.items():
            if option != "exclude":
                raise FormatError(f"{file}: unknown option {option!r} in [{key}]")
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise FormatError(f"{file}: [{key}] exclude must be a list of paths")
            exclude[key] = tuple(value)
    return Project(file.parent, file, exclude)


def find_project(path: Path) -> Project:
    """The project `path` (a file or folder) belongs to: the nearest folder at or above it
    that holds ``aida-kb.toml``; without one, a project without exclusions in `path` (its
    folder, for a file). `FormatError` for a project file that cannot be read or is wrong."""
    start = Path(os.path.realpath(path))
    if not start.is_dir():
        start = start.parent
    for folder in (start, *start.parents):
        candidate = folder / PROJECT_FILE
        if candidate.is_file():
            return _read(candidate)
    return Project(start, None, {})
