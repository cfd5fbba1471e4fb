"""`aida-kb batch` on a Dask cluster: failures recorded, interrupted runs resumed."""

from __future__ import annotations

import csv
import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from aida_kb.batch.outcome import SceneOutcome, read_outcome, read_summary
from aida_kb.batch.run import LOCK_FILE, BatchOptions, run_batch
from aida_kb.batch.scenes import find_scenes, scene_refs
from aida_kb.cli.main import main
from aida_kb.errors import FormatError
from aida_kb.interpret.result import read_interpretation
from aida_kb.io.evidence import read_evidence

ROOT = Path(__file__).resolve().parents[2]
# In-process: a local cluster of worker threads starts in a fraction of a second; the scene
# code is the same as in worker processes (one scene at a time per process either way).
THREADS = BatchOptions(workers=2, processes=False)


def _closed(obj: str) -> bool:
    """True if every edge of the OBJ mesh's faces is shared by exactly two faces."""
    edges: dict[tuple[int, int], int] = {}
    for line in obj.splitlines():
        if line.startswith("f "):
            ring = [int(v.split("/")[0]) for v in line.split()[1:]]
            for a, b in zip(ring, ring[1:] + ring[:1], strict=True):
                edges[min(a, b), max(a, b)] = edges.get((min(a, b), max(a, b)), 0) + 1
    return bool(edges) and set(edges.values()) == {2}


def _check_published(out: Path, outcome: SceneOutcome) -> None:
    """A good scene's folder: what `reconstruct` writes, agreeing with its outcome."""
    folder = out / "scenes" / outcome.scene
    assert outcome.status in ("accepted", "nothing"), outcome.error
    assert read_outcome(folder / "outcome.json") == outcome
    interp = read_interpretation(folder / "interpretation.json")
    found = interp.accepted and interp.verdict != "nothing"
    assert outcome.verdicts[0].accepted == interp.accepted
    assert found == (outcome.status == "accepted")
    assert outcome.verdicts[0].message == interp.message
    assert outcome.verdicts[0].verdict == interp.verdict
    assert outcome.objects == int(found)
    assert outcome.seconds is not None
    assert outcome.seconds_evidence is not None
    assert 0 < outcome.seconds_evidence < outcome.seconds
    assert read_evidence(folder / "evidence.json").views[0].id == "00"
    model = folder / "model.obj"
    assert model.exists() == found
    if found:
        assert _closed(model.read_text())
    assert sorted(outcome.files) == sorted(p.name for p in folder.iterdir())


def _published(out: Path) -> dict[str, os.stat_result]:
    """The scenes whose output folder has appeared, with the stat of their outcome.json."""
    scenes = out / "scenes"
    if not scenes.is_dir():
        return {}
    return {
        d.name: (d / "outcome.json").stat()
        for d in scenes.iterdir()
        if d.is_dir() and (d / "outcome.json").exists()
    }


def test_a_corrupt_scene_is_recorded_and_the_others_complete(
    city: Path, kb: object, tmp_path: Path
) -> None:
    shutil.rmtree(city / "house3")  # two good scenes are enough here
    bad_index = city / "bad-index"
    bad_index.mkdir()
    (bad_index / "scene.yaml").write_text("views: [\n")
    no_image = Path(shutil.copytree(city / "house1", city / "no-image"))
    (no_image / "views" / "00" / "left.png").unlink()
    out = tmp_path / "out"
    refs = scene_refs(find_scenes([city]))
    summary = run_batch(kb, "buildings.kb", refs, out, THREADS)  # type: ignore[arg-type]

    rows = {row.outcome.scene: row.outcome for row in summary.rows}
    assert list(rows) == ["bad-index", "house1", "house2", "no-image"]
    assert rows["bad-index"].status == "error"
    assert rows["bad-index"].error is not None
    assert rows["bad-index"].error.startswith(f"{bad_index / 'scene.yaml'}:2:1: not valid YAML")
    assert rows["no-image"].status == "error"
    assert rows["no-image"].error is not None
    assert "left.png" in rows["no-image"].error
    for name in ("house1", "house2"):
        _check_published(out, rows[name])
    assert (summary.scenes, summary.errors, summary.pending) == (4, 2, 0)
    assert summary.accepted + summary.nothing == 2
    assert read_summary(out / "summary.json") == summary
    with open(out / "summary.csv", newline="") as handle:
        table = {row["scene"]: row for row in csv.DictReader(handle)}
    assert table["house2"]["status"] == rows["house2"].status
    assert table["house2"]["model"] == (
        "scenes/house2/model.obj" if rows["house2"].status == "accepted" else ""
    )
    assert table["bad-index"]["error"] == rows["bad-index"].error
    assert not (out / ".work").exists()
    _check_city_sequence(out, [rows[n] for n in rows if rows[n].status == "accepted"])


