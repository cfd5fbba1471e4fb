"""Plain-text views of an interpretation: the instance tree and the explanation of rejections."""

from __future__ import annotations

from aida_kb.interpret.result import INSERTED, Instance, Interpretation


def _label(inst: Instance) -> str:
    name = inst.role.rsplit(".", 1)[-1] if inst.role else inst.concept
    head = f"{name}: {inst.concept}" if inst.role else inst.concept
    if inst.concept != inst.instance_of:
        head += f" (instance-of {inst.instance_of})"
    if inst.link == "con-of":
        head = f"{head}  [con-of]"
    if inst.bindings == [INSERTED]:
        head += "  <- inserted from knowledge"
    elif inst.bindings:
        head += "  <- " + ", ".join(inst.bindings)
    return head


def instance_tree(interp: Interpretation) -> list[str]:
    """The accepted instances as an indented tree, one line each (empty if none)."""
    children: dict[str | None, list[Instance]] = {}
    for inst in interp.instances:
        children.setdefault(inst.parent, []).append(inst)
    lines: list[str] = []

    def walk(inst: Instance, prefix: str, last: bool, top: bool) -> None:
        lines.append(_label(inst) if top else f"{prefix}{'└── ' if last else '├── '}{_label(inst)}")
        kids = children.get(inst.role, [])
        deeper = "" if top else prefix + ("    " if last else "│   ")
        for i, kid in enumerate(kids):
            walk(kid, deeper, i == len(kids) - 1, False)

    for root in children.get(None, []):
        walk(root, "", True, True)
    return lines


def explanation(interp: Interpretation) -> list[str]:
    """Why each rejected hypothesis fell: the constraint and its normalised cost, or the reason."""
    lines: list[str] = []
    for h in interp.rejected():
        where = h.role or "(goal)"
        if h.constraint is not None and h.cost is not None:
            at = f" at {h.span}" if h.span is not None else ""
            why = f"constraint {h.constraint!r}{at} cost {h.cost:.3g} (normalised)"
            if h.reason:
                why += f": {h.reason}"
        else:
            why = h.reason or "rejected"
        lines.append(f"#{h.id} {h.concept} as {where} (step {h.step}) rejected: {why}")
    return lines
