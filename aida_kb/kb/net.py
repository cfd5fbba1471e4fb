"""The semantic net of a compiled knowledge base as a networkx MultiDiGraph.

networkx is imported here only, and this module only when `build_net` is called, so the lint
path never pays for it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from aida_kb.kb.model import KnowledgeBase

if TYPE_CHECKING:
    import networkx as nx

    from aida_kb.diagnostics.core import Diagnostic
    from aida_kb.kb.loader import Loaded

__all__ = ["build_net", "build_partial_net"]


def build_net(kb: KnowledgeBase) -> nx.MultiDiGraph[str]:
    """The net: nodes are concepts and instances, edges the links between them.

    Concept nodes carry ``kind="concept"``, ``layer``, ``abstract``; instance nodes
    ``kind="instance"``, ``concept``. Edges carry ``kind`` (``part-of``, ``con-of``, ``is-a``,
    ``instance-of``) and, for part-of and con-of, ``role``, ``min`` and ``max`` (None:
    unbounded). Part-of and con-of edges go from the whole to the part (from the concept to
    its concrete realisation); is-a from the specialisation to its parent; instance-of from the
    instance to its concept; an instance's role bindings are part-of/con-of edges between
    instances, named by role.
    """
    import networkx as nx

    g: nx.MultiDiGraph[str] = nx.MultiDiGraph(layers=list(kb.layers))
    for name, c in kb.concepts.items():
        g.add_node(name, kind="concept", layer=c.layer, abstract=c.abstract)
    for name, c in kb.concepts.items():
        for p in c.parents:
            g.add_edge(name, p, kind="is-a")
        for role, part in c.parts.items():
            g.add_edge(name, part.concept, kind="part-of", role=role, min=part.min, max=part.max)
        for role, con in c.con_ofs.items():
            g.add_edge(name, con.concept, kind="con-of", role=role, min=con.min, max=con.max)
    for name, inst in kb.instances.items():
        g.add_node(name, kind="instance", concept=inst.concept)
        g.add_edge(name, inst.concept, kind="instance-of")
    for name, inst in kb.instances.items():
        concept = kb.concepts.get(inst.concept)
        for role, b in inst.bindings.items():
            kind = "con-of" if concept is not None and role in concept.con_ofs else "part-of"
            for other in b.instances:
                if other in kb.instances:
                    g.add_edge(name, other, kind=kind, role=role, min=None, max=None)
    return g


def _within(d: Diagnostic, file: str, line: int, end_line: int) -> bool:
    return d.span.file == file and line <= d.span.line <= end_line


def build_partial_net(loaded: Loaded, diagnostics: Sequence[Diagnostic]) -> nx.MultiDiGraph[str]:
    """The net of a knowledge base with errors, as far as its declarations parsed.

    Built from the declarations themselves (each concept's own links; nothing inherited), with
    the node attributes of `build_net` and ``broken=True`` on what the errors touch: a concept
    or instance with an error inside its declaration, and a node for each name that is linked
    but not declared (``kind="unknown"``; a declaration that did not parse is one). The graph
    attribute ``layers`` holds the first layers declaration's names (empty without one).
    """
    import networkx as nx

    from aida_kb.dsl import ast

    errors = [d for d in diagnostics if d.is_error]
    layers: list[str] = []
    g: nx.MultiDiGraph[str] = nx.MultiDiGraph(layers=layers)
    concepts: list[tuple[str, ast.Concept]] = []
    instances: list[tuple[str, ast.Instance]] = []
    for module in loaded.modules:
        for item in module.items:
            if isinstance(item, ast.Layers) and not layers:
                layers.extend(n.text for n in item.names)
            elif isinstance(item, ast.Concept | ast.Instance):
                span = item.span
                broken = any(_within(d, module.file, span.line, span.end_line) for d in errors)
                if isinstance(item, ast.Concept):
                    layer = item.layer.text if item.layer is not None else None
                    g.add_node(
                        item.name.text,
                        kind="concept",
                        layer=layer,
                        abstract=item.abstract,
                        broken=broken,
                    )
                    concepts.append((item.name.text, item))
                else:
                    g.add_node(
                        item.name.text, kind="instance", concept=item.concept.text, broken=broken
                    )
                    instances.append((item.name.text, item))

    def link(source: str, target: str, **attrs: object) -> None:
        if target not in g:
            g.add_node(target, kind="unknown", broken=True)
        g.add_edge(source, target, **attrs)

    for name, c in concepts:
        for p in c.parents:
            link(name, p.text, kind="is-a")
        for member in c.members:
            if isinstance(member, ast.Part | ast.ConOf):
                kind = "part-of" if isinstance(member, ast.Part) else "con-of"
                card = member.cardinality
                low, high = (card.min, card.max) if card is not None else (1, 1)
                if isinstance(member, ast.Part) and member.optional:
                    low = 0
                roles = member.roles if isinstance(member, ast.Part) else (member.role,)
                for role in roles:
                    link(name, member.concept.text, kind=kind, role=role.text, min=low, max=high)
    for name, inst in instances:
        link(name, inst.concept.text, kind="instance-of")
    return g
