"""Syntax errors in the language's words: what was expected after a keyword, in a
declaration or a concept's member, and what was found instead (never the grammar's terminal
names).

`describe` turns Lark's exception for a syntax error into a `Diagnostic` with a code of the
registry (`aida_kb.diagnostics.codes`), a span and a hint where one helps.
"""

from __future__ import annotations

from typing import Any

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span

__all__ = ["describe", "diagnostic"]

_AFTER_KEYWORD: dict[str, str] = {
    "PART": "expected a role name after 'part'",
    "_CON_OF": "expected a role name after 'con-of'",
    "CONCEPT": "expected a concept name after 'concept'",
    "TEMPLATE": "expected a template name after 'template'",
    "INSTANCE": "expected an instance name after 'instance'",
    "ATTRIBUTE": "expected an attribute name after 'attribute'",
    "OF": "expected a concept name after 'of'",
    "_IS_A": "expected a parent concept name after 'is-a'",
    "LAYERS": "expected a layer name after 'layers'",
    "MORETHAN": "expected a layer name after '>'",
    "IMPORT": "expected a file name in double quotes after 'import'",
    "ADJACENT": "expected 'ring(...)' or 'pairs(...)' after 'adjacent'",
    "CONSTRAINT": "expected a relation after 'constraint', such as parallel(a, b) "
    "or angle(a, b) == 90 deg",
    "MEASURE": "expected a measurement after 'measure', such as position(self) or edge(edge(a, b))",
    "_PLUSMINUS": "expected a tolerance after '+-', such as 0.5 deg",
    "WEIGHT": "expected a number after 'weight'",
    "REJECT": "expected 'above' after 'reject'",
    "ABOVE": "expected a threshold after 'reject above', such as 3 deg",
    "EQ": "expected a value after '=='",
    "EQUAL": "expected a value after '='",
    "OPTIONAL": "expected 'part' after 'optional'",
    "ABSTRACT": "expected 'concept' after 'abstract'",
    "__ANON_0": "expected a number or '*' after '..'",
    "DOT": "expected a role name after '.'",
    "RING": "expected '(' and the parts of the ring after 'ring'",
    "PAIRS": "expected '(' and the pairs after 'pairs'",
    "FRAME": "expected 'from' and the part that gives the frame, as in 'frame from front'",
    "ORIENT": "expected the parts to orient after 'orient', as in 'orient front: forward'",
    "UNSEEN": "expected the unseen parts after 'unseen', as in 'unseen back: at depth from front'",
    "ATTACH": "expected the attached part after 'attach', as in 'attach oriels: backward in front'",
    "TILTED": "expected 'by' and an angle after 'tilted', as in 'tilted by pitch'",
    "BY": "expected an angle or an attribute after 'by'",
    "MIRROR": "expected a part after 'mirror', as in 'mirror front about edge(a, b)'",
    "ABOUT": "expected an edge after 'about', as in 'about edge(roof.front, roof.back)'",
    "REACH": "expected an edge after 'reach', as in 'reach edge(roof.front, roof.back)'",
    "AT": "expected a distance after 'at', as in 'at depth from front'",
    "FROM": "expected a part after 'from'",
    "IS": "expected a measure after 'is', such as slope(self) or height(self)",
    "AS": "expected a name for the face after 'as'",
    "WHEN": "expected a role after 'when', as in 'when roof is HipRoof { ... }'",
    "TOUCHING": "expected a part role after 'touching', as in 'touching houses share body.roof'",
    "SHARE": "expected a role path after 'share', as in 'share body.roof'",
}
_TERMINAL_WORDS: dict[str, str] = {
    "NAME": "a name",
    "NUMBER": "a number",
    "QUANTITY": "a quantity such as 90 deg",
    "STRING": "a string",
    "$END": "the end of the file",
}
_DECLARATION_KEYWORDS = {"CONCEPT", "TEMPLATE", "INSTANCE", "IMPORT", "LAYERS", "ABSTRACT"}
_MEMBER_KEYWORDS = {
    "PART",
    "OPTIONAL",
    "_CON_OF",
    "ATTRIBUTE",
    "ADJACENT",
    "CONSTRAINT",
    "FRAME",
    "ORIENT",
    "UNSEEN",
    "ATTACH",
    "WHEN",
    "TOUCHING",
}


def _terminal_word(lark: Lark, name: str) -> str:
    if name in _TERMINAL_WORDS:
        return _TERMINAL_WORDS[name]
    try:
        term = lark.get_terminal(name)
    except KeyError:
        return name
    if term.pattern.type == "str":
        return f"'{term.pattern.value}'"
    return name.lower()


def _found(tok: Token) -> str:
    if tok.type == "$END":
        return "the end of the file"
    return f"'{tok}'"


# A name followed by something other than ':' - what the ':' introduces depends on the keyword
# a few tokens back (``part front, back Wall``); "PARAM" stands for a template's parameter list.
_COLON_AFTER: dict[str, str] = {
    "PART": "expected ':' and the part's concept after the role names, as in 'part front: Wall'",
    "_CON_OF": (
        "expected ':' and the realising concept after the role, as in 'con-of region: Region'"
    ),
    "ATTRIBUTE": "expected ':' and a type after the attribute name, as in 'attribute tilt: angle'",
    "PARAM": "expected ':' and a type after the parameter name, as in 'a: Plane'",
}


