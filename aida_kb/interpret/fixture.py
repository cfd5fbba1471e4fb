"""Interpretation fixtures: run an expectation written in the language, compare, update.

A fixture (docs/testing.md) is an expectation file of instances (`aida_kb.kb.expectation`)
and the input it is about:

- a folder holding ``expected.kb`` and either ``evidence.json`` (`aida-kb evidence`) or a
  scene (``scene.yaml`` and its images: the whole of ``aida-kb reconstruct`` is run);
- or one file ``NAME.expected.kb`` beside its input, ``NAME.json`` (evidence) or the scene
  folder ``NAME/``.

`run_fixture` compiles the expectation with the knowledge base it imports (errors make the
fixture an *error*, not a failure), interprets the input with that knowledge base (the
expectation's own instances left out), judges the result as ``aida-kb interpret`` does and
compares (`compare`): the verdict, the instance tree by role path (instances up to naming:
concepts, that is the specialisations chosen, role bindings, inserted parts, evidence ids),
the measured values within their tolerances, and the rejections expected. Each difference
is one line in the language's terms at the line of the expectation it contradicts
(``expected body.roof of GableRoof, got HipRoof``). With ``update`` a fixture that differs
is rewritten from the result (`updated_text`: the file's annotations and value tolerances
kept), atomically.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from aida_kb.diagnostics.core import Span
from aida_kb.interpret.kbfile import (
    GENERATED_HEAD,
    GENERATED_NOTES,
    evidence_roles,
    interpretation_kb,
    role_name,
)
from aida_kb.interpret.result import INSERTED, Interpretation
from aida_kb.kb.expectation import (
    DEFAULT_TOLERANCE,
    ExpectedTree,
    Node,
    Rejection,
    expected_tree,
)
from aida_kb.kb.model import KnowledgeBase

__all__ = [
    "EXPECTED_FILE",
    "EXPECTED_SUFFIX",
    "Difference",
    "Fixture",
    "Interpreter",
    "Outcome",
    "compare",
    "default_interpreter",
    "find_fixtures",
    "result_tree",
    "run_fixture",
    "updated_text",
]

EXPECTED_FILE = "expected.kb"
"""The expectation of a folder fixture."""
EXPECTED_SUFFIX = ".expected.kb"
"""The suffix of a one-file fixture's expectation, ``NAME.expected.kb``."""
EVIDENCE_FILE = "evidence.json"
"""The evidence of a folder fixture (otherwise the folder is a scene)."""

_CHOICES = re.compile(r"\[([^\]]*)\]")


@dataclass(frozen=True)
class Fixture:
    """An expectation file and its input: an evidence file, or a scene folder."""

    expectation: Path
    evidence: Path | None = None
    scene: Path | None = None


@dataclass(frozen=True)
class Difference:
    """One way the result contradicts the expectation, at the expectation's place."""

    span: Span | None
    message: str

    def __str__(self) -> str:
        where = f"{self.span.file}:{self.span.line}: " if self.span is not None else ""
        return where + self.message


@dataclass
class Outcome:
    """What running one fixture gave: passed, failed (the differences), error (why it could
    not run: a bad expectation or a missing input), or updated (rewritten from the result)."""

    fixture: Fixture
    status: Literal["passed", "failed", "error", "updated"]
    lines: list[str] = field(default_factory=list)
    seconds: float = 0.0


# ---- finding fixtures ----------------------------------------------------------------------
def _input_of(expectation: Path) -> Fixture:
    """The fixture of an expectation file (FileNotFoundError naming what is missing)."""
    name = expectation.name
    if name == EXPECTED_FILE:
        folder = expectation.parent
        if (folder / EVIDENCE_FILE).is_file():
            return Fixture(expectation, evidence=folder / EVIDENCE_FILE)
        if (folder / "scene.yaml").is_file():
            return Fixture(expectation, scene=folder)
        raise FileNotFoundError(
            f"{expectation}: no input beside it: expected {EVIDENCE_FILE} or a scene "
            "(scene.yaml) in its folder"
        )
    stem = name[: -len(EXPECTED_SUFFIX)] if name.endswith(EXPECTED_SUFFIX) else expectation.stem
    evidence = expectation.with_name(stem + ".json")
    if evidence.is_file():
        return Fixture(expectation, evidence=evidence)
    scene = expectation.with_name(stem)
    if (scene / "scene.yaml").is_file():
        return Fixture(expectation, scene=scene)
    raise FileNotFoundError(
        f"{expectation}: no input beside it: expected {evidence.name} (evidence) or a scene "
        f"folder {stem}/ with scene.yaml"
    )


