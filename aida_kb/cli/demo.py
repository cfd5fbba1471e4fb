"""`aida-kb demo`: lint and compile the shipped building knowledge and show its net as a tree."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from typing import Any

EXAMPLE = """\
what it does (until the vision and interpretation pipeline exists):
  1. lints kb/buildings.kb (the paper's building domain) and prints any diagnostics;
  2. compiles it into the semantic net;
  3. prints the net as a tree from each scene-layer concept down to the image layer:
     con-of realisations, parts with their cardinalities, is-a alternatives.

examples:
  aida-kb demo
  aida-kb demo --kb my_buildings.kb
  make demo                      # creates .venv first
"""

PIPELINE = """\
Next, the full pipeline (being built) will:
  - see: rectify calibrated stereo pairs, match them (NCC disparity with a certainty map),
    and segment depth into regions of equal orientation and image line segments;
  - interpret: instantiate this net against that evidence by hypothesis and verification,
    trying the is-a alternatives above (gable, hip, flat, shed roofs ...);
  - reconstruct: solve the instantiated constraints as one weighted least-squares problem,
    reject hypotheses whose constraints do not fit, and export a closed polyhedral model."""


def register(subparsers: Any) -> None:
    """Add the `demo` command."""
    p = subparsers.add_parser(
        "demo",
        help="lint and compile the building knowledge; show its semantic net",
        description=(
            "Lint and compile kb/buildings.kb (shipped with aida-kb) and print its semantic "
            "net as a tree: scene -> 3-D world -> 2-D image."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--kb",
        metavar="FILE",
        default=None,
        help="knowledge base to show (default: the shipped buildings.kb)",
    )
    p.set_defaults(run=run)


# ---- the net ----------------------------------------------------------------------------------
def _net_from_module(module: Any) -> Any:
    """A semantic net (networkx MultiDiGraph) read straight from a parsed module.

    Nodes are concepts (attributes ``layer``, ``abstract``); edges run from the whole to the
    part (``part-of``), from the concept to its realisation (``con-of``) and from the
    specialisation to its parent (``is-a``), with ``role``, ``min``, ``max``.
    """
    import networkx as nx

    from aida_kb.dsl import ast

    net: Any = nx.MultiDiGraph()
    concepts = [item for item in module.items if isinstance(item, ast.Concept)]
    for c in concepts:
        net.add_node(
            c.name.text,
            kind="concept",
            layer=c.layer.text if c.layer else None,
            abstract=c.abstract,
        )
    for c in concepts:
        for parent in c.parents:
            net.add_edge(c.name.text, parent.text, kind="is-a", role=None, min=None, max=None)
        for m in c.members:
            if isinstance(m, ast.Part | ast.ConOf):
                card = m.cardinality
                low = card.min if card else (0 if getattr(m, "optional", False) else 1)
                high = card.max if card else 1
                kind = "part-of" if isinstance(m, ast.Part) else "con-of"
                roles = m.roles if isinstance(m, ast.Part) else (m.role,)
                for role in roles:
                    net.add_edge(
                        c.name.text, m.concept.text, kind=kind, role=role.text, min=low, max=high
                    )
    return net


# ---- the tree ---------------------------------------------------------------------------------
def _edges(net: Any, node: str, kind: str) -> Iterator[tuple[str, str, dict[str, Any]]]:
    for _, target, data in net.out_edges(node, data=True):
        if data.get("kind") == kind:
            yield node, target, data


def _parents(net: Any, node: str) -> list[str]:
    return [t for _, t, _ in _edges(net, node, "is-a")]


def _children(net: Any, node: str) -> list[str]:
    return sorted(s for s, _, d in net.in_edges(node, data=True) if d.get("kind") == "is-a")


def _ancestry(net: Any, node: str) -> list[str]:
    """`node` and its is-a ancestors, nearest first (cycles cut)."""
    order: list[str] = []
    stack = [node]
    while stack:
        n = stack.pop(0)
        if n in order or n not in net:
            continue
        order.append(n)
        stack.extend(_parents(net, n))
    return order


def _layer(net: Any, node: str) -> str | None:
    for n in _ancestry(net, node):
        layer = net.nodes[n].get("layer")
        if layer:
            return str(layer)
    return None


def _members(net: Any, node: str, kind: str) -> list[tuple[str, str, Any, Any, str]]:
    """(role, concept, min, max, declared-in) of `kind` edges, inherited ones included."""
    out: dict[str, tuple[str, str, Any, Any, str]] = {}
    for n in reversed(_ancestry(net, node)):  # nearer declarations override
        for _, target, data in _edges(net, n, kind):
            role = str(data.get("role"))
            out[role] = (role, target, data.get("min"), data.get("max"), n)
    return list(out.values())


def _card(low: Any, high: Any) -> str:
    if low is None and high is None:
        return ""
    hi = "*" if high is None else str(high)
    return f" [{low}]" if str(low) == hi else f" [{low}..{hi}]"


def _label(net: Any, node: str) -> str:
    attrs = net.nodes[node] if node in net else {}
    layer = _layer(net, node)
    extra = "abstract, " if attrs.get("abstract") else ""
    parents = _parents(net, node) if node in net else []
    isa = f" is-a {', '.join(parents)}" if parents else ""
    return f"[bold]{node}[/bold]{isa} [dim]({extra}{layer or 'no layer'})[/dim]"


def _grow(
    net: Any,
    tree: Any,
    node: str,
    seen: set[str],
    depth: int = 0,
    known: frozenset[str] = frozenset(),
) -> None:
    """Add `node`'s realisations, parts and alternatives under `tree`.

    Members declared in `known` (the concept an alternative specialises, and its ancestors)
    were shown already and are left out.
    """
    if node in seen or depth > 30:
        tree.add(f"[dim]{node}: see above[/dim]")
        return
    seen.add(node)
    for kind, style in (("con-of", "magenta"), ("part-of", "cyan")):
        groups: dict[tuple[str, Any, Any], list[str]] = {}
        origin: dict[tuple[str, Any, Any], str] = {}
        for role, target, low, high, declared in _members(net, node, kind):
            if declared in known:
                continue
            key = (target, low, high)
            groups.setdefault(key, []).append(role)
            origin[key] = declared
        for (target, low, high), roles in groups.items():
            word = "con-of" if kind == "con-of" else ("optional part" if low == 0 else "part")
            inherited = origin[(target, low, high)]
            via = f" [dim](from {inherited})[/dim]" if inherited != node else ""
            branch = tree.add(
                f"[{style}]{word}[/{style}] {', '.join(roles)}: "
                f"{_label(net, target)}{_card(low, high)}{via}"
            )
            if target in net:
                _grow(net, branch, target, seen, depth + 1)
    alternatives = _children(net, node)
    if alternatives:
        alt = tree.add(f"[yellow]is-a alternatives[/yellow] of {node}")
        shown = frozenset(_ancestry(net, node))
        for child in alternatives:
            _grow(net, alt.add(_label(net, child)), child, seen, depth + 1, shown)


def net_tree(net: Any, title: str) -> Any:
    """A rich Tree of the net from every scene-layer concept (roots: concepts of the top layer).

    Each concept is expanded once; later mentions say "see above".
    """
    from rich.tree import Tree

    tree = Tree(title)
    layers = [_layer(net, n) for n in net.nodes]
    top = next((lay for lay in ("scene",) if lay in layers), None)
    roots = sorted(
        n
        for n in net.nodes
        if net.nodes[n].get("kind", "concept") == "concept"
        and _layer(net, n) == top
        and not _parents(net, n)
    )
    seen: set[str] = set()
    for root in roots:
        _grow(net, tree.add(_label(net, root)), root, seen)
    return tree


def run(args: argparse.Namespace) -> int:
    """Lint and compile the knowledge base; print the diagnostics, the net and what comes next."""
    from pathlib import Path

    from rich.console import Console

    from aida_kb.cli._kbfiles import (
        EXIT_ERRORS,
        EXIT_OK,
        check,
        display_path,
        packaged_kb,
        use_color,
    )
    from aida_kb.diagnostics.render import render_summary, render_text
    from aida_kb.dsl import parse

    path = Path(args.kb) if args.kb else packaged_kb("buildings.kb")
    console = Console(highlight=False)
    console.width = max(console.width, 100)
    console.rule("[bold]aida-kb demo[/bold]: the building knowledge of the paper")
    console.print(f"1. lint {display_path(path)}")
    result = check(path)
    color = use_color(console.file)
    if result.diagnostics:
        print(render_text(result.diagnostics, result.sources, color=color))
    print("   " + render_summary(result.diagnostics, 1, color=color))
    if not result.ok:
        console.print("[red]the knowledge base has errors; no net to show[/red]")
        return EXIT_ERRORS
    console.print("2. compile it into the semantic net")
    name = next(iter(result.sources))
    net = _net_from_module(parse(result.sources[name], name).module)
    kinds: dict[str, int] = {}
    for _, _, kind in net.edges(data="kind"):
        kinds[kind] = kinds.get(kind, 0) + 1
    summary = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items()))
    console.print(f"   {net.number_of_nodes()} concepts; links: {summary}")
    console.print("3. the net, from the scene layer down to the image layer:")
    console.print(net_tree(net, f"[bold]{name}[/bold]"))
    console.print()
    print(PIPELINE)
    return EXIT_OK
