"""Interpret evidence against a compiled knowledge base: the `Interpretation` and its model."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.errors import InterpretError
from aida_kb.interpret.interpreter import Interpreter, State
from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import view_of
from aida_kb.interpret.result import Interpretation
from aida_kb.interpret.verify import verify_levels
from aida_kb.io.evidence import Evidence
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel

if TYPE_CHECKING:
    from aida_kb.interpret.scene import Preference
    from aida_kb.kb.model import KnowledgeBase


def _v3(a: object) -> tuple[float, float, float]:
    v = np.asarray(a, dtype=np.float64).ravel()
    return (float(v[0]), float(v[1]), float(v[2]))


def _cameras(evidence: Evidence) -> list[ModelCamera]:
    return [
        ModelCamera(
            view=v.id,
            K=v.left.K,
            R=v.left.R,
            t=v.left.t,
            image_width=v.image_width,
            image_height=v.image_height,
            cahv=v.left.cahv,
        )
        for v in evidence.views
        if v.frame == "world"
    ]


FloatArray = npt.NDArray[np.float64]

# a closed polygon off its adjusted plane by more than this (metres) was made concurrent with
# its neighbours (`closure.close`): the part's plane is the polygon's
OFF_PLANE_M = 1e-9


def _plane_of(polygon: FloatArray, normal: FloatArray, offset_m: float) -> tuple[FloatArray, float]:
    """The plane of a closed polygon (K, 3): the adjusted plane (`normal` (3,) unit,
    `offset_m`) if the polygon lies in it, else the polygon's own (least squares, same side)."""
    if float(np.max(np.abs(polygon @ normal - offset_m))) <= OFF_PLANE_M:
        return normal, offset_m
    centre = polygon.mean(axis=0)
    n = np.linalg.svd(polygon - centre)[2][-1]
    n = n if float(n @ normal) >= 0 else -n
    return n, float(n @ centre)


def model_of(state: State, evidence: Evidence) -> ReconstructedModel:
    """The reconstructed model of an accepted state: every part's plane and closed polygon.

    Each level is one closed solid: its parts, and the faces that close it from the levels it
    belongs to (a wing's bottom in its body's floor plane, `closure.closing_faces`).
    """
    parts: list[ModelPart] = []
    for level in state.levels:
        faces = [
            (leaf.role, leaf.concept, *level.outcome.planes[leaf.role])
            for leaf in level.structure.leaves
        ]
        faces += [(c.role, c.concept, c.normal, c.offset_m) for c in level.closing]
        for role, concept, n, d in faces:
            n, d = _plane_of(level.polygons[role], n / np.linalg.norm(n), float(d))
            parts.append(
                ModelPart(
                    role=role,
                    concept=concept,
                    normal=_v3(n),
                    offset_m=d,
                    polygon=[_v3(p) for p in level.polygons[role]],
                )
            )
    up = state.levels[0].frame.up if state.levels else None
    return ReconstructedModel(
        parts=parts, cameras=_cameras(evidence), up=None if up is None else _v3(up)
    )


def check_goal(kb: KnowledgeBase, goal: str | None) -> str:
    """The goal concept; refuse (InterpretError) one that is not a concept of the knowledge
    base's top layer.

    The goal of an interpretation is a scene object: a concept of the first layer of
    ``layers scene > world > image``. None stands for the knowledge base's only concrete
    concept of that layer (an error when it has several: name one). Cheap; commands call it
    before any long work.
    """
    top = kb.layers[0] if kb.layers else "scene"
    names = sorted(n for n, c in kb.concepts.items() if c.layer == top)
    scene = ", ".join(names) or "none"
    if goal is None:
        # the concrete concepts no other one of the layer holds as a part (a street, not
        # its houses)
        held = {p.concept for n in names for p in kb.concepts[n].parts.values()}
        concrete = [n for n in names if not kb.concepts[n].abstract and n not in held]
        if len(concrete) != 1:
            raise InterpretError(
                f"the knowledge base has {len(concrete) or 'no'} concrete {top}-layer concepts "
                f"({scene}): name the goal"
            )
        return concrete[0]
    concept = kb.concepts.get(goal)
    if concept is None:
        raise InterpretError(
            f"goal {goal!r} is not a concept of the knowledge base ({top} concepts: {scene})"
        )
    if concept.layer != top:
        raise InterpretError(
            f"goal {goal!r} is a concept of the {concept.layer} layer; the goal must be a "
            f"{top}-layer concept ({scene})"
        )
    return goal


