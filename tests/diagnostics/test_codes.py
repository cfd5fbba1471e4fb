"""The code registry: unique, well-formed codes."""

from __future__ import annotations

import pytest

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Severity


def test_registered_codes_are_well_formed() -> None:
    assert codes.REGISTRY, "no codes registered"
    for name, entry in codes.REGISTRY.items():
        assert name == entry.code
        assert entry.summary
        assert not entry.summary.endswith(".")


def test_register_rejects_duplicates_and_bad_names() -> None:
    with pytest.raises(ValueError, match="twice"):
        codes.register("KB001", Severity.ERROR, "again")
    with pytest.raises(ValueError, match="form"):
        codes.register("E12", Severity.ERROR, "bad")


def test_lookup_is_case_insensitive() -> None:
    assert codes.lookup("kb001") is codes.SYNTAX
    assert codes.lookup("KB999") is None
