"""Several objects per scene: a goal that holds scene objects (``part houses: House [1..*]``).

A scene-layer goal whose part-of role is filled by another scene-layer concept (kb/street.kb:
a street holding one or more houses) is interpreted object by object. Each round runs the
single-object search (`interpreter.Interpreter`) for the member concept on the evidence that
the objects found so far do not explain (`Context.build(..., explained)`): the regions an
accepted object binds, and the regions lying on its faces though unbound (a window band, a
sliver of a side wall), are never bound again, and segments bordering only them measure no
edge. The rounds end when the search finds nothing more, or the role's maximum (or
`MAX_OBJECTS`) is reached. Touching objects need nothing special: a party wall no view sees is
inserted for each of them from its own evidence (the two planes coincide); a region hidden in
part by a nearer object is still one region, bound to the object behind.

Each object is then judged alone (`verdict.judge`) on the evidence without the regions the
others explain: its own verdict, 'verified' or 'doubtful'; one the verdict finds 'nothing'
(its evidence does not support it) is dropped. The scene's result is one `Interpretation`:
the goal, each object's instances, model parts and residuals under its role (``houses[0]``,
``houses[1]`` ...; the order found), the traces one after the other, and `objects` with every
object's verdict; the scene is verified when every object is, doubtful when one is.

An object the first view does not show (hidden behind another) is looked for in each registered
later view once the views are registered (`later_view_objects`).

Cost: round k searches with the regions of k objects removed; each round tries at most
`ANCHORS_PER_ROUND` anchors, and each anchor's search is bounded like one object's: at most
`interpreter.MAX_BODY_VERIFICATIONS` adjustments of the body (of the hypotheses
`generate` enumerates from the anchor's neighbourhood, at most `NEIGHBOUR_HOPS` borders
away, not from the whole view) and `interpreter.MAX_OPTIONAL_EXPANSIONS` for its optional
parts. With N objects there are at most N + 1 rounds (the last finds nothing), so the
adjustments grow linearly with N — at most (N + 1) · `ANCHORS_PER_ROUND` ·
(`MAX_BODY_VERIFICATIONS` + `MAX_OPTIONAL_EXPANSIONS`) — each over the regions of one
neighbourhood; only ranking the anchors and finding the neighbourhoods look at all R regions
of the view each round (O(N · R²) cheap border tests). Never the combinations of objects.

The modules, in the order they build on one another:

- `members`: the role of a goal that holds objects (`Members`) and the choices other views or
  the knowledge decided for one of them (`Preference`);
- `roles`: role paths of one object within the scene's result (`prefixed`, `relative_role`,
  `object_interpretation`, `object_truth`, `object_uncertainty`);
- `faces`: the regions an object explains without binding them (`on_faces`,
  `explained_by_others`);
- `shared`: what touching objects share (kb: ``touching ROLE share PATH``);
- `rounds`: the rounds of the search, one object each (`find_objects`, `interpret_scene`);
- `judging`: every object judged again on all views (`judge_objects`);
- `later`: the objects only the later views show (`later_view_objects`);
- `ties`: ties the other views decide, and the whole reconstruction (`reconstruct_objects`);
- `truth`: a scene's result against its truth, object by object (`evaluate_scene`; the
  ``evaluate`` command, tests and benchmarks).
"""

from aida_kb.interpret.scene.faces import explained_by_others, on_faces
from aida_kb.interpret.scene.judging import judge_objects
from aida_kb.interpret.scene.later import later_view_objects
from aida_kb.interpret.scene.members import Members, Preference, members
from aida_kb.interpret.scene.rounds import (
    MAX_OBJECTS,
    Search,
    find_objects,
    interpret_scene,
    scene_evidence_of,
)
from aida_kb.interpret.scene.shared import alike_doubts, confirmed_choices, shared_choices, touching
from aida_kb.interpret.scene.ties import Score, inside_faces, object_score, reconstruct_objects
from aida_kb.interpret.scene.truth import evaluate_scene

__all__ = [
    "MAX_OBJECTS",
    "Members",
    "Preference",
    "Score",
    "Search",
    "alike_doubts",
    "confirmed_choices",
    "evaluate_scene",
    "explained_by_others",
    "find_objects",
    "inside_faces",
    "interpret_scene",
    "judge_objects",
    "later_view_objects",
    "members",
    "object_score",
    "on_faces",
    "reconstruct_objects",
    "scene_evidence_of",
    "shared_choices",
    "touching",
]
