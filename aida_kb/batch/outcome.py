"""A batch run's records: one ``outcome.json`` per scene, ``summary.csv`` and ``summary.json``.

A scene's outcome is written into its output folder, which is published in one rename
(`aida_kb.batch.work`): a scene whose folder holds a readable ``outcome.json`` is finished.
"""

from __future__ import annotations

import csv
import io
import os
from typing import Literal

from pydantic import Field

from aida_kb.io.atomic import write_text_atomic
from aida_kb.io.jsonio import FrozenModel, read_json_model, write_json_model
from aida_kb.io.model import Finite

OUTCOME_FILE = "outcome.json"
SUMMARY_CSV = "summary.csv"
SUMMARY_JSON = "summary.json"

Status = Literal["accepted", "nothing", "error", "pending"]
"""accepted: the goal object was found; nothing: the interpretation found none; error: the
scene could not be reconstructed (the message says why); pending: not run (interrupted)."""


class Verdict(FrozenModel):
    """What the interpretation of a scene said about one goal object."""

    goal: str = Field(description="the goal concept, e.g. 'House'")
    accepted: bool = Field(description="True if the object was verified")
    verdict: Literal["verified", "doubtful", "nothing"] | None = Field(
        default=None, description="the interpretation's verdict (aida_kb.interpret.verdict)"
    )
    message: str = Field(description="the interpretation's one-line summary")


class SceneOutcome(FrozenModel):
    """How one scene of a batch ended (``outcome.json`` in its output folder)."""

    format: Literal["aida-kb/batch-scene"] = "aida-kb/batch-scene"
    version: Literal[1] = 1
    scene: str = Field(description="the scene's key: its output folder below OUT/scenes")
    source: str = Field(description="the scene directory that was read (absolute)")
    status: Status
    objects: int = Field(ge=0, description="number of accepted objects")
    verdicts: list[Verdict] = Field(default_factory=list)
    error: str | None = Field(default=None, description="why the scene failed (status error)")
    seconds: Finite | None = Field(default=None, ge=0, description="wall time of the scene")
    seconds_evidence: Finite | None = Field(default=None, ge=0, description="vision stage")
    seconds_interpretation: Finite | None = Field(
        default=None, ge=0, description="interpretation, registration and model"
    )
    cpu_seconds: Finite | None = Field(
        default=None, ge=0, description="CPU time of the worker process during the scene"
    )
    files: list[str] = Field(default_factory=list, description="files in the output folder")
    worker: str = Field(default="", description="host:pid of the process that ran it")
    peak_rss_mb: Finite | None = Field(
        default=None, ge=0, description="the worker process's peak resident memory so far, MiB"
    )
    finished: str = Field(default="", description="when it ended (UTC, ISO 8601)")


def read_outcome(path: str | os.PathLike[str]) -> SceneOutcome:
    """Load ``outcome.json``; FormatError names the file and field on bad input."""
    return read_json_model(path, SceneOutcome)


def write_outcome(path: str | os.PathLike[str], outcome: SceneOutcome) -> None:
    """Write ``outcome.json`` atomically."""
    write_json_model(path, outcome)


class SummaryRow(FrozenModel):
    """One scene in ``summary.json``: its outcome and whether an earlier run finished it."""

    outcome: SceneOutcome
    resumed: bool = Field(description="True if an earlier run had finished the scene")
    model: str | None = Field(description="the model file (model.obj) relative to OUT, if any")


class Summary(FrozenModel):
    """``summary.json``: the whole batch, one row per scene in the order of the input."""

    format: Literal["aida-kb/batch-summary"] = "aida-kb/batch-summary"
    version: Literal[1] = 1
    kb: str = Field(description="the knowledge base file")
    goal: str
    scenes: int = Field(ge=0)
    accepted: int = Field(ge=0)
    nothing: int = Field(ge=0)
    errors: int = Field(ge=0)
    pending: int = Field(ge=0, description="scenes not run (the run was interrupted)")
    resumed: int = Field(ge=0, description="scenes an earlier run had finished")
    workers: int = Field(ge=0, description="worker processes of the cluster")
    seconds: Finite = Field(ge=0, description="wall time of this run")
    rows: list[SummaryRow]


CSV_COLUMNS = (
    "scene",
    "status",
    "objects",
    "verdicts",
    "seconds",
    "seconds_evidence",
    "seconds_interpretation",
    "peak_rss_mb",
    "resumed",
    "model",
    "error",
    "source",
)


def _cell(value: float | None) -> str:
    return "" if value is None else f"{value:.3f}"


def summary_csv(summary: Summary) -> str:
    """The summary as CSV text (`CSV_COLUMNS`, one row per scene)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for row in summary.rows:
        o = row.outcome
        verdicts = "; ".join(
            f"{v.goal}: {v.verdict or ('accepted' if v.accepted else 'not found')}"
            for v in o.verdicts
        )
        writer.writerow(
            [
                o.scene,
                o.status,
                o.objects,
                verdicts,
                _cell(o.seconds),
                _cell(o.seconds_evidence),
                _cell(o.seconds_interpretation),
                _cell(o.peak_rss_mb),
                "yes" if row.resumed else "no",
                row.model or "",
                o.error or "",
                o.source,
            ]
        )
    return buffer.getvalue()


def write_summary(out: str | os.PathLike[str], summary: Summary) -> tuple[str, str]:
    """Write ``summary.json`` and ``summary.csv`` into `out` (atomically); return their paths."""
    json_path = os.path.join(out, SUMMARY_JSON)
    csv_path = os.path.join(out, SUMMARY_CSV)
    write_json_model(json_path, summary)
    write_text_atomic(csv_path, summary_csv(summary))
    return json_path, csv_path


def read_summary(path: str | os.PathLike[str]) -> Summary:
    """Load ``summary.json``; FormatError names the file and field on bad input."""
    return read_json_model(path, Summary)
