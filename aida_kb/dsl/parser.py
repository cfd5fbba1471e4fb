"""Parse ``.kb`` source text into an `ast.Module` and syntax diagnostics; never raises.

The grammar (``grammars/kb.lark``) is parsed by Lark's LALR(1) parser with the contextual
lexer, driven by `aida_kb.dsl.lexer.FastContextualLexer` (the same tokens in one tight loop);
the AST is built *during* the parse by an inline transformer (no parse tree), so a parse costs
less than Lark's plain parse to a tree (``benchmarks/lint.py``). When the text has a syntax
error, the parser resynchronises: it cuts the text at every top-level declaration keyword
(``concept``, ``abstract``, ``template``, ``instance``, ``import``, ``layers``) and parses each
piece on its own, so one run reports every broken declaration and keeps every sound one.
"""

from __future__ import annotations

import bisect
import gc
import itertools
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from typing import Any

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedInput, UnexpectedToken

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast
from aida_kb.dsl.build import BOM, NAME_PATTERN, AstBuilder
from aida_kb.dsl.lexer import install as install_fast_lexer
from aida_kb.dsl.messages import describe, diagnostic

__all__ = ["ParseResult", "grammar_path", "make_lark", "parse"]


@dataclass(frozen=True, slots=True)
class ParseResult:
    """What `parse` found: the module (every declaration that parsed) and the diagnostics.

    ``broken`` names the declarations that failed to parse (``concept Foo`` with a syntax
    error gives ``"Foo"``), so that later phases need not report them again as unknown.
    """

    module: ast.Module
    diagnostics: tuple[Diagnostic, ...]
    broken: frozenset[str] = field(default_factory=frozenset)
    #: concepts kept without a member that did not parse: their other members may name it
    incomplete: frozenset[str] = field(default_factory=frozenset)

    @property
    def ok(self) -> bool:
        """True when no diagnostic is an error."""
        return not any(d.is_error for d in self.diagnostics)


def grammar_path() -> FsPath:
    """The grammar file: inside the installed wheel, else the repository's ``grammars/``."""
    from importlib import resources

    packaged = resources.files("aida_kb").joinpath("_data", "grammars", "kb.lark")
    if packaged.is_file():
        return FsPath(str(packaged))
    return FsPath(__file__).resolve().parents[2] / "grammars" / "kb.lark"


# ---- the parser, built once ---------------------------------------------------------------------
_lock = threading.Lock()
_builder = AstBuilder()
_lark: Lark | None = None


def make_lark(
    transformer: Transformer[Token, Any] | None = None,
    lexer_callbacks: dict[str, Callable[[Token], Token]] | None = None,
) -> Lark:
    """Lark's LALR parser with the contextual lexer for the grammar, as aida-kb configures it.

    Every token is kept and absent optional parts are ``None`` placeholders (the builder's
    callbacks rely on both). With ``transformer`` the parse builds its results inline. The
    lexer is Lark's own: `parse` drives it with `aida_kb.dsl.lexer.FastContextualLexer`.
    ``lexer_callbacks`` (terminal name -> function of the token) see every token of those
    terminals, the ignored comments too (the formatter collects them so).

    The tables are built from the packaged grammar in memory at every start (about 30 ms) and
    never cached: Lark's cache is a pickle under a predictable name in the shared temporary
    directory, and unpickling a file another user can write runs their code.
    """
    return Lark(
        grammar_path().read_text(encoding="utf-8"),
        parser="lalr",
        lexer="contextual",
        maybe_placeholders=True,
        keep_all_tokens=True,
        cache=False,
        transformer=transformer,
        lexer_callbacks=lexer_callbacks or {},
    )


def _parser() -> Lark:
    global _lark
    if _lark is None:
        _lark = make_lark(_builder)
        install_fast_lexer(_lark)
    return _lark


def parse(text: str, file: str = "<string>") -> ParseResult:
    """Parse one ``.kb`` source text.

    Parameters
    ----------
    text : str
        The source.
    file : str
        The file name put into every span and diagnostic.

    Returns
    -------
    ParseResult
        The module of every declaration that parsed, the syntax diagnostics (codes KB001-KB099)
        sorted by position, and the names of the declarations that did not parse. Never raises.
    """
    # The AST is a tree of fresh objects without reference cycles: the cyclic garbage
    # collector would only re-scan them over and over (superlinear on large files).
    collecting = gc.isenabled()
    gc.disable()
    try:
        with _lock:
            return _parse_locked(text, file)
    except Exception as exc:  # the last safety net: parse() must never raise
        span = Span.point(file, 1, 1)
        diag = Diagnostic(
            codes.INTERNAL_PARSER_ERROR.code,
            codes.INTERNAL_PARSER_ERROR.severity,
            f"internal parser error: {type(exc).__name__}: {exc}",
            span,
        )
        return ParseResult(ast.Module(file, (), span), (diag,))
    finally:
        if collecting:
            gc.enable()


