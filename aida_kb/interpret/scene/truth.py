"""A scene's result against its truth, object by object (the ``evaluate`` command, tests and
benchmarks).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.result import (
    Interpretation,
)
from aida_kb.io.scene import SceneTruth

if TYPE_CHECKING:
    pass

from aida_kb.interpret.scene.roles import (
    object_interpretation,
    object_of,
    object_truth,
    relative_role,
)

FloatArray = npt.NDArray[np.float64]


def evaluate_scene(
    interp: Interpretation,
    truth: SceneTruth,
    members_role: str,
    unmeasurable: tuple[str, ...] | None = None,
) -> list[dict[str, object]]:
    """Every true object of `truth` against the reconstructed object paired with it.

    Objects are roles ``MEMBERS[K]`` (`members_role`) in the truth's part roles and in the
    result's. A reconstructed object is paired with the true one whose faces its model's
    vertices lie nearest (mean distance to the nearest true vertex); each true object takes
    at most one reconstructed object. Returns one row per true object (its role, the paired
    object or None, `evaluate.evaluate`'s figures of the pair) and one per reconstructed
    object paired with no true one ('invented') or with a true object already taken
    ('twice'). `unmeasurable`: the scene's true parts no view shows
    (`aida_kb.interpret.sight.unmeasurable`, role paths of the whole scene; None: not known);
    each true object's row lists its own, relative to it.
    """
    from aida_kb.interpret.evaluate import evaluate

    true_roles = sorted({o for p in truth.parts if (o := object_of(p.role, members_role))})
    model = interp.model
    found = [o.role for o in interp.objects]
    verdicts = {o.role: o for o in interp.objects}

    def vertices(
        role: str, parts: list[tuple[str, list[tuple[float, float, float]]]]
    ) -> FloatArray:
        pts = [v for r, poly in parts if object_of(r, members_role) == role for v in poly]
        return np.asarray(pts, dtype=np.float64).reshape(-1, 3)

    true_parts = [(p.role, p.polygon) for p in truth.parts]
    mine = [] if model is None else [(p.role, p.polygon) for p in model.parts]
    distance = np.full((len(found), len(true_roles)), np.inf)
    for i, f in enumerate(found):
        a = vertices(f, mine)
        for j, t in enumerate(true_roles):
            b = vertices(t, true_parts)
            if len(a) and len(b):
                distance[i, j] = float(
                    np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2).min(axis=1).mean()
                )
    pairs: dict[str, str] = {}  # true -> found
    rows: list[dict[str, object]] = []
    for i in np.argsort(distance.min(axis=1) if len(true_roles) else np.zeros(len(found))):
        f = found[int(i)]
        j = int(np.argmin(distance[i])) if len(true_roles) else -1
        if j < 0 or not np.isfinite(distance[i, j]):
            rows.append({"object": f, "truth": None, "status": "invented"})
            continue
        t = true_roles[j]
        size = vertices(t, true_parts)
        diag = float(np.linalg.norm(size.max(axis=0) - size.min(axis=0)))
        if distance[i, j] > 0.25 * diag:
            rows.append({"object": f, "truth": None, "status": "invented"})
        elif t in pairs:
            rows.append({"object": f, "truth": t, "status": "twice"})
        else:
            pairs[t] = f
    for t in true_roles:
        f_role = pairs.get(t)
        sub_truth = object_truth(truth, t)
        hidden = (
            None
            if unmeasurable is None
            else tuple(relative_role(t, r) for r in unmeasurable if r.startswith(t + "."))
        )
        if f_role is None or model is None:
            rows.append(
                {
                    "truth": t,
                    "object": None,
                    "status": "missed",
                    "correct": False,
                    "unmeasurable": None if hidden is None else list(hidden),
                }
            )
            continue
        sub = object_interpretation(interp, f_role, verdicts[f_role])
        result = evaluate(sub, sub_truth, goal=sub.goal, unmeasurable=hidden)
        rows.append({"truth": t, "object": f_role, "status": "found", **result.summary()})
    return rows
