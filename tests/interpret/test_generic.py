"""The interpreter is generic: kb/buildings.kb with every identifier renamed (concepts, roles,
attributes, templates — the same knowledge in other words) gives the same interpretation."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aida_kb.interpret.run import interpret
from aida_kb.io.evidence import read_evidence
from aida_kb.kb import compile_text
from aida_kb.testing.knowledge import declared_identifiers

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "tests" / "fixtures"
WORD = re.compile(r"\b[A-Za-z_][A-Za-z0-9_]*\b")


def _renamed() -> tuple[object, dict[str, str]]:
    mapping = {n: f"Q{n[::-1]}Z" for n in declared_identifiers(ROOT / "kb" / "buildings.kb")}
    assert {"House", "HouseBody", "front", "roof", "tilt", "perpendicular"} <= set(mapping)
    text = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")
    renamed = WORD.sub(lambda m: mapping.get(m.group(0), m.group(0)), text)
    result = compile_text(renamed, "renamed.kb")
    assert result.ok, result.diagnostics
    return result.kb, {v: k for k, v in mapping.items()}


def _assert_same(original: Any, got: Any, back: dict[str, str]) -> None:
    """The interpretation with the renamed knowledge is the original one up to names: the
    same instances (role, concept, bindings) and the same model within 1e-6 m."""
    assert original.accepted, original.message
    assert got.accepted, got.message
    assert got.goal == "QesuoHZ"  # the only scene concept is the goal

    def plain(role: str) -> str:
        return WORD.sub(lambda m: back.get(m.group(0), m.group(0)), role)

    assert sorted((plain(i.role), plain(i.concept), tuple(i.bindings)) for i in got.instances) == (
        sorted((i.role, i.concept, tuple(i.bindings)) for i in original.instances)
    )
    want = {p.role: p for p in original.model.parts}
    have = {plain(p.role): p for p in got.model.parts}
    assert set(have) == set(want)
    for role, part in want.items():
        np.testing.assert_allclose(have[role].normal, part.normal, atol=1e-9)
        assert have[role].offset_m == pytest.approx(part.offset_m, abs=1e-6)
        np.testing.assert_allclose(
            sorted(map(tuple, have[role].polygon)), sorted(map(tuple, part.polygon)), atol=1e-6
        )


@pytest.mark.parametrize("name", ["house_occluded.json", "wing_90.json"])
def test_renamed_knowledge_gives_the_same_model(
    name: str, interpreted: Callable[[str], object]
) -> None:
    kb, back = _renamed()
    got = interpret(kb, read_evidence(FIXTURES / name), source=name)  # type: ignore[arg-type]
    _assert_same(interpreted(name), got, back)


@pytest.mark.parametrize("scene", ["demo", "lshape"])
def test_renamed_knowledge_interprets_the_rendered_scenes_alike(
    scene: str, demo_run: Any, lshape_run: Any, buildings_kb: Any
) -> None:
    """The rendered demo house and L-shape (their evidence, from the session's renders)."""
    out = demo_run.root / "model" if scene == "demo" else lshape_run.out
    evidence = read_evidence(out / "evidence.json")
    kb, back = _renamed()
    original = interpret(buildings_kb, evidence, source=scene)
    _assert_same(original, interpret(kb, evidence, source=scene), back)  # type: ignore[arg-type]
