"""One scene of a batch: the reconstruct pipeline into a private folder, published in one rename.

`run_scene` is what a Dask worker runs. It calls `aida_kb.interpret.pipeline.reconstruct_scene`
(the `reconstruct` command's pipeline) into ``OUT/.work/<random>/out``, adds ``outcome.json``
and renames that folder to ``OUT/scenes/<key>``. A scene's output therefore appears whole or not
at all: a run that is killed loses only the scenes in flight, whose private folders the next
run removes (`clear_work`). A failure of the scene (bad input, or a bug) is recorded in its
outcome and published like a result, so that the run goes on and a restart does not retry it
(unless asked to).
"""

from __future__ import annotations

import contextlib
import errno
import os
import resource
import shutil
import socket
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import cv2

from aida_kb.batch.outcome import OUTCOME_FILE, SceneOutcome, Verdict, read_outcome, write_outcome
from aida_kb.batch.scenes import SceneRef
from aida_kb.errors import AidaError, FormatError
from aida_kb.interpret.pipeline import reconstruct_scene
from aida_kb.interpret.verdict import NOTHING
from aida_kb.io.atomic import make_dirs

if TYPE_CHECKING:
    from aida_kb.interpret.result import Interpretation
    from aida_kb.kb.model import KnowledgeBase

SCENES_DIR = "scenes"
WORK_DIR = ".work"

# A worker process runs one scene at a time, whatever its thread count: the memory of a
# worker is then bounded by one scene's (a cluster started elsewhere may give its workers
# several threads; they queue here).
_ONE_SCENE = threading.Lock()

# Threads per scene inside a worker process. Workers are processes, one per core: a second
# thread per scene (OpenCV's, or the stereo's row bands) would only oversubscribe the cores.
THREADS_PER_SCENE = 1


def verdicts_of(interp: Interpretation) -> list[Verdict]:
    """The verdict of each object of a scene: the goal's, or each of several objects' own
    (`aida_kb.interpret.scene`: a street's houses) with its role."""
    if interp.objects:
        return [
            Verdict(
                goal=f"{o.concept} {o.role}",
                accepted=True,
                verdict=o.verdict,
                message=o.message,
            )
            for o in interp.objects
        ]
    return [
        Verdict(
            goal=interp.goal,
            accepted=interp.accepted,
            verdict=interp.verdict,
            message=interp.message,
        )
    ]


def found_objects(interp: Interpretation) -> int:
    """How many objects the scene's result holds: accepted and not judged `nothing` (an
    object the verdict rejects, e.g. for sizes outside the knowledge's ranges, is none)."""
    if interp.objects:
        return sum(1 for o in interp.objects if o.verdict != NOTHING)
    return int(interp.accepted and interp.verdict != NOTHING)


def scene_dir(out: Path, key: str) -> Path:
    """The published output folder of the scene `key` below the batch output `out`."""
    return out / SCENES_DIR / key


def finished_outcome(out: Path, key: str) -> SceneOutcome | None:
    """The outcome of an earlier run of scene `key`, or None if it has not finished.

    A folder whose ``outcome.json`` cannot be read (changed by hand) counts as not finished.
    """
    path = scene_dir(out, key) / OUTCOME_FILE
    if not path.is_file():
        return None
    try:
        return read_outcome(path)
    except FormatError:
        return None


def clear_work(out: Path) -> None:
    """Remove the private folders of scenes a killed run left in flight."""
    shutil.rmtree(out / WORK_DIR, ignore_errors=True)


def describe_error(exc: BaseException) -> str:
    """One line for a scene's failure: the message of an aida-kb error, else its kind too."""
    if isinstance(exc, AidaError):
        return str(exc)
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or type(exc).__name__}"
    return f"internal error: {type(exc).__name__}: {exc}"


def peak_rss_mb() -> float:
    """This process's peak resident memory since it started, MiB.

    Linux: ``VmHWM`` of /proc/self/status (the high-water mark of this program's memory).
    ``getrusage``'s ru_maxrss is not used there: it keeps the parent's peak across fork and
    exec, so a worker started by a large process would report that process's memory.
    Elsewhere ru_maxrss (KiB, macOS bytes).
    """
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError):
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024.0 * 1024.0) if sys.platform == "darwin" else peak / 1024.0


def _publish(done: Path, target: Path, work: Path) -> None:
    """Rename the folder `done` to `target`; an older `target` is moved into `work` first."""
    make_dirs(target.parent)
    try:
        os.rename(done, target)
    except OSError as exc:
        if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR):
            raise
        os.rename(target, work / "previous")
        os.rename(done, target)


@contextlib.contextmanager
def _threads(n: int) -> Iterator[None]:
    """OpenCV's thread count (which the stereo follows) set to `n` for the block."""
    before = cv2.getNumThreads()
    cv2.setNumThreads(n)
    try:
        yield
    finally:
        cv2.setNumThreads(before)


def run_scene(
    kb: KnowledgeBase,
    ref: SceneRef,
    out: str,
    *,
    goal: str | None = None,
    views: Sequence[str] | None = None,
) -> SceneOutcome:
    """Reconstruct one scene into ``out/scenes/<key>`` and return its outcome.

    Never raises for a problem of the scene itself: it is the outcome's error. An error in
    writing the output (disk full, no permission) is raised: the run cannot go on.
    """
    with _ONE_SCENE, _threads(THREADS_PER_SCENE):
        root = Path(out)
        work = Path(tempfile.mkdtemp(prefix="scene-", dir=make_dirs(root / WORK_DIR)))
        done = work / "out"
        start = time.perf_counter()
        cpu_start = time.process_time()
        evidence_end: list[float] = []

        def stage(view: str, name: str) -> None:
            if view == "-" and not evidence_end:  # the first stage after the vision front end
                evidence_end.append(time.perf_counter())

        common = {
            "scene": ref.key,
            "source": str(ref.path),
            "worker": f"{socket.gethostname()}:{os.getpid()}",
        }
        try:
            try:
                result = reconstruct_scene(kb, ref.path, done, goal=goal, views=views, stage=stage)
            except Exception as exc:  # the scene's failure is recorded; the run goes on
                shutil.rmtree(done, ignore_errors=True)
                make_dirs(done)
                outcome = SceneOutcome(
                    status="error",
                    objects=0,
                    error=describe_error(exc),
                    seconds=time.perf_counter() - start,
                    **common,
                )
            else:
                end = time.perf_counter()
                interp = result.interpretation
                split = evidence_end[0] if evidence_end else None
                found = found_objects(interp)
                outcome = SceneOutcome(
                    status="accepted" if found else "nothing",
                    objects=found,
                    verdicts=verdicts_of(interp),
                    seconds=end - start,
                    seconds_evidence=None if split is None else split - start,
                    seconds_interpretation=None if split is None else end - split,
                    files=[p.name for p in result.files],
                    **common,
                )
            outcome = outcome.model_copy(
                update={
                    "peak_rss_mb": peak_rss_mb(),
                    "cpu_seconds": time.process_time() - cpu_start,
                    "finished": datetime.now(UTC).isoformat(timespec="seconds"),
                    "files": [*outcome.files, OUTCOME_FILE],
                }
            )
            write_outcome(done / OUTCOME_FILE, outcome)
            _publish(done, scene_dir(root, ref.key), work)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        return outcome
