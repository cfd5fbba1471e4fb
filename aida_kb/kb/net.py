"""The semantic net of a compiled knowledge base as a networkx MultiDiGraph.

networkx is imported here only, and this module only when `build_net` is called, so the lint
path never pays for it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aida_kb.kb.model import KnowledgeBase

if TYPE_CHECKING:
    import networkx as nx

__all__ = ["build_net"]


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

    g: nx.MultiDiGraph[str] = nx.MultiDiGraph()
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