def find_fixtures(paths: Iterable[str | os.PathLike[str]]) -> list[Path]:
    """The expectation files under `paths`, sorted per path: a file is taken as it is, a
    folder is searched for ``expected.kb`` and ``*.expected.kb`` (FileNotFoundError for a
    path that does not exist)."""
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = {f for f in p.rglob("*.kb") if f.is_file() and _is_expectation(f)}
            out += sorted(found)
        elif p.is_file():
            out.append(p)
        else:
            raise FileNotFoundError(f"{p}: no such file or folder")
    return list(dict.fromkeys(out))


def _is_expectation(path: Path) -> bool:
    return path.name == EXPECTED_FILE or path.name.endswith(EXPECTED_SUFFIX)


# ---- the result as a tree ------------------------------------------------------------------
def result_tree(kb: KnowledgeBase, interp: Interpretation) -> dict[str, Node]:
    """The accepted instances of `interp` by role path, as its ``interpretation.kb`` states
    them (`aida_kb.interpret.kbfile`): an image-layer instance bound to evidence is its
    parent's evidence, each measured attribute a value (SI). Empty when nothing was found."""
    if not interp.accepted:
        return {}
    from aida_kb.interpret.verdict import measured_attributes

    evidence = evidence_roles(kb, interp)
    nodes = {
        i.role: Node(i.concept, INSERTED in i.bindings)
        for i in interp.instances
        if i.role not in evidence
    }
    for inst in interp.instances:
        if inst.parent is None or inst.parent not in nodes:
            continue
        parent = nodes[inst.parent]
        role = role_name(inst)
        if inst.role in evidence:
            parent.evidence[role] = parent.evidence.get(role, ()) + tuple(inst.bindings)
        else:
            parent.children[role] = (*parent.children.get(role, ()), inst.role)
    if interp.model is not None:
        for inst, attr, value in measured_attributes(kb, interp, interp.model):
            if inst.role in nodes:
                nodes[inst.role].values[attr.name] = value
    return nodes


# ---- comparing -----------------------------------------------------------------------------
def _shown(role: str) -> str:
    return role or "the goal"


def _value_text(value: float, unit: str) -> str:
    if unit == "rad":
        return f"{math.degrees(value):.2f}".rstrip("0").rstrip(".") + " deg"
    return f"{value:.3f}".rstrip("0").rstrip(".") + " m"


def _unit_of(kb: KnowledgeBase, concept: str, attr: str) -> str:
    c = kb.concepts.get(concept)
    a = c.attributes.get(attr) if c is not None else None
    return a.unit if a is not None else ""


def _ids(ids: Sequence[str]) -> str:
    quoted = [f'"{i}"' for i in ids]
    return quoted[0] if len(quoted) == 1 else f"[{', '.join(quoted)}]"


def _below(role: str, roots: Iterable[str]) -> bool:
    return any(role.startswith(r + ".") or role.startswith(r + "[") for r in roots)


def _tolerance(tree: ExpectedTree, span: Span, unit: str) -> float:
    ann = tree.annotations
    if span.line in ann.value_tolerances:
        return ann.value_tolerances[span.line][0]
    return ann.tolerance.get(unit, DEFAULT_TOLERANCE.get(unit, 0.0))


def _alternative(choices: str, role: str, concept: str) -> bool:
    """True when a hypothesis trace's choices (``body.roof=GableRoof; front=00/1``) make
    the instance at `role` a `concept`."""
    return f"{role}={concept}" in [c.strip() for c in choices.split(";")]


def _check_rejection(interp: Interpretation, r: Rejection) -> Difference | None:
    """None when a hypothesis that makes `r.role` a `r.concept` was rejected by the
    constraint `r.constraint` (None: when such hypotheses were tried and all rejected);
    otherwise what happened to it instead."""
    tried = []
    for h in interp.trace:
        m = _CHOICES.match(h.reason)
        if (h.role, h.concept) == (r.role, r.concept) or (
            m is not None and _alternative(m.group(1), r.role, r.concept)
        ):
            tried.append(h)
    if r.constraint is None:
        kept = [h for h in tried if h.status != "rejected"]
        if tried and not kept:
            return None
        want = f"expected {r.role} of {r.concept} rejected"
        if kept:
            return Difference(r.span, f"{want}, got it {kept[0].status}: {kept[0].reason}")
        return Difference(r.span, f"{want}, got no such hypothesis")
    if any(h.status == "rejected" and h.constraint == r.constraint for h in tried):
        return None
    want = f"expected '{r.constraint}' to reject {r.role} of {r.concept}"
    rejected = [h for h in tried if h.status == "rejected"]
    if any(h.constraint for h in rejected):
        by = sorted({f"'{h.constraint}'" for h in rejected if h.constraint})
        return Difference(r.span, f"{want}, got it rejected by {', '.join(by)}")
    if rejected:
        return Difference(r.span, f"{want}, got it rejected: {rejected[0].reason}")
    if tried:
        return Difference(r.span, f"{want}, got it {tried[-1].status}")
    return Difference(r.span, f"{want}, got no such hypothesis")


