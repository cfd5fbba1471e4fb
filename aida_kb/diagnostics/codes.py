"""The registry of diagnostic codes, in the manner of mypy's ``errorcodes.py``.

Every diagnostic aida-kb emits carries a stable code registered here with its default
severity and a one-line summary; ``docs/diagnostics.md`` and ``aida-kb explain CODE`` give
the long explanation with a bad and a fixed example.

Ranges: ``KB001``-``KB099`` syntax (the parser, ``aida_kb.dsl``); ``KB100``-``KB399``
semantic errors and warnings (the compiler, ``aida_kb.kb``); ``KB400``-``KB499`` notes of an
interpretation about the knowledge base's constraints (``aida-kb interpret``, ``reconstruct``,
``demo``: a constraint that rejected a hypothesis, shown at its ``.kb`` line);
``KB900``-``KB999`` files and imports that cannot be read.
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
NUMBER_TOO_LARGE = register(
    "KB010", Severity.ERROR, "a number is beyond the range of a 64-bit float (such as 1e999)"
)
NESTED_TOO_DEEP = register("KB011", Severity.ERROR, "calls or lists are nested more than 32 deep")
UNCLOSED_BODY = register(
    "KB012", Severity.ERROR, "a '{' is not closed by '}' before the next declaration"
)
INTERNAL_PARSER_ERROR = register(
    "KB099", Severity.ERROR, "the parser failed unexpectedly (a bug in aida-kb: please report it)"
)

# --- semantic (aida_kb.kb) -----------------------------------------------------------------
_E, _W = Severity.ERROR, Severity.WARNING
# names
UNKNOWN_CONCEPT = register("KB100", _E, "a name where a concept is due names no concept")
UNKNOWN_LAYER = register("KB101", _E, "a concept is put in a layer the layers declaration lacks")
UNKNOWN_ROLE = register(
    "KB102", _E, "a role path or binding names no role or attribute of its concept"
)
UNKNOWN_RELATION = register(
    "KB103", _E, "a call is neither a primitive relation nor a declared template"
)
UNKNOWN_INSTANCE = register("KB104", _E, "an instance binding names no declared instance")
UNKNOWN_TYPE = register(
    "KB105", _E, "an attribute or parameter type is not angle, length, number or a concept"
)
DUPLICATE_DEFINITION = register(
    "KB110", _E, "two concepts, templates or instances of the knowledge base share a name"
)
DUPLICATE_MEMBER = register(
    "KB111", _E, "a concept, template or instance declares the same member name twice"
)
LAYERS_DECLARATION = register(
    "KB112", _E, "the knowledge base has no layers declaration, or more than one"
)
LAYER_CONFLICT = register("KB113", _E, "a concept's own layer differs from the layer of a parent")
# structure of the net
ISA_CYCLE = register("KB120", _E, "concepts specialise each other in a cycle (is-a)")
PART_CYCLE = register("KB121", _E, "concepts contain each other in a cycle (part-of)")
CONOF_LAYER = register("KB122", _E, "a con-of does not go exactly one layer down")
PART_LAYER = register("KB123", _E, "a part lies in another layer than its whole")
CARDINALITY_RANGE = register("KB124", _E, "a cardinality's minimum exceeds its maximum")
INHERITED_CONFLICT = register(
    "KB125", _E, "two parents give a member of the same name different declarations"
)
BAD_OVERRIDE = register(
    "KB126", _E, "a member overrides an inherited one with another kind or an unrelated type"
)
# templates, relations, values
TEMPLATE_ARITY = register("KB130", _E, "a template is used with too few or too many arguments")
ARGUMENT_TYPE = register(
    "KB131", _E, "an argument does not have the type of its template parameter or relation"
)
UNIT_MISMATCH = register("KB132", _E, "a quantity has a unit of the wrong kind (90 m for an angle)")
OUT_OF_RANGE = register(
    "KB133", _E, "a value lies outside its attribute's range, or the range is empty"
)
EDGE_NOT_ADJACENT = register("KB134", _E, "edge(a, b) names two parts not declared adjacent")
MALFORMED_RELATION = register(
    "KB135", _E, "a primitive relation has the wrong number or shape of arguments"
)
MEASUREMENT_MISUSE = register("KB136", _E, "a measure is not a measurement, or a constraint is one")
BAD_QUALIFIER = register(
    "KB137", _E, "a tolerance or weight is not positive, or a threshold cannot be read"
)
NO_ATTRIBUTE_VALUE = register(
    "KB138", _E, "a relation uses an attribute that has no value in some concept"
)
DEGENERATE_ADJACENCY = register(
    "KB139",
    _E,
    "an adjacency is degenerate: a ring of fewer than three parts, a part repeated in a ring "
    "or paired with itself, or a ring entry with several fillers",
)
# geometry: frames, orientations, measured attributes, unseen parts, attachments
BAD_ORIENTATION = register(
    "KB150", _E, "an orientation names a part that is not planar, or orients a part twice"
)
BAD_FRAME = register(
    "KB151", _E, "a frame is declared twice, or its anchor is no planar part facing forward"
)
BAD_ATTRIBUTE_MEASURE = register(
    "KB152", _E, "an attribute's measure is unknown, has the wrong arguments or the wrong type"
)
BAD_PLACEMENT = register(
    "KB153", _E, "an unseen part's placement names no planar part or no edge, or a bad distance"
)
BAD_ATTACHMENT = register(
    "KB154", _E, "an attachment names no composite part, or planes that are no planar parts"
)
BAD_CONDITION = register(
    "KB155",
    _E,
    "a 'when' block names no part, a concept that cannot fill it, a member that is no "
    "relation, or a relation that never holds under its condition",
)
BAD_SHARE = register(
    "KB156",
    _E,
    "a 'touching ... share' names no part role that can hold several objects, or a path that "
    "is no part with specialisations to share",
)
# instances
ABSTRACT_INSTANCE = register("KB140", _E, "an instance is declared of an abstract concept")
MISSING_ROLE = register("KB141", _E, "an instance leaves an obligatory role unbound")
BAD_BINDING = register(
    "KB142", _E, "an instance binding does not fit its role (type, count or kind of value)"
)
BAD_EXPECTATION = register(
    "KB143", _E, "an expectation annotation ('// expect: ...') is malformed or names nothing"
)
# warnings
UNUSED_TEMPLATE = register("KB300", _W, "a template is declared but never used")
UNREACHABLE_CONCEPT = register(
    "KB301", _W, "a concept cannot be reached from any concept of the top layer"
)
UNVERIFIABLE_CONCEPT = register(
    "KB302", _W, "a concept has no part-of/con-of path down to a measured image concept"
)

INTERNAL_COMPILER_ERROR = register(
    "KB399", _E, "the compiler failed unexpectedly (a bug in aida-kb: please report it)"
)

# --- interpretation: what the knowledge's constraints did to the hypotheses ------------------
REJECTED_BY = register(
    "KB400", Severity.NOTE, "a constraint of the knowledge base rejected a hypothesis"
)
CLOSEST_TO_THRESHOLD = register(
    "KB401", Severity.NOTE, "the constraint of the accepted interpretation closest to rejecting it"
)

# --- files and imports ---------------------------------------------------------------------
UNREADABLE_FILE = register(
    "KB900", Severity.ERROR, "a file cannot be read (missing, unreadable, not UTF-8)"
)
MISSING_IMPORT = register("KB901", Severity.ERROR, "an imported file does not exist")
IMPORT_CYCLE = register("KB902", Severity.ERROR, "files import each other in a cycle")
IMPORT_OUTSIDE = register(
    "KB903",
    Severity.ERROR,
    "an import names a file outside the project (the root file's folder and the import paths) "
    "or one that is not a .kb file",
)