def interpret(
    kb: KnowledgeBase,
    evidence: Evidence,
    *,
    goal: str | None = None,
    source: str = "",
    progress: Callable[[str], None] | None = None,
    choices: tuple[tuple[str, str], ...] = (),
    prefer: Sequence[Preference] = (),
) -> Interpretation:
    """Interpret `evidence` against `kb` for the goal concept `goal` (None: the knowledge
    base's only scene concept, `check_goal`). ``choices``: is-a choices the object's body
    must make (``(role path, concept)``, `Interpreter.choices`; () : any). prefer : for a goal
    holding several objects, the choices the other views decided for some of them
    (`interpret.scene.reconstruct_objects`).

    Returns the interpretation: accepted with instances, model, residuals and trace, or not
    accepted (no instances, no model) with a message saying why. Raises InterpretError when the
    goal is not a concept of the knowledge base's top (scene) layer (`check_goal`).
    """
    goal = check_goal(kb, goal)
    knowledge = Knowledge.from_kb(kb)
    from aida_kb.interpret.scene import interpret_scene, members  # it builds on this module

    slot = members(knowledge, goal)
    if slot is not None:  # a goal holding several scene objects
        return interpret_scene(
            kb, evidence, goal, slot, source=source, progress=progress, prefer=prefer
        )
    view = view_of(evidence, source)
    interpreter = Interpreter(knowledge, view, goal, choices=choices)
    if progress is not None:
        progress(f"interpreting {len(view.regions)} regions, {len(view.segments)} segments")
    state, expanded, goal_id = interpreter.run()
    return interpretation_of(interpreter, state, expanded, goal_id, evidence)


def interpretation_of(
    interpreter: Interpreter, state: State | None, expanded: int, goal_id: int, evidence: Evidence
) -> Interpretation:
    """The `Interpretation` of one search of `interpreter` (its result `Interpreter.run`):
    accepted with instances, model and residuals, or not accepted with the reason."""
    goal = interpreter.goal
    trace = list(interpreter.trace.entries)
    if state is None:
        reasons = [h for h in trace if h.status == "rejected" and h.id != goal_id]
        # a rejection by a named constraint says most; else the first one
        named = [h for h in reasons if h.constraint is not None]
        first = (named or reasons)[:1]
        why = first[0].reason if first else "no alternative was verified"
        # an attribute's rejection (no cost) names the attribute and its line in its text
        if first and first[0].constraint is not None and first[0].cost is not None:
            why = f"constraint {first[0].constraint!r} (cost {first[0].cost:.3g}): {why}"
        if len(reasons) > 1:
            why = f"{len(reasons)} alternatives rejected, e.g. {why}"
        return Interpretation(
            goal=goal,
            accepted=False,
            message=f"no {goal} in the evidence: {why}",
            trace=trace,
            expanded=expanded,
        )
    # the accepted levels solved once more as a whole, level by level (the main parts first,
    # then fixed for the smaller ones): one residual report for the whole interpretation
    whole = verify_levels([level.verification for level in state.levels])
    residuals = list(whole.residuals)
    choices = ", ".join(
        level.structure.describe() for level in state.levels if level.structure.describe()
    )
    inserted = sum(len(level.inserted) for level in state.levels)
    ties = interpreter.ties(state)
    undecided = f"; the evidence does not decide it from {', '.join(ties)}" if ties else ""
    return Interpretation(
        goal=goal,
        accepted=True,
        message=(
            f"{goal} verified ({choices or 'no alternatives'}); "
            f"{sum(len(lv.structure.leaves) for lv in state.levels)} planar parts, "
            f"{inserted} inserted from knowledge; {expanded} hypotheses expanded{undecided}"
        ),
        instances=interpreter.instances(state),
        model=model_of(state, evidence),
        residuals=residuals,
        trace=trace,
        expanded=expanded,
        cost=state.cost,
        ties=ties,
    )
