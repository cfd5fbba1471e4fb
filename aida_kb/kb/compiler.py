"""The compiler's driver: load -> resolve -> check -> build, never raising on bad input."""

from __future__ import annotations

import gc
import os
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from typing import TYPE_CHECKING

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
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

    __slots__ = ("_built", "_files", "_kb", "_table", "diagnostics", "sources")

    def __init__(
        self,
        diagnostics: Iterable[Diagnostic],
        sources: Mapping[str, str],
        table: Table | None = None,
        files: tuple[str, ...] = (),
    ) -> None:
        self.diagnostics: tuple[Diagnostic, ...] = tuple(
            sorted(dict.fromkeys(diagnostics), key=Diagnostic.sort_key)
        )
        self.sources: dict[str, str] = dict(sources)
        self._table = table if not any(d.is_error for d in self.diagnostics) else None
        self._files = files
        self._kb: KnowledgeBase | None = None
        self._built = False

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


def _compile(loaded: Loaded) -> CompileResult:
    from aida_kb.kb.check import run_checks
    from aida_kb.kb.expectation import check_expectations
    from aida_kb.kb.resolve import resolve

    diags = list(loaded.diagnostics)
    try:
        table, found = resolve(loaded.modules, loaded.broken)
        diags.extend(found)
        diags.extend(run_checks(table))
        diags.extend(check_expectations(table, loaded.sources))  # issue 20: fixtures
    except Exception as exc:  # the safety net: compiling must never raise
        diags.append(_internal(exc, loaded.modules[0].file if loaded.modules else "<string>"))
        return CompileResult(diags, loaded.sources)
    files = tuple(m.file for m in loaded.modules)
    return CompileResult(diags, loaded.sources, table, files)


def compile_text(
    text: str, file: str = "<string>", *, search_paths: Iterable[str] = ()
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

    Returns
    -------
    CompileResult
        Never raises on bad input: every problem is a diagnostic.
    """
    with _no_cyclic_gc():
        return _compile(load_text(text, file, tuple(search_paths)))


def compile_path(
    path: str | os.PathLike[str], *, search_paths: Iterable[str] = ()
) -> CompileResult:
    """Read and compile the knowledge base whose root file is ``path`` (imports followed).

    Parameters
    ----------
    path : str or path-like
        The root ``.kb`` file; an unreadable file is the diagnostic ``KB900``.
    search_paths : iterable of str
        Further directories where imported files are looked for.

    Returns
    -------
    CompileResult
        Never raises on bad input: every problem is a diagnostic.
    """
    with _no_cyclic_gc():
        return _compile(load_path(os.fspath(path), tuple(search_paths)))
