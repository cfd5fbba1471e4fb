"""The identifiers a knowledge base declares, for the tests that rename them
(`tests/interpret/test_generic.py`) and scan the code for them
(`tests/test_knowledge_names.py`)."""

from __future__ import annotations

import re
from pathlib import Path

from aida_kb.dsl.ast import DIRECTIONS
from aida_kb.dsl.parser import grammar_path
from aida_kb.errors import AidaError
from aida_kb.kb import compile_path
from aida_kb.kb.relations import PRIMITIVES
from aida_kb.kb.resolve import VALUE_TYPES
from aida_kb.kb.shape import MEASURES


def language_words() -> frozenset[str]:
    """The words of the language itself: keywords of the grammar, primitive relations,
    measures, directions and value types."""
    grammar = grammar_path().read_text(encoding="utf-8")
    keywords = set(re.findall(r'"([a-z][a-z-]*)"', grammar))
    return frozenset(
        keywords | set(PRIMITIVES) | set(MEASURES) | set(DIRECTIONS) | set(VALUE_TYPES)
    )


def declared_identifiers(path: Path) -> frozenset[str]:
    """Every concept, template, role (part and con-of), attribute and attachment name the
    ``.kb`` file at `path` declares, less the words of the language (`language_words`).

    Raises AidaError if the file does not compile.
    """
    kb = compile_path(path).kb
    if kb is None:
        raise AidaError(f"{path}: does not compile")
    names = set(kb.templates)
    for c in kb.concepts.values():
        names |= {c.name, *c.parts, *c.con_ofs, *c.attributes}
        names |= {a.name for a in c.attachments.values()}
    return frozenset(names - language_words())
