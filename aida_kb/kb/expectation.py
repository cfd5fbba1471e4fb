"""Expectations: ``.kb`` files of instances that say what an interpretation must find.

An interpretation fixture (docs/language.md 5.1, docs/testing.md) is a file of instance
declarations, importing the knowledge base, with *annotations*: line comments that start
with ``expect:``. The compiler reads the instances as in any file; this module reads the
annotations, checks them against the knowledge base (`check_expectations`, run by the
compiler, so ``aida-kb lint`` catches a wrong expectation before it is run) and builds the
expected instance tree (`expected_tree`) that ``aida-kb test`` compares a result with.

The annotations, each on a line of its own::

    // expect: verdict verified              (or doubtful, nothing: one per file)
    // expect: reject body.roof of GableRoof by slopes
    // expect: tolerance 0.5 deg, 5 cm        (the file's tolerances for measured values)

and after an attribute value, on its line: ``pitch = 38 deg  // expect: +- 1 deg``.

Pure Python: ``lint`` imports it, so no numpy here.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast
from aida_kb.kb.relations import SCALE, UNIT_KIND
from aida_kb.kb.resolve import Table, diag, did_you_mean

if TYPE_CHECKING:  # the pydantic model: lint imports this module and must start fast
    from aida_kb.kb.model import KnowledgeBase

__all__ = [
    "DEFAULT_TOLERANCE",
    "INSERTED_DOC",
    "VERDICTS",
    "VERDICT_DOC",
    "Annotations",
    "ExpectedTree",
    "Node",
    "Rejection",
    "check_expectations",
    "expected_tree",
    "line_comments",
    "read_annotations",
]

INSERTED_DOC = "inserted from the knowledge base: no view shows this part"
"""The doc string that marks an instance inserted from the knowledge (no view shows it)."""

VERDICT_DOC = "verdict: "
"""The goal instance's doc string in a written interpretation starts with this."""

VERDICTS = ("verified", "doubtful", "nothing")
"""The verdicts an interpretation can get (aida_kb.interpret.verdict)."""

DEFAULT_TOLERANCE: dict[str, float] = {"rad": math.radians(0.5), "m": 0.05}
"""How far a measured value may lie from its expected value when neither the value nor the
file gives a tolerance, in SI (radians, metres): half a degree and 5 cm are ten times the
precision a written interpretation keeps (0.01 deg, 1 mm) and well below what telling
alternatives apart needs (a wing at 90 or 135 degrees, a roof pitch 15 degrees off), so a
re-run that only moves the numbers by solver noise passes and a changed result does not."""

_PREFIX = re.compile(r"//\s*expect:\s*")
_QUANTITY = re.compile(r"(-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?)[ \t]*([A-Za-z_]\w*)")
_REJECT = re.compile(r"reject\s+(\S+)\s+of\s+([A-Za-z_]\w*)(?:\s+by\s+(\S+))?\s*$")
_STEP = re.compile(r"([A-Za-z_]\w*)(?:\[(\d+)\])?$")
_AUTO_LABEL = re.compile(r"([A-Za-z_]\w*)#\d+(?:/\d+)?$")


@dataclass(frozen=True, slots=True)
class Comment:
    """A ``//`` comment: where it starts (1-based line and column), its text from ``//`` on,
    and whether code stands before it on its line (a trailing comment)."""

    line: int
    column: int
    text: str
    trailing: bool


def line_comments(text: str) -> list[Comment]:
    """Every ``//`` comment of a ``.kb`` source, in order (not those inside strings or
    ``/* */`` comments). Strings end at their line (``KB002``), as the lexer reads them."""
    out: list[Comment] = []
    i, n, line, col0 = 0, len(text), 1, 0  # col0: index of the current line's start
    code_on_line = False
    while i < n:
        c = text[i]
        if c == "\n":
            i, line, col0, code_on_line = i + 1, line + 1, i + 1, False
        elif c == '"':
            j = i + 1
            while j < n and text[j] not in '"\n':
                j += 2 if text[j] == "\\" else 1
            i, code_on_line = min(j + 1, n) if j < n and text[j] == '"' else j, True
        elif text.startswith("//", i):
            end = text.find("\n", i)
            end = n if end < 0 else end
            out.append(Comment(line, i - col0 + 1, text[i:end].rstrip(), code_on_line))
            i = end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            newlines = text.count("\n", i, end)
            if newlines:
                line += newlines
                col0 = text.rfind("\n", i, end) + 1
                code_on_line = False
            i = end
        else:
            if not c.isspace():
                code_on_line = True
            i += 1
    return out


