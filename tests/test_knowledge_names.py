"""The code knows no building: no identifier declared in kb/buildings.kb is written in
aida_kb/ (issue 13, deliverable 2).

What is scanned, and why
------------------------
The identifiers are every concept, template, role (part and con-of), attribute and
attachment name kb/buildings.kb declares, less the words of the language itself (keywords,
primitive relations, measures, directions, value types: an attribute may be called ``height``
after the measure ``height(self)``).

Knowledge reaches the code only as *strings*: role paths (``body.roof.front``), concept and
attribute names, looked up in the compiled knowledge base. A Python identifier cannot look
anything up in a ``.kb`` file (``Frame.front``, ``Frame.right`` are the axes of an instance
frame, a geometric notion of the language's directions, not roles), so the scan reads the
*string literals* of every module with Python's ``ast`` (docstrings excepted: prose may
mention the knowledge to explain it). A literal is a hit when it is a role path — names joined
by dots, optionally indexed (``wings[0]``), an f-string's replacement field standing for a
name — one of whose names is declared (``"front"``, ``f"{body}.roof"``, ``"body.wings[0]"``).
Prose such as ``"region {rid} lies outside ..."`` is no role path.

Exempt: the synthetic renderer `aida_kb/synth` and the test helpers `aida_kb/testing`, which
name the parts they render and check. And three declared names that are also the vocabulary
of stereo vision (`VISION_WORDS`: ``left``/``right``, the two images of a stereo pair;
``contours``, the image-layer evidence table) are allowed in a module only when that module
cannot reach the knowledge: it imports nothing from `aida_kb.dsl`, `aida_kb.kb` or
`aida_kb.interpret` (checked from its import statements, function-local ones included). In
any module that reads the knowledge they are hits like every other name. The alternative,
renaming the walls of buildings.kb (``left`` -> ``west``), would hide the collision without
making the scan stronger.
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

from aida_kb.testing.knowledge import declared_identifiers

ROOT = Path(__file__).resolve().parents[1]
NAME = r"[A-Za-z_][A-Za-z0-9_]*(?:\[\d*\]?)?"
PATH = re.compile(rf"\.?{NAME}(?:\.{NAME})*\.?")
WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
EXEMPT_PACKAGES = {"synth", "testing"}
#: declared names that are also words of stereo vision, allowed where no knowledge is read
VISION_WORDS = {
    "left": "the left image of a stereo pair",
    "right": "the right image of a stereo pair",
    "contours": "the image-layer evidence table of region outlines",
}
KNOWLEDGE_PACKAGES = ("aida_kb.dsl", "aida_kb.kb", "aida_kb.interpret")


@functools.cache
def _declared() -> frozenset[str]:
    return declared_identifiers(ROOT / "kb" / "buildings.kb")


def _literals(tree: ast.Module) -> list[tuple[int, str]]:
    """(line, text) of every string literal that is not a docstring; an f-string's text has
    ``X`` for each replacement field."""
    docs: set[int] = set()
    parts: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            first = node.body[0] if node.body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                docs.add(id(first.value))
        if isinstance(node, ast.JoinedStr):
            parts |= {id(v) for v in node.values}
    out: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            text = "".join(
                v.value if isinstance(v, ast.Constant) and isinstance(v.value, str) else "X"
                for v in node.values
            )
            out.append((node.lineno, text))
        elif (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and id(node) not in docs
            and id(node) not in parts
        ):
            out.append((node.lineno, node.value))
    return sorted(out)


def _reads_knowledge(tree: ast.Module) -> bool:
    """True if the module imports from the language, the knowledge base or the interpreter."""
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.ImportFrom) and node.module is not None:
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        if any(n == p or n.startswith(p + ".") for n in names for p in KNOWLEDGE_PACKAGES):
            return True
    return False


def hits_in(tree: ast.Module, names: frozenset[str], where: str) -> list[str]:
    """The literals of one module that name an identifier of `names` (see the docstring)."""
    allowed = set() if _reads_knowledge(tree) else set(VISION_WORDS)
    found: list[str] = []
    for line, text in _literals(tree):
        stripped = text.strip()
        if not PATH.fullmatch(stripped):
            continue
        named = sorted((set(WORD.findall(stripped)) & names) - allowed)
        if named:
            found.append(f"{where}:{line}: {stripped!r} names {', '.join(named)}")
    return found


def hits() -> list[str]:
    """Every literal of aida_kb/ (not synth, not testing) naming an identifier of buildings.kb."""
    names = _declared()
    found: list[str] = []
    for path in sorted((ROOT / "aida_kb").rglob("*.py")):
        rel = path.relative_to(ROOT)
        if rel.parts[1] in EXEMPT_PACKAGES:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        found += hits_in(tree, names, str(rel))
    return found


def test_the_scan_finds_what_it_looks_for() -> None:
    names = _declared()
    assert {"HouseBody", "RoofPlane", "front", "roof", "tilt", "perpendicular"} <= names
    assert set(VISION_WORDS) <= names  # each exemption is a real collision
    assert "forward" not in names  # a direction of the language, not of the knowledge
    source = (
        '"""a docstring about body.roof.front"""\n'
        'x = "body.roof.front"\ny = f"{a}.tilt"\nz = f"region {r} lies outside"\n'
        'w = {"left": 1}\nv = "wings[0]"\n'
    )
    found = hits_in(ast.parse(source), names, "m.py")
    # 'left' is allowed here: this module imports nothing that reads the knowledge
    assert [h.split(": ", 1)[1] for h in found] == [
        "'body.roof.front' names body, front, roof",
        "'X.tilt' names tilt",
        "'wings[0]' names wings",
    ]
    # a module that reads the knowledge may not say 'left' either; one that does not, may
    reader = ast.parse('from aida_kb.kb import compile_path\nw = "left"\n')
    local = ast.parse(
        'def f():\n    from aida_kb.interpret.run import interpret\n    return "left"\n'
    )
    stereo = ast.parse('from aida_kb.io.scene import read_image\nw = "left"\nx = "body.front"\n')
    assert hits_in(reader, names, "r.py") == ["r.py:2: 'left' names left"]
    assert hits_in(local, names, "l.py") == ["l.py:3: 'left' names left"]
    assert hits_in(stereo, names, "s.py") == ["s.py:3: 'body.front' names body, front"]


def test_no_identifier_of_the_knowledge_base_is_written_in_the_code() -> None:
    found = hits()
    assert not found, f"{len(found)} hits:\n" + "\n".join(found)
