"""One language server for the protocol tests: started once, driven over its stdin/stdout."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from aida_kb.lsp.client import ServerClient


@pytest.fixture(scope="session")
def server() -> Iterator[ServerClient]:
    """``aida-kb lsp`` as a child process with a client connected, as an editor has it."""
    with ServerClient() as client:
        yield client