def compare(kb: KnowledgeBase, tree: ExpectedTree, interp: Interpretation) -> list[Difference]:
    """Every way `interp` (judged: it has a verdict) differs from the expectation `tree`,
    in the order of the expectation file (see the module docstring)."""
    out: list[Difference] = []
    ann = tree.annotations
    got_verdict = interp.verdict or ("verified" if interp.accepted else "nothing")
    if ann.verdict is not None and ann.verdict != got_verdict:
        why = "; ".join(interp.doubts) if interp.doubts else interp.message
        out.append(
            Difference(
                ann.spans.get("verdict"),
                f"expected verdict {ann.verdict}, got {got_verdict}: {why}",
            )
        )
    got = result_tree(kb, interp)
    if tree.nodes and not got:
        root = tree.nodes[""]
        out.append(Difference(root.span, f"expected the goal of {root.concept}, got nothing"))
    elif got and not tree.nodes and ann.verdict == "nothing":
        pass  # the verdict line says it
    else:
        out += _compare_nodes(kb, tree, got)
    for r in ann.rejections:
        d = _check_rejection(interp, r)
        if d is not None:
            out.append(d)
    return sorted(out, key=lambda d: _line(d.span))


def _compare_nodes(kb: KnowledgeBase, tree: ExpectedTree, got: dict[str, Node]) -> list[Difference]:
    out: list[Difference] = []
    cut: list[str] = []  # subtrees not compared further (their root differs)
    for role, want in sorted(tree.nodes.items(), key=lambda kv: _line(kv[1].span)):
        if _below(role, cut):
            continue
        have = got.get(role)
        if have is None or have.concept != want.concept:
            what = "no instance there" if have is None else have.concept
            out.append(
                Difference(want.span, f"expected {_shown(role)} of {want.concept}, got {what}")
            )
            cut.append(role)
            continue
        if want.inserted != have.inserted:
            seen = "; ".join(f"{k} = {_ids(v)}" for k, v in have.evidence.items())
            out.append(
                Difference(
                    want.span,
                    f"expected {_shown(role)} inserted (no view shows it), got it seen: {seen}"
                    if want.inserted
                    else f"expected {_shown(role)} seen, got it inserted from the knowledge",
                )
            )
        for k in sorted(set(want.evidence) | set(have.evidence)):
            w, h = want.evidence.get(k, ()), have.evidence.get(k, ())
            if sorted(w) != sorted(h):
                path = f"{role}.{k}" if role else k
                out.append(
                    Difference(
                        want.binding_spans.get(k, want.span),
                        f"expected {path} = {_ids(w) if w else 'unbound'}, "
                        f"got {_ids(h) if h else 'unbound'}",
                    )
                )
        for k in sorted(set(want.children) | set(have.children)):
            extra = [c for c in have.children.get(k, ()) if c not in tree.nodes]
            for c in extra:
                out.append(
                    Difference(
                        want.binding_spans.get(k, want.span),
                        f"got {c} of {got[c].concept}, not expected",
                    )
                )
        for attr, value in want.values.items():
            span = want.binding_spans[attr]
            unit = _unit_of(kb, want.concept, attr)
            if unit not in ("rad", "m"):
                continue
            tol = _tolerance(tree, span, unit)
            path = f"{role}.{attr}" if role else attr
            expected = f"{path} = {_value_text(value, unit)} +- {_value_text(tol, unit)}"
            if attr not in have.values:
                out.append(Difference(span, f"expected {expected}, got no measured value"))
            elif not abs(have.values[attr] - value) <= tol:
                out.append(
                    Difference(
                        span, f"expected {expected}, got {_value_text(have.values[attr], unit)}"
                    )
                )
    return out


def _line(span: Span | None) -> int:
    return span.line if span is not None else 0


