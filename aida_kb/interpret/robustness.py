"""One randomised scene through the whole pipeline, judged against its truth.

`run_random_scene` renders `aida_kb.synth.randomised.random_scene(seed)`, reconstructs it
exactly as `aida-kb reconstruct` does and judges the result with
`aida_kb.interpret.evaluate.evaluate`. `benchmarks/robustness.py` aggregates many seeds;
a test runs a few small ones so that a regression shows in `make test`.

The verdict (`aida_kb.interpret.verdict.judge`) only reads the interpretation and the
evidence, so a kept scene can be judged again without reconstructing it: `rejudge_scene`
reads ``scene-SEED`` and ``out-SEED`` (or ``error-SEED.txt``) from the folder
`run_random_scene` wrote them to.

Streets (`run_random_street`): the randomised street variant of a seed
(`aida_kb.synth.street.random_street_spec`: 2-5 free-standing houses, a terrace of 2-5 touching
ones or a house half hidden behind another) is reconstructed against a knowledge base whose
goal holds several houses (kb/street.kb, goal ``Street``) and judged house by house
(`aida_kb.interpret.scene.evaluate_scene`): every true house correct, wrong but verified,
doubtful or missed, and every reconstructed object paired with no house (invented) or with
a house another object already took (twice). Its seeds are a sequence of their own: the
single-object seeds draw the same kinds whether streets are run or not.
"""

from __future__ import annotations

import time
from collections import Counter, defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from aida_kb.errors import AidaError
from aida_kb.interpret.evaluate import Evaluation, evaluate
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.interpret.result import Interpretation, read_interpretation
from aida_kb.interpret.scene import evaluate_scene, judge_objects, members
from aida_kb.interpret.sight import unseen_parts
from aida_kb.interpret.verdict import judge, with_verdict
from aida_kb.io.evidence import read_evidence
from aida_kb.io.scene import left_images, read_scene
from aida_kb.synth.randomised import random_scene
from aida_kb.synth.scenes import render_scene
from aida_kb.synth.street import random_street, random_street_labels, random_street_spec

if TYPE_CHECKING:
    from aida_kb.io.scene import Scene, SceneTruth
    from aida_kb.kb.model import KnowledgeBase

STREET_GOAL = "Street"  # kb/street.kb's scene concept: one or more houses


@dataclass(frozen=True)
class SceneOutcome:
    """What became of one random scene."""

    seed: int
    kind: str
    labels: bool  # the scene has labels.png
    views: int
    outcome: str  # 'verified', 'doubtful', 'nothing' or 'error'
    correct: bool
    cause: str  # '' when correct; the first failed check (or the error's message)
    seconds: float
    figures: dict[str, object]

    @classmethod
    def judged(
        cls, seed: int, kind: str, labels: bool, views: int, evaluation: Evaluation, seconds: float
    ) -> SceneOutcome:
        """The outcome of a scene whose result `evaluation` judged against its truth."""
        return cls(
            seed,
            kind,
            labels,
            views,
            evaluation.outcome,
            evaluation.correct,
            evaluation.cause,
            seconds,
            evaluation.summary(),
        )

    @classmethod
    def failed(
        cls,
        seed: int,
        kind: str,
        labels: bool,
        views: int,
        error: str,
        message: str,
        seconds: float,
    ) -> SceneOutcome:
        """The outcome of a scene whose pipeline raised `error` (its class name) with `message`."""
        return cls(
            seed,
            kind,
            labels,
            views,
            "error",
            False,
            f"error: {error}",
            seconds,
            {"message": message},
        )

    @property
    def wrong_accepted(self) -> bool:
        """Reported as verified, but not correct."""
        return self.outcome == "verified" and not self.correct


