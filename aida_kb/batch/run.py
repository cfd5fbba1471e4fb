"""A batch run on Dask: every scene reconstructed by `aida_kb.batch.work.run_scene` on a worker.

The cluster is a local one (one single-threaded worker process per core, each with a memory
limit) or an existing one (``scheduler``; its workers must see the scenes and the output
folder under the same paths, e.g. a shared file system). The knowledge base is compiled once
by the caller and sent to every worker once. Scenes are submitted a few per worker thread at
a time (`SCENES_IN_FLIGHT_PER_THREAD`), so that the scheduler's and the client's state stay
small however many scenes there are. Scenes an earlier run finished are not submitted.
"""

from __future__ import annotations

import contextlib
import fcntl
import itertools
import logging
import os
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aida_kb.batch.cityseq import CITYSEQ_FILE, write_city_sequence
from aida_kb.batch.outcome import SceneOutcome, Summary, SummaryRow, write_summary
from aida_kb.batch.scenes import SceneRef, check_output_root
from aida_kb.batch.work import SCENES_DIR, clear_work, finished_outcome, run_scene
from aida_kb.errors import FormatError
from aida_kb.interpret.run import check_goal
from aida_kb.io.atomic import make_dirs

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase

LOCK_FILE = ".batch.lock"

log = logging.getLogger(__name__)

# Scenes queued per worker thread beyond the one it runs: enough that a worker never waits
# for the client between two scenes, few enough that 100,000 scenes are not 100,000 tasks
# held by the scheduler at once.
SCENES_IN_FLIGHT_PER_THREAD = 2

# How often a scene may take a worker process down (memory limit exceeded, crash) before it
# is recorded as failed: once more on a fresh worker, since another cause may have killed it.
ALLOWED_WORKER_DEATHS = 1

# The environment Dask's nannies give the local cluster's worker processes before they start:
# one BLAS/OpenMP thread per process (the cores are shared out by processes). Dask's default
# also sets MALLOC_TRIM_THRESHOLD_=65536, which hands every freed numpy buffer back to the
# system: the stereo's and the evidence's large temporaries then fault their pages in again
# each time (measured on 320x240 scenes: 14x the page faults, the evidence stage 2-3x slower).
WORKER_ENVIRON = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}

# How the local cluster starts its worker processes: forked from one server process that has
# imported the pipeline (numpy, scipy, OpenCV, the interpreter) once, with `WORKER_ENVIRON`
# set, instead of each worker starting a fresh interpreter and importing it all again
# (Dask's default, "spawn"): one import instead of one per worker, and the workers share its
# pages. Measured with two workers on this machine under load 9, pipeline imported in every
# worker: the cluster up in 1.5-1.9 s instead of 3.4-4.4 s, time taken from the run's wall
# time, not from its scenes.
WORKER_START_METHOD = "forkserver"
WORKER_PRELOAD_MODULES = ("distributed", "aida_kb.batch.work")

# Seconds to wait for an existing scheduler to answer and to have at least one worker.
CONNECT_TIMEOUT_S = 30.0

Progress = Callable[[int, int, SceneOutcome], None]
"""Called as each scene ends: (scenes finished, scenes in the run, the scene's outcome)."""


@dataclass(frozen=True)
class BatchOptions:
    """How to run a batch; `goal` and `views` are those of ``aida-kb reconstruct``."""

    goal: str | None = None  # None: the knowledge base's only scene concept
    views: Sequence[str] | None = None
    scheduler: str | None = None
    workers: int | None = None  # local cluster: worker processes (default: one per core)
    memory_limit: str = "auto"  # local cluster: per worker, Dask's syntax ("4GB"); auto: RAM/n
    processes: bool = True  # local cluster: worker processes (False: threads, for tests)
    retry_failed: bool = False  # run scenes again whose earlier outcome is an error


