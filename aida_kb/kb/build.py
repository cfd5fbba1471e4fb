"""Phase 4, build: the checked symbol table -> the immutable `KnowledgeBase` (pydantic).

Runs only on a knowledge base without errors, so the models are made with ``model_construct``
(no second validation). Each concept gets its members with inheritance resolved and its
constraints expanded into `ConstraintSpec` primitives (templates bound, defaults applied,
tolerances as sigma in SI, weights 1/sigma² unless explicit, thresholds in SI).
"""

from __future__ import annotations

from typing import Any, TypeVar, cast

from pydantic import BaseModel

from aida_kb.dsl import ast
from aida_kb.kb.model import (
    AdjacencyModel,
    AttachmentModel,
    AttributeModel,
    BindingModel,
    ConceptModel,
    ConOfModel,
    ConstraintKind,
    ConstraintSpec,
    FrameModel,
    InstanceModel,
    KnowledgeBase,
    MeasureModel,
    OrientationModel,
    ParamModel,
    PartModel,
    PlacementModel,
    ResidualUnit,
    ShareModel,
    TemplateModel,
    ValueType,
    ValueUnit,
)
from aida_kb.kb.relations import UNIT_KIND, Analyzer, Prim, quantity_si
from aida_kb.kb.resolve import VALUE_TYPES, CInfo, PathRes, SlotKind, Table
from aida_kb.kb.shape import attribute_measure, build_shape

__all__ = ["build"]

_M = TypeVar("_M", bound=BaseModel)
_setattr = object.__setattr__


def _make(cls: type[_M], **values: Any) -> _M:
    """A model from checked values, every field given: what ``model_construct`` does, without
    its per-field loop over defaults and aliases (the build makes tens of thousands)."""
    m = cls.__new__(cls)
    _setattr(m, "__dict__", values)
    _setattr(m, "__pydantic_fields_set__", set(values))
    _setattr(m, "__pydantic_extra__", None)
    _setattr(m, "__pydantic_private__", None)
    return m


def _si(expr: ast.Expr | None) -> float | None:
    if isinstance(expr, ast.Quantity) and expr.unit in UNIT_KIND:
        return quantity_si(expr)
    if isinstance(expr, ast.Number):
        return expr.value
    return None


def _attribute(
    table: Table, info: CInfo, name: str, node: ast.Attribute, owner: str
) -> AttributeModel:
    rng = node.range
    if rng is None:  # an override without a range keeps the inherited one
        for anc in table.ancestors(info.node.name.text):
            slot = table.concepts[anc].slots.get(name)
            if slot is not None and isinstance(slot.node, ast.Attribute) and slot.node.range:
                rng = slot.node.range
                break
    vtype = node.type.text
    measure = attribute_measure(node)
    return _make(
        AttributeModel,
        name=name,
        type=cast(ValueType, vtype),
        unit=cast(ValueUnit, VALUE_TYPES[vtype]),
        low=_si(rng.low) if rng else None,
        high=_si(rng.high) if rng else None,
        default=_si(node.default),
        declared_in=owner,
        span=node.span,
        measure=_make(MeasureModel, **measure) if measure is not None else None,
    )


def _specs(
    cname: str, prims_by_rule: list[tuple[str | None, str, list[Prim]]]
) -> tuple[ConstraintSpec, ...]:
    out: list[ConstraintSpec] = []
    counters: dict[str, int] = {}
    for label, owner, prims in prims_by_rule:
        if label is None:
            counters[owner] = counters.get(owner, 0) + 1
            base = f"{owner}#{counters[owner]}"
        else:
            base = label
        distinct = {(p.kind, p.args) for p in prims}
        for i, p in enumerate(prims, 1):
            name = base if len(distinct) <= 1 else f"{base}/{i}"
            out.append(
                _make(
                    ConstraintSpec,
                    label=name,
                    kind=cast(ConstraintKind, p.kind),
                    args=p.args,
                    value=p.value,
                    unit=cast(ResidualUnit, p.unit),
                    sigma=p.sigma,
                    weight=p.weight,
                    reject_above=p.reject_above,
                    measurement=p.measurement,
                    concept=owner,
                    span=p.span,
                    requires=p.requires,
                )
            )
    return tuple(out)