def run_random_scene(
    kb: KnowledgeBase,
    seed: int,
    workdir: str | Path,
    *,
    goal: str | None = None,
    max_views: int = 8,
    max_width: int = 800,
    supersample: int = 2,
    knowledge: Callable[[str], KnowledgeBase] | None = None,
) -> SceneOutcome:
    """Render seed's random scene into `workdir`, reconstruct it and judge the result.

    kb : the knowledge every scene is reconstructed with, unless `knowledge` is given: then
    each scene with the knowledge base it names (its ``knowledge`` parameter, a file name
    under ``kb/``: the tower with ``tower.kb``, the turntable box with ``reference_box.kb``),
    as a user would choose the knowledge for the object they photographed.

    An error of the pipeline (an `AidaError`: bad evidence, a degenerate solve) is an
    outcome of its own ('error'), with its message as the cause (also written to
    ``error-SEED.txt`` in `workdir`, for `rejudge_scene`).
    """
    spec = random_scene(seed, max_views=max_views, max_width=max_width)
    scene_dir, out_dir = Path(workdir) / f"scene-{seed}", Path(workdir) / f"out-{seed}"
    render_scene(spec, scene_dir, supersample=supersample)
    kind = str(spec.model.parameters["kind"])
    if knowledge is not None:
        kb = knowledge(str(spec.model.parameters.get("knowledge", "buildings.kb")))
    start = time.perf_counter()
    try:
        result = reconstruct_scene(kb, scene_dir, out_dir, goal=goal)
    except AidaError as exc:
        seconds = time.perf_counter() - start
        (Path(workdir) / f"error-{seed}.txt").write_text(f"{type(exc).__name__}: {exc}\n")
        return SceneOutcome.failed(
            seed,
            kind,
            spec.write_labels,
            len(spec.views_site),
            type(exc).__name__,
            str(exc),
            seconds,
        )
    seconds = time.perf_counter() - start
    scene = read_scene(scene_dir)
    truth = scene.truth
    assert truth is not None  # render_scene always writes one
    hidden = unseen_parts(scene)
    judged = evaluate(result.interpretation, truth, goal=goal, unmeasurable=hidden)
    return SceneOutcome.judged(seed, kind, spec.write_labels, len(spec.views_site), judged, seconds)


def _kept(
    workdir: Path, folder: str, name: str
) -> tuple[Scene, SceneTruth, bool, Path, Path] | None:
    """A kept scene (``FOLDER-SEED`` in `workdir`; `name` its ``SEED`` or ``street-SEED``): the
    scene, its truth, whether it has labels.png, its results' folder ``out-NAME`` and error file
    ``error-NAME.txt`` (None: no scene there)."""
    scene_dir = workdir / f"{folder}-{name.rsplit('-', 1)[-1]}"
    if not (scene_dir / "truth.json").is_file():
        return None
    scene = read_scene(scene_dir)
    truth = scene.truth
    assert truth is not None  # checked above
    labels = any(v.labels is not None for v in scene.views)
    return scene, truth, labels, workdir / f"out-{name}", workdir / f"error-{name}.txt"


def rejudge_scene(
    kb: KnowledgeBase,
    seed: int,
    workdir: str | Path,
    knowledge: Callable[[str], KnowledgeBase] | None = None,
) -> SceneOutcome | None:
    """Seed's scene as `run_random_scene` left it in `workdir`, judged again with the current
    verdict (`judge` on the kept interpretation and evidence) and evaluated against its truth.

    None when the folder holds neither a result nor an error of that seed. The kind, the
    labels and the views are read from the scene's truth and files; seconds are 0.
    `knowledge` : as for `run_random_scene`.
    """
    kept = _kept(Path(workdir), "scene", f"{seed}")
    if kept is None:
        return None
    scene, truth, labels, out_dir, error = kept
    kind = str(truth.parameters.get("kind", truth.object))
    if error.is_file():
        name, _, message = error.read_text().strip().partition(": ")
        return SceneOutcome.failed(seed, kind, labels, len(scene.views), name, message, 0.0)
    if not (out_dir / "interpretation.json").is_file():
        return None
    if knowledge is not None:
        kb = knowledge(str(truth.parameters.get("knowledge", "buildings.kb")))
    interp = read_interpretation(out_dir / "interpretation.json")
    evidence = read_evidence(out_dir / "evidence.json")
    images = left_images(scene, [v.id for v in evidence.views])
    interp = with_verdict(interp, judge(kb, interp, evidence, all_views=True, images=images))
    judged = evaluate(interp, truth, unmeasurable=unseen_parts(scene))
    return SceneOutcome.judged(seed, kind, labels, len(scene.views), judged, 0.0)


# ---- streets: several houses per scene, judged house by house ------------------------------
HOUSE_STATES = ("correct", "wrong_verified", "doubtful", "missed")


