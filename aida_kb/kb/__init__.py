"""The knowledge-base compiler: imports, resolution, semantic checks -> pydantic model and net.

>>> from aida_kb.kb import compile_text
>>> result = compile_text("layers scene > world\\nconcept A in scene { }", "x.kb")
>>> result.ok
True

`compile_path` / `compile_text` give a `CompileResult` (diagnostics, sources, ``kb``). The
pydantic models (`KnowledgeBase`, `ConceptModel`, `ConstraintSpec`, ...) and `build_net`
(networkx) are imported on first use, so that linting stays light.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from aida_kb.kb.compiler import CompileResult, compile_path, compile_text

if TYPE_CHECKING:
    from aida_kb.kb.model import (
        AdjacencyModel,
        AttributeModel,
        BindingModel,
        ConceptModel,
        ConOfModel,
        ConstraintSpec,
        InstanceModel,
        KnowledgeBase,
        ParamModel,
        PartModel,
        TemplateModel,
    )
    from aida_kb.kb.net import build_net

__all__ = [
    "AdjacencyModel",
    "AttributeModel",
    "BindingModel",
    "CompileResult",
    "ConOfModel",
    "ConceptModel",
    "ConstraintSpec",
    "InstanceModel",
    "KnowledgeBase",
    "ParamModel",
    "PartModel",
    "TemplateModel",
    "build_net",
    "compile_path",
    "compile_text",
]

_MODEL = {n for n in __all__ if n.endswith(("Model", "Spec")) or n == "KnowledgeBase"}


def __getattr__(name: str) -> Any:
    if name in _MODEL:
        from aida_kb.kb import model

        return getattr(model, name)
    if name == "build_net":
        from aida_kb.kb.net import build_net

        return build_net
    raise AttributeError(f"module 'aida_kb.kb' has no attribute {name!r}")
