"""Positions between the compiler and the protocol.

The compiler's spans are 1-based, in characters (code points), end exclusive; the protocol's
ranges are 0-based, in UTF-16 code units (its default encoding), end exclusive.
"""

from __future__ import annotations

import os
from urllib.parse import unquote, urlparse
from urllib.request import pathname2url

from lsprotocol import types

from aida_kb.diagnostics.core import Span

__all__ = ["Lines", "path_of_uri", "uri_of_path"]


def _utf16_len(text: str) -> int:
    """The length of ``text`` in UTF-16 code units."""
    return len(text) + sum(1 for ch in text if ord(ch) > 0xFFFF)


class Lines:
    """A text's lines, for converting between compiler columns and protocol characters."""

    __slots__ = ("lines",)

    def __init__(self, text: str) -> None:
        self.lines = text.split("\n")

    def line(self, index: int) -> str:
        """Line ``index`` (0-based), or "" past the end."""
        return self.lines[index] if 0 <= index < len(self.lines) else ""

    def position(self, line: int, column: int) -> types.Position:
        """The protocol position of the compiler's 1-based ``line:column``."""
        text = self.line(line - 1)
        return types.Position(max(line - 1, 0), _utf16_len(text[: max(column - 1, 0)]))

    def range(self, span: Span) -> types.Range:
        """The protocol range of a compiler span."""
        return types.Range(
            self.position(span.line, span.column), self.position(span.end_line, span.end_column)
        )

    def column(self, position: types.Position) -> int:
        """The compiler's 1-based column of a protocol position (on its line)."""
        text = self.line(position.line)
        units = 0
        for i, ch in enumerate(text):
            if units >= position.character:
                return i + 1
            units += 2 if ord(ch) > 0xFFFF else 1
        return len(text) + 1


def path_of_uri(uri: str) -> str:
    """The file system path of a ``file:`` URI; another URI (``untitled:``) stays as it is."""
    parsed = urlparse(uri)
    if parsed.scheme != "file":
        return uri
    return os.path.normpath(unquote(parsed.path))


def uri_of_path(path: str) -> str:
    """The ``file:`` URI of a path (made absolute); a URI given as a path stays as it is."""
    if "://" in path or path.startswith("untitled:"):
        return path
    return "file://" + pathname2url(os.path.abspath(path))