@dataclass(frozen=True)
class StreetOutcome:
    """What became of one randomised street: the scene's outcome and every true house's."""

    seed: int
    preset: str  # 'street', 'terrace' or 'occluded'
    labels: bool  # the scene has labels.png
    views: int
    outcome: str  # the scene's: 'verified', 'doubtful', 'nothing' or 'error'
    houses: tuple[dict[str, object], ...]  # per true house: its state (HOUSE_STATES) and figures
    invented: int  # reconstructed objects near no true house
    twice: int  # reconstructed objects on a house another object already took
    seconds: float
    message: str  # the error's message ('' without one)

    def count(self, state: str) -> int:
        """How many of the true houses are in `state` (one of HOUSE_STATES)."""
        return sum(1 for h in self.houses if h["state"] == state)


def house_state(row: dict[str, object]) -> str:
    """A true house's state from its `evaluate_scene` row: 'missed' (no object paired with it),
    'correct' (verified and right), 'wrong_verified' (verified but not right: the worst) or
    'doubtful' (found, not verified: right or wrong)."""
    if row.get("status") != "found":
        return "missed"
    if row.get("correct"):
        return "correct"
    return "wrong_verified" if row.get("outcome") == "verified" else "doubtful"


def _judged_street(
    role: str,
    seed: int,
    preset: str,
    labels: bool,
    views: int,
    interp: Interpretation,
    scene: Scene,
    seconds: float,
) -> StreetOutcome:
    truth = scene.truth
    assert truth is not None  # a kept or rendered street always has one
    rows = evaluate_scene(interp, truth, role, unseen_parts(scene))
    houses = tuple(
        {
            "truth": r["truth"],
            "object": r.get("object"),
            "state": house_state(r),
            "cause": r.get("cause", "missed"),
            "max_normal_error_deg": r.get("max_normal_error_deg"),
            "max_vertex_error_pct": r.get("max_vertex_error_pct"),
            "unmeasurable": r.get("unmeasurable"),
        }
        for r in rows
        if r.get("status") in ("found", "missed")
    )
    return StreetOutcome(
        seed,
        preset,
        labels,
        views,
        outcome_of_scene(interp),
        houses,
        sum(1 for r in rows if r["status"] == "invented"),
        sum(1 for r in rows if r["status"] == "twice"),
        seconds,
        "",
    )


def outcome_of_scene(interp: Interpretation) -> str:
    """'verified', 'doubtful' or 'nothing': what a scene's result claims as a whole."""
    if not interp.accepted or interp.model is None:
        return "nothing"
    return interp.verdict if interp.verdict in ("verified", "doubtful") else "nothing"


def _street_error(
    role: str,
    seed: int,
    preset: str,
    labels: bool,
    views: int,
    houses: int,
    exc_name: str,
    message: str,
) -> StreetOutcome:
    missed: tuple[dict[str, object], ...] = tuple(
        {"truth": f"{role}[{k}]", "object": None, "state": "missed", "cause": f"error: {exc_name}"}
        for k in range(houses)
    )
    return StreetOutcome(seed, preset, labels, views, "error", missed, 0, 0, 0.0, message)


def run_random_street(
    kb: KnowledgeBase,
    seed: int,
    workdir: str | Path,
    *,
    max_views: int = 8,
    max_width: int | None = None,
    supersample: int = 2,
) -> StreetOutcome:
    """Render seed's randomised street (`synth.street.random_street_spec`, labels.png drawn
    with `random_street_labels`) into `workdir` as ``street-SEED``, reconstruct it against `kb`
    (whose goal ``Street`` holds the houses: kb/street.kb) exactly as `aida-kb reconstruct`
    does, and judge it house by house against its truth.

    max_views : cap on the views (the presets have two). max_width : cap on the image width
    (pixels; None: the presets' 1280). An `AidaError` of the pipeline is the outcome 'error'
    (every house missed, its message kept and written to ``error-street-SEED.txt``)."""
    role = members_of(kb)
    if role is None:
        raise ValueError(f"the knowledge has no {STREET_GOAL} holding objects")
    labels = random_street_labels(seed)
    spec = random_street_spec(seed, max_width=max_width, labels=labels)
    if len(spec.views_site) > max_views:
        spec = random_street_spec(seed, views=max_views, max_width=max_width, labels=labels)
    preset = random_street(seed)[0]
    scene_dir = Path(workdir) / f"street-{seed}"
    out_dir = Path(workdir) / f"out-street-{seed}"
    render_scene(spec, scene_dir, supersample=supersample)
    views = len(spec.views_site)
    start = time.perf_counter()
    try:
        result = reconstruct_scene(kb, scene_dir, out_dir, goal=STREET_GOAL)
    except AidaError as exc:
        (Path(workdir) / f"error-street-{seed}.txt").write_text(f"{type(exc).__name__}: {exc}\n")
        houses = int(spec.model.parameters["houses"])
        name = type(exc).__name__
        return _street_error(role, seed, preset, labels, views, houses, name, str(exc))
    seconds = time.perf_counter() - start
    scene = read_scene(scene_dir)
    return _judged_street(role, seed, preset, labels, views, result.interpretation, scene, seconds)


