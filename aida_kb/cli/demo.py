"""`aida-kb demo`: lint and compile the shipped building knowledge and show its net as a tree."""

from __future__ import annotations

import argparse
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


# ---- the tree -------------------------------------------------------------------------------
def _card(low: int | None, high: int | None) -> str:
    hi = "*" if high is None else str(high)
    return f" [{low}]" if str(low) == hi else f" [{low}..{hi}]"


def _label(kb: Any, name: str) -> str:
    concept = kb.concepts.get(name)
    if concept is None:
        return f"[bold]{name}[/bold]"
    parents = f" is-a {', '.join(concept.parents)}" if concept.parents else ""
    abstract = "abstract, " if concept.abstract else ""
    return f"[bold]{name}[/bold]{parents} [dim]({abstract}{concept.layer})[/dim]"


def _value(attribute: Any) -> str:
    import math

    if attribute.default is None:
        return ""
    if attribute.unit == "rad":
        return f" = {math.degrees(attribute.default):g} deg"
    return f" = {attribute.default:g} {attribute.unit}".rstrip()


def _grow(
    kb: Any, tree: Any, name: str, seen: set[str], known: frozenset[str] = frozenset()
) -> None:
    """Add concept `name`'s con-of realisations, parts and is-a alternatives under `tree`.

    Members declared in `known` (the concept an alternative specialises and its ancestors)
    were shown already and are left out. Each concept is expanded once; later mentions say so.
    """
    concept = kb.concepts.get(name)
    if concept is None:
        return
    if name in seen:
        tree.add(f"[dim]{name}: see above[/dim]")
        return
    seen.add(name)
    for members, style in ((concept.con_ofs, "magenta"), (concept.parts, "cyan")):
        groups: dict[tuple[str, int, int | None, str, str], list[str]] = {}
        for role, m in members.items():
            if m.declared_in in known:
                continue
            optional = getattr(m, "optional", False)
            word = "con-of" if style == "magenta" else ("optional part" if optional else "part")
            groups.setdefault((m.concept, m.min, m.max, m.declared_in, word), []).append(role)
        for (target, low, high, declared, word), roles in groups.items():
            via = f" [dim](from {declared})[/dim]" if declared != name else ""
            branch = tree.add(
                f"[{style}]{word}[/{style}] {', '.join(roles)}: "
                f"{_label(kb, target)}{_card(low, high)}{via}"
            )
            _grow(kb, branch, target, seen)
    own = [
        a for a in concept.attributes.values() if a.declared_in == name and a.default is not None
    ]
    if known and own:
        tree.add("[green]with[/green] " + ", ".join(f"{a.name}{_value(a)}" for a in own))
    if concept.specialisations:
        alt = tree.add(f"[yellow]is-a alternatives[/yellow] of {name}")
        ancestry = frozenset(
            n for n in kb.concepts if kb.is_a(name, n)
        )  # name and its ancestors: their members are shown above
        for child in sorted(concept.specialisations):
            _grow(kb, alt.add(_label(kb, child)), child, seen, ancestry)


def net_tree(kb: Any, title: str) -> Any:
    """A rich Tree of the knowledge base from each concept of the top layer downwards.

    Under a concept: its con-of realisations and parts (roles sharing a concept and a
    cardinality grouped), each with its cardinality, then its is-a alternatives.
    """
    from rich.tree import Tree

    tree = Tree(title)
    top = kb.layers[0] if kb.layers else None
    roots = sorted(n for n, c in kb.concepts.items() if c.layer == top and not c.parents)
    seen: set[str] = set()
    for root in roots:
        _grow(kb, tree.add(_label(kb, root)), root, seen)
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
    from aida_kb.kb import build_net

    path = Path(args.kb) if args.kb else packaged_kb("buildings.kb")
    console = Console(highlight=False)
    console.width = max(console.width, 100)
    console.rule("[bold]aida-kb demo[/bold]: the building knowledge of the paper")
    console.print(f"1. lint {display_path(path)}")
    result = check(path)
    color = use_color(console.file)
    if result.diagnostics:
        print(render_text(result.diagnostics, result.sources, color=color))
    print("   " + render_summary(result.diagnostics, len(result.sources), color=color))
    kb = result.kb
    if kb is None:
        console.print("[red]the knowledge base has errors; no net to show[/red]")
        return EXIT_ERRORS
    net = build_net(kb)
    kinds: dict[str, int] = {}
    for _, _, data in net.edges(data=True):
        kind = str(data.get("kind"))
        kinds[kind] = kinds.get(kind, 0) + 1
    links = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items()))
    n_constraints = sum(
        1 for c in kb.concepts.values() for spec in c.constraints if spec.concept == c.name
    )
    console.print("2. compile it into the semantic net")
    console.print(f"   {len(kb.concepts)} concepts in layers {' > '.join(kb.layers)}")
    console.print(f"   links: {links}")
    console.print(f"   {len(kb.templates)} templates, {n_constraints} primitive constraints")
    console.print("3. the net, from the scene layer down to the image layer:")
    console.print(net_tree(kb, f"[bold]{display_path(path)}[/bold]"))
    console.print()
    print(PIPELINE)
    return EXIT_OK
