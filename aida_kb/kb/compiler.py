"""The compiler's driver: load -> resolve -> check -> build, never raising on bad input."""

from __future__ import annotations

import gc
import os
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import replace
from typing import TYPE_CHECKING

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast
from aida_kb.kb.loader import Loaded, load_path, load_text

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase
    from aida_kb.kb.resolve import Table

__all__ = ["CompileResult", "compile_path", "compile_text"]


class CompileResult:
    """What compiling a knowledge base gave.

    Attributes
    ----------
    diagnostics : tuple of Diagnostic
        Every error and warning, sorted by file, line, column and code.
    sources : dict
        File name (as in the spans) -> its text, for rendering carets.
    kb : KnowledgeBase or None
        The compiled model; None when there are errors. Built on first access, so that
        linting (diagnostics only) does not pay for the pydantic models.
    """

    __slots__ = (
        "_built",
        "_files",
        "_kb",
        "_table",
        "diagnostics",
        "files",
        "imported_from",
        "library",
        "sources",
    )

    def __init__(
        self,
        diagnostics: Iterable[Diagnostic],
        sources: Mapping[str, str],
        table: Table | None = None,
        files: tuple[str, ...] = (),
        *,
        loaded: tuple[str, ...] = (),
        imported_from: Mapping[str, tuple[str, Span]] | None = None,
        library: bool = False,
    ) -> None:
        self.diagnostics: tuple[Diagnostic, ...] = tuple(
            sorted(dict.fromkeys(diagnostics), key=Diagnostic.sort_key)
        )
        self.sources: dict[str, str] = dict(sources)
        self._table = table if not any(d.is_error for d in self.diagnostics) else None
        self._files = files
        self._kb: KnowledgeBase | None = None
        self._built = False
        #: every file loaded (root first), also when the knowledge base has errors
        self.files: tuple[str, ...] = loaded or files
        #: each imported file -> (the file that first imported it, the span of its import)
        self.imported_from: dict[str, tuple[str, Span]] = dict(imported_from or {})
        #: True when no loaded file declares layers (a library, docs/language.md §2.3)
        self.library = library

    @property
    def ok(self) -> bool:
        """True when no diagnostic is an error."""
        return not any(d.is_error for d in self.diagnostics)

    @property
    def errors(self) -> tuple[Diagnostic, ...]:
        """The diagnostics of severity error."""
        return tuple(d for d in self.diagnostics if d.is_error)

    @property
    def kb(self) -> KnowledgeBase | None:
        """The compiled knowledge base, or None when there are errors."""
        if not self._built:
            self._built = True
            if self._table is not None:
                from aida_kb.kb.build import build

                try:
                    with _no_cyclic_gc():
                        self._kb = build(self._table, self._files)
                except Exception as exc:  # a bug: report it as a diagnostic, never raise
                    file = self._files[0] if self._files else "<string>"
                    self.diagnostics = (*self.diagnostics, _internal(exc, file))
                self._table = None
        return self._kb

    def __repr__(self) -> str:
        return f"CompileResult(ok={self.ok}, diagnostics={len(self.diagnostics)})"