def members_of(kb: KnowledgeBase) -> str | None:
    """The role of `STREET_GOAL` holding the houses in `kb` (None: it holds none)."""
    from aida_kb.interpret.knowledge import Knowledge

    if STREET_GOAL not in kb.concepts:
        return None
    slot = members(Knowledge.from_kb(kb), STREET_GOAL)
    return None if slot is None else slot.role


def rejudge_street(kb: KnowledgeBase, seed: int, workdir: str | Path) -> StreetOutcome | None:
    """Seed's street as `run_random_street` left it in `workdir`, every house judged again with
    the current verdict (`scene.judge_objects` on the kept interpretation and evidence) and
    against its truth. None when the folder holds neither a result nor an error of the seed."""
    role = members_of(kb)
    if role is None:
        raise ValueError(f"the knowledge has no {STREET_GOAL} holding objects")
    kept = _kept(Path(workdir), "street", f"street-{seed}")
    if kept is None:
        return None
    scene, truth, labels, out_dir, error = kept
    preset = random_street(seed)[0]
    if error.is_file():
        name, _, message = error.read_text().strip().partition(": ")
        houses = int(float(truth.parameters.get("houses", 0)))
        views = len(scene.views)
        return _street_error(role, seed, preset, labels, views, houses, name, message)
    if not (out_dir / "interpretation.json").is_file():
        return None
    interp = read_interpretation(out_dir / "interpretation.json")
    evidence = read_evidence(out_dir / "evidence.json")
    interp = judge_objects(kb, interp, evidence)
    interp = with_verdict(interp, judge(kb, interp, evidence, all_views=True))
    return _judged_street(role, seed, preset, labels, len(scene.views), interp, scene, 0.0)


def scene_rates(rows: Sequence[SceneOutcome]) -> dict[str, object]:
    """The figures of a robustness run over `rows` (benchmarks/robustness.py's JSON line,
    benchmarks/independent.py's): rates of correct, wrongly accepted (verified but not
    correct), doubtful, nothing found and errors, the object-less scenes found empty, the
    correct share per kind, the failure causes and the registered cameras' figures
    (`camera_figures`)."""
    n = len(rows)
    if n == 0:
        return {"scenes": 0}

    def rate(k: int) -> float:
        return round(k / n, 3)

    by_kind: dict[str, list[bool]] = defaultdict(list)
    for r in rows:
        by_kind[r.kind].append(r.correct)
    empty = [r for r in rows if not r.figures.get("expected_object", True)]
    # scenes whose views show every true part (`aida_kb.interpret.sight`); in the others an
    # unseen part is right only where the knowledge's guess happens to be
    # (scenes without rendered depth, as from another renderer, are not counted: None)
    objects = [
        r
        for r in rows
        if r.figures.get("expected_object", False) and r.figures.get("unmeasurable") is not None
    ]
    shown = [r for r in objects if r.figures.get("unmeasurable") == []]
    return {
        "scenes": n,
        "correct_rate": rate(sum(r.correct for r in rows)),
        "wrong_accepted_rate": rate(sum(r.wrong_accepted for r in rows)),
        "doubtful_rate": rate(sum(r.outcome == "doubtful" for r in rows)),
        "nothing_rate": rate(sum(r.outcome == "nothing" for r in rows)),
        "error_rate": rate(sum(r.outcome == "error" for r in rows)),
        "no_object_nothing_found": f"{sum(r.outcome == 'nothing' for r in empty)}/{len(empty)}",
        "objects_fully_shown": f"{len(shown)}/{len(objects)}",
        "correct_of_fully_shown": f"{sum(r.correct for r in shown)}/{len(shown)}",
        "correct_by_kind": {
            k: f"{sum(v)}/{len(v)}" for k, v in sorted(by_kind.items(), key=lambda kv: kv[0])
        },
        "causes": dict(Counter(r.cause for r in rows if not r.correct).most_common()),
        **camera_figures(rows),
    }


