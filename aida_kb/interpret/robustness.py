"""One randomised scene through the whole pipeline, judged against its truth.

`run_random_scene` renders `aida_kb.synth.randomised.random_scene(seed)`, reconstructs it
exactly as `aida-kb reconstruct` does and judges the result with
`aida_kb.interpret.evaluate.evaluate`. `benchmarks/robustness.py` aggregates many seeds;
a test runs a few small ones so that a regression shows in `make test`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from aida_kb.errors import AidaError
from aida_kb.interpret.evaluate import evaluate
from aida_kb.interpret.pipeline import reconstruct_scene
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
) -> SceneOutcome:
    """Render seed's random scene into `workdir`, reconstruct it and judge the result.

    An error of the pipeline (an `AidaError`: bad evidence, a degenerate solve) is an
    outcome of its own ('error'), with its message as the cause.
    """
    spec = random_scene(seed, max_views=max_views, max_width=max_width)
    scene_dir, out_dir = Path(workdir) / f"scene-{seed}", Path(workdir) / f"out-{seed}"
    render_scene(spec, scene_dir, supersample=supersample)
    kind = str(spec.model.parameters["kind"])
    start = time.perf_counter()
    try:
        result = reconstruct_scene(kb, scene_dir, out_dir, goal=goal)
    except AidaError as exc:
        seconds = time.perf_counter() - start
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
