"""Shared helpers: the synthetic evidence generator of tests/fixtures, loaded by path."""

from __future__ import annotations

import importlib.util
import math
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
KB_FILE = Path(__file__).resolve().parents[2] / "kb" / "buildings.kb"


def _load(name: str) -> ModuleType:
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, FIXTURES / f"{name}.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def synthetic() -> ModuleType:
    """tests/fixtures/synthetic.py: synthetic evidence from synth building models."""
    return _load("synthetic")


@pytest.fixture(scope="session")
def generate() -> ModuleType:
    """tests/fixtures/generate.py: the fixture scenes and their ground truth."""
    _load("synthetic")
    return _load("generate")


@pytest.fixture(scope="session")
def buildings_kb() -> object:
    """The shipped kb/buildings.kb, compiled."""
    from aida_kb.kb import compile_path

    result = compile_path(Path(__file__).resolve().parents[2] / "kb" / "buildings.kb")
    assert result.kb is not None
    return result.kb


@pytest.fixture(scope="session")
def interpreted(buildings_kb: object) -> object:
    """interpret() of each evidence fixture, computed once per session."""
    from aida_kb.interpret.run import interpret
    from aida_kb.io.evidence import read_evidence

    cache: dict[str, object] = {}

    def get(name: str) -> object:
        if name not in cache:
            evidence = read_evidence(FIXTURES / name)
            cache[name] = interpret(buildings_kb, evidence, source=name)  # type: ignore[arg-type]
        return cache[name]

    return get


def _check_interpretation_kb(path: Path, kb: Any, interp: Any) -> None:
    """`path` (an interpretation.kb) lints clean with the knowledge base's folder as import
    path, and its instances are `interp`'s: concepts, role bindings, evidence ids, inserted
    parts, the verdict, and the measured values (bound, or a comment when out of range)."""
    from aida_kb.dsl.format import format_source
    from aida_kb.interpret.kbfile import INSERTED_DOC, VERDICT_DOC, instance_name
    from aida_kb.interpret.result import INSERTED
    from aida_kb.interpret.verdict import measured_attributes
    from aida_kb.kb import compile_path

    result = compile_path(path, search_paths=[str(KB_FILE.parent)])
    assert not result.diagnostics, [d.message for d in result.diagnostics]
    assert result.kb is not None
    declared = result.kb.instances
    text = path.read_text(encoding="utf-8")
    assert not format_source(text, str(path)).changed  # as `aida-kb fmt` lays it out
    verdict = interp.verdict or ("not judged" if interp.accepted else "nothing")
    if verdict == "not judged":
        assert "// verdict: not judged\n" in text
    else:  # an annotation: the file is an expectation of aida-kb test (docs/testing.md)
        assert f"// expect: verdict {verdict}\n" in text
    assert all(f"// doubt: {d}" in text for d in interp.doubts)
    if not interp.accepted:
        assert declared == {}
        return
    # walk the written instances from the goal down, rebuilding the role paths
    goal = instance_name("", interp.goal)
    assert declared[goal].doc == VERDICT_DOC + verdict
    found: dict[str, tuple[str, str | None]] = {}  # role path -> (concept, doc)
    evidence: dict[str, list[str]] = {}  # role path of an image-layer instance -> ids
    values: dict[tuple[str, str], float] = {}
    todo = [("", goal)]
    while todo:
        role, name = todo.pop()
        inst = declared[name]
        assert role not in found, f"{role} declared twice"
        found[role] = (inst.concept, inst.doc)
        concept = kb.concepts[inst.concept]
        for b in inst.bindings.values():
            path_of = f"{role}.{b.role}" if role else b.role
            if b.value is not None:
                values[(role, b.role)] = b.value
                continue
            slot = concept.parts.get(b.role) or concept.con_ofs.get(b.role)
            assert slot is not None
            if b.evidence:
                evidence[path_of] = list(b.evidence)
            several = slot.max != 1
            todo += [
                (f"{path_of}[{i}]" if several else path_of, child)
                for i, child in enumerate(b.instances)
            ]
    assert len(found) == len(declared)  # every declared instance hangs on the goal
    image = kb.layers[-1]
    expected = {i.role: i for i in interp.instances if kb.concepts[i.concept].layer != image}
    assert {r: c for r, (c, _) in found.items()} == {r: i.concept for r, i in expected.items()}
    for role, inst in expected.items():
        inserted = found[role][1] == INSERTED_DOC
        assert inserted == (INSERTED in inst.bindings), role
    bound = {i.role: i.bindings for i in interp.instances if kb.concepts[i.concept].layer == image}
    assert evidence == bound
    assert interp.model is not None
    measured = measured_attributes(kb, interp, interp.model)
    assert measured
    for inst, attr, value in measured:
        key = (inst.role, attr.name)
        if key in values:  # written to 0.01 deg or 1 mm
            tol = math.radians(0.006) if attr.unit == "rad" else 6e-4
            assert abs(values[key] - value) <= tol, key
        else:  # outside its range: a comment in the instance, and a doubt
            low = -math.inf if attr.low is None else attr.low
            high = math.inf if attr.high is None else attr.high
            assert not low <= value <= high, key
            assert f"// measured {attr.name} = " in text
            assert interp.verdict == "doubtful"


@pytest.fixture(scope="session")
def check_interpretation_kb() -> Callable[[Path, Any, Any], None]:
    """Check a written interpretation.kb against its interpretation (AssertionError)."""
    return _check_interpretation_kb


@pytest.fixture
def unbiased(monkeypatch: pytest.MonkeyPatch, interpreted: Any) -> None:
    """The verdict's deviations without the model edges' shared bias
    (`aida_kb.interpret.uncertainty.EDGE_BIAS_PX` 0): the fixtures' segments are drawn about
    their true edges with independent noise (tests/fixtures/generate.py), so house_correct's
    right model is verified, and a test of another check keeps it as its positive control.
    With the bias of real images it is doubtful (tests/fixtures/house_correct.expected.kb).
    The session's interpretation of house_correct is made first, with the bias, so that the
    other tests' cached result does not depend on which test ran first."""
    import aida_kb.interpret.uncertainty as uncertainty

    interpreted("house_correct.json")
    monkeypatch.setattr(uncertainty, "EDGE_BIAS_PX", 0.0)
