"""The accepted interpretation in the knowledge language: ``interpretation.kb``.

`interpretation_kb` writes an `Interpretation` as ``.kb`` instance declarations
(docs/language.md 5) that import the knowledge base it was interpreted with:

- one ``instance NAME of CONCEPT`` per instance node above the image layer, CONCEPT the
  concept chosen along is-a; NAME is the role path made an identifier (`instance_name`:
  ``body.oriels[0].front`` -> ``body_oriels_0_front``; the goal is its concept in lower case;
  a name already taken, by the knowledge base's own instances too, gets ``_2``, ``_3``);
- each role bound to the instances that fill it (a list for a role with several fillers), a
  con-of role realised in the image layer bound to the evidence ids (``"VIEW/REGION"``) of
  its image-layer instance, which gets no declaration of its own;
- a part the views cannot see carries the doc string `INSERTED_DOC`;
- each attribute that stands for a geometric measure (``is slope(self)``, 3.10) bound to its
  value measured on the model, in ``deg`` or ``m`` (`aida_kb.interpret.verdict.
  measured_attributes`); a value outside the attribute's range (a doubtful result) is
  written as a comment, so that the file stays lint clean;
- the verdict as the goal instance's doc string (``"verdict: verified"``) and as the
  annotation ``// expect: verdict verified`` (`aida_kb.kb.expectation`: the written file is
  an expectation ``aida-kb test`` can check a later run against), the doubts and the
  summary line in the header comment; an interpretation that found nothing is the import
  and that header alone.

The text is in the canonical layout of `aida-kb fmt` (`aida_kb.dsl.format`). The import is
relative to the written file's folder and usually leaves it, so the file is
checked with the knowledge base's folder as an import path (docs/language.md 2.2):
``aida-kb lint out/interpretation.kb --import-path kb``; the header names that command.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from aida_kb.interpret.result import INSERTED, Instance, Interpretation
from aida_kb.interpret.verdict import measured_attributes
from aida_kb.io.atomic import write_text_atomic
from aida_kb.kb.expectation import INSERTED_DOC, VERDICT_DOC, VERDICTS
from aida_kb.kb.model import AttributeModel, KnowledgeBase

__all__ = [
    "INSERTED_DOC",
    "VERDICT_DOC",
    "evidence_roles",
    "instance_name",
    "interpretation_kb",
    "relative_import",
    "role_name",
    "write_interpretation_kb",
]


GENERATED_HEAD = "The interpretation of aida-kb for the goal"
"""How the first header line of a written interpretation starts."""

GENERATED_NOTES = ("// doubt: ", "// summary: ", "// check: ", "// verdict: ")
"""The header comments written from the result (rewritten with it)."""

DECIMALS = {"rad": 2, "m": 3}
"""Decimals of a written measured value: degrees to 0.01 deg, metres to the millimetre (finer
than any measure the model supports, coarse enough to read)."""

_INDEX = re.compile(r"\[(\d+)\]")
_NOT_NAME = re.compile(r"[^A-Za-z0-9_]")


def instance_name(role: str, goal: str) -> str:
    """The identifier of the instance at role path `role` (the goal's: `goal` in lower case).

    ``body.roof.front`` -> ``body_roof_front``, ``body.oriels[1]`` -> ``body_oriels_1``.
    """
    if role == "":
        base = goal.lower()
    else:
        base = _NOT_NAME.sub("_", _INDEX.sub(r"_\1", role).replace(".", "_"))
    if not base or base[0].isdigit():
        base = "i_" + base
    return base


def role_name(inst: Instance) -> str:
    """The role of `inst` in its parent: the last path component without its index."""
    tail = inst.role[len(inst.parent) + 1 :] if inst.parent else inst.role
    return _INDEX.sub("", tail)


def evidence_roles(kb: KnowledgeBase, interp: Interpretation) -> set[str]:
    """The role paths of the image-layer instances bound to evidence: written as their
    parent's binding to the evidence ids, with no declaration of their own."""
    bottom = kb.layers[-1] if kb.layers else None
    return {
        i.role
        for i in interp.instances
        if i.bindings
        and INSERTED not in i.bindings
        and bottom is not None
        and i.concept in kb.concepts
        and kb.concepts[i.concept].layer == bottom
        and i.parent is not None
    }


def _number(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _quantity(attr: AttributeModel, value: float) -> tuple[str, bool]:
    """The written value of a measured attribute (`value` in SI) and whether it lies in the
    attribute's range as the compiler reads the written text back."""
    if attr.unit == "rad":
        text = _number(math.degrees(value), DECIMALS["rad"])
        read, unit = math.radians(float(text)), " deg"
    else:
        text = _number(value, DECIMALS.get(attr.unit, 3))
        read, unit = float(text), (" m" if attr.unit == "m" else "")
    low = -math.inf if attr.low is None else attr.low
    high = math.inf if attr.high is None else attr.high
    return text + unit, low <= read <= high


def _string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _comment_lines(lines: Iterable[str]) -> list[str]:
    return ["// " + line.replace("\n", " ").replace("\r", " ") for line in lines]


def interpretation_kb(
    kb: KnowledgeBase,
    interp: Interpretation,
    import_path: str,
    *,
    lint_hint: str = "",
    annotations: Sequence[str] = (),
    value_notes: Mapping[tuple[str, str], str] = {},
    preamble: Sequence[str] = (),
) -> str:
    """The text of ``interpretation.kb`` for `interp` (see the module docstring).

    import_path : the knowledge base's root file, relative to the folder the text is written to
    lint_hint : the command that checks the file, for the header comment ('' for none)
    annotations : further ``// expect:`` lines for the header (an updated fixture keeps its
        rejections and tolerances, aida_kb.interpret.fixture)
    value_notes : (role path, attribute) -> a comment written after that measured value
    preamble : comment lines (``// ...``) that open the file instead of the standard one
    """
    verdict = interp.verdict or ("not judged" if interp.accepted else "nothing")
    header = list(preamble) or _comment_lines(
        [
            f"{GENERATED_HEAD} {interp.goal}, as instances of the "
            "knowledge base it imports (docs/formats.md); as an expectation of aida-kb test, "
            "the 'expect:' lines are what it checks (docs/testing.md)."
        ]
    )
    header.append(
        f"// expect: verdict {verdict}" if verdict in VERDICTS else f"// verdict: {verdict}"
    )
    header += [a for a in annotations if not a.startswith("// expect: verdict")]
    notes_header = [*(f"doubt: {d}" for d in interp.doubts), f"summary: {interp.message}"]
    if lint_hint:
        notes_header.append(f"check: {lint_hint}")
    lines = header + _comment_lines(notes_header)
    lines += [f"import {_string(import_path)}", ""]
    if not interp.accepted:
        return "\n".join(lines)

    evidence = evidence_roles(kb, interp)
    names: dict[str, str] = {}
    taken = set(kb.instances)  # instances the knowledge base declares itself (KB110)
    for inst in interp.instances:
        if inst.role in evidence:
            continue
        name = base = instance_name(inst.role, interp.goal)
        k = 2
        while name in taken:
            name, k = f"{base}_{k}", k + 1
        names[inst.role] = name
        taken.add(name)
    children: dict[str, list[Instance]] = {}
    for inst in interp.instances:
        if inst.parent is not None:
            children.setdefault(inst.parent, []).append(inst)
    values: dict[str, list[tuple[AttributeModel, float]]] = {}
    if interp.model is not None:
        for inst, attr, value in measured_attributes(kb, interp, interp.model):
            values.setdefault(inst.role, []).append((attr, value))

    for inst in interp.instances:
        if inst.role not in names:
            continue
        concept = kb.concepts.get(inst.concept)
        body: list[str] = []
        if inst.role == "":
            body.append(_string(VERDICT_DOC + verdict))
        if INSERTED in inst.bindings:
            body.append(_string(INSERTED_DOC))
        roles: dict[str, list[str]] = {}
        several: set[str] = set()
        for child in children.get(inst.role, []):
            role = role_name(child)
            if child.role in evidence:
                roles.setdefault(role, []).extend(_string(b) for b in child.bindings)
            else:
                roles.setdefault(role, []).append(names[child.role])
            if child.role.endswith("]"):
                several.add(role)
        for role, fillers in roles.items():
            slot = None
            if concept is not None:
                slot = concept.parts.get(role) or concept.con_ofs.get(role)
            if len(fillers) == 1 and role not in several and (slot is None or slot.max == 1):
                body.append(f"{role} = {fillers[0]}")
            else:
                body.append(f"{role} = [{', '.join(fillers)}]")
        notes: list[str] = []
        for attr, value in values.get(inst.role, []):
            text, inside = _quantity(attr, value)
            if inside:
                note = value_notes.get((inst.role, attr.name))
                body.append(f"{attr.name} = {text}" + (f"  {note}" if note else ""))
            else:
                notes.append(f"// measured {attr.name} = {text}: outside its range (see verdict)")
        if lines[-1] == "}":
            lines.append("")  # a blank line between declarations, as `aida-kb fmt` lays out
        lines.append(f"instance {names[inst.role]} of {inst.concept} {{")
        lines += ["    " + b for b in [*body, *notes]]
        lines.append("}")
    return "\n".join(lines) + "\n"


def relative_import(kb_file: str | os.PathLike[str], out_dir: str | os.PathLike[str]) -> str:
    """The import path of `kb_file` from the folder `out_dir` (real paths, '/' separators)."""
    rel = os.path.relpath(os.path.realpath(kb_file), os.path.realpath(out_dir))
    return Path(rel).as_posix()


def write_interpretation_kb(
    path: str | os.PathLike[str],
    kb: KnowledgeBase,
    interp: Interpretation,
    kb_file: str | os.PathLike[str],
    *,
    folder: str | os.PathLike[str] | None = None,
) -> None:
    """Write ``interpretation.kb`` to `path` atomically, importing `kb_file` relative to
    `folder` (the folder the file ends up in; default: `path`'s own)."""
    where = Path(folder) if folder is not None else Path(path).parent
    rel = relative_import(kb_file, where)
    kb_dir = Path(rel).parent.as_posix()
    hint = f"(in this folder) aida-kb lint {Path(path).name} --import-path {kb_dir}"
    write_text_atomic(path, interpretation_kb(kb, interp, rel, lint_hint=hint))
