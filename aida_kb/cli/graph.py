"""`aida-kb graph`: the semantic net of a knowledge base as DOT, GraphML or JSON."""

from __future__ import annotations

import argparse
import itertools
from typing import Any

from aida_kb.cli._kbfiles import add_import_path_option

EXAMPLE = """\
formats:
  dot      Graphviz (render with: dot -Tsvg net.dot -o net.svg)
  graphml  GraphML, for yEd, Gephi, networkx.read_graphml
  json     networkx node-link JSON: {"nodes": [...], "edges": [...]}

examples:
  aida-kb graph kb/buildings.kb --format dot -o net.dot
  aida-kb graph kb/buildings.kb --format dot | dot -Tsvg > net.svg
  aida-kb graph kb/buildings.kb --format json
"""

#: The colour of what an error touches.
_BROKEN = '"#d62728"'
# How each link kind is drawn in DOT.
_EDGE_STYLE = {
    "part-of": 'color="#1f77b4"',
    "con-of": 'color="#9467bd", style=bold',
    "is-a": 'color="#7f7f7f", style=dashed, arrowhead=empty',
    "instance-of": 'color="#2ca02c", style=dotted',
}


def register(subparsers: Any) -> None:
    """Add the `graph` command."""
    p = subparsers.add_parser(
        "graph",
        help="write the semantic net of a .kb file (dot, graphml, json)",
        description=(
            "Compile a .kb file and write its semantic net: concepts and instances as nodes, "
            "part-of, con-of, is-a and instance-of links as edges (with role and cardinality); "
            "in dot, each layer's concepts share a rank. A file with errors gives the net of "
            "what parsed, the broken parts marked (exit status 1)."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", metavar="FILE", help="the .kb file (its imports are followed)")
    p.add_argument(
        "--format", choices=("dot", "graphml", "json"), default="dot", help="default: dot"
    )
    p.add_argument(
        "-o", "--output", metavar="OUT", default=None, help="file to write (default: stdout)"
    )
    add_import_path_option(p)
    p.set_defaults(run=run)


def _quote(text: object) -> str:
    escaped = str(text).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'


def _cardinality(data: dict[str, Any]) -> str:
    low, high = data.get("min"), data.get("max")
    if low is None and high is None:
        return ""
    hi = "*" if high is None else str(high)
    return f" [{low}]" if str(low) == hi else f" [{low}..{hi}]"


def to_dot(net: Any, name: str = "kb") -> str:
    """The net as a Graphviz digraph: concepts boxes (abstract ones dashed), instances ellipses.

    Edge labels give the link kind, the role and the cardinality (``part front [1]``). The
    concepts of each layer share a rank, the layers top to bottom in their declared order
    (a column of layer names, chained by invisible edges, holds them in place). What an error
    touches (``broken`` nodes of a net built from a knowledge base with errors) is drawn red;
    a name linked but not declared is an octagon.
    """
    lines = [f"digraph {_quote(name)} {{", "  rankdir=TB;", "  node [shape=box, fontsize=11];"]
    for node, data in sorted(net.nodes(data=True), key=lambda item: str(item[0])):
        layer = data.get("layer")
        label = f"{node}\n({layer})" if layer else str(node)
        attrs = []
        if data.get("kind") == "instance":
            attrs.append("shape=ellipse")
        if data.get("kind") == "unknown":
            label = f"{node}\n(not declared)"
            attrs.append("shape=octagon")
        if data.get("abstract"):
            attrs.append("style=dashed")
        if data.get("broken"):
            attrs.append(f"color={_BROKEN}, fontcolor={_BROKEN}, penwidth=2")
        lines.append(f"  {_quote(node)} [{', '.join([f'label={_quote(label)}', *attrs])}];")
    layers = [str(layer) for layer in net.graph.get("layers", ())]
    if layers:
        lines.append('  node [shape=plaintext, fontcolor="#7f7f7f"];')
        for layer in layers:
            members = sorted(str(n) for n, d in net.nodes(data=True) if d.get("layer") == layer)
            ranked = " ".join(f"{_quote(m)};" for m in [f"layer {layer}", *members])
            lines.append(f"  {_quote(f'layer {layer}')} [label={_quote(layer)}];")
            lines.append(f"  {{ rank=same; {ranked} }}")
        for upper, lower in itertools.pairwise(layers):
            lines.append(
                f"  {_quote(f'layer {upper}')} -> {_quote(f'layer {lower}')} [style=invis];"
            )
    edges = sorted(net.edges(data=True), key=lambda e: (str(e[0]), str(e[1]), str(e[2])))
    for source, target, data in edges:
        kind = str(data.get("kind", ""))
        role = data.get("role")
        label = kind + (f" {role}" if role else "") + _cardinality(data)
        style = _EDGE_STYLE.get(kind, "")
        extra = f", {style}" if style else ""
        lines.append(f"  {_quote(source)} -> {_quote(target)} [label={_quote(label)}{extra}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _plain(value: Any) -> Any:
    """A value GraphML and JSON can hold: scalars as they are, anything else as text."""
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return str(value)


def to_graphml(net: Any) -> str:
    """The net as GraphML (attributes that are None are left out; others become scalars)."""
    import networkx as nx

    clean: Any = nx.MultiDiGraph()
    for node, data in net.nodes(data=True):
        clean.add_node(str(node), **{k: _plain(v) for k, v in data.items() if v is not None})
    for source, target, key, data in net.edges(keys=True, data=True):
        attrs = {k: _plain(v) for k, v in data.items() if v is not None}
        clean.add_edge(str(source), str(target), key=str(key), **attrs)
    return "\n".join(nx.generate_graphml(clean, prettyprint=True)) + "\n"


def to_json(net: Any) -> str:
    """The net as networkx node-link JSON (``nodes`` and ``edges`` lists)."""
    import json

    import networkx as nx

    data = nx.node_link_data(net, edges="edges")
    return json.dumps(data, indent=2, default=str, ensure_ascii=False) + "\n"


def run(args: argparse.Namespace) -> int:
    """Compile FILE, build its net and write it. A knowledge base with errors gives the net of
    what parsed, its broken parts marked (exit 1); nothing is written when no concept parsed."""
    import sys
    from pathlib import Path

    from aida_kb.cli._kbfiles import check, check_output_file, print_error, write_output
    from aida_kb.diagnostics.core import Diagnostic
    from aida_kb.diagnostics.render import render_summary, render_text
    from aida_kb.kb import build_net

    check_output_file(args.output, [args.file])
    result = check(Path(args.file), args.import_path)
    if result.diagnostics:
        diags = sorted(result.diagnostics, key=Diagnostic.sort_key)
        print(render_text(diags, result.sources) + "\n", file=sys.stderr)
        print(render_summary(diags, 1), file=sys.stderr)
    kb = result.kb
    if kb is not None:
        net = build_net(kb)
    else:
        from aida_kb.kb.loader import load_path
        from aida_kb.kb.net import build_partial_net

        loaded = load_path(result.files[0] if result.files else args.file, args.import_path)
        net = build_partial_net(loaded, result.diagnostics)
        if not any(d.get("kind") == "concept" for _, d in net.nodes(data=True)):
            print_error(f"{args.file}: no concept parsed: no net to write")
            return 1
    if args.format == "dot":
        text = to_dot(net, Path(args.file).stem)
    elif args.format == "graphml":
        text = to_graphml(net)
    else:
        text = to_json(net)
    write_output(args.output, text, [args.file, *result.files])
    return 0 if kb is not None else 1
