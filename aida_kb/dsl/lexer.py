"""A faster driver for Lark's contextual lexer: the same tokens, one tight loop.

Lark's `ContextualLexer` keeps one scanner (a compiled alternation of the terminals the parser
accepts) per LALR state and goes through several layers of calls per token. `FastContextualLexer`
wraps a built contextual lexer and runs the very same per-state scanners and keyword callbacks
in one loop with local variables. Every token it yields equals the one Lark's lexer would
yield: type, value, start and end position, line and column. Where the text does not match
(a syntax error), it hands the rest of the text to the wrapped lexer, so that the errors are
Lark's own.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from lark import Lark, Token
from lark.lexer import ContextualLexer, LexerState

__all__ = ["FastContextualLexer", "install"]

_Match = Callable[[str, int, int], Any]
_str_new = str.__new__


def _matcher(mres: list[Any]) -> _Match:
    """One match function over a scanner's compiled patterns (usually just one)."""
    if len(mres) == 1:
        return mres[0].match  # type: ignore[no-any-return]

    def match(text: str, pos: int, end: int) -> Any:
        for mre in mres:
            m = mre.match(text, pos, end)
            if m:
                return m
        return None

    return match


class FastContextualLexer:
    """Lark's contextual lexer, driven by one loop (see the module docstring).

    Parameters
    ----------
    inner : lark.lexer.ContextualLexer
        The contextual lexer Lark built for the grammar; its scanners and callbacks are reused,
        and it takes over at a syntax error.
    """

    def __init__(self, inner: ContextualLexer) -> None:
        self.inner = inner
        #: LALR state -> (match function, keyword callbacks, terminals that may hold newlines);
        #: filled on first use, as Lark builds its scanners (start-up stays short)
        self.states: dict[int, tuple[_Match, dict[str, Any], frozenset[str]]] = {}
        self._by_lexer: dict[int, tuple[_Match, dict[str, Any], frozenset[str]]] = {}
        self.ignore: frozenset[str] = frozenset(inner.root_lexer.ignore_types)  # type: ignore[attr-defined]

    def _entry(self, state: int) -> tuple[_Match, dict[str, Any], frozenset[str]]:
        lexer: Any = self.inner.lexers[state]
        entry = self._by_lexer.get(id(lexer))
        if entry is None:
            scanner = lexer.scanner  # builds the scanner and the keyword callbacks
            entry = (_matcher(scanner._mres), dict(lexer.callback), frozenset(lexer.newline_types))
            self._by_lexer[id(lexer)] = entry
        self.states[state] = entry
        return entry

    def lex(self, lexer_state: LexerState, parser_state: Any) -> Iterator[Token]:
        """The tokens of ``lexer_state``'s text, each in the parser's current context."""
        states = self.states
        ignore = self.ignore
        source: Any = lexer_state.text  # a TextSlice (Lark >= 1.2) or the text itself
        text: str = source if isinstance(source, str) else source.text
        end: int = len(source) if isinstance(source, str) else source.end
        ctr = lexer_state.line_ctr
        pos = ctr.char_pos
        line = ctr.line
        line_start = ctr.line_start_pos
        stack = parser_state.state_stack
        new = _str_new
        while pos < end:
            try:
                match, callbacks, newline_types = states[stack[-1]]
            except KeyError:
                match, callbacks, newline_types = self._entry(stack[-1])
            m = match(text, pos, end)
            if m is None:  # a syntax error: let Lark's own lexer raise it
                ctr.char_pos, ctr.line, ctr.line_start_pos = pos, line, line_start
                ctr.column = pos - line_start + 1
                yield from self.inner.lex(lexer_state, parser_state)
                return
            value: str = m.group()
            type_: str = m.lastgroup
            start, start_line, start_column = pos, line, pos - line_start + 1
            pos = m.end()
            if type_ in newline_types:
                newlines = value.count("\n")
                if newlines:
                    line += newlines
                    line_start = start + value.rindex("\n") + 1
            if type_ in ignore and type_ not in callbacks:
                continue
            tok: Any = new(Token, value)
            tok.type = type_
            tok.value = value
            tok.start_pos = start
            tok.line = start_line
            tok.column = start_column
            tok.end_line = line
            tok.end_column = pos - line_start + 1
            tok.end_pos = pos
            callback = callbacks.get(type_)
            if callback is not None:
                tok = callback(tok)
            if type_ in ignore:
                continue
            lexer_state.last_token = tok
            ctr.char_pos, ctr.line, ctr.line_start_pos = pos, line, line_start
            ctr.column = pos - line_start + 1
            yield tok
        ctr.char_pos, ctr.line, ctr.line_start_pos = pos, line, line_start
        ctr.column = pos - line_start + 1


def install(lark: Lark) -> bool:
    """Drive ``lark``'s contextual lexer with `FastContextualLexer`.

    Returns False, and leaves Lark's own lexer in place, when ``lark`` has no contextual lexer
    or its lexer lacks the internals the driver reuses (another Lark version).
    """
    frontend: Any = lark.parser
    inner = getattr(frontend, "lexer", None)
    if not isinstance(inner, ContextualLexer) or not _reusable(inner):
        return False
    frontend.lexer = FastContextualLexer(inner)
    return True


def _reusable(inner: ContextualLexer) -> bool:
    """Whether the contextual lexer has the per-state scanners and callbacks the driver uses."""
    try:
        lexers: Any = inner.lexers
        root: Any = inner.root_lexer
        some: Any = next(iter(lexers.values()))
        return (
            isinstance(lexers, dict)
            and isinstance(root.ignore_types, frozenset | set)
            and isinstance(some.scanner._mres, list)
            and isinstance(some.callback, dict)
            and isinstance(some.newline_types, frozenset | set)
        )
    except (AttributeError, StopIteration, TypeError):
        return False
