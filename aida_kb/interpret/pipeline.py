"""The whole pipeline on a scene directory: evidence -> interpretation -> model files."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from aida_kb.interpret.multiview import reconstruct_views
from aida_kb.interpret.result import Interpretation, write_interpretation
from aida_kb.interpret.run import check_goal
from aida_kb.io.atomic import check_outputs
from aida_kb.io.evidence import Evidence, write_evidence
from aida_kb.io.model import write_model, write_obj
from aida_kb.io.scene import read_scene

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase

OUTPUT_FILES = ("evidence.json", "interpretation.json", "model.json", "model.obj")


@dataclass(frozen=True)
class Reconstruction:
    """What `reconstruct_scene` produced and where it wrote it."""

    evidence: Evidence
    interpretation: Interpretation
    files: tuple[Path, ...]


def reconstruct_scene(
    kb: KnowledgeBase,
    scene_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    goal: str = "House",
    views: Sequence[str] | None = None,
    stage: Callable[[str, str], None] | None = None,
    max_disp: int | None = None,
    warn: Callable[[str], None] | None = None,
) -> Reconstruction:
    """Evidence of a scene's views, their interpretation, and the model; write the files.

    The files (`OUTPUT_FILES`; model.json and model.obj only when the goal was found) are
    written to a temporary folder beside `out_dir` and moved into place together, so that
    a failed run leaves no half-written output. The scene's truth.json is never read.
    Every view is used: the first is interpreted, the others are registered against its
    model and the model is refined with all of them (`aida_kb.interpret.multiview`).
    max_disp : disparities 0..max_disp-1 searched (None: found from feature matches).
    warn : called with each warning of the vision front end (a disparity range too small).
    """
    from aida_kb.vision.evidence import VisionParams, scene_evidence

    check_goal(kb, goal)
    scene = read_scene(scene_dir, with_truth=False)
    check_outputs([], [*kb.files, *scene.files], directories=[out_dir])
    out = Path(out_dir)
    params = VisionParams(num_disp=max_disp)
    evidence, products = scene_evidence(scene, views=views, params=params, stage=stage)
    for prod in products:
        for text in prod.warnings:
            if warn is not None:
                warn(text)
    if stage is not None:
        stage("-", "interpretation")
    progress = None if stage is None else (lambda what: stage("-", what))
    interp = reconstruct_views(
        kb,
        evidence,
        goal=goal,
        source=str(Path(scene_dir) / "evidence"),
        scene=scene,
        progress=progress,
    )
    work = Path(tempfile.mkdtemp(prefix=".reconstruct-", dir=out))
    try:
        write_evidence(work / "evidence.json", evidence)
        write_interpretation(work / "interpretation.json", interp)
        names = ["evidence.json", "interpretation.json"]
        if interp.model is not None:
            write_model(work / "model.json", interp.model)
            write_obj(work / "model.obj", interp.model)
            names += ["model.json", "model.obj"]
        for stale in OUTPUT_FILES:
            if stale not in names and (out / stale).exists():
                (out / stale).unlink()
        for name in names:
            os.replace(work / name, out / name)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return Reconstruction(evidence, interp, tuple(out / n for n in names))
