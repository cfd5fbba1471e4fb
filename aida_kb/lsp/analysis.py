"""One open document, compiled: the compiler's diagnostics and the index of its names.

The diagnostics are exactly those of ``aida-kb lint`` (`aida_kb.kb.compile_text`, the open
text as the root file, its imports read from disk; a file that declares no layers is a
library, docs/language.md §2.3, which the server shows in the context of a file importing it
when there is one, as lint does). The index comes from the same front end:
the loader's parse (`aida_kb.kb.loader.load_text`) and the resolution pass
(`aida_kb.kb.resolve.resolve`), whose table the compiler drops once a file has errors but
an editor needs while the file is being written. Compiling `kb/buildings.kb` takes about
15 ms, so every change is compiled at once.
"""

from __future__ import annotations

from collections.abc import Sequence

from aida_kb.diagnostics.core import Diagnostic
from aida_kb.dsl import ast
from aida_kb.kb.compiler import CompileResult, compile_text
from aida_kb.kb.loader import load_text
from aida_kb.kb.resolve import Table, resolve
from aida_kb.lsp.convert import Lines, path_of_uri, uri_of_path
from aida_kb.lsp.index import Index, build_index

__all__ = ["Analysis"]


class Analysis:
    """A compiled document.

    Attributes
    ----------
    uri, path : str
        The document's URI and the file name its spans carry.
    result : CompileResult
        The compiler's result (diagnostics sorted by place).
    modules : list of ast.Module
        The document's module first, then those it imports.
    table : Table
        The resolved symbol table (also when there are errors).
    index : Index
        Every name and what it refers to.
    sources : dict
        File name -> text, the document's own from the editor.
    """

    def __init__(self, uri: str, text: str, search_paths: Sequence[str] = ()) -> None:
        self.uri = uri
        self.path = path_of_uri(uri)
        self.search_paths = tuple(search_paths)
        self.text = text
        self.result: CompileResult = compile_text(
            text, self.path, search_paths=search_paths, library=True
        )
        loaded = load_text(text, self.path, tuple(search_paths))
        self.modules: list[ast.Module] = loaded.modules
        self.sources: dict[str, str] = dict(loaded.sources)
        self.sources[self.path] = text
        try:
            self.table, _ = resolve(
                loaded.modules, loaded.broken, library=True, incomplete=loaded.incomplete
            )
            self.index = build_index(loaded.modules, self.table)
        except Exception:  # a bug in resolution: the compiler's KB999 says so; no index
            self.table, self.index = Table(), Index()
        self._lines: dict[str, Lines] = {}

    @property
    def module(self) -> ast.Module | None:
        """The document's own module (None if it could not be parsed at all)."""
        return self.modules[0] if self.modules else None

    @property
    def diagnostics(self) -> tuple[Diagnostic, ...]:
        """The compiler's diagnostics, every file."""
        return self.result.diagnostics

    @property
    def library(self) -> bool:
        """True when neither the document nor what it imports declares layers."""
        return self.result.library

    def lines(self, file: str) -> Lines:
        """The lines of ``file`` (one of the compiled files), for converting positions."""
        found = self._lines.get(file)
        if found is None:
            found = Lines(self.sources.get(file, ""))
            self._lines[file] = found
        return found

    def uri_of(self, file: str) -> str:
        """The URI of a compiled file: the document's own URI for its own spans."""
        return self.uri if file == self.path else uri_of_path(file)

    def file_of(self, uri: str) -> str | None:
        """The file name the spans carry for ``uri``, if the file is one of the compiled ones."""
        if uri == self.uri:
            return self.path
        wanted = path_of_uri(uri)
        return wanted if wanted in self.sources else None