@dataclass(frozen=True, slots=True)
class Rejection:
    """``// expect: reject ROLE of CONCEPT by CONSTRAINT``: the constraint labelled
    CONSTRAINT rejects the alternative that makes the instance at role path ROLE a CONCEPT;
    without ``by CONSTRAINT`` (`constraint` None) the alternative is tried and every
    hypothesis of it rejected, for whatever reason."""

    role: str
    concept: str
    constraint: str | None
    span: Span


@dataclass(frozen=True, slots=True)
class Annotations:
    """The ``expect:`` annotations of one file (see the module docstring).

    verdict : the expected verdict, or None when the file gives none
    tolerance : the file's tolerances by SI unit ("rad", "m"); absent: `DEFAULT_TOLERANCE`
    value_tolerances : line -> (tolerance in SI, its unit "rad"/"m") of a value on that line
    spans : where each annotation is ("verdict", "tolerance"), for messages
    problems : the annotations that could not be read
    """

    verdict: str | None = None
    rejections: tuple[Rejection, ...] = ()
    tolerance: Mapping[str, float] = field(default_factory=dict)
    value_tolerances: Mapping[int, tuple[float, str]] = field(default_factory=dict)
    spans: Mapping[str, Span] = field(default_factory=dict)
    problems: tuple[Diagnostic, ...] = ()
    #: the file-level annotation lines as written (``--update`` keeps them)
    lines: tuple[str, ...] = ()
    #: line -> the trailing annotation as written (``--update`` keeps it)
    trailing: Mapping[int, str] = field(default_factory=dict)

    @property
    def present(self) -> bool:
        """True when the file has any annotation (it is an expectation)."""
        return bool(self.spans or self.rejections or self.value_tolerances or self.problems)


def _quantity(text: str) -> tuple[float, str] | None:
    """``1 deg`` -> (radians, "rad"), ``5 cm`` -> (0.05, "m"); None if not an angle or length."""
    m = _QUANTITY.fullmatch(text.strip())
    if m is None or m.group(2) not in SCALE or UNIT_KIND[m.group(2)] == "image":
        return None
    value = float(m.group(1)) * SCALE[m.group(2)]
    if not math.isfinite(value) or value < 0:
        return None
    return value, ("rad" if UNIT_KIND[m.group(2)] == "angle" else "m")