def _in_context(stack: list[Any], prev_type: str | None, expected: set[str]) -> str | None:
    """A message that needs the keyword before the last names (None: no such case)."""
    if prev_type == "NAME" and "COLON" in expected:
        for item in reversed(stack):
            if isinstance(item, Token) and item.type in ("NAME", "COMMA"):
                continue
            keyword = item.type if isinstance(item, Token) else "PARAM"
            if keyword == "LPAR":
                keyword = "PARAM"
            return _COLON_AFTER.get(keyword)
    if {"RPAR", "COMMA"} <= expected:
        return "expected ',' or a closing ')'"
    return None


def describe(lark: Lark, exc: UnexpectedInput, text: str, file: str, off: int) -> Diagnostic:
    """A diagnostic for a syntax error, in the language's words (not the grammar's)."""
    if isinstance(exc, UnexpectedCharacters):
        return _describe_characters(exc, text, file, off)
    if isinstance(exc, UnexpectedToken):
        return _describe_token(lark, exc, text, file, off)
    span = Span.point(file, max(exc.line, 1) + off, max(exc.column, 1))
    return diagnostic(codes.SYNTAX, "syntax error", span)


def diagnostic(code: codes.Code, message: str, span: Span, hint: str | None = None) -> Diagnostic:
    return Diagnostic(code.code, code.severity, message, span, hint)


def _describe_characters(exc: UnexpectedCharacters, text: str, file: str, off: int) -> Diagnostic:
    pos = exc.pos_in_stream or 0
    line, col = exc.line + off, exc.column
    if text.startswith('"', pos):
        eol = text.find("\n", pos)
        length = (len(text) if eol < 0 else eol) - pos
        span = Span(file, line, col, line, col + max(length, 1))
        return diagnostic(
            codes.UNTERMINATED_STRING,
            "unterminated string",
            span,
            "close the string with '\"' on the same line; write \\\" for a quote inside it",
        )
    if text.startswith("/*", pos):
        return diagnostic(
            codes.UNTERMINATED_COMMENT,
            "unterminated comment: '/*' has no closing '*/'",
            Span(file, line, col, line, col + 2),
        )
    char = exc.char
    hints = {
        "#": "comments start with // or /*",
        ";": "no ';' is needed: members and declarations end by themselves",
        "'": "strings are written in double quotes",
        "°": "write angles with the unit deg: 90 deg",
        "′": "lengths are metric: write m, cm or mm",
        "″": "lengths are metric: write m, cm or mm",
    }
    return diagnostic(
        codes.UNEXPECTED_CHARACTER,
        f"unexpected character {char!r}",
        Span.point(file, line, col),
        hints.get(char),
    )


def _describe_token(lark: Lark, exc: UnexpectedToken, text: str, file: str, off: int) -> Diagnostic:
    tok = exc.token
    expected = set(exc.expected)
    found = _found(tok)
    if tok.type == "$END":
        lines = text.split("\n")
        span = Span.point(file, len(lines) + off, len(lines[-1]) + 1)
    else:
        span = Span(
            file,
            (tok.line or 1) + off,
            tok.column or 1,
            (tok.end_line or 1) + off,
            tok.end_column or 1,
        )
    prev: Any = None
    if exc.interactive_parser is not None:
        stack = exc.interactive_parser.parser_state.value_stack
        prev = stack[-1] if stack else None
    prev_type = prev.type if isinstance(prev, Token) else None

    message: str | None = None
    hint: str | None = None
    if prev_type == "NAME" and "IN" in expected and "_IS_A" in expected:
        message = "expected 'in LAYER' or 'is-a PARENT' after the concept name"
    elif prev_type == "IN" and "LSQB" in expected:
        message = "expected a range such as [85 deg, 95 deg] after 'in'"
    elif prev_type == "IN":
        message = "expected a layer name after 'in'"
    elif prev_type == "COLON" and expected <= {"NAME"}:
        message = "expected a concept or type name after ':'"
    elif prev_type is not None and prev_type in _AFTER_KEYWORD:
        message = _AFTER_KEYWORD[prev_type]
    elif expected & _DECLARATION_KEYWORDS and "RBRACE" not in expected:
        message = (
            "expected a declaration (concept, abstract concept, template, instance, import "
            "or layers)"
        )
        if tok.type == "RBRACE":
            hint = "this '}' closes nothing"
    elif prev_type == "COLON" and "FORWARD" in expected:
        message = "expected a direction: forward, backward, leftward, rightward, upward or downward"
    elif expected & _MEMBER_KEYWORDS:
        message = (
            "expected a member (part, optional part, con-of, attribute, adjacent, constraint, "
            "measure, frame, orient, unseen, attach, when, touching) or '}'"
        )
        if tok.type == "NAME":
            hint = "a role is declared with 'part NAME: Concept'"
    if (
        tok.type == "DOT"
        and tok.end_pos is not None
        and text[tok.end_pos : tok.end_pos + 1].isdigit()
    ):
        hint = f"a number starts with a digit: write 0.{text[tok.end_pos :].split()[0]}"
    if message is None and exc.interactive_parser is not None:
        message = _in_context(exc.interactive_parser.parser_state.value_stack, prev_type, expected)
    if message is None:
        words = sorted({_terminal_word(lark, t) for t in expected})
        if len(words) > 8:
            words = [*words[:8], "..."]
        message = "expected " + (words[0] if len(words) == 1 else "one of " + ", ".join(words))
    if tok.type == "$END":
        code = codes.UNEXPECTED_EOF if "RBRACE" in expected else codes.SYNTAX
        if "RBRACE" in expected and hint is None:
            hint = "a '}' is missing"
        return diagnostic(code, f"{message}, found the end of the file", span, hint)
    return diagnostic(codes.SYNTAX, f"{message}, found {found}", span, hint)
