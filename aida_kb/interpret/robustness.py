"""One randomised scene through the whole pipeline, judged against its truth.

`run_random_scene` renders `aida_kb.synth.randomised.random_scene(seed)`, reconstructs it
exactly as `aida-kb reconstruct` does and judges the result with
`aida_kb.interpret.evaluate.evaluate`. `benchmarks/robustness.py` aggregates many seeds;
a test runs a few small ones so that a regression shows in `make test`.

The verdict (`aida_kb.interpret.verdict.judge`) only reads the interpretation and the
evidence, so a kept scene can be judged again without reconstructing it: `rejudge_scene`
reads ``scene-SEED`` and ``out-SEED`` (or ``error-SEED.txt``) from the folder
`run_random_scene` wrote them to.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from aida_kb.errors import AidaError
from aida_kb.interpret.evaluate import evaluate
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.interpret.result import read_interpretation
from aida_kb.interpret.verdict import judge, with_verdict
from aida_kb.io.evidence import read_evidence
from aida_kb.io.scene import read_scene
from aida_kb.synth.randomised import random_scene
from aida_kb.synth.scenes import render_scene

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase


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
        return SceneOutcome(
            seed,
            kind,
            spec.write_labels,
            len(spec.views_site),
            "error",
            False,
            f"error: {type(exc).__name__}",
            seconds,
            {"message": str(exc)},
        )
    seconds = time.perf_counter() - start
    truth = read_scene(scene_dir).truth
    assert truth is not None  # render_scene always writes one
    judged = evaluate(result.interpretation, truth, goal=goal)
    return SceneOutcome(
        seed,
        kind,
        spec.write_labels,
        len(spec.views_site),
        judged.outcome,
        judged.correct,
        judged.cause,
        seconds,
        judged.summary(),
    )


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
    scene_dir, out_dir = Path(workdir) / f"scene-{seed}", Path(workdir) / f"out-{seed}"
    error = Path(workdir) / f"error-{seed}.txt"
    if not (scene_dir / "truth.json").is_file():
        return None
    scene = read_scene(scene_dir)
    truth = scene.truth
    assert truth is not None  # checked above
    kind = str(truth.parameters.get("kind", truth.object))
    labels = any(v.labels is not None for v in scene.views)
    if error.is_file():
        name, _, message = error.read_text().strip().partition(": ")
        return SceneOutcome(
            seed,
            kind,
            labels,
            len(scene.views),
            "error",
            False,
            f"error: {name}",
            0.0,
            {"message": message},
        )
    if not (out_dir / "interpretation.json").is_file():
        return None
    if knowledge is not None:
        kb = knowledge(str(truth.parameters.get("knowledge", "buildings.kb")))
    interp = read_interpretation(out_dir / "interpretation.json")
    evidence = read_evidence(out_dir / "evidence.json")
    interp = with_verdict(interp, judge(kb, interp, evidence, all_views=True))
    judged = evaluate(interp, truth)
    return SceneOutcome(
        seed,
        kind,
        labels,
        len(scene.views),
        judged.outcome,
        judged.correct,
        judged.cause,
        0.0,
        judged.summary(),
    )