def read_annotations(text: str, file: str) -> Annotations:
    """The ``// expect:`` annotations of the source `text` of `file` (none: empty)."""
    verdict: str | None = None
    rejections: list[Rejection] = []
    tolerance: dict[str, float] = {}
    values: dict[int, tuple[float, str]] = {}
    spans: dict[str, Span] = {}
    problems: list[Diagnostic] = []
    lines: list[str] = []
    trailing: dict[int, str] = {}
    for c in line_comments(text):
        m = _PREFIX.match(c.text)
        if m is None:
            continue
        body = c.text[m.end() :].strip()
        span = Span(file, c.line, c.column, c.line, c.column + len(c.text))

        def bad(message: str, hint: str, span: Span = span) -> None:
            problems.append(diag(codes.BAD_EXPECTATION, message, span, hint))

        if c.trailing:
            q = _quantity(body[2:]) if body.startswith("+-") else None
            if q is None:
                bad(
                    f"'{body}' after a value: expected a tolerance such as '+- 1 deg' or '+- 5 cm'",
                    "a tolerance is '+-' and a non-negative angle or length",
                )
            else:
                values[c.line] = q
                trailing[c.line] = c.text
            continue
        lines.append(c.text)
        word = body.split(maxsplit=1)[0] if body else ""
        rest = body[len(word) :].strip()
        if word == "verdict":
            if rest not in VERDICTS:
                bad(f"unknown verdict '{rest}'", f"one of {', '.join(VERDICTS)}")
            elif "verdict" in spans:
                bad("the verdict is expected twice", "keep one '// expect: verdict' line")
            else:
                verdict, spans["verdict"] = rest, span
        elif word == "reject":
            r = _REJECT.match(body)
            if r is None:
                bad(
                    f"'{body}' is no rejection",
                    "write '// expect: reject ROLE of CONCEPT [by CONSTRAINT]', as in "
                    "'// expect: reject body.roof of GableRoof by slopes'",
                )
            else:
                rejections.append(Rejection(r.group(1), r.group(2), r.group(3), span))
        elif word == "tolerance":
            for item in (p for p in rest.split(",") if p.strip()) if rest else [""]:
                q = _quantity(item)
                if q is None:
                    bad(
                        f"'{item.strip()}' is no tolerance",
                        "an angle or a length: '// expect: tolerance 0.5 deg, 5 cm'",
                    )
                elif q[1] in tolerance:
                    bad(f"the {q[1]} tolerance is given twice", "give each unit kind once")
                else:
                    tolerance[q[1]] = q[0]
            spans.setdefault("tolerance", span)
        else:
            bad(
                f"unknown annotation '{word}'",
                "an expectation annotation is 'verdict', 'reject' or 'tolerance', or "
                "'+- TOLERANCE' after a value",
            )
    return Annotations(
        verdict,
        tuple(rejections),
        tolerance,
        values,
        spans,
        tuple(problems),
        tuple(lines),
        trailing,
    )


# ---- checks (the compiler runs them: `aida-kb lint` of an expectation) --------------------
def _slot_in(table: Table, concept: str, role: str) -> tuple[str | None, int | None] | None:
    """The concept filling `role` of `concept` or of one of its specialisations, and the
    role's maximum count; None when no such role exists."""
    todo = [concept, *table.descendants(concept)]
    for c in todo:
        info = table.concepts.get(c)
        slot = info.slots.get(role) if info is not None else None
        if slot is not None and slot.kind != "attribute":
            return slot.concept, slot.max
    return None


def _role_concept(table: Table, goal: str, path: str) -> str | None:
    """The concept a role path from `goal` ends on (``body.wings[0]``: the wing's concept);
    None when a step names no role of the concept before it or its specialisations."""
    concept: str | None = goal
    for step in path.split("."):
        m = _STEP.fullmatch(step)
        if m is None or concept is None:
            return None
        found = _slot_in(table, concept, m.group(1))
        if found is None:
            return None
        concept = found[0]
    return concept


def _labels(table: Table) -> set[str]:
    return {r.label for info in table.concepts.values() for r in info.rules if r.label}


def _check_rejection(table: Table, goals: list[str], r: Rejection) -> Iterator[Diagnostic]:
    if r.concept not in table.concepts:
        yield diag(
            codes.UNKNOWN_CONCEPT,
            f"unknown concept '{r.concept}' in the expected rejection",
            r.span,
            did_you_mean(r.concept, table.concepts),
        )
        return
    filler = [c for g in goals for c in [_role_concept(table, g, r.role)] if isinstance(c, str)]
    if not filler:
        yield diag(
            codes.BAD_EXPECTATION,
            f"'{r.role}' is no role path from the goal ({', '.join(goals) or 'none'})",
            r.span,
            "a role path as the interpreter names instances: body.roof, body.wings[0]",
        )
    elif not any(table.is_a(r.concept, c) for c in filler):
        yield diag(
            codes.BAD_EXPECTATION,
            f"{r.concept} cannot fill '{r.role}', which takes a {filler[0]}",
            r.span,
        )
    if r.constraint is None:
        return
    auto = _AUTO_LABEL.fullmatch(r.constraint)
    if r.constraint not in _labels(table) and not (auto and auto.group(1) in table.concepts):
        yield diag(
            codes.BAD_EXPECTATION,
            f"no constraint of the knowledge base is labelled '{r.constraint}'",
            r.span,
            did_you_mean(r.constraint, _labels(table)),
        )


