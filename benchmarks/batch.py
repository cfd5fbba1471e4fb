"""Many scenes: one after another in one process against `aida-kb batch` on a local Dask cluster.

Run: .venv/bin/python benchmarks/batch.py [--scenes 40] [--workers N] [--size 320x240]

Renders `--scenes` synthetic scenes (not timed): presets house (gable, hip, flat, shed roofs),
lshape (90 and 135 degrees) and oriel with random dimensions, pitches and seeds drawn from
`BENCH_SEED`, two stereo views each. Then reconstructs them twice with the shipped knowledge
base:

- sequential: `aida_kb.batch.work.run_scene` for each scene in turn, in one fresh process —
  the per-scene work of a batch with no parallelism (no process start-up per scene, which a
  shell loop of `aida-kb reconstruct` would add);
- dask: `aida_kb.batch.run.run_batch` on a fresh local cluster of `--workers` single-threaded
  worker processes (default: one per core), cluster start-up included.

Both run one thread per scene: the workers and the sequential process get the same
environment (`aida_kb.batch.run.WORKER_ENVIRON`: OMP/MKL/OpenBLAS threads 1, glibc's malloc
left as it is), and `run_scene` sets OpenCV's threads (which the stereo's row bands follow)
to 1, so the worker processes do not oversubscribe the cores. The sequential baseline is
therefore single-threaded; `evidence_share` says how much of a scene's time is the stereo
stage, the only one `aida-kb reconstruct` runs on several threads.

On a shared machine wall times measure the other processes too. Linux shares the CPU fairly
between sessions when autogroup scheduling is on (it is on this machine): the sequential
process and each worker therefore run in a session of their own (`dask_setup`;
`--same-session` leaves them in this one, where two workers together get one session's
share). The load averages before and after each phase are in the output, with the share of a
core each process got (`cpu_share_*`: CPU time of the scenes over wall time, 1.0 on an idle
machine); the CPU time per scene (`cpu_s_per_scene`) does not depend on the load.
`dask_overhead_ms_per_task` is what Dask itself costs per scene: no-op tasks submitted the way
`run_batch` submits scenes.

Ends with ONE JSON line: scenes, seconds_sequential, seconds_dask, speedup,
peak_rss_mb_per_worker, scenes_per_core_hour (scenes / (seconds_dask x workers) x 3600), and
the figures that qualify them.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import dask  # noqa: E402
import distributed  # noqa: E402, F401  (its configuration defaults before dask.config.set)

from aida_kb.batch.outcome import read_outcome  # noqa: E402
from aida_kb.batch.run import (  # noqa: E402
    SCENES_IN_FLIGHT_PER_THREAD,
    WORKER_ENVIRON,
    BatchOptions,
    default_workers,
    run_batch,
)
from aida_kb.batch.scenes import find_scenes, scene_refs  # noqa: E402
from aida_kb.batch.work import peak_rss_mb, run_scene, scene_dir  # noqa: E402
from aida_kb.kb import compile_path  # noqa: E402
from aida_kb.synth.scenes import preset, render_scene  # noqa: E402

KB = ROOT / "kb" / "buildings.kb"
BENCH_SEED = 19  # the scene mix; no parameter of the pipeline was tuned on these scenes


def scene_params(rng: random.Random) -> tuple[str, dict[str, str]]:
    """A random preset and its parameters (metres, degrees)."""
    kind = rng.choice(["house", "house", "lshape", "oriel"])
    p: dict[str, str] = {}
    if kind == "house":
        p["roof"] = rng.choice(["gable", "hip", "flat", "shed"])
        p["width"] = f"{rng.uniform(11.0, 18.0):.2f}"
        p["depth"] = f"{rng.uniform(8.0, 11.0):.2f}"
        p["pitch_deg"] = f"{rng.uniform(25.0, 45.0):.1f}"
    elif kind == "lshape":
        p["meeting_deg"] = rng.choice(["90", "135"])
        p["width"] = f"{rng.uniform(14.0, 18.0):.2f}"
        p["pitch_deg"] = f"{rng.uniform(30.0, 42.0):.1f}"
    else:
        p["n_oriels"] = str(rng.choice([1, 2]))
        p["pitch_deg"] = f"{rng.uniform(32.0, 45.0):.1f}"
    return kind, p


def render(root: Path, n: int, size: tuple[int, int]) -> None:
    """Render `n` scenes ``s000`` ... into `root`."""
    rng = random.Random(BENCH_SEED)
    width, height = size
    camera = {"image_width": str(width), "image_height": str(height), "focal_px": str(width * 1.25)}
    for i in range(n):
        kind, params = scene_params(rng)
        spec = preset(kind, seed=rng.randrange(1, 2**31 - 1), views=2, params={**params, **camera})
        render_scene(spec, root / f"s{i:03d}")


def sequential_child(scenes_root: str, out: str) -> None:
    """(In a fresh process.) Every scene with `run_scene`, one after another; print JSON."""
    result = compile_path(KB)
    assert result.kb is not None
    refs = scene_refs(find_scenes([scenes_root]))
    start = time.perf_counter()
    for ref in refs:
        run_scene(result.kb, ref, out)
    seconds = time.perf_counter() - start
    print(json.dumps({"seconds": seconds, "peak_rss_mb": peak_rss_mb()}))


def dask_setup(worker: object) -> None:
    """Dask preload hook (this file is the workers' preload): the worker in its own session.

    Linux's autogroup scheduling (kernel.sched_autogroup_enabled) shares the CPU fairly
    between sessions, not processes: on a machine shared with other sessions, two workers in
    the benchmark's session would together get the share of the one sequential process. In
    their own sessions each gets a session's share, as the sequential process (started in a
    session of its own) does. On a machine nobody else uses this changes nothing.
    """
    os.setsid()


def _autogroup() -> str:
    try:
        return Path("/proc/sys/kernel/sched_autogroup_enabled").read_text().strip()
    except OSError:
        return "n/a"


def _noop(i: int) -> int:
    return i


def scheduler_overhead_ms(workers: int, tasks: int) -> float:
    """Milliseconds per task of a task that does nothing, submitted as `run_batch` submits.

    The same local cluster, the same window of tasks in flight: what Dask itself costs per
    scene (client, scheduler, worker and the round trips between them).
    """
    import itertools
    import logging

    from distributed import Client, LocalCluster, as_completed

    with (
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster, set_as_default=False) as client,
    ):
        client.submit(_noop, -1).result()  # workers up and connected
        window = workers * (1 + SCENES_IN_FLIGHT_PER_THREAD)
        queue = iter(range(tasks))
        start = time.perf_counter()
        first = [client.submit(_noop, i, pure=False) for i in itertools.islice(queue, window)]
        futures = as_completed(first, loop=client.loop)
        for future in futures:
            future.result()
            future.release()
            following = next(queue, None)
            if following is not None:
                futures.add(client.submit(_noop, following, pure=False))
        return (time.perf_counter() - start) / tasks * 1000.0


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=40)
    parser.add_argument("--workers", type=int, default=default_workers())
    parser.add_argument("--size", default="320x240", help="image size WxH")
    parser.add_argument("--noop-tasks", type=int, default=2000, help="for the Dask overhead")
    parser.add_argument(
        "--same-session",
        dest="own_sessions",
        action="store_false",
        help="leave the sequential process and the workers in this session (see dask_setup)",
    )
    parser.add_argument("--keep", default=None, help="keep the scenes and outputs here")
    parser.add_argument("--sequential-child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.sequential_child:
        sequential_child(*args.sequential_child)
        return
    width, height = (int(v) for v in args.size.split("x"))
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="aida-kb-batch-bench-"))
    try:
        scenes_root = work / "scenes"
        refs = scene_refs(find_scenes([scenes_root])) if scenes_root.is_dir() else []
        if len(refs) != args.scenes:  # --keep DIR holding these scenes: not rendered again
            shutil.rmtree(scenes_root, ignore_errors=True)
            render(scenes_root, args.scenes, (width, height))
            refs = scene_refs(find_scenes([scenes_root]))
        for phase in ("seq", "dask"):
            shutil.rmtree(work / phase, ignore_errors=True)

        load_before_seq = _load()
        child = subprocess.run(
            [sys.executable, __file__, "--sequential-child", str(scenes_root), str(work / "seq")],
            env={**os.environ, **{k: str(v) for k, v in WORKER_ENVIRON.items()}},
            capture_output=True,
            text=True,
            check=True,
            start_new_session=args.own_sessions,
        )
        seq = json.loads(child.stdout.strip().splitlines()[-1])
        load_after_seq = _load()

        compiled = compile_path(KB)
        assert compiled.kb is not None
        load_before_dask = _load()
        preload = {"distributed.worker.preload": [__file__] if args.own_sessions else []}
        with dask.config.set(preload):
            start = time.perf_counter()
            summary = run_batch(
                compiled.kb, str(KB), refs, work / "dask", BatchOptions(workers=args.workers)
            )
            seconds_dask = time.perf_counter() - start
        load_after_dask = _load()
        overhead_ms = scheduler_overhead_ms(args.workers, args.noop_tasks)

        outcomes = [row.outcome for row in summary.rows]
        seq_outcomes = [read_outcome(scene_dir(work / "seq", r.key) / "outcome.json") for r in refs]
        peak_by_worker: dict[str, float] = {}
        for o in outcomes:
            peak_by_worker[o.worker] = max(peak_by_worker.get(o.worker, 0.0), o.peak_rss_mb or 0.0)
        cpu = sum(o.cpu_seconds or 0.0 for o in outcomes)
        cpu_seq = sum(o.cpu_seconds or 0.0 for o in seq_outcomes)
        evidence = sum(o.seconds_evidence or 0.0 for o in seq_outcomes)
        total = sum(o.seconds or 0.0 for o in seq_outcomes)
        same = sum(a.status == b.status for a, b in zip(outcomes, seq_outcomes, strict=True))
        print(
            json.dumps(
                {
                    "scenes": len(refs),
                    "image_size": args.size,
                    "views_per_scene": 2,
                    "workers": summary.workers,
                    "cores": os.cpu_count(),
                    "seconds_sequential": round(seq["seconds"], 1),
                    "seconds_dask": round(seconds_dask, 1),
                    "speedup": round(seq["seconds"] / seconds_dask, 2),
                    "peak_rss_mb_per_worker": round(max(peak_by_worker.values()), 1),
                    "peak_rss_mb_sequential": round(seq["peak_rss_mb"], 1),
                    "scenes_per_core_hour": round(
                        len(refs) / (seconds_dask * summary.workers) * 3600.0, 1
                    ),
                    "cpu_s_per_scene": round(cpu / len(refs), 2),
                    "cpu_s_per_scene_sequential": round(cpu_seq / len(refs), 2),
                    "cpu_share_sequential": round(cpu_seq / seq["seconds"], 2),
                    "cpu_share_per_worker_dask": round(cpu / (seconds_dask * summary.workers), 2),
                    "dask_overhead_ms_per_task": round(overhead_ms, 2),
                    "evidence_share": round(evidence / total, 3),
                    "accepted": summary.accepted,
                    "errors": summary.errors,
                    "same_status_sequential_and_dask": same,
                    "own_sessions": args.own_sessions,
                    "sched_autogroup_enabled": _autogroup(),
                    "load_1min_before_after_sequential": [load_before_seq, load_after_seq],
                    "load_1min_before_after_dask": [load_before_dask, load_after_dask],
                }
            )
        )
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
