"""The canonical layout of ``.kb`` source text (``aida-kb fmt``); docs/language.md §8.

The formatter is driven by the lexer's token stream: the file is parsed by the grammar's own
LALR parser (``grammars/kb.lark``, the same contextual lexer), into a plain parse tree that
keeps every token, while a lexer callback collects the comments the grammar ignores. The tree
only says where a *line unit* starts (a declaration head, a doc string, a member, a template's
relation, an instance's binding, a closing ``}``); the text is rebuilt from the tokens with
canonical spacing, and every comment is put back where it was, relative to the tokens:

- a comment on the line of the token before it stays at the end of that line;
- a comment on a line of its own stays on a line of its own, indented like the code around it;
- the text of a comment is kept as written (only trailing blanks of a ``//`` comment go).

`format_source` checks its own output: the result is parsed again and its AST, spans left
out, must equal the original's; otherwise it raises `FormatError` and nothing is written.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Iterator
from dataclasses import dataclass, fields, is_dataclass
from typing import Any

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedInput

from aida_kb.dsl import ast
from aida_kb.dsl import parser as kb_parser
from aida_kb.errors import FormatError

__all__ = ["INDENT", "FormatResult", "format_source", "strip_spans"]

#: One level of indentation: four spaces (the layout of kb/buildings.kb).
INDENT = "    "
#: A line comment inside a member pushes the rest of the member to a continuation line,
#: indented one level deeper than the member.
_CONTINUATION = 1

#: What separates a trailing line comment from the code before it (as black and ruff do); a
#: block comment amid code gets one blank.
_TRAILING = "  "
_COMMENT_TYPES = ("LINE_COMMENT", "BLOCK_COMMENT")
#: Declarations whose body is a block of lines; the others (layers, import) are one line.
_BLOCK_DECLS = frozenset({"template_decl", "concept_decl", "instance_decl"})
_NUMBER = r"-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?"
_QUANTITY_PARTS = re.compile(rf"({_NUMBER})[ \t]*([A-Za-z_][A-Za-z0-9_]*)$")
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*$")

#: AST fields that only say where a node was written.
_LAYOUT_FIELDS = ("span", "file")

_lock = threading.Lock()
_lark: Lark | None = None
_comments: list[Token] = []


@dataclass(frozen=True, slots=True)
class FormatResult:
    """The formatted text and whether it differs from the input."""

    text: str
    changed: bool


def _collect_comment(tok: Token) -> Token:
    _comments.append(tok)
    return tok


def _tree_parser() -> Lark:
    global _lark
    if _lark is None:
        _lark = kb_parser.make_lark(
            lexer_callbacks={name: _collect_comment for name in _COMMENT_TYPES}
        )
    return _lark


def strip_spans(node: Any) -> Any:
    """An AST node as nested tuples without its layout: what two parses compare on.

    Spans and file names are left out, and so is a quantity's spelling (``90deg`` and
    ``90 deg`` are one value and unit; the formatter writes the second).
    """
    if isinstance(node, tuple | list):
        return tuple(strip_spans(n) for n in node)
    if is_dataclass(node) and not isinstance(node, type):
        skip = _LAYOUT_FIELDS + (("text",) if isinstance(node, ast.Quantity) else ())
        kept = [f.name for f in fields(node) if f.name not in skip]
        return (type(node).__name__, *((n, strip_spans(getattr(node, n))) for n in kept))
    return node


def format_source(text: str, file: str = "<string>") -> FormatResult:
    """The canonical layout of one ``.kb`` source text.

    Parameters
    ----------
    text : str
        The source.
    file : str
        The file name used in error messages.

    Returns
    -------
    FormatResult
        The formatted text (ending in one newline; empty for a file with neither code nor
        comments) and whether it differs from ``text``.

    Raises
    ------
    FormatError
        ``FILE:LINE:COL: message`` when the text has a syntax error (or another error of the
        parser, such as a number beyond float range): such a file is left as it is.
    """
    before = kb_parser.parse(text, file)
    errors = [d for d in before.diagnostics if d.is_error]
    if errors:
        d = errors[0]
        raise FormatError(
            f"{file}:{d.span.line}:{d.span.column}: not formatted: {d.code} {d.message}"
        )
    source = text.replace("\r\n", "\n")
    with _lock:
        lark = _tree_parser()
        _comments.clear()
        try:
            tree = lark.parse(source)
        except UnexpectedInput as exc:  # parse() accepted it; kept as a safety net
            raise FormatError(
                f"{file}:{exc.line}:{exc.column}: not formatted: a syntax error"
            ) from None
        comments = list(_comments)
        _comments.clear()
    out = _Printer(_units(tree), comments).render()
    after = kb_parser.parse(out, file)
    if not after.ok or strip_spans(after.module.items) != strip_spans(before.module.items):
        raise FormatError(
            f"{file}:1:1: not formatted: the formatted text would not mean the same "
            "(a bug of the formatter; please report it)"
        )
    return FormatResult(out, out != text)


# ---- line units -----------------------------------------------------------------------------
def _leaves(node: Any) -> Iterator[Token]:
    """The tokens below a parse-tree node, in order (iterative: no recursion limit)."""
    stack: list[Any] = [node]
    while stack:
        item = stack.pop()
        if isinstance(item, Token):
            yield item
        elif isinstance(item, Tree):
            stack.extend(reversed(item.children))


def _units(tree: Tree[Token]) -> list[tuple[Token, int, bool]]:
    """(token, depth, starts a line) for every token of the file, in source order.

    ``depth`` is the indentation level of the line unit the token belongs to; the third item
    is True for the first token of a declaration, a doc string, a member or a closing brace.
    A token that starts a top-level declaration with a body gets depth -1 (a blank line
    separates it from what comes before).
    """
    out: list[tuple[Token, int, bool]] = []
    for decl in tree.children:
        if not isinstance(decl, Tree):
            continue
        first = True
        in_body = False
        for child in decl.children:
            if child is None:
                continue
            if in_body:
                if isinstance(child, Token):  # the closing brace
                    out.append((child, 0, True))
                    continue
                if child.data == "doc":
                    out.extend((tok, 1, True) for tok in _leaves(child))
                    continue
                out.extend(_member_units(child, 1))
                continue
            for tok in _leaves(child):
                if first:
                    out.append((tok, -1 if decl.data in _BLOCK_DECLS else 0, True))
                    first = False
                else:
                    out.append((tok, 0, False))
                if tok.type == "LBRACE":
                    in_body = True
    return out


def _member_units(member: Tree[Token], depth: int) -> Iterator[tuple[Token, int, bool]]:
    """The units of one member at ``depth``: one line, or for a ``when`` block its head line,
    each member inside one level deeper, and its closing brace on a line of its own."""
    if member.data != "when":
        for i, tok in enumerate(_leaves(member)):
            yield tok, depth, i == 0
        return
    first = True
    in_block = False
    for child in member.children:
        if child is None:
            continue
        if in_block and isinstance(child, Tree):
            yield from _member_units(child, depth + 1)
            continue
        for tok in _leaves(child):
            closing = in_block and tok.type == "RBRACE"
            yield tok, depth, first or closing
            first = False
            if tok.type == "LBRACE":
                in_block = True


# ---- spacing ----------------------------------------------------------------------------------
_NO_SPACE_BEFORE = frozenset({",", ")", "]", ":", ".", ".."})
_NO_SPACE_AFTER = frozenset({"(", "[", ".", ".."})


def _spell(tok: Token) -> str:
    """A token as the canonical layout writes it: a quantity as number, one blank, unit."""
    if tok.type == "QUANTITY":
        m = _QUANTITY_PARTS.match(str(tok))
        if m:
            return f"{m.group(1)} {m.group(2)}"
    return str(tok)


def _space(prev: str, cur: str) -> str:
    """The blank between two tokens on one line: '' or ' '."""
    if cur in _NO_SPACE_BEFORE or prev in _NO_SPACE_AFTER:
        return ""
    if cur == "(" and _WORD.match(prev):  # a call, a template head, ring(...), pairs(...)
        return ""
    return " "


class _Printer:
    """Lays out the tokens line by line and puts the comments back between them."""

    def __init__(self, units: list[tuple[Token, int, bool]], comments: list[Token]) -> None:
        self.units = units
        self.comments = comments
        self.lines: list[str] = []
        self.line = ""  # the line being built
        self.prev = ""  # the text of the last token or comment put on the line
        self.last_end_line = 0  # source line where the last token or comment ended
        self.last_was_token = False
        self.unit_depth = 0  # indentation of the current line unit
        self.mid_unit = False  # the last token is not the last one of its line unit
        self.braces = 0  # how many braces are open (a declaration's body, a 'when' block)
        self.last_token = ""  # the text of the last token written
        self.own_line_comment = False  # the last item written is a comment on its own line

    def flush(self) -> None:
        if self.line.strip():
            self.lines.append(self.line.rstrip())
        self.line = ""

    def blank(self) -> None:
        """One blank line, unless at the start, after another blank line or after a '{'."""
        self.flush()
        if self.lines and self.lines[-1] != "" and not self.lines[-1].endswith("{"):
            self.lines.append("")

    def gap_before(self, line: int) -> bool:
        """Whether the source has a blank line between the last item and source line `line`."""
        return self.last_end_line > 0 and line > self.last_end_line + 1

    def start_line(self, depth: int, text: str) -> None:
        self.flush()
        self.line = INDENT * depth + text
        self.prev = text

    def comment(self, tok: Token) -> None:
        text = str(tok).rstrip() if tok.type == "LINE_COMMENT" else str(tok)
        line: int = tok.line  # type: ignore[assignment]
        if self.line.strip() and line == self.last_end_line:
            # a comment after code stays on its line
            self.line += (_TRAILING if tok.type == "LINE_COMMENT" else " ") + text
            self.prev = text
            self.own_line_comment = False
        else:
            self.own_line_comment = True
            if self.mid_unit:  # a comment on its own line amid a member
                depth = self.unit_depth + _CONTINUATION
            else:
                depth = self.braces
                if self.gap_before(line):
                    self.blank()
            self.start_line(depth, text)
            self.flush()
        if tok.type == "LINE_COMMENT":
            self.flush()  # the line ends with the comment
        self.last_end_line = tok.end_line  # type: ignore[assignment]
        self.last_was_token = False

    def token(self, tok: Token, depth: int, starts: bool, ends: bool) -> None:
        line: int = tok.line  # type: ignore[assignment]
        text = _spell(tok)
        if tok.type == "RBRACE" and self.prev == "{" and self.last_was_token:
            self.line += text  # an empty body: {}
            self.prev = text
            self.braces -= 1
        elif starts:
            self.unit_depth = max(depth, 0)
            if tok.type == "RBRACE":
                self.braces -= 1
            elif (
                self.last_token
                and not self.own_line_comment
                and (depth < 0 or (depth == 0 and self.last_token == "}"))
            ):
                self.blank()  # declarations with a body stand apart
            elif self.gap_before(line) and self.prev != "{":
                self.blank()
            self.start_line(self.unit_depth, text)
        elif not self.line.strip():  # after a comment that ended the line
            self.start_line(self.unit_depth + _CONTINUATION, text)
        else:
            self.line += _space(self.prev, text) + text
            self.prev = text
        if tok.type == "LBRACE":
            self.braces += 1
        self.mid_unit = not ends
        self.last_token = text
        self.own_line_comment = False
        self.last_end_line = tok.end_line  # type: ignore[assignment]
        self.last_was_token = True

    def render(self) -> str:
        comments = self.comments
        units = self.units
        ci = 0
        for i, (tok, depth, starts) in enumerate(units):
            pos: int = tok.start_pos  # type: ignore[assignment]
            while ci < len(comments) and comments[ci].start_pos < pos:  # type: ignore[operator]
                self.comment(comments[ci])
                ci += 1
            ends = i + 1 == len(units) or units[i + 1][2]
            self.token(tok, depth, starts, ends)
        for c in comments[ci:]:
            self.comment(c)
        self.flush()
        while self.lines and self.lines[-1] == "":
            self.lines.pop()
        return "\n".join(self.lines) + "\n" if self.lines else ""
