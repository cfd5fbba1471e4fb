"""Shared helpers: the synthetic evidence generator of tests/fixtures, loaded by path."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


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