def _concept(table: Table, cname: str, info: CInfo) -> ConceptModel:
    parts: dict[str, PartModel] = {}
    con_ofs: dict[str, ConOfModel] = {}
    attributes: dict[str, AttributeModel] = {}
    for key, s in info.slots.items():
        if s.kind is SlotKind.PART:
            parts[key] = _make(
                PartModel,
                role=key,
                concept=s.concept or "",
                min=s.min,
                max=s.max,
                optional=s.optional,
                declared_in=s.owner,
                span=s.node.span,
            )
        elif s.kind is SlotKind.CON_OF:
            con_ofs[key] = _make(
                ConOfModel,
                role=key,
                concept=s.concept or "",
                min=s.min,
                max=s.max,
                declared_in=s.owner,
                span=s.node.span,
            )
        else:
            assert isinstance(s.node, ast.Attribute)
            attributes[key] = _attribute(table, info, key, s.node, s.owner)
    adjacencies: list[AdjacencyModel] = []
    for adj, owner in info.adjacency:
        when = table.condition_requires(cname, adj.condition)
        if when is None:
            continue  # a 'when' block that cannot hold here (or did not resolve)
        for a, b in adj.edges:
            ra, rb = table.resolve_path(cname, a), table.resolve_path(cname, b)
            if not (isinstance(ra, PathRes) and isinstance(rb, PathRes)):
                continue  # a conditional pair that a narrowed role rules out
            req = tuple(dict.fromkeys(ra.requires + rb.requires + when))
            adjacencies.append(
                _make(
                    AdjacencyModel,
                    a=a.dotted,
                    b=b.dotted,
                    declared_in=owner,
                    span=adj.span,
                    requires=req,
                )
            )
    az = Analyzer(table, cname)
    done = table.expansions  # the rules the checks analysed in this concept
    prims = [
        (
            r.label,
            r.owner,
            done[(cname, id(r.node))]
            if (cname, id(r.node)) in done
            else az.rule(r.node, inherited=r.owner != cname),
        )
        for r in info.rules
    ]
    shape = build_shape(table, cname, info)
    frame = shape["frame"]
    return _make(
        ConceptModel,
        name=cname,
        layer=info.layer or "",
        abstract=info.node.abstract,
        parents=tuple(info.parents),
        specialisations=tuple(info.children),
        doc=info.node.doc,
        parts=parts,
        con_ofs=con_ofs,
        attributes=attributes,
        adjacencies=tuple(adjacencies),
        constraints=_specs(cname, prims),
        span=info.node.span,
        frame=_make(FrameModel, **frame) if frame is not None else None,
        orientations={k: _make(OrientationModel, **v) for k, v in shape["orientations"].items()},
        placements=tuple(_make(PlacementModel, **v) for v in shape["placements"]),
        attachments={k: _make(AttachmentModel, **v) for k, v in shape["attachments"].items()},
        shares=tuple(_make(ShareModel, **v) for v in shape["shares"]),
    )


def _template(t: ast.Template) -> TemplateModel:
    params = tuple(
        _make(ParamModel, name=p.name.text, type=p.type.text, default=_si(p.default))
        for p in t.params
    )
    return _make(TemplateModel, name=t.name.text, params=params, doc=t.doc, span=t.span)


def _instance(inst: ast.Instance) -> InstanceModel:
    bindings: dict[str, BindingModel] = {}
    for b in inst.bindings:
        items = b.value.items if isinstance(b.value, ast.ListExpr) else (b.value,)
        bindings[b.role.text] = _make(
            BindingModel,
            role=b.role.text,
            instances=tuple(i.dotted for i in items if isinstance(i, ast.Path)),
            evidence=tuple(i.value for i in items if isinstance(i, ast.String)),
            value=next(
                (
                    v
                    for i in items
                    if isinstance(i, ast.Quantity | ast.Number)
                    if (v := _si(i)) is not None
                ),
                None,
            ),
            span=b.span,
        )
    return _make(
        InstanceModel,
        name=inst.name.text,
        concept=inst.concept.text,
        doc=inst.doc,
        bindings=bindings,
        span=inst.span,
    )


def build(table: Table, files: tuple[str, ...]) -> KnowledgeBase:
    """The `KnowledgeBase` of a checked table (call only when the checks found no error)."""
    concepts = {c: _concept(table, c, table.concepts[c]) for c in table.concepts}
    return _make(
        KnowledgeBase,
        layers=tuple(table.layers),
        concepts=concepts,
        templates={n: _template(t) for n, t in table.templates.items()},
        instances={n: _instance(i) for n, i in table.instances.items()},
        files=files,
    )