def default_workers() -> int:
    """One worker process per core this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def _exclusive(out: Path) -> Iterator[None]:
    """Hold a lock on `out` for the run: two runs into one folder would publish over each other."""
    with open(out / LOCK_FILE, "a+b") as handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FormatError(f"{out}: another batch run is writing into this folder") from None
        yield


def _start_forkserver() -> None:
    """Start the fork server local workers are forked from, preloaded, in `WORKER_ENVIRON`.

    The server takes the environment it starts in: OpenBLAS and OpenMP read their thread
    counts once, at import, so the variables must be set before it imports numpy (Dask's
    ``pre-spawn-environ`` reaches spawned workers only). Started once per process; later
    runs reuse it.
    """
    import multiprocessing
    from multiprocessing import forkserver

    from distributed.utils import get_mp_context

    get_mp_context()  # Dask's own preload list first, so that it does not replace ours later
    multiprocessing.get_context("forkserver").set_forkserver_preload(list(WORKER_PRELOAD_MODULES))
    saved = {name: os.environ.get(name) for name in WORKER_ENVIRON}
    os.environ.update({name: str(value) for name, value in WORKER_ENVIRON.items()})
    try:
        forkserver.ensure_running()
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _lost(ref: SceneRef, exc: BaseException) -> SceneOutcome:
    """The outcome of a scene whose worker died; not published, so a restart runs it again."""
    return SceneOutcome(
        scene=ref.key,
        source=str(ref.path),
        status="error",
        objects=0,
        error=f"the worker running it died ({type(exc).__name__}: {exc}); "
        "it may have exceeded the worker memory limit",
    )


def _on_dask(
    kb: KnowledgeBase,
    todo: Sequence[SceneRef],
    out: Path,
    options: BatchOptions,
    finished: Callable[[SceneRef, SceneOutcome], None],
) -> int:
    """Run `todo` on the cluster; call `finished` per scene; return the number of workers."""
    import dask
    from distributed import Client, LocalCluster, as_completed
    from distributed.scheduler import KilledWorker

    preload = [*dask.config.get("distributed.worker.preload", []), "aida_kb.batch.preload"]
    config = {
        "distributed.worker.multiprocessing-method": WORKER_START_METHOD,
        "distributed.scheduler.allowed-failures": ALLOWED_WORKER_DEATHS,
        "distributed.nanny.pre-spawn-environ": WORKER_ENVIRON,
        "distributed.worker.preload": preload,
    }
    with contextlib.ExitStack() as stack:
        stack.enter_context(dask.config.set(config))
        if options.scheduler is not None:
            try:
                client = stack.enter_context(
                    Client(options.scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
                )
                client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError) as exc:
                raise FormatError(
                    f"--scheduler {options.scheduler}: no scheduler with workers answered "
                    f"within {CONNECT_TIMEOUT_S:.0f} s ({exc})"
                ) from None
        else:
            if options.processes and WORKER_START_METHOD == "forkserver":
                _start_forkserver()
            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=options.workers or default_workers(),
                    threads_per_worker=1,
                    processes=options.processes,
                    memory_limit=options.memory_limit,
                    dashboard_address=":0",  # random: the default 8787 may be taken
                    silence_logs=logging.ERROR,
                )
            )
            client = stack.enter_context(Client(cluster, set_as_default=False))
        workers: dict[str, Any] = client.scheduler_info()["workers"]
        threads = sum(int(w.get("nthreads", 1)) for w in workers.values()) or 1
        kb_future = client.scatter(kb, broadcast=True)
        run_id = uuid.uuid4().hex[:12]
        refs: dict[str, SceneRef] = {}

        def submit(index: int, ref: SceneRef) -> Any:
            key = f"aida-kb-scene-{run_id}-{index}"
            refs[key] = ref
            return client.submit(
                run_scene,
                kb_future,
                ref,
                str(out),
                goal=options.goal,
                views=options.views,
                key=key,
                pure=False,
                retries=0,
            )

        in_flight = threads * (1 + SCENES_IN_FLIGHT_PER_THREAD)
        queue = iter(enumerate(todo))
        first = [submit(i, ref) for i, ref in itertools.islice(queue, in_flight)]
        futures = as_completed(first, loop=client.loop)
        for future in futures:
            ref = refs.pop(future.key)
            try:
                outcome: SceneOutcome = future.result()
            except KilledWorker as exc:
                outcome = _lost(ref, exc)
            future.release()
            finished(ref, outcome)
            following = next(queue, None)
            if following is not None:
                futures.add(submit(*following))
        return len(workers)


def run_batch(
    kb: KnowledgeBase,
    kb_path: str,
    scenes: Sequence[SceneRef],
    out: str | os.PathLike[str],
    options: BatchOptions | None = None,
    progress: Progress | None = None,
) -> Summary:
    """Reconstruct `scenes` into `out` (resuming an earlier run there); write the summary.

    Finished scenes of an earlier run are kept (``outcome.json``), failed ones too unless
    `options.retry_failed`. The summary (``summary.json``, ``summary.csv``) lists every scene
    of `scenes`, also when the run is interrupted (the rest then ``pending``); ``city.jsonl``
    holds every accepted object so far as a CityJSONSeq (`aida_kb.batch.cityseq`).
    """
    options = options or BatchOptions()
    options = replace(options, goal=check_goal(kb, options.goal))  # None: the only scene concept
    root = make_dirs(out)
    check_output_root(root, scenes)
    with _exclusive(root):
        clear_work(root)
        outcomes: dict[str, SceneOutcome] = {}
        resumed: set[str] = set()
        todo: list[SceneRef] = []
        for ref in scenes:
            earlier = finished_outcome(root, ref.key)
            if earlier is None or (options.retry_failed and earlier.status == "error"):
                todo.append(ref)
            else:
                outcomes[ref.key] = earlier
                resumed.add(ref.key)

        def finished(ref: SceneRef, outcome: SceneOutcome) -> None:
            outcomes[ref.key] = outcome
            if progress is not None:
                progress(len(outcomes), len(scenes), outcome)

        start = time.perf_counter()
        workers = 0
        try:
            if todo:
                workers = _on_dask(kb, todo, root, options, finished)
                clear_work(root)
        finally:
            summary = _summary(
                kb_path, options.goal or "", scenes, outcomes, resumed, workers, start
            )
            write_summary(root, summary)
            _, left_out = write_city_sequence(root, summary.rows)
            for problem in left_out:
                log.warning("%s: %s left out", problem, CITYSEQ_FILE)
        return summary


def _summary(
    kb_path: str,
    goal: str,
    scenes: Sequence[SceneRef],
    outcomes: dict[str, SceneOutcome],
    resumed: set[str],
    workers: int,
    start: float,
) -> Summary:
    rows: list[SummaryRow] = []
    for ref in scenes:
        outcome = outcomes.get(ref.key) or SceneOutcome(
            scene=ref.key, source=str(ref.path), status="pending", objects=0
        )
        model = f"{SCENES_DIR}/{ref.key}/model.obj" if "model.obj" in outcome.files else None
        rows.append(SummaryRow(outcome=outcome, resumed=ref.key in resumed, model=model))
    count = {s: sum(r.outcome.status == s for r in rows) for s in ("accepted", "nothing")}
    return Summary(
        kb=kb_path,
        goal=goal,
        scenes=len(rows),
        accepted=count["accepted"],
        nothing=count["nothing"],
        errors=sum(r.outcome.status == "error" for r in rows),
        pending=sum(r.outcome.status == "pending" for r in rows),
        resumed=len(resumed),
        workers=workers,
        seconds=time.perf_counter() - start,
        rows=rows,
    )
