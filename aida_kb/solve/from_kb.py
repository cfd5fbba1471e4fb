"""From the knowledge base to a problem: a compiled concept plus an assignment of its parts.

Given the compiled knowledge base (`aida_kb.kb.KnowledgeBase`), a root concept (``HouseBody``)
and an *assignment* of role paths (relative to the root, DOMAIN.md spelling: ``front``,
``roof.front``, ``oriels[1].left``) to part indices, `constraints_from_kb` walks the concept's
parts and con-of roles recursively and turns every `ConstraintSpec` it meets into solver
`Constraint` s, with no code specific to any concept:

* a path through a role with several fillers (``oriels.front``) stands for each filler that
  the assignment (or ``fillers``) names: ``oriels[0].front``, ``oriels[1].front``, ...;
* ``requires`` conditions are checked against the concept filling each role: ``fillers``
  (role path -> concrete concept, e.g. ``{"roof": "HipRoof", "wings[0]": "SkewWing"}``) or the
  declared concept;
* ``self`` is the path of the concept that declared the constraint; a path that is not
  assigned falls back to its nearest assigned ancestor through con-of roles, so a region's
  ``position(self)`` at ``front.region`` applies to the part ``front``;
* measurements need evidence: ``positions`` (part index -> `PositionData`), ``edges`` (sorted
  pair of part indices -> the image segments seen of that edge) and ``contours`` (a contour's
  role path -> its two parts and segment). A constraint whose parts or evidence are missing is
  not an error: it is listed in ``skipped`` with the reason.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, EdgeData, Origin, PositionData, kind_of
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.kb.model import ConceptModel, ConstraintSpec, KnowledgeBase
from aida_kb.kb.paths import ROOT, RolePath
from aida_kb.solve.problem import Problem, build_problem

_V = TypeVar("_V")
#: A mapping keyed by role paths, or by their dotted spellings (parsed once, at the edge).
PathMap = Mapping[RolePath, _V] | Mapping[str, _V]


@dataclass(frozen=True)
class KbConstraints:
    """The constraints of an assignment, and what was left out and why.

    Attributes
    ----------
    constraints : solver constraints, labels ``<path>:<label>(<concrete args>)``.
    specs : for each constraint, the `ConstraintSpec` it came from.
    skipped : ``"<path>:<label>: <reason>"`` for each spec instance that was not used.
    """

    constraints: tuple[Constraint, ...]
    specs: tuple[ConstraintSpec, ...]
    skipped: tuple[str, ...]


class _Walker:
    def __init__(
        self,
        kb: KnowledgeBase,
        assignment: Mapping[RolePath, int],
        fillers: Mapping[RolePath, str],
        positions: Mapping[int, PositionData],
        edges: Mapping[tuple[int, int], Sequence[EdgeData]],
        contours: Mapping[RolePath, tuple[int, int, EdgeData]],
    ) -> None:
        self.kb = kb
        self.assignment = assignment
        self.fillers = fillers
        self.positions = positions
        self.edges = edges
        self.contours = contours
        self.keys = set(assignment) | set(fillers) | set(contours)
        self.root = ""
        self.out: list[Constraint] = []
        self.specs: list[ConstraintSpec] = []
        self.skipped: list[str] = []

    # ---- paths -----------------------------------------------------------------------------

    def concept_at(self, path: RolePath, declared: str) -> ConceptModel:
        name = self.fillers.get(path, declared)
        if name not in self.kb.concepts:
            raise SolveError(f"{path or 'the root'}: unknown concept {name!r}")
        return self.kb.concepts[name]

    def present(self, path: RolePath) -> bool:
        return any(k.is_under(path) for k in self.keys)

    def indices(self, path: RolePath) -> list[int]:
        """The filler indices i for which ``path[i]`` is named by a key."""
        n = len(path)
        head, role = path.steps[:-1], path.last.role
        return sorted(
            {
                int(step.index)
                for k in self.keys
                if len(k) >= n
                and k.steps[: n - 1] == head
                and (step := k.steps[n - 1]).role == role
                and step.index is not None
            }
        )

    def role(self, concept: ConceptModel, name: str) -> tuple[str, bool, bool] | None:
        """(declared concept, several fillers?, con-of?) of role ``name`` of ``concept``."""
        if name in concept.parts:
            p = concept.parts[name]
            return p.concept, p.max is None or p.max > 1, False
        if name in concept.con_ofs:
            c = concept.con_ofs[name]
            return c.concept, c.max is None or c.max > 1, True
        return None

    def resolve(self, path: RolePath) -> int | None:
        """The part index of ``path``, or of its nearest ancestor through con-of roles."""
        while True:
            if path in self.assignment:
                return int(self.assignment[path])
            if len(path) < 2:
                return None  # a top-level role: no owner to fall back to
            concept = self._concept_of_path(path.parent)
            if concept is None or path.last.role not in concept.con_ofs:
                return None
            path = path.parent

    def _concept_of_path(self, path: RolePath) -> ConceptModel | None:
        concept = self.kb.concepts[self.root]
        for k, step in enumerate(path.steps):
            r = self.role(concept, step.role)
            if r is None:
                return None
            concept = self.concept_at(RolePath(path.steps[: k + 1]), r[0])
        return concept

    # ---- the walk --------------------------------------------------------------------------

    def walk(self, root: str) -> None:
        if root not in self.kb.concepts:
            raise SolveError(f"unknown concept {root!r}")
        self.root = root
        self.visit(ROOT, self.kb.concepts[root])

    def visit(self, path: RolePath, concept: ConceptModel) -> None:
        for spec in concept.constraints:
            self.expand(path, concept, spec)
        roles = [(n, p.concept, p.max) for n, p in concept.parts.items()]
        roles += [(n, c.concept, c.max) for n, c in concept.con_ofs.items()]
        for name, declared, most in roles:
            sub = path.child(name)
            if most is None or most > 1:
                for i in self.indices(sub):
                    filler = path.child(name, i)
                    self.visit(filler, self.concept_at(filler, declared))
                continue
            # a con-of role (a region) is visited wherever its owner is
            owner_present = bool(path) and name in concept.con_ofs and self.present(path)
            if self.present(sub) or owner_present:
                self.visit(sub, self.concept_at(sub, declared))

    def concretise(
        self, path: RolePath, concept: ConceptModel, rel: RolePath
    ) -> list[dict[RolePath, int]]:
        """The bindings (multi-role prefix -> filler index) that make ``rel`` concrete."""
        multi: list[RolePath] = []
        current = concept
        prefix = ROOT
        for step in rel.steps:
            r = self.role(current, step.role)
            if r is None:
                return []
            prefix = prefix.child(step.role, step.index)
            if r[1] and step.index is None:
                multi.append(prefix)
                prefix = prefix.indexed(0)
            current = self.concept_at(path.join(prefix), r[0])
        if not multi:
            return [{}]
        choices = [self.indices(path.join(p)) for p in multi]
        return [dict(zip(multi, combo, strict=True)) for combo in itertools.product(*choices)]

    @staticmethod
    def substitute(rel: RolePath, binding: Mapping[RolePath, int]) -> RolePath:
        for prefix, i in sorted(binding.items(), key=lambda kv: -len(str(kv[0]))):
            if rel.is_under(prefix):
                rel = prefix.indexed(i).join(rel.relative_to(prefix))
        return rel

    def expand(self, path: RolePath, concept: ConceptModel, spec: ConstraintSpec) -> None:
        rels = [RolePath.parse(a) for a in spec.args]
        rels += [RolePath.parse(rp) for rp, _ in spec.requires]
        bindings: list[dict[RolePath, int]] = [{}]
        for rel in rels:
            options = self.concretise(path, concept, rel)
            bindings = [
                {**b, **o}
                for b in bindings
                for o in options
                if all(b.get(k, v) == v for k, v in o.items())
            ]
        if not bindings:
            where = f"{path or '.'}:{spec.label}"
            self.skipped.append(f"{where}: no filler of {', '.join(spec.args)}")
        for binding in bindings:
            self.emit(path, spec, binding)

    def emit(self, path: RolePath, spec: ConstraintSpec, binding: Mapping[RolePath, int]) -> None:
        args = [self.substitute(RolePath.parse(a), binding) for a in spec.args]
        shown = [path.join(a) for a in args]
        label = f"{path or '.'}:{spec.label}({', '.join(str(s) for s in shown)})"
        for rp, allowed in spec.requires:
            concrete = path.join(self.substitute(RolePath.parse(rp), binding))
            filler = self.fillers.get(concrete)
            if filler is None:
                decl = self._concept_of_path(concrete)
                filler = decl.name if decl is not None else None
            if filler is None or not any(self.kb.is_a(filler, a) for a in allowed):
                self.skipped.append(
                    f"{label}: requires {concrete} to be {' or '.join(allowed)} (is {filler})"
                )
                return
        evidence = kind_of(spec.kind).evidence
        if evidence == "segment" and args == [ROOT]:
            found = self.contours.get(path)
            if found is None:
                self.skipped.append(f"{label}: no image segment for this contour")
                return
            a, b, seg = found
            self.add(spec, path, (int(a), int(b)), label, edge=seg)
            return
        parts = [self.resolve(s) for s in shown]
        if any(p is None for p in parts):
            missing = [str(s) for s, p in zip(shown, parts, strict=True) if p is None]
            self.skipped.append(f"{label}: unassigned {', '.join(missing)}")
            return
        ids = tuple(int(p) for p in parts if p is not None)
        if evidence == "plane_fit":
            pos = self.positions.get(ids[0])
            if pos is None:
                self.skipped.append(f"{label}: no region evidence for part {ids[0]}")
                return
            self.add(spec, path, ids, label, position=pos)
        elif evidence == "segment":
            segs = self.edges.get((min(ids), max(ids)), ())
            if not segs:
                self.skipped.append(f"{label}: no image segment of this edge")
            for k, seg in enumerate(segs):
                self.add(spec, path, ids, f"{label}#{k}" if len(segs) > 1 else label, edge=seg)
        else:
            self.add(spec, path, ids, label)

    def add(
        self,
        spec: ConstraintSpec,
        owner: RolePath,
        parts: tuple[int, ...],
        label: str,
        *,
        position: PositionData | None = None,
        edge: EdgeData | None = None,
    ) -> None:
        self.out.append(
            Constraint(
                kind=spec.kind,
                parts=parts,
                value=spec.value,
                sigma=spec.sigma,
                weight=spec.weight,
                reject_above=spec.reject_above,
                unit=spec.unit,
                measurement=spec.measurement,
                label=label,
                position=position,
                edge=edge,
                origin=Origin(
                    label=spec.label,
                    rule="knowledge",
                    concept=spec.concept,
                    owner=owner,
                    span=spec.span,
                ),
            )
        )
        self.specs.append(spec)


def _paths(mapping: PathMap[_V] | None) -> dict[RolePath, _V]:
    """A mapping keyed by role paths; dotted keys are parsed (once: paths are interned)."""
    items: list[tuple[RolePath | str, _V]] = list((mapping or {}).items())
    return {k if isinstance(k, RolePath) else RolePath.parse(k): v for k, v in items}


def constraints_from_kb(
    kb: KnowledgeBase,
    root: str,
    assignment: PathMap[int],
    *,
    fillers: PathMap[str] | None = None,
    positions: Mapping[int, PositionData] | None = None,
    edges: Mapping[tuple[int, int], Sequence[EdgeData]] | None = None,
    contours: PathMap[tuple[int, int, EdgeData]] | None = None,
) -> KbConstraints:
    """The solver constraints of concept ``root`` under ``assignment`` (see the module doc).

    Parameters
    ----------
    kb : the compiled knowledge base.
    root : the concept whose instance is being reconstructed (e.g. "HouseBody").
    assignment : role path relative to ``root`` -> part index (each a plane of the problem).
    fillers : role path -> the concrete concept filling it (specialisations, e.g. the roof
        type); roles not named are filled by their declared concept.
    positions : part index -> region evidence, for position constraints (eq. 4).
    edges : (i, j) with i < j -> image segments of the edge of parts i and j (eq. 5).
    contours : a contour's role path -> (part i, part j, its segment), for ``edge(self)``.

    Raises
    ------
    SolveError
        If ``root`` or a filler names an unknown concept.
    """
    walker = _Walker(
        kb, _paths(assignment), _paths(fillers), positions or {}, edges or {}, _paths(contours)
    )
    walker.walk(root)
    return KbConstraints(tuple(walker.out), tuple(walker.specs), tuple(walker.skipped))


def problem_from_kb(
    kb: KnowledgeBase,
    root: str,
    assignment: PathMap[int],
    normals: npt.ArrayLike,
    offsets: npt.ArrayLike,
    *,
    centres: npt.ArrayLike | None = None,
    fillers: PathMap[str] | None = None,
    positions: Mapping[int, PositionData] | None = None,
    edges: Mapping[tuple[int, int], Sequence[EdgeData]] | None = None,
    contours: PathMap[tuple[int, int, EdgeData]] | None = None,
    cameras: Sequence[PinholeCamera] = (),
    fixed_parts: Iterable[int] = (),
    free_cameras: Iterable[int] = (),
) -> tuple[Problem, KbConstraints]:
    """`constraints_from_kb` and `aida_kb.solve.build_problem` in one call.

    ``normals`` (P, 3) and ``offsets`` (P,) are the initial planes of the parts, world frame,
    metres; part names are the assignment's role paths.
    """
    found = constraints_from_kb(
        kb, root, assignment, fillers=fillers, positions=positions, edges=edges, contours=contours
    )
    names_by_index = {int(i): str(path) for path, i in assignment.items()}
    count = int(np.asarray(offsets).reshape(-1).shape[0])
    names = tuple(names_by_index.get(i, f"part {i}") for i in range(count))
    problem = build_problem(
        normals,
        offsets,
        found.constraints,
        centres=centres,
        fixed_parts=fixed_parts,
        names=names,
        cameras=cameras,
        free_cameras=free_cameras,
    )
    return problem, found
