"""A blocking language client: starts ``aida-kb lsp`` as a child process and talks the
protocol with it over its standard input and output, as an editor does.

``aida-kb lsp --check`` uses it to show what an editor would show; the tests use it to drive
the server through the protocol. The pygls client is asynchronous: its event loop runs in a
thread of its own and each call here waits for its answer (at most ``timeout`` seconds).
"""

from __future__ import annotations

import asyncio
import sys
import threading
from collections.abc import Awaitable, Callable, Sequence
from typing import Any, TypeVar

from lsprotocol import types
from pygls.lsp.client import LanguageClient

from aida_kb.errors import AidaError

__all__ = ["SERVER_COMMAND", "ServerClient"]

#: How the client starts the server: this Python, this package.
SERVER_COMMAND: tuple[str, ...] = (sys.executable, "-m", "aida_kb", "lsp")
#: Seconds to wait for one answer of the server. Compiling a knowledge base takes
#: milliseconds; only the server's start (imports) takes about a second.
TIMEOUT_S = 30.0

T = TypeVar("T")


class ServerClient:
    """A running server and a client connected to it; use as a context manager.

    Each request method takes the protocol's parameters and returns its result. Published
    diagnostics are kept per URI (`diagnostics` waits for those of a document version).
    """

    def __init__(
        self,
        command: Sequence[str] = SERVER_COMMAND,
        initialization_options: Any = None,
        timeout: float = TIMEOUT_S,
    ) -> None:
        self.timeout = timeout
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._thread.start()
        self._published: dict[str, types.PublishDiagnosticsParams] = {}
        self._changed = threading.Condition()
        self.client = LanguageClient("aida-kb-client", "1")

        @self.client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)  # type: ignore[untyped-decorator]
        def published(params: types.PublishDiagnosticsParams) -> None:
            with self._changed:
                self._published[params.uri] = params
                self._changed.notify_all()

        self._run(lambda: self.client.start_io(command[0], *command[1:]))
        params = types.InitializeParams(
            capabilities=types.ClientCapabilities(),
            initialization_options=initialization_options,
        )
        self.initialized = self._run(lambda: self.client.initialize_async(params))
        self._notify(lambda: self.client.initialized(types.InitializedParams()))
        self.versions: dict[str, int] = {}

    def _run(self, make: Callable[[], Awaitable[T]]) -> T:
        """Make and await an awaitable in the client's loop (its futures belong there)."""

        async def wait() -> T:
            return await make()

        future = asyncio.run_coroutine_threadsafe(wait(), self._loop)
        try:
            return future.result(self.timeout)
        except TimeoutError:
            future.cancel()
            raise AidaError(f"the language server did not answer within {self.timeout} s") from None

    def _notify(self, send: Callable[[], None]) -> None:
        """Send a notification from the client's loop (its writer belongs there)."""

        async def now() -> None:
            send()

        self._run(now)

    # -- documents
    def open(self, uri: str, text: str) -> None:
        """Open a document (version 1); what was published for it before is forgotten."""
        self.versions[uri] = 1
        with self._changed:
            self._published.pop(uri, None)
        item = types.TextDocumentItem(uri, "aida-kb", 1, text)
        self._notify(
            lambda: self.client.text_document_did_open(types.DidOpenTextDocumentParams(item))
        )

    def change(self, uri: str, text: str, at: types.Range | None = None) -> int:
        """Replace the whole text (or the range ``at``) of a document; returns its new version."""
        version = self.versions[uri] + 1
        self.versions[uri] = version
        change: types.TextDocumentContentChangeEvent = (
            types.TextDocumentContentChangeWholeDocument(text)
            if at is None
            else types.TextDocumentContentChangePartial(at, text)
        )
        params = types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(version, uri), [change]
        )
        self._notify(lambda: self.client.text_document_did_change(params))
        return version

    def save(self, uri: str) -> None:
        """Say that a document was saved; the diagnostics published before are forgotten, so
        that `diagnostics` waits for those the save brings (for it and what imports it)."""
        with self._changed:
            self._published.clear()
        params = types.DidSaveTextDocumentParams(types.TextDocumentIdentifier(uri))
        self._notify(lambda: self.client.text_document_did_save(params))

    def close(self, uri: str) -> None:
        """Close a document."""
        params = types.DidCloseTextDocumentParams(types.TextDocumentIdentifier(uri))
        self._notify(lambda: self.client.text_document_did_close(params))

    def diagnostics(self, uri: str, version: int | None = None) -> list[types.Diagnostic]:
        """The diagnostics published for ``uri`` at ``version`` (default: the last one sent)."""
        wanted = self.versions.get(uri) if version is None else version

        def ready() -> bool:
            got = self._published.get(uri)
            return got is not None and (wanted is None or got.version == wanted)

        with self._changed:
            if not self._changed.wait_for(ready, self.timeout):
                raise AidaError(f"the language server published no diagnostics for {uri}")
            return list(self._published[uri].diagnostics)

    # -- requests
    def request(self, method: str, params: Any) -> Any:
        """Send the request ``method`` (``"textDocument/hover"``) and return its result."""
        return self._run(lambda: self.client.protocol.send_request_async(method, params))

    def notify(self, method: str, params: Any) -> None:
        """Send the notification ``method`` (``"workspace/didChangeWorkspaceFolders"``)."""
        self._notify(lambda: self.client.protocol.notify(method, params))

    def stop(self) -> None:
        """Shut the server down and end the client."""
        try:
            self._run(lambda: self.client.shutdown_async(None))
            self._notify(lambda: self.client.exit(None))
            self._run(self.client.stop)
        finally:
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(self.timeout)

    def __enter__(self) -> ServerClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
