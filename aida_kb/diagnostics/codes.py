"""The registry of diagnostic codes, in the manner of mypy's ``errorcodes.py``.

Every diagnostic aida-kb emits carries a stable code registered here with its default
severity and a one-line summary; ``docs/diagnostics.md`` and ``aida-kb explain CODE`` give
the long explanation with a bad and a fixed example.

Ranges: ``KB001``-``KB099`` syntax (the parser, ``aida_kb.dsl``); ``KB100``-``KB399``
semantic errors and warnings (the compiler, ``aida_kb.kb``); ``KB900``-``KB999`` files and
imports that cannot be read.
"""

from __future__ import annotations

from dataclasses import dataclass

from aida_kb.diagnostics.core import Severity


@dataclass(frozen=True, slots=True)
class Code:
    """A registered diagnostic code: ``KB`` and three digits, a default severity, a summary."""

    code: str
    severity: Severity
    summary: str

    def __str__(self) -> str:
        return self.code


REGISTRY: dict[str, Code] = {}


def register(code: str, severity: Severity, summary: str) -> Code:
    """Register a code once; registering the same code twice is a programming error."""
    if code in REGISTRY:
        raise ValueError(f"diagnostic code {code} registered twice")
    if not (len(code) == 5 and code.startswith("KB") and code[2:].isdigit()):
        raise ValueError(f"diagnostic code {code!r} is not of the form KB000")
    entry = Code(code, severity, summary)
    REGISTRY[code] = entry
    return entry


def lookup(code: str) -> Code | None:
    """The registered code, or None (codes are matched case-insensitively)."""
    return REGISTRY.get(code.upper())


# --- syntax (aida_kb.dsl) ----------------------------------------------------------------
SYNTAX = register("KB001", Severity.ERROR, "the text does not follow the grammar of the language")
UNTERMINATED_STRING = register(
    "KB002", Severity.ERROR, "a string is not closed by '\"' on the line where it starts"
)
UNKNOWN_UNIT = register(
    "KB003", Severity.ERROR, "a quantity carries a unit other than deg, rad, m, cm, mm or px"
)
UNTERMINATED_COMMENT = register("KB004", Severity.ERROR, "a '/*' comment has no closing '*/'")
UNEXPECTED_CHARACTER = register(
    "KB005", Severity.ERROR, "a character that no token of the language can start with"
)
BAD_CARDINALITY = register(
    "KB006", Severity.ERROR, "a cardinality bound is not a whole number ([1..*], [0..4], [2])"
)
DUPLICATE_QUALIFIER = register(
    "KB007", Severity.ERROR, "a relation gives its tolerance, weight or threshold twice"
)
UNEXPECTED_EOF = register(
    "KB008", Severity.ERROR, "the file ends inside a declaration (a '}' or more is missing)"
)
BAD_RELATION = register(
    "KB009", Severity.ERROR, "a relation is neither a call such as parallel(a, b) nor a comparison"
)
INTERNAL_PARSER_ERROR = register(
    "KB099", Severity.ERROR, "the parser failed unexpectedly (a bug in aida-kb: please report it)"
)

# --- semantic (aida_kb.kb) -----------------------------------------------------------------
# (registered by the compiler's owners, KB100 upwards)

# --- files and imports ---------------------------------------------------------------------
UNREADABLE_FILE = register(
    "KB900", Severity.ERROR, "a file cannot be read (missing, unreadable, not UTF-8)"
)