def _value_lines(table: Table, file: str) -> dict[int, str | None]:
    """Line -> the SI unit ("rad", "m", "") of the attribute value bound on it, for the
    instances of `file`; None where the binding's own check failed (an unknown concept or
    role, reported already: the tolerance after it is not judged)."""
    out: dict[int, str | None] = {}
    for inst in table.instances.values():
        if inst.span.file != file:
            continue
        info = table.concepts.get(inst.concept.text)
        for b in inst.bindings:
            slot = info.slots.get(b.role.text) if info is not None else None
            if slot is None:
                out[b.value.span.line] = None
                continue
            if slot.kind != "attribute":
                continue
            node = slot.node
            assert isinstance(node, ast.Attribute)
            unit = {"angle": "rad", "length": "m"}.get(node.type.text, "")
            out[b.value.span.line] = unit
    return out


def _tree_problems(table: Table, file: str, ann: Annotations) -> Iterator[Diagnostic]:
    """An expectation of a result has one goal instance that every other instance of the
    file hangs on; an expectation of nothing declares none."""
    mine = [i for i in table.instances.values() if i.span.file == file]
    where = ann.spans["verdict"]
    if ann.verdict == "nothing":
        for inst in mine:
            yield diag(
                codes.BAD_EXPECTATION,
                f"the verdict expected is 'nothing', but instance {inst.name.text} is declared",
                inst.name.span,
                "delete the instances, or expect 'verified' or 'doubtful'",
            )
        return
    uses = [
        item
        for inst in mine
        for b in inst.bindings
        for item in (b.value.items if isinstance(b.value, ast.ListExpr) else (b.value,))
        if isinstance(item, ast.Path) and item.is_simple
    ]
    bound = {item.dotted for item in uses}
    first: dict[str, ast.Path] = {}
    for item in uses:  # a tree: each instance fills one role (no sharing, no cycle)
        if item.dotted in first:
            yield diag(
                codes.BAD_EXPECTATION,
                f"instance {item.dotted} is bound twice: an expected instance fills one role",
                item.span,
                "declare an instance for each role it fills",
                ((first[item.dotted].span, "first bound here"),),
            )
        first.setdefault(item.dotted, item)
    top = table.layers[0] if table.layers else None
    goals = [
        i
        for i in mine
        if i.name.text not in bound
        and (info := table.concepts.get(i.concept.text)) is not None
        and info.layer == top
    ]
    if len(goals) != 1:
        yield diag(
            codes.BAD_EXPECTATION,
            f"an expected result has one goal instance (of a {top} concept, bound by no other "
            f"instance); this file has {len(goals)}",
            goals[1].name.span if len(goals) > 1 else where,
            "declare the goal, e.g. 'instance house of House { body = body }'",
        )
        return
    seen, todo = set(), [goals[0].name.text]
    while todo:
        name = todo.pop()
        if name in seen or name not in table.instances:
            continue
        seen.add(name)
        for b in table.instances[name].bindings:
            items = b.value.items if isinstance(b.value, ast.ListExpr) else (b.value,)
            todo += [i.dotted for i in items if isinstance(i, ast.Path) and i.is_simple]
    for inst in mine:
        if inst.name.text not in seen:
            yield diag(
                codes.BAD_EXPECTATION,
                f"instance {inst.name.text} does not hang on the goal instance "
                f"{goals[0].name.text}",
                inst.name.span,
                "bind it to a role of an instance below the goal, or delete it",
            )


