"""Property-based fuzzing of every reader (issue 16): a result, or an AidaError of one line
naming the file; never another exception, never NaN or infinity in a result.

The targets, mutations and the contract are those of `benchmarks/fuzz.py` (which runs
thousands of cases); here hypothesis drives a small fixed budget per target.
"""

from __future__ import annotations

import importlib.util
import random
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]


def _load_fuzz() -> ModuleType:
    spec = importlib.util.spec_from_file_location("aida_kb_fuzz", ROOT / "benchmarks" / "fuzz.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


FUZZ = _load_fuzz()
#: Examples per target: the suite's budget (a few seconds in all); the .kb compile is slowest.
EXAMPLES = {"kb": 8}
DEFAULT_EXAMPLES = 15
TARGETS = (
    "kb",
    "scene_yaml",
    "calib_yaml",
    "image",
    "labels",
    "depth",
    "evidence",
    "model",
    "interpretation",
    "truth",
)


@pytest.fixture(scope="session")
def targets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    return dict(FUZZ.build_targets(tmp_path_factory.mktemp("fuzz")))


def test_every_reader_is_a_target(targets: dict[str, Any]) -> None:
    assert set(targets) == set(TARGETS)


@pytest.mark.parametrize("name", TARGETS)
def test_reader_contract(name: str, targets: dict[str, Any]) -> None:
    target = targets[name]

    @settings(
        max_examples=EXAMPLES.get(name, DEFAULT_EXAMPLES),
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow],
    )
    @given(st.randoms(use_true_random=False))
    def run(rnd: random.Random) -> None:
        outcome, why = FUZZ.check(target, FUZZ.mutate(target, rnd))
        assert outcome in ("error", "result"), why

    run()


@pytest.mark.parametrize("name", TARGETS)
def test_unmutated_seeds_are_read(name: str, targets: dict[str, Any]) -> None:
    target = targets[name]
    outcomes = {FUZZ.check(target, seed)[0] for seed in target.seeds}
    assert "violation" not in outcomes
    assert "result" in outcomes