def _module_span(text: str, file: str) -> Span:
    last_start = text.rfind("\n") + 1
    return Span(file, 1, 1, text.count("\n") + 1, len(text) - last_start + 1)


def _keyword_as_name(exc: UnexpectedInput) -> bool:
    """Lark's ``on_error``: a keyword where a name may stand is that name (keywords are
    contextual, docs/language.md §1). An LALR state shared by several contexts lets the
    contextual lexer read ``weight`` as the keyword after a binding's number (where only
    a relation could take it): retyped, the parse goes on."""
    if not isinstance(exc, UnexpectedToken) or "NAME" not in exc.expected:
        return False
    tok = exc.token
    if tok.type == "NAME" or not NAME_PATTERN.fullmatch(str(tok)) or exc.interactive_parser is None:
        return False
    exc.interactive_parser.feed_token(Token.new_borrow_pos("NAME", str(tok), tok))
    return True


def _parse_locked(text: str, file: str) -> ParseResult:
    lark = _parser()
    if text.startswith(BOM):  # a byte-order mark is no column of the first line
        text = text[1:]
    _builder.reset(file, 0)
    try:
        items: list[ast.Item] = lark.parse(text, on_error=_keyword_as_name)  # type: ignore[assignment]
    except UnexpectedInput:
        pass
    else:
        diags = tuple(sorted(_builder.diagnostics, key=Diagnostic.sort_key))
        return ParseResult(ast.Module(file, tuple(items), _module_span(text, file)), diags)
    return _recover(lark, text, file)


# ---- recovery -----------------------------------------------------------------------------------
_SCAN = re.compile(
    r'//[^\n]*|/\*.*?(?:\*/|\Z)|"(?:[^"\\\n]|\\.)*"?'
    r"|(?<![A-Za-z0-9_-])(abstract|concept|template|instance|import|layers)(?![A-Za-z0-9_-])",
    re.S,
)
_DECL_NAME = re.compile(r"(?:abstract\s+)?(?:concept|template|instance)\s+([A-Za-z_][A-Za-z0-9_]*)")


def _declaration_starts(text: str) -> list[int]:
    """Offsets where a top-level declaration keyword starts (outside strings and comments)."""
    starts: list[int] = []
    last_kw = ""
    last_end = 0
    for m in _SCAN.finditer(text):
        kw = m.group(1)
        if kw is None:
            continue
        if kw == "concept" and last_kw == "abstract" and not text[last_end : m.start()].strip():
            last_kw = kw
            continue
        starts.append(m.start())
        last_kw, last_end = kw, m.end()
    return starts


_MEMBER_START = re.compile(
    r'//[^\n]*|/\*.*?(?:\*/|\Z)|"(?:[^"\\\n]|\\.)*"?'
    r"|(?<![A-Za-z0-9_.-])(optional\s+part|part|con-of|attribute|adjacent|constraint|measure"
    r"|frame|orient|unseen|attach|when|touching)(?![A-Za-z0-9_-])",
    re.S,
)
#: A concept body with more broken members than this is reported up to this many (each retry
#: parses the declaration again).
MAX_MEMBER_ERRORS = 50


def _member_starts(text: str, body: int) -> list[int]:
    """Offsets in `text` after `body` where a concept member starts (outside strings and
    comments)."""
    return [m.start() for m in _MEMBER_START.finditer(text, body) if m.group(1) is not None]


def _blank(text: str, start: int, end: int) -> str:
    """`text` with ``[start, end)`` replaced by blanks (line breaks kept: positions hold)."""
    cut = text[start:end]
    return text[:start] + re.sub(r"[^\n]", " ", cut) + text[end:]


def _error_offset(exc: UnexpectedInput, text: str) -> int:
    if isinstance(exc, UnexpectedToken):
        if exc.token.type == "$END":
            return len(text)
        return exc.token.start_pos if exc.token.start_pos is not None else len(text)
    return exc.pos_in_stream if exc.pos_in_stream is not None else len(text)


