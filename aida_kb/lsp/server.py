"""The language server: pygls wiring of the features over the documents the editor has open.

Every open document is compiled on open and on each change (full or incremental sync) and
its diagnostics are published with the document's version. Requests are answered from the
last analysis of their document; references and rename also search the other open documents
that compile the same declarations (a file and the files importing it).

Initialisation options: ``{"importPaths": ["DIR", ...]}``, the directories the compiler's
``--import-path`` names (relative ones from the workspace root).
"""

from __future__ import annotations

import os
from typing import Any

from lsprotocol import types
from pygls.exceptions import JsonRpcInvalidParams
from pygls.lsp.server import LanguageServer

from aida_kb import __version__
from aida_kb.limits import MAX_KB_BYTES, read_text_limited
from aida_kb.lsp import features
from aida_kb.lsp.analysis import Analysis
from aida_kb.lsp.complete import completions
from aida_kb.lsp.convert import path_of_uri
from aida_kb.lsp.diagnose import publishable
from aida_kb.lsp.signature import signature_help
from aida_kb.lsp.workspace import WorkspaceFiles

__all__ = ["KbServer", "make_server"]

#: Characters after which an editor asks for completion unprompted.
TRIGGER_CHARACTERS = [".", ":", " "]


class KbServer(LanguageServer):
    """The aida-kb language server: open documents and their analyses."""

    def __init__(self) -> None:
        super().__init__("aida-kb", __version__)
        self.analyses: dict[str, Analysis] = {}
        self.search_paths: list[str] = []
        self.files = WorkspaceFiles()

    def analyse(self, uri: str) -> Analysis:
        """Compile the document ``uri`` as the editor has it; publish its diagnostics."""
        doc = self.workspace.get_text_document(uri)
        a = Analysis(uri, doc.source, self.search_paths)
        self.analyses[uri] = a
        shown = publishable(a, self.context(a))
        self.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=uri, diagnostics=shown, version=doc.version)
        )
        return a

    def context(self, a: Analysis) -> list[Analysis]:
        """For a library as it is on disk: the open documents and workspace files that declare
        layers and import it (they read it from disk); none while it differs from the disk."""
        if not a.library or not _same_as_disk(a):
            return []
        return [b for b in self.others(a.uri) if not b.library and a.path in b.sources]

    def analysis(self, uri: str) -> Analysis:
        """The last analysis of ``uri`` (compiled now if there is none)."""
        found = self.analyses.get(uri)
        return found if found is not None else self.analyse(uri)

    def others(self, uri: str) -> list[Analysis]:
        """The analyses of the open documents other than ``uri``, then of the workspace's
        .kb files that are not open."""
        folders = [path_of_uri(f.uri) for f in self.workspace.folders.values()]
        if not folders and self.workspace.root_uri:
            folders = [path_of_uri(self.workspace.root_uri)]
        opened = [a for u, a in self.analyses.items() if u != uri]
        closed = self.files.analyses(folders, {uri, *self.analyses}, self.search_paths)
        return opened + closed


def _same_as_disk(a: Analysis) -> bool:
    try:
        return read_text_limited(a.path, MAX_KB_BYTES) == a.text
    except (OSError, UnicodeDecodeError):
        return False