def _check_city_sequence(out: Path, accepted: list[SceneOutcome]) -> None:
    """city.jsonl: a header, then per accepted scene its model.city.json, in metres exactly."""
    lines = [json.loads(line) for line in (out / "city.jsonl").read_text().splitlines()]
    header, features = lines[0], lines[1:]
    assert header["type"] == "CityJSON"
    assert (header["CityObjects"], header["vertices"]) == ({}, [])
    scale = np.asarray(header["transform"]["scale"])
    translate = np.asarray(header["transform"]["translate"])
    assert [f["id"] for f in features] == [f"{o.scene}/building" for o in accepted]
    assert accepted, "no scene accepted: the sequence would not be checked"
    for outcome, feature in zip(accepted, features, strict=True):
        assert feature["type"] == "CityJSONFeature"
        scene = json.loads((out / "scenes" / outcome.scene / "model.city.json").read_text())
        expected = np.asarray(scene["vertices"]) * scene["transform"]["scale"]
        expected += scene["transform"]["translate"]
        got = np.asarray(feature["vertices"]) * scale + translate
        np.testing.assert_allclose(got, expected, atol=1e-9)
        building = feature["CityObjects"][feature["id"]]
        assert building["type"] == "Building"
        assert building["attributes"]["aida-kb:scene"] == outcome.scene
        assert building["attributes"]["aida-kb:verdict"] == outcome.verdicts[0].verdict
        for name, obj in feature["CityObjects"].items():
            assert name.startswith(f"{outcome.scene}/")
            for ref in obj.get("children", []) + obj.get("parents", []):
                assert ref in feature["CityObjects"]
            rings = [r for shell in obj["geometry"][0]["boundaries"] for f in shell for r in f]
            assert max(max(r) for r in rings) < len(feature["vertices"])


@pytest.mark.slow
def test_a_killed_run_finishes_the_rest_without_redoing_finished_scenes(
    city: Path, kb: object, tmp_path: Path
) -> None:
    for copy in range(4, 9):  # eight scenes: the kill lands well before the last
        shutil.copytree(city / f"house{copy - 3}", city / f"house{copy}")
    out = tmp_path / "out"
    # the real command, one worker process, killed with its whole process group (its Dask
    # scheduler, nanny and worker) as soon as the first scene has been published
    proc = subprocess.Popen(
        [sys.executable, "-m", "aida_kb", "batch", str(city), "-o", str(out), "--workers", "1"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 180
    try:
        while not _published(out) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    before = _published(out)
    assert 1 <= len(before) < 8, "killed midway"
    earlier = {name: read_outcome(out / "scenes" / name / "outcome.json") for name in before}

    refs = scene_refs(find_scenes([city]))
    summary = run_batch(kb, "buildings.kb", refs, out, THREADS)  # type: ignore[arg-type]

    assert summary.scenes == 8
    assert summary.errors == summary.pending == 0
    assert summary.resumed == len(before)
    for row in summary.rows:
        name = row.outcome.scene
        assert row.resumed == (name in before)
        if name in before:  # not run again: the same file, the first run's outcome
            after = (out / "scenes" / name / "outcome.json").stat()
            assert (after.st_ino, after.st_mtime_ns) == (
                before[name].st_ino,
                before[name].st_mtime_ns,
            )
            assert row.outcome == earlier[name]
        else:
            assert row.outcome.worker.endswith(f":{os.getpid()}")  # run by this (threaded) run
        _check_published(out, row.outcome)
    assert sorted(_published(out)) == [f"house{i}" for i in range(1, 9)]
    assert not (out / ".work").exists()


def test_two_runs_into_one_folder_are_refused(city: Path, kb: object, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    with open(out / LOCK_FILE, "a+b") as held:
        fcntl.flock(held.fileno(), fcntl.LOCK_EX)
        with pytest.raises(FormatError, match="another batch run is writing into this folder"):
            run_batch(kb, "kb", scene_refs(find_scenes([city])), out, THREADS)  # type: ignore[arg-type]
    assert not (out / "scenes").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ([], "aida-kb: error: no scenes: give folders (DIR...) or --list FILE"),
        (["{city}", "--workers", "0"], "aida-kb: error: --workers 0: must be at least 1"),
        (
            ["{city}", "--scheduler", "tcp://127.0.0.1:1", "--workers", "2"],
            "aida-kb: error: --workers is for the local cluster; an existing one has its own",
        ),
        (["{city}/nope"], "aida-kb: error: {city}/nope: no such directory"),
    ],
)
def test_bad_arguments_are_one_line_before_any_work(
    argv: list[str], message: str, city: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    args = [a.format(city=city) for a in argv]
    assert main(["batch", *args, "-o", str(out), "--quiet"]) == 2
    assert capsys.readouterr().err.strip() == message.format(city=city)
    assert not out.exists()
