"""Phase 1, loading: read the root file, parse it, follow its imports transitively.

An import names a file relative to the importing file; when it is not there, each of the
``search_paths`` is tried in turn. A file imported twice (a diamond) is loaded once; a file that
imports itself through a chain of imports is an import cycle (``KB902``); a missing file is
``KB901``; a file that cannot be read as UTF-8 is ``KB900``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast, parse
from aida_kb.dsl.build import BOM
from aida_kb.kb.resolve import chain_text
from aida_kb.limits import MAX_KB_BYTES, read_text_limited

__all__ = ["Loaded", "load_path", "load_text"]


class Loaded:
    """Every module of a knowledge base, in load order (root first), and what loading found."""

    __slots__ = ("broken", "diagnostics", "imported_from", "incomplete", "modules", "sources")

    def __init__(
        self,
        modules: list[ast.Module] | None = None,
        sources: dict[str, str] | None = None,
        diagnostics: list[Diagnostic] | None = None,
        broken: set[str] | None = None,
    ) -> None:
        self.modules: list[ast.Module] = list() if modules is None else modules
        self.sources: dict[str, str] = dict() if sources is None else sources
        self.diagnostics: list[Diagnostic] = list() if diagnostics is None else diagnostics
        self.broken: set[str] = set() if broken is None else broken
        #: each imported file -> (the file that first imported it, the span of its import)
        self.imported_from: dict[str, tuple[str, Span]] = {}
        #: concepts kept without a member that did not parse
        self.incomplete: set[str] = set()


def _diag(code: codes.Code, message: str, span: Span, hint: str | None = None) -> Diagnostic:
    return Diagnostic(code.code, code.severity, message, span, hint)


def _read(path: str) -> str | Exception:
    try:
        return read_text_limited(path, MAX_KB_BYTES)
    except (OSError, UnicodeDecodeError) as exc:
        return exc


def _reason(exc: Exception) -> str:
    if isinstance(exc, UnicodeDecodeError):
        return f"not UTF-8 text ({exc.reason} at byte {exc.start})"
    if isinstance(exc, OSError):
        return exc.strerror or str(exc)
    return str(exc)


class _Loader:
    def __init__(self, search_paths: Sequence[str]) -> None:
        self.search_paths = [str(p) for p in search_paths]
        self.out = Loaded()
        self.done: set[str] = set()
        #: the project: folders an import may resolve into (symlinks followed); the root
        #: file's folder is added by `load_text`
        self.roots = [os.path.realpath(p) for p in self.search_paths]

    def inside(self, target: str) -> bool:
        """True when `target` is a ``.kb`` file whose real path lies inside the project."""
        real = os.path.realpath(target)
        return real.endswith(".kb") and any(
            os.path.commonpath([real, root]) == root for root in self.roots
        )

    def inside_folder(self, folder: str) -> bool:
        """True when the real path of `folder` lies inside the project."""
        real = os.path.realpath(folder)
        return any(os.path.commonpath([real, root]) == root for root in self.roots)

    def key(self, name: str) -> str:
        return os.path.realpath(name)

    def add(self, name: str, text: str, stack: list[tuple[str, str]]) -> None:
        """Parse ``text`` (the file ``name``) and load its imports; ``stack`` is the chain."""
        self.done.add(self.key(name))
        if text.startswith(BOM):  # the parser drops it: so do the shown lines
            text = text[1:]
        self.out.sources[name] = text
        result = parse(text, name)
        self.out.modules.append(result.module)
        self.out.diagnostics.extend(result.diagnostics)
        self.out.broken |= result.broken
        self.out.incomplete |= result.incomplete
        chain = [*stack, (self.key(name), name)]
        for imp in result.module.imports:
            self.follow(name, imp, chain)

    def candidates(self, importer: str, rel: str) -> list[str]:
        """Where the import `rel` of `importer` may resolve: beside it, then each search path."""
        if os.path.isabs(rel):
            return [rel]
        base = os.path.dirname(importer)
        found = [os.path.normpath(os.path.join(base, rel))]
        return found + [os.path.normpath(os.path.join(p, rel)) for p in self.search_paths]

    def locate(self, importer: str, rel: str) -> str | None:
        return next((c for c in self.candidates(importer, rel) if os.path.isfile(c)), None)

    def locate_folder(self, importer: str, rel: str) -> str | None:
        """The folder `rel` names, when an import names a folder instead of a file."""
        return next((c for c in self.candidates(importer, rel) if os.path.isdir(c)), None)

    def follow(self, importer: str, imp: ast.Import, chain: list[tuple[str, str]]) -> None:
        rel = imp.path.value
        span = imp.path.span
        target = self.locate(importer, rel)
        if target is None and rel.strip():
            folder = self.locate_folder(importer, rel)
            if folder is not None and self.inside_folder(folder):
                self.out.diagnostics.append(
                    _diag(
                        codes.MISSING_IMPORT,
                        f"imported '{rel}' is a folder, not a .kb file",
                        span,
                        "import each file of the folder by name, as in "
                        f'import "{rel.rstrip("/")}/walls.kb"',
                    )
                )
                return
        if target is None:
            where = ", ".join([os.path.dirname(importer) or ".", *self.search_paths])
            self.out.diagnostics.append(
                _diag(
                    codes.MISSING_IMPORT,
                    f"imported file '{rel}' does not exist",
                    span,
                    f"looked in: {where}",
                )
            )
            return
        if not self.inside(target):
            # never read (nor echo a line of) a file outside the project: /etc/passwd,
            # /proc/self/environ, ../../secret.kb, a symlink out of the folder
            self.out.diagnostics.append(
                _diag(
                    codes.IMPORT_OUTSIDE,
                    f"import '{rel}' is outside the project or not a .kb file",
                    span,
                    "imports resolve to .kb files inside the root file's folder; widen the "
                    "project with --import-path DIR",
                )
            )
            return
        key = self.key(target)
        keys = [k for k, _ in chain]
        if key in keys:
            names = [n for _, n in chain[keys.index(key) :]]
            cycle = chain_text(names, " imports ")
            self.out.diagnostics.append(
                _diag(
                    codes.IMPORT_CYCLE,
                    f"import cycle: {cycle}",
                    span,
                    "break the cycle: move what both files need into a third file",
                )
            )
            return
        if key in self.done:
            return
        text = _read(target)
        if isinstance(text, Exception):
            self.out.diagnostics.append(
                _diag(codes.UNREADABLE_FILE, f"cannot read '{target}': {_reason(text)}", span)
            )
            return
        self.out.imported_from[target] = (importer, span)
        self.add(target, text, chain)


def load_text(text: str, file: str, search_paths: Sequence[str] = ()) -> Loaded:
    """Parse ``text`` as the root file ``file`` and load what it imports."""
    loader = _Loader(search_paths)
    loader.roots.append(os.path.realpath(os.path.dirname(file) or "."))
    loader.add(file, text, [])
    return loader.out


def load_path(path: str, search_paths: Sequence[str] = ()) -> Loaded:
    """Read and parse the root file ``path`` and load what it imports (``KB900`` if unreadable)."""
    text = _read(path)
    if isinstance(text, Exception):
        out = Loaded()
        out.diagnostics.append(
            _diag(
                codes.UNREADABLE_FILE,
                f"cannot read '{path}': {_reason(text)}",
                Span.point(path, 1, 1),
            )
        )
        return out
    return load_text(text, path, search_paths)