def make_server() -> KbServer:
    """A server with every feature registered (not yet started)."""
    server = KbServer()

    @server.feature(types.INITIALIZE)
    def initialize(ls: KbServer, params: types.InitializeParams) -> None:
        options: Any = params.initialization_options
        paths = options.get("importPaths", []) if isinstance(options, dict) else []
        if not isinstance(paths, list):
            return
        root = path_of_uri(params.root_uri) if params.root_uri else os.getcwd()
        # a relative folder is relative to the workspace, as the editor's settings write it
        ls.search_paths = [os.path.normpath(os.path.join(root, str(p))) for p in paths]

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: KbServer, params: types.DidOpenTextDocumentParams) -> None:
        ls.analyse(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: KbServer, params: types.DidChangeTextDocumentParams) -> None:
        ls.analyse(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: KbServer, params: types.DidSaveTextDocumentParams) -> None:
        saved = params.text_document.uri
        ls.analyse(saved)
        for uri in list(ls.analyses):  # what imports it, and the libraries it is context of
            if uri != saved:
                ls.analyse(uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: KbServer, params: types.DidCloseTextDocumentParams) -> None:
        uri = params.text_document.uri
        ls.analyses.pop(uri, None)
        ls.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(uri=uri, diagnostics=[])
        )

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    def hover(ls: KbServer, params: types.HoverParams) -> types.Hover | None:
        uri = params.text_document.uri
        return features.hover(ls.analysis(uri), uri, params.position)

    @server.feature(types.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: KbServer, params: types.DefinitionParams) -> list[types.Location]:
        uri = params.text_document.uri
        return features.definition(ls.analysis(uri), uri, params.position)

    @server.feature(types.TEXT_DOCUMENT_REFERENCES)
    def references(ls: KbServer, params: types.ReferenceParams) -> list[types.Location]:
        uri = params.text_document.uri
        return features.references(
            ls.analysis(uri),
            ls.others(uri),
            uri,
            params.position,
            params.context.include_declaration,
        )

    @server.feature(
        types.TEXT_DOCUMENT_COMPLETION,
        types.CompletionOptions(trigger_characters=TRIGGER_CHARACTERS),
    )
    def completion(ls: KbServer, params: types.CompletionParams) -> types.CompletionList:
        uri = params.text_document.uri
        text = ls.workspace.get_text_document(uri).source
        items = completions(ls.analysis(uri), text, params.position)
        return types.CompletionList(is_incomplete=False, items=items)

    @server.feature(
        types.TEXT_DOCUMENT_SIGNATURE_HELP,
        types.SignatureHelpOptions(trigger_characters=["(", ","]),
    )
    def signature(ls: KbServer, params: types.SignatureHelpParams) -> types.SignatureHelp | None:
        uri = params.text_document.uri
        text = ls.workspace.get_text_document(uri).source
        return signature_help(ls.analysis(uri), text, params.position)

    @server.feature(types.TEXT_DOCUMENT_PREPARE_RENAME)
    def prepare_rename(
        ls: KbServer, params: types.PrepareRenameParams
    ) -> types.PrepareRenamePlaceholder | None:
        uri = params.text_document.uri
        return features.prepare_rename(ls.analysis(uri), uri, params.position)

    @server.feature(types.TEXT_DOCUMENT_RENAME, types.RenameOptions(prepare_provider=True))
    def rename(ls: KbServer, params: types.RenameParams) -> types.WorkspaceEdit | None:
        uri = params.text_document.uri
        try:
            return features.rename(
                ls.analysis(uri), ls.others(uri), uri, params.position, params.new_name
            )
        except features.RenameError as exc:
            raise JsonRpcInvalidParams(str(exc)) from None

    @server.feature(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def document_symbol(
        ls: KbServer, params: types.DocumentSymbolParams
    ) -> list[types.DocumentSymbol]:
        return features.document_symbols(ls.analysis(params.text_document.uri))

    @server.feature(types.WORKSPACE_SYMBOL)
    def workspace_symbol(
        ls: KbServer, params: types.WorkspaceSymbolParams
    ) -> list[types.WorkspaceSymbol]:
        return features.workspace_symbols(ls.others(""), params.query)  # every analysis

    @server.feature(
        types.TEXT_DOCUMENT_CODE_ACTION,
        types.CodeActionOptions(code_action_kinds=[types.CodeActionKind.QuickFix]),
    )
    def code_action(ls: KbServer, params: types.CodeActionParams) -> list[types.CodeAction]:
        uri = params.text_document.uri
        return features.code_actions(
            ls.analysis(uri), uri, params.range, params.context.diagnostics
        )

    return server


def serve() -> None:
    """Run the server on standard input and output until the client ends it."""
    make_server().start_io()