@contextmanager
def _no_cyclic_gc() -> Iterator[None]:
    """Compile with Python's cyclic garbage collector off: the compiler makes trees and tables
    without reference cycles, and the collector would only rescan them, again and again."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()


def _internal(exc: Exception, file: str) -> Diagnostic:
    return Diagnostic(
        codes.INTERNAL_COMPILER_ERROR.code,
        codes.INTERNAL_COMPILER_ERROR.severity,
        f"internal compiler error: {type(exc).__name__}: {exc}",
        Span.point(file, 1, 1),
        "please report this with the file that caused it",
    )


#: An "imported from" note chain longer than this is cut (its first and last links kept).
MAX_IMPORT_CHAIN = 8


def import_chain(
    file: str, imported_from: Mapping[str, tuple[str, Span]]
) -> tuple[tuple[Span, str], ...]:
    """The "imported from FILE:LINE" notes that lead from the root file to `file`, innermost
    first (empty for the root file itself)."""
    notes: list[tuple[Span, str]] = []
    seen = {file}
    while file in imported_from:
        importer, span = imported_from[file]
        notes.append((span, f"{file} imported from {importer}:{span.line}"))
        if importer in seen:  # never: each file is loaded once, from its first importer
            break
        seen.add(importer)
        file = importer
    if len(notes) > MAX_IMPORT_CHAIN:
        keep = MAX_IMPORT_CHAIN // 2
        cut = len(notes) - 2 * keep
        first_cut = notes[keep][0]
        notes = [*notes[:keep], (first_cut, f"... {cut} more imports ..."), *notes[-keep:]]
    return tuple(notes)


def _with_import_notes(
    diags: list[Diagnostic], imported_from: Mapping[str, tuple[str, Span]]
) -> list[Diagnostic]:
    """Each diagnostic inside an imported file, with the chain of imports that led there."""
    if not imported_from:
        return diags
    chains: dict[str, tuple[tuple[Span, str], ...]] = {}
    out = []
    for d in diags:
        file = d.span.file
        if file not in imported_from:
            out.append(d)
            continue
        chain = chains.get(file)
        if chain is None:
            chain = chains[file] = import_chain(file, imported_from)
        out.append(replace(d, related=(*d.related, *chain)))
    return out


def _inside(inner: Span, outer: Span) -> bool:
    return (
        inner.file == outer.file
        and (outer.line, outer.column) <= (inner.line, inner.column)
        and (inner.end_line, inner.end_column) <= (outer.end_line, outer.end_column)
    )


def _without_follow_ons(diags: list[Diagnostic]) -> list[Diagnostic]:
    """Drop the semantic diagnostics about an expression cut short for its nesting (``KB011``
    lies inside their span): they describe the cut, not the file."""
    deep = [d.span for d in diags if d.code == codes.NESTED_TOO_DEEP.code]
    if not deep:
        return diags
    return [
        d
        for d in diags
        if d.code < "KB100" or d.code >= "KB900" or not any(_inside(s, d.span) for s in deep)
    ]


def _declares_layers(loaded: Loaded) -> bool:
    return any(isinstance(item, ast.Layers) for m in loaded.modules for item in m.items)


def _compile(loaded: Loaded, library: bool = False) -> CompileResult:
    from aida_kb.kb.check import run_checks
    from aida_kb.kb.expectation import check_expectations
    from aida_kb.kb.resolve import resolve

    is_library = library and not _declares_layers(loaded)
    files = tuple(m.file for m in loaded.modules)
    diags = list(loaded.diagnostics)
    table: Table | None = None
    try:
        table, found = resolve(
            loaded.modules, loaded.broken, library=is_library, incomplete=loaded.incomplete
        )
        diags.extend(found)
        diags.extend(run_checks(table))
        diags.extend(check_expectations(table, loaded.sources))  # issue 20: fixtures
    except Exception as exc:  # the safety net: compiling must never raise
        diags.append(_internal(exc, loaded.modules[0].file if loaded.modules else "<string>"))
        table = None
    return CompileResult(
        _with_import_notes(_without_follow_ons(diags), loaded.imported_from),
        loaded.sources,
        None if table is None or is_library else table,
        files,
        loaded=files,
        imported_from=loaded.imported_from,
        library=is_library,
    )


def compile_text(
    text: str,
    file: str = "<string>",
    *,
    search_paths: Iterable[str] = (),
    library: bool = False,
) -> CompileResult:
    """Compile a knowledge base given as text.

    Parameters
    ----------
    text : str
        The root file's source.
    file : str
        Its name, put into spans; imports are resolved relative to its directory.
    search_paths : iterable of str
        Further directories where imported files are looked for.
    library : bool
        Accept a library: a file that declares no layers (nor does anything it imports) is
        checked without ``KB112`` and gives no model (docs/language.md §2.3).

    Returns
    -------
    CompileResult
        Never raises on bad input: every problem is a diagnostic.
    """
    with _no_cyclic_gc():
        return _compile(load_text(text, file, tuple(search_paths)), library)


def compile_path(
    path: str | os.PathLike[str], *, search_paths: Iterable[str] = (), library: bool = False
) -> CompileResult:
    """Read and compile the knowledge base whose root file is ``path`` (imports followed).

    Parameters
    ----------
    path : str or path-like
        The root ``.kb`` file; an unreadable file is the diagnostic ``KB900``.
    search_paths : iterable of str
        Further directories where imported files are looked for.
    library : bool
        Accept a library file (see `compile_text`).

    Returns
    -------
    CompileResult
        Never raises on bad input: every problem is a diagnostic.
    """
    with _no_cyclic_gc():
        return _compile(load_path(os.fspath(path), tuple(search_paths)), library)
