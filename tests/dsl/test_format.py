"""The formatter: idempotent, meaning-preserving, comment-preserving, on every .kb in the repo."""

from __future__ import annotations

import re
from pathlib import Path
from random import Random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aida_kb.dsl.format import _leaves, _tree_parser, format_source, strip_spans
from aida_kb.dsl.parser import parse
from aida_kb.errors import FormatError

ROOT = Path(__file__).resolve().parents[2]
KB_FILES = sorted(p for p in (ROOT / "kb").rglob("*.kb"))
PARSING = [p for p in KB_FILES if parse(p.read_text(encoding="utf-8"), str(p)).ok]
DOC_BLOCKS = re.findall(
    r"^```kb\n(.*?)^```", (ROOT / "docs" / "language.md").read_text(encoding="utf-8"), re.S | re.M
)
#: A docs example is a whole file or the members of a concept body (tests/dsl/test_language_doc).
_WRAPS = ("{}", "concept Example in world {{\n{}\n}}")
COMMENT = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:[^"\\\n]|\\.)*"', re.S)


def _comments(text: str) -> list[str]:
    """Every comment of a source text, in order (strings skipped), trailing blanks cut."""
    return [m.group().rstrip() for m in COMMENT.finditer(text) if not m.group().startswith('"')]


def _same_meaning(a: str, b: str) -> bool:
    pa, pb = parse(a), parse(b)
    return pa.ok and pb.ok and strip_spans(pa.module.items) == strip_spans(pb.module.items)


def _check(text: str) -> str:
    out = format_source(text).text
    assert _same_meaning(text, out)
    assert format_source(out).text == out, "not idempotent"
    assert _comments(out) == _comments(text), "a comment was lost or changed"
    return out


def test_most_repository_files_parse() -> None:
    """All but the golden files of syntax errors (kb/examples/broken_syntax*.kb)."""
    refused = {p.name for p in KB_FILES} - {p.name for p in PARSING}
    assert refused == {"broken_syntax.kb", "broken_syntax_members.kb"}
    assert len(PARSING) >= 10


@pytest.mark.parametrize("path", PARSING, ids=lambda p: str(p.relative_to(ROOT)))
def test_repository_file_is_formatted_idempotently_and_keeps_its_meaning(path: Path) -> None:
    _check(path.read_text(encoding="utf-8"))


def test_every_docs_example_is_formatted_idempotently() -> None:
    checked = 0
    for block in DOC_BLOCKS:
        for wrap in _WRAPS:
            text = wrap.format(block)
            if parse(text).ok:
                _check(text)
                checked += 1
                break
    assert checked == len(DOC_BLOCKS) >= 15


def test_canonical_layout() -> None:
    src = (
        "layers scene>world   >image\n"
        'template t(a:P,b :P,tol: angle=1deg){"doc" angle(a,b)==90 deg+-tol parallel(a,b)}\n'
        "concept P in world{con-of region : Region[0 .. 1]}\n"
        "concept House in scene {\n\n\n  part front,back : P  // trailing\n"
        "  constraint c : t( front , back ) weight 2 reject above 3 deg\n\n}\n"
        "concept Region in image { }\n"
        'instance h of House { front = [ 1 , 2 ] n = 2\n k = "x" }\n'
    )
    assert _check(src) == (
        "layers scene > world > image\n"
        "\n"
        "template t(a: P, b: P, tol: angle = 1 deg) {\n"
        '    "doc"\n'
        "    angle(a, b) == 90 deg +- tol\n"
        "    parallel(a, b)\n"
        "}\n"
        "\n"
        "concept P in world {\n"
        "    con-of region: Region [0..1]\n"
        "}\n"
        "\n"
        "concept House in scene {\n"
        "    part front, back: P  // trailing\n"
        "    constraint c: t(front, back) weight 2 reject above 3 deg\n"
        "}\n"
        "\n"
        "concept Region in image {}\n"
        "\n"
        "instance h of House {\n"
        "    front = [1, 2]\n"
        "    n = 2\n"
        '    k = "x"\n'
        "}\n"
    )


def test_comments_keep_their_places() -> None:
    src = (
        "// head\n\n/* block\n   over lines */\nlayers a > b\n"
        "concept X in a { // after brace\n"
        "    // own line\n"
        "    adjacent pairs((p, q), // mid member\n"
        "        /* own */ (r, s))\n"
        "    part p, /* inline */ q, r, s: X\n"
        "    // before the brace\n"
        "}\n// tail\n"
    )
    out = _check(src)
    assert out == (
        "// head\n\n/* block\n   over lines */\nlayers a > b\n\n"
        "concept X in a {  // after brace\n"
        "    // own line\n"
        "    adjacent pairs((p, q),  // mid member\n"
        "        /* own */\n"
        "        (r, s))\n"
        "    part p, /* inline */ q, r, s: X\n"
        "    // before the brace\n"
        "}\n// tail\n"
    )


def test_syntax_error_is_refused_with_its_place() -> None:
    with pytest.raises(FormatError, match=r"^f\.kb:2:23: not formatted: KB\d{3} "):
        format_source("layers a\nconcept X in a { part : Y }\n", "f.kb")


def test_crlf_and_empty_sources() -> None:
    assert format_source("layers a > b\r\n").text == "layers a > b\n"
    assert format_source("").text == ""
    assert format_source("\n\n").text == ""
    assert format_source("// only\n").text == "// only\n"


# ---- generated sources: the repository's declarations re-joined with random blanks and comments
def _declarations(text: str) -> list[list[str]]:
    """The token texts of each top-level declaration of a source that parses."""
    return [[str(t) for t in _leaves(d)] for d in _tree_parser().parse(text).children]


#: Every declaration of every .kb file of the repository that parses (layers, imports,
#: templates, concepts, instances): the generated files need only parse, not compile.
_DECLS = [d for p in PARSING for d in _declarations(p.read_text(encoding="utf-8"))]
_BLANKS = [" ", "\n", "\t", "  \n\n"]
_SEPARATORS = [*_BLANKS, " /* c */ ", " // c\n", "\n// own\n", "\n/* a\n b */\n"]


@settings(max_examples=25, derandomize=True, deadline=None)
@given(st.lists(st.integers(0, len(_DECLS) - 1), min_size=1, max_size=5), st.randoms())
def test_generated_layouts_format_to_the_same_code(picked: list[int], rnd: Random) -> None:
    tokens = [t for i in picked for t in _DECLS[i]]
    commented = rnd.random() < 0.5
    choices = _SEPARATORS if commented else _BLANKS
    text = "".join(t + rnd.choice(choices) for t in tokens)
    plain = " ".join(tokens)
    if not _same_meaning(text, plain):  # a line break split a number from its unit
        return
    out = _check(text)
    if not commented:  # without comments, the layout does not depend on the original one
        assert re.sub(r"\n\n+", "\n", out) == re.sub(r"\n\n+", "\n", format_source(plain).text)