# ---- updating ------------------------------------------------------------------------------
def updated_text(kb: KnowledgeBase, tree: ExpectedTree, interp: Interpretation, text: str) -> str:
    """The expectation `text` rewritten from the result `interp`: its import, the author's
    comments that open it and its annotations (rejections, tolerances; value tolerances
    after the values of the same role path and attribute) kept, the instances, the verdict
    and the notes on the result (summary, doubts) the result's."""
    from aida_kb.dsl import ast, parse

    module = parse(text, tree.file).module
    imports = [i.path.value for i in module.items if isinstance(i, ast.Import)]
    ann = tree.annotations
    notes = {
        (role, attr): ann.trailing[span.line]
        for role, node in tree.nodes.items()
        for attr, span in node.binding_spans.items()
        if attr in node.values and span.line in ann.trailing
    }
    preamble = []  # the author's comments before the first declaration
    for line in text.splitlines():
        if not line.startswith("//"):
            break
        if not (
            line.startswith(GENERATED_NOTES)
            or line.startswith("// " + GENERATED_HEAD)
            or line in ann.lines
        ):
            preamble.append(line)
    return interpretation_kb(
        kb,
        interp,
        imports[0] if imports else "",
        annotations=ann.lines,
        value_notes=notes,
        preamble=preamble,
    )


# ---- running -------------------------------------------------------------------------------
def default_interpreter(stage: Callable[[str], None] | None = None) -> Interpreter:
    """The result of a fixture as the commands give it: the evidence interpreted and judged
    (``aida-kb interpret``), or the scene reconstructed (``aida-kb reconstruct``, into a
    temporary folder); `stage` is told each stage of a reconstruction ("view 00: evidence")."""

    def run(kb: KnowledgeBase, fixture: Fixture, goal: str | None) -> Interpretation:
        from aida_kb.interpret.run import check_goal, interpret
        from aida_kb.interpret.verdict import judge, with_verdict
        from aida_kb.io.evidence import read_evidence

        goal = check_goal(kb, goal)
        if fixture.evidence is not None:
            evidence = read_evidence(fixture.evidence)
            interp = interpret(kb, evidence, goal=goal, source=str(fixture.evidence))
            return with_verdict(interp, judge(kb, interp, evidence))
        from aida_kb.interpret.pipeline import reconstruct_scene

        def tell(view: str, name: str) -> None:
            if stage is not None:
                stage(f"view {view}: {name}" if view != "-" else name)

        assert fixture.scene is not None
        with tempfile.TemporaryDirectory(prefix="aida-kb-test-") as tmp:
            out = Path(tmp) / "out"
            return reconstruct_scene(kb, fixture.scene, out, goal=goal, stage=tell).interpretation

    return run


Interpreter = Callable[[KnowledgeBase, Fixture, "str | None"], Interpretation]
"""What gives a fixture's judged result: (knowledge base, fixture, goal or None) -> result."""


def run_fixture(
    path: str | os.PathLike[str],
    search_paths: Sequence[str] = (),
    *,
    update: bool = False,
    interpret: Interpreter | None = None,
) -> Outcome:
    """Run the fixture whose expectation is `path` (see the module docstring); never
    raises on a bad fixture (an *error* outcome says what is wrong).

    interpret : what gives the result (default: interpret the evidence and judge it, or
        reconstruct the scene, as ``aida-kb interpret`` and ``reconstruct`` do); a test
        suite passes one that reuses results it has computed already
    """
    from aida_kb.diagnostics.render import render_text
    from aida_kb.errors import AidaError
    from aida_kb.io.atomic import write_text_atomic
    from aida_kb.kb import compile_path

    start = time.perf_counter()
    path = Path(path)
    try:
        fixture = _input_of(path)
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        return Outcome(Fixture(path), "error", [str(exc)], time.perf_counter() - start)
    result = compile_path(path, search_paths=search_paths)
    if result.kb is None:
        errors = [d for d in result.diagnostics if d.severity.value == "error"]
        lines = render_text(errors, result.sources).splitlines()
        return Outcome(fixture, "error", lines, time.perf_counter() - start)
    kb_all = result.kb
    root = kb_all.files[0]
    tree = expected_tree(kb_all, root, text)
    if tree.annotations.verdict is None:
        return Outcome(
            fixture,
            "error",
            [f"{path}:1: no '// expect: verdict ...' line: not an expectation (docs/testing.md)"],
            time.perf_counter() - start,
        )
    kb = kb_all.model_copy(
        update={"instances": {n: i for n, i in kb_all.instances.items() if i.span.file != root}}
    )
    goal = tree.nodes[""].concept if "" in tree.nodes else None
    try:
        interp = (interpret or default_interpreter())(kb, fixture, goal)
    except AidaError as exc:
        return Outcome(fixture, "error", [f"{path}: {exc}"], time.perf_counter() - start)
    diffs = compare(kb, tree, interp)
    if not diffs:
        return Outcome(fixture, "passed", [], time.perf_counter() - start)
    lines = [str(d) for d in diffs]
    if update:
        write_text_atomic(path, updated_text(kb, tree, interp, text))
        return Outcome(fixture, "updated", lines, time.perf_counter() - start)
    return Outcome(fixture, "failed", lines, time.perf_counter() - start)