RIGHT_FORM_CAUSES = ("", "camera", "vertices", "normals", "right but doubtful")
"""The causes of scenes whose model has the truth's form (an object found, the right
specialisations, no part missing or extra): their errors are the measurement's, which the
adjustment's standard deviations describe; the others' are the hypothesis's, which they do not."""


def _median(values: Sequence[float]) -> float:
    ordered = sorted(values)
    return ordered[len(ordered) // 2]


def camera_figures(rows: Sequence[SceneOutcome]) -> dict[str, object]:
    """The registered cameras (not view 00, which sets the world frame) of the scenes where
    the right specialisations were found: how many, the median rotation error, the share
    within the 0.1 degree target, and the share within two of the adjustment's standard
    deviations (its honesty: about 0.95 if they are calibrated). The same honesty for the
    scenes whose model has the truth's form (`RIGHT_FORM_CAUSES`): the median of the
    cameras' and the parts' normals' errors over their deviations (calibrated: 0.7-0.9 for a
    rotation's, whose sd is the root of its three axes' variances; about 0.7-1.2 for a
    normal's, two axes) and the parts' share within two deviations (`sd_figures`)."""
    errors: list[float] = []
    within_2sd: list[bool] = []
    for r in rows:
        if r.figures.get("specialisations") or r.figures.get("missing"):
            continue
        cameras = r.figures.get("cameras")
        for c in cameras if isinstance(cameras, list) else []:
            angle = c.get("angle_deg")
            if c.get("view") == "00" or not isinstance(angle, float) or angle != angle:
                continue
            errors.append(angle)
            sd = c.get("sd_deg")
            if isinstance(sd, float):
                within_2sd.append(angle <= 2.0 * sd)
    if not errors:
        return {"registered_cameras": 0, **sd_figures(rows)}
    return {
        "registered_cameras": len(errors),
        "camera_error_median_deg": round(_median(errors), 3),
        "cameras_within_0p1_deg": round(sum(e <= 0.1 for e in errors) / len(errors), 3),
        "cameras_within_2sd": (round(sum(within_2sd) / len(within_2sd), 3) if within_2sd else None),
        **sd_figures(rows),
    }


def sd_figures(rows: Sequence[SceneOutcome]) -> dict[str, object]:
    """How honest the adjustment's standard deviations are where the model has the truth's
    form (`RIGHT_FORM_CAUSES`; camera errors over 5 degrees are registration failures, not
    noise, and left out): the median error over sd of the later cameras' rotations and of
    the parts' normals, and the parts' share within two sd. Empty without such scenes."""
    cams: list[float] = []
    parts: list[float] = []
    for r in rows:
        if not r.figures.get("expected_object") or r.cause not in RIGHT_FORM_CAUSES:
            continue
        if r.outcome == "nothing":
            continue
        cameras = r.figures.get("cameras")
        for c in cameras if isinstance(cameras, list) else []:
            angle, sd = c.get("angle_deg"), c.get("sd_deg")
            if c.get("view") == "00" or not isinstance(sd, float) or sd <= 0:
                continue
            if isinstance(angle, float) and angle <= FAR_CAMERA_DEG:
                cams.append(angle / sd)
        normals = r.figures.get("normals")
        for pair in normals.values() if isinstance(normals, dict) else []:
            error, sd = pair
            if isinstance(sd, float) and sd > 0:
                parts.append(float(error) / sd)
    out: dict[str, object] = {}
    if cams:
        out["camera_error_over_sd_median"] = round(_median(cams), 2)
    if parts:
        out["part_normals_judged"] = len(parts)
        out["part_normal_error_over_sd_median"] = round(_median(parts), 2)
        out["part_normals_within_2sd"] = round(sum(q <= 2.0 for q in parts) / len(parts), 3)
    return out


FAR_CAMERA_DEG = 5.0
"""A camera this far off was registered to a wrong pose (a twin, a wrong model): its error
is no measurement noise, and its sd does not describe it."""