def check_expectations(table: Table, sources: Mapping[str, str]) -> list[Diagnostic]:
    """The diagnostics of the ``expect:`` annotations of every file of the knowledge base
    (`read_annotations`): malformed ones, a rejection naming no concept (``KB100``), no role
    path or no constraint label, a value tolerance on a line without an attribute value or of
    another unit kind (``KB132``), an expected tree with no single goal or instances off it
    (``BAD_EXPECTATION``)."""
    out: list[Diagnostic] = []
    top = table.layers[0] if table.layers else None
    goals = sorted(c for c, info in table.concepts.items() if info.layer == top)
    for file, text in sources.items():
        if "expect:" not in text:
            continue
        ann = read_annotations(text, file)
        if not ann.present:
            continue
        out += ann.problems
        if not table.layers:  # nothing resolved (an import missing): no more to say here
            continue
        for r in ann.rejections:
            out += _check_rejection(table, goals, r)
        value_lines = _value_lines(table, file)
        for line, (_, unit) in ann.value_tolerances.items():
            span = Span(file, line, 1, line, 2)
            if line not in value_lines:
                out.append(
                    diag(
                        codes.BAD_EXPECTATION,
                        "a tolerance '+- ...' stands after an attribute value, on its line",
                        span,
                        "put it after a binding such as 'pitch = 38 deg'",
                    )
                )
            elif value_lines[line] is not None and value_lines[line] != unit:
                kind = {"rad": "an angle", "m": "a length", "": "a number"}[value_lines[line] or ""]
                out.append(diag(codes.UNIT_MISMATCH, f"the value's tolerance must be {kind}", span))
        if ann.verdict is not None:
            out += _tree_problems(table, file, ann)
    return out


# ---- the expected tree ---------------------------------------------------------------------
@dataclass
class Node:
    """One instance of an interpretation tree, by role path (docs/language.md 5.1).

    concept : its concept (after specialisation); inserted : no view shows it
    children : role -> the role paths of the instances filling it
    evidence : con-of role -> the evidence ids ("VIEW/REGION") bound to it
    values : attribute -> value in SI (radians, metres)
    span : where the instance is declared (expected trees only)
    binding_spans : role or attribute -> where it is bound (expected trees only)
    """

    concept: str
    inserted: bool = False
    children: dict[str, tuple[str, ...]] = field(default_factory=dict)
    evidence: dict[str, tuple[str, ...]] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)
    span: Span | None = None
    binding_spans: dict[str, Span] = field(default_factory=dict)


@dataclass
class ExpectedTree:
    """The expected instances of one expectation file, by role path ('' the goal), with its
    annotations; ``nodes`` is empty when nothing is expected."""

    file: str
    annotations: Annotations
    nodes: dict[str, Node] = field(default_factory=dict)


def child_path(parent: str, role: str, index: int, several: bool) -> str:
    """The role path of a filler of `role` of the instance at `parent` (``body.wings[0]``)."""
    path = f"{parent}.{role}" if parent else role
    return f"{path}[{index}]" if several else path


def expected_tree(kb: KnowledgeBase, file: str, text: str) -> ExpectedTree:
    """The instances `file` (source `text`) declares in `kb` (its compiled expectation, lint
    clean), walked from the goal instance down and keyed by role path."""
    ann = read_annotations(text, file)
    tree = ExpectedTree(file, ann)
    mine = {n: i for n, i in kb.instances.items() if i.span.file == file}
    bound = {c for i in mine.values() for b in i.bindings.values() for c in b.instances}
    top = kb.layers[0] if kb.layers else None
    goals = [n for n, i in mine.items() if n not in bound and kb.concepts[i.concept].layer == top]
    if len(goals) != 1:
        return tree
    todo, seen = [("", goals[0])], set()
    while todo:
        role, name = todo.pop()
        if name in seen:  # shared or cyclic (KB143 for a checked file): walked once
            continue
        seen.add(name)
        inst = kb.instances[name]
        concept = kb.concepts[inst.concept]
        node = Node(inst.concept, inst.doc == INSERTED_DOC, span=inst.span)
        tree.nodes[role] = node
        for b in inst.bindings.values():
            node.binding_spans[b.role] = b.span
            if b.value is not None:
                node.values[b.role] = b.value
                continue
            if b.evidence:
                node.evidence[b.role] = b.evidence
            slot = concept.parts.get(b.role) or concept.con_ofs.get(b.role)
            several = slot is None or slot.max != 1
            paths = [child_path(role, b.role, k, several) for k in range(len(b.instances))]
            if paths:
                node.children[b.role] = tuple(paths)
            todo += list(zip(paths, b.instances, strict=True))
    return tree
