"""The core diagnostic types: where (`Span`), how bad (`Severity`), and what (`Diagnostic`).

Lines and columns are 1-based; ``end_line``/``end_column`` point one past the last
character of the span (half-open), as Lark's ``end_line``/``end_column`` do.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True, order=True)
class Span:
    """A region of a source file: 1-based line and column, end exclusive."""

    file: str
    line: int
    column: int
    end_line: int
    end_column: int

    @classmethod
    def point(cls, file: str, line: int, column: int) -> Span:
        """A span of one character at ``line:column``."""
        return cls(file, line, column, line, column + 1)

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


class Severity(enum.Enum):
    """How bad a diagnostic is. Only errors make ``validate`` fail."""

    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One finding about a knowledge base: a stable code, a message, a span, an optional hint.

    ``related`` holds secondary places (the first definition of a duplicate, each link of a
    cycle) as ``(span, message)`` pairs.
    """

    code: str
    severity: Severity
    message: str
    span: Span
    hint: str | None = None
    related: tuple[tuple[Span, str], ...] = field(default=())

    @property
    def is_error(self) -> bool:
        """True for severity error."""
        return self.severity is Severity.ERROR

    def sort_key(self) -> tuple[str, int, int, str]:
        """Order by file, then position, then code."""
        return (self.span.file, self.span.line, self.span.column, self.code)
