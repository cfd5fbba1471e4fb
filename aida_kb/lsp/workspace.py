"""The .kb files of the editor's workspace folders that are not open, compiled on demand.

Find references and rename reach the files that import a document even when the editor has
not opened them: each ``.kb`` file below a workspace folder is compiled as a root (cached by
its modification time) and searched like an open document.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence

from aida_kb.limits import MAX_KB_BYTES, read_text_limited
from aida_kb.lsp.analysis import Analysis
from aida_kb.lsp.convert import uri_of_path

__all__ = ["MAX_WORKSPACE_FILES", "WorkspaceFiles"]

#: At most this many files of the workspace are compiled for references and rename: each
#: takes about 15 ms (kb/buildings.kb), so a larger tree would stall the editor's request.
MAX_WORKSPACE_FILES = 400


class WorkspaceFiles:
    """Compiled ``.kb`` files of some folders, recompiled when a file changes on disk."""

    def __init__(self) -> None:
        self._cache: dict[str, tuple[int, Analysis]] = {}

    def analyses(
        self, folders: Iterable[str], skip: set[str], search_paths: Sequence[str] = ()
    ) -> list[Analysis]:
        """The analyses of the ``.kb`` files below ``folders`` whose URIs are not in ``skip``."""
        out = []
        for path in _kb_files(folders):
            uri = uri_of_path(path)
            if uri in skip:
                continue
            try:
                stamp = os.stat(path).st_mtime_ns
                cached = self._cache.get(path)
                if cached is None or cached[0] != stamp:
                    text = read_text_limited(path, MAX_KB_BYTES)
                    cached = (stamp, Analysis(uri, text, search_paths))
                    self._cache[path] = cached
            except (OSError, UnicodeDecodeError):
                continue  # unreadable: the editor shows nothing of it
            out.append(cached[1])
        return out


def _kb_files(folders: Iterable[str]) -> list[str]:
    found: list[str] = []
    for folder in folders:
        for root, dirs, names in os.walk(folder):
            dirs[:] = sorted(d for d in dirs if not d.startswith(".") and d != "node_modules")
            found.extend(os.path.join(root, n) for n in sorted(names) if n.endswith(".kb"))
            if len(found) >= MAX_WORKSPACE_FILES:
                return found[:MAX_WORKSPACE_FILES]
    return found