def _parse_declaration(
    lark: Lark, padded: str, file: str, line_index: int, last: bool, incomplete: set[str]
) -> tuple[list[ast.Item], list[Diagnostic], bool]:
    """Parse one declaration (`padded`: blanks before it keep its columns), member by member.

    A syntax error inside a concept's body blanks the broken member (from its keyword to the
    next member's) and parses again, so that every broken member is reported and the sound
    ones are kept; a body that the next declaration cuts short (not `last`) is ``KB012`` and
    closed. Returns the items, the diagnostics and whether the declaration had an error; a
    concept kept without its broken members is added to `incomplete`.
    """
    diags: list[Diagnostic] = []
    attempt = padded
    brace = padded.find("{")
    is_concept = _DECL_NAME.match(padded.lstrip()) is not None and (
        padded.lstrip().startswith(("concept", "abstract"))
    )
    closed = False
    for _ in range(MAX_MEMBER_ERRORS):
        _builder.reset(file, line_index)
        try:
            items: list[ast.Item] = lark.parse(attempt, on_error=_keyword_as_name)  # type: ignore[assignment]
        except UnexpectedInput as exc:
            pos = _error_offset(exc, attempt)
            at_end = isinstance(exc, UnexpectedToken) and exc.token.type == "$END"
            expects_brace = isinstance(exc, UnexpectedToken) and "RBRACE" in exc.expected
            if at_end and brace >= 0 and not closed and expects_brace:
                # the body runs to the next declaration (or the end of the file): say so,
                # close it, and parse its members
                unclosed = describe(lark, exc, attempt, file, line_index)
                diags.append(unclosed if last else _unclosed(padded, brace, file, line_index))
                attempt = attempt.rstrip() + " }"
                closed = True
                continue
            diags.append(describe(lark, exc, attempt, file, line_index))
            if not is_concept or brace < 0 or pos <= brace or at_end:
                return [], [*diags, *_builder.diagnostics], True
            starts = _member_starts(attempt, brace + 1)
            before = [p for p in starts if p < pos]
            if not before:
                return [], [*diags, *_builder.diagnostics], True
            after = [p for p in starts if p > pos]
            stop = after[0] if after else attempt.rfind("}")
            if stop <= before[-1]:
                stop = len(attempt.rstrip()) - (1 if attempt.rstrip().endswith("}") else 0)
            attempt = _blank(attempt, before[-1], stop)
            continue
        if diags and is_concept:
            incomplete.update(i.name.text for i in items if isinstance(i, ast.Concept))
        return items, [*diags, *_builder.diagnostics], bool(diags)
    return [], diags, True


def _unclosed(padded: str, brace: int, file: str, line_index: int) -> Diagnostic:
    """``KB012`` at the '{' of a declaration that the next declaration cuts short."""
    line = padded.count("\n", 0, brace) + 1 + line_index
    column = brace - (padded.rfind("\n", 0, brace) + 1) + 1
    end_line = line_index + padded.rstrip().count("\n") + 2
    name = _DECL_NAME.match(padded.lstrip())
    what = f"the body of {name.group(0).split()[-2]} {name.group(1)}" if name else "this body"
    return diagnostic(
        codes.UNCLOSED_BODY,
        f"'{{' of {what} is not closed before the next declaration",
        Span(file, line, column, line, column + 1),
        f"close it with '}}' before line {end_line}",
    )


def _recover(lark: Lark, text: str, file: str) -> ParseResult:
    line_starts = [0] + [i + 1 for i, ch in enumerate(text) if ch == "\n"]
    bounds = _declaration_starts(text)
    if not bounds or bounds[0] != 0:
        bounds.insert(0, 0)
    bounds.append(len(text))
    items: list[ast.Item] = []
    diags: list[Diagnostic] = []
    broken: set[str] = set()
    incomplete: set[str] = set()
    pairs = list(itertools.pairwise(bounds))
    for index, (start, end) in enumerate(pairs):
        chunk = text[start:end]
        if not chunk.strip():
            continue
        line_index = bisect.bisect_right(line_starts, start) - 1
        column = start - line_starts[line_index] + 1
        padded = " " * (column - 1) + chunk
        last = not any(text[s:e].strip() for s, e in pairs[index + 1 :])
        found, found_diags, failed = _parse_declaration(
            lark, padded, file, line_index, last, incomplete
        )
        items.extend(found)
        diags.extend(found_diags)
        if failed and not found:
            m = _DECL_NAME.match(chunk)
            if m:
                broken.add(m.group(1))
    diags = list(dict.fromkeys(diags))
    diags.sort(key=Diagnostic.sort_key)
    module = ast.Module(file, tuple(items), _module_span(text, file))
    return ParseResult(module, tuple(diags), frozenset(broken), frozenset(incomplete))
