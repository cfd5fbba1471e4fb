"""`aida-kb demo`: the whole pipeline on a rendered house, measured against its ground truth."""

from __future__ import annotations

import argparse
from typing import Any

EXAMPLE = """\
what it does:
  1. lints and compiles kb/buildings.kb (the paper's building domain) and shows its net;
  2. renders the `house` preset (two calibrated stereo views of a gable house) into a
     temporary folder (or --out DIR);
  3. reconstructs it: evidence (stereo, segmentation, line segments) -> hypothesis-
     verification interpretation -> closed polyhedral model;
  4. prints the instance tree, the main angles and the error against the ground truth
     (read here only, never by the pipeline), where it wrote the files (the textured model
     as OBJ, glTF, CityJSON, the stereo points as PLY) and, last, the path of report.html.
  It exits 1 when the model misses the targets: angles within 0.5 degrees of the truth and
  vertices within 2% of the house's size. The full check (normals, specialisation, cameras)
  is `aida-kb evaluate`'s, printed as well.

examples:
  aida-kb demo
  aida-kb demo --out out/demo --no-net
  make demo                      # creates .venv first; writes into ./demo-output/
"""

DEMO_PREFIX = "aida-kb-demo-"  # the temporary folder's name when no --out is given
ANGLE_TARGET_DEG = 0.5  # the demo's own target: dihedral angles within half a degree


def register(subparsers: Any) -> None:
    """Add the `demo` command."""
    p = subparsers.add_parser(
        "demo",
        help="reconstruct a rendered house and compare it with the truth",
        description=(
            "Compile kb/buildings.kb, render the `house` preset, reconstruct it "
            "(evidence -> interpretation -> closed model) and report the errors "
            "against the ground truth."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--kb",
        metavar="FILE",
        default=None,
        help="knowledge base (default: the shipped buildings.kb)",
    )
    p.add_argument("--out", metavar="DIR", default=None, help="folder for the scene and model")
    p.add_argument("--no-net", action="store_true", help="do not print the semantic net")
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
    """Compile, render, reconstruct, compare; print everything and where the files are."""
    import tempfile
    from pathlib import Path

    from rich.console import Console

    from aida_kb.cli._kbfiles import EXIT_ERRORS, EXIT_OK, display_path, packaged_kb
    from aida_kb.cli.interpret import constraint_notes, load_kb
    from aida_kb.diagnostics.render import render_text
    from aida_kb.interpret.evaluate import VERTEX_TARGET, evaluate, format_evaluation
    from aida_kb.interpret.pipeline import reconstruct_scene
    from aida_kb.interpret.report import explanation, instance_tree
    from aida_kb.io.atomic import make_dirs
    from aida_kb.io.scene import read_scene
    from aida_kb.report.html import REPORT_FILE, write_report
    from aida_kb.synth.scenes import HOUSE_ANGLES, preset, render_scene

    path = Path(args.kb) if args.kb else packaged_kb("buildings.kb")
    console = Console(highlight=False)
    console.width = max(console.width, 100)
    console.rule("[bold]aida-kb demo[/bold]: a house from two stereo views, as in the paper")
    console.print(f"1. compile {display_path(path)}")
    kb, sources = load_kb(str(path))
    # the output folder only once the knowledge compiles: a broken .kb leaves nothing behind
    root = make_dirs(args.out) if args.out else Path(tempfile.mkdtemp(prefix=DEMO_PREFIX))
    console.print(f"   {len(kb.concepts)} concepts in layers {' > '.join(kb.layers)}")
    if not args.no_net:
        console.print(net_tree(kb, f"[bold]{display_path(path)}[/bold]"))
    scene_dir, out_dir = root / "scene", root / "model"
    with console.status("2. rendering the house preset (two stereo views) ..."):
        render_scene(preset("house"), scene_dir)
    console.print(f"2. rendered the house preset into {scene_dir}")
    with console.status("3. reconstructing ...") as status:

        def stage(view: str, name: str) -> None:
            where = f"view {view}: " if view != "-" else ""
            status.update(f"3. reconstructing: {where}{name}")

        result = reconstruct_scene(kb, scene_dir, out_dir, stage=stage, extra=write_report)
    interp = result.interpretation
    console.print(f"3. reconstructed: {interp.message}")
    for line in instance_tree(interp):
        console.print("   " + line, markup=False)
    rejected = explanation(interp)
    if rejected:
        console.print(f"   {len(rejected)} hypotheses rejected, e.g.:", markup=False)
        for line in rejected[:3]:
            console.print("     " + line, markup=False)
    # the first rejection by a constraint and the closest call, at their .kb lines
    notes = constraint_notes(interp, explain=True)
    shown = [n for n in notes if n.code == "KB400"][:1] + [n for n in notes if n.code == "KB401"]
    if shown:
        console.print(render_text(shown, sources), markup=False, highlight=False)
    for file in result.files:
        console.print(f"   wrote {file}")
    truth = read_scene(scene_dir).truth
    if truth is None:
        console.print("[red]the scene has no truth.json; nothing to compare[/red]")
        console.print(f"report: {(out_dir / REPORT_FILE).resolve()}", soft_wrap=True)
        return EXIT_ERRORS
    evaluation = evaluate(interp, truth)
    comparison = evaluation.comparison
    console.print("4. against the ground truth (truth.json, read only here; aida-kb evaluate):")
    if comparison is None:
        console.print(f"[red]{format_evaluation(evaluation)[0]}[/red]", markup=True)
        console.print(f"report: {(out_dir / REPORT_FILE).resolve()}", soft_wrap=True)
        return EXIT_ERRORS
    found = {(a.a, a.b): a for a in comparison.angles}
    found.update({(a.b, a.a): a for a in comparison.angles})
    for a, b, what in HOUSE_ANGLES:
        angle = found.get((a, b))
        if angle is not None:
            console.print(
                f"   {what:<20} {a} / {b}: {angle.model_deg:8.3f} deg "
                f"(truth {angle.truth_deg:.3f}, error {angle.error_deg:.3f})"
            )
    ok_angles = comparison.max_angle_error_deg <= ANGLE_TARGET_DEG
    ok_vertices = comparison.max_vertex_error_rel <= VERTEX_TARGET and not comparison.missing
    console.print(
        f"   largest angle error over {len(comparison.angles)} adjacent pairs: "
        f"{comparison.max_angle_error_deg:.3f} deg (target {ANGLE_TARGET_DEG}) "
        + ("[green]ok[/green]" if ok_angles else "[red]missed[/red]")
    )
    for line in format_evaluation(evaluation):
        console.print("   " + line, markup=False)
    console.print(f"files: scene {scene_dir}, model {out_dir}")
    console.print(f"report: {(out_dir / REPORT_FILE).resolve()}", soft_wrap=True)
    return EXIT_OK if ok_angles and ok_vertices else EXIT_ERRORS
