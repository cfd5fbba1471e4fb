"""report.html of the demo, opened in headless Chromium: no console errors, every image decodes,
an image per view, the residual table with its .kb locations, a screenshot with content."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from aida_kb.interpret.result import read_interpretation

# the flags a sandboxed, offline headless Chromium needs (no GPU, no network services)
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def _chromium() -> str:
    """The Chromium binary ($AIDA_KB_CHROMIUM, or chromium / chromium-browser on the PATH)."""
    found = os.environ.get("AIDA_KB_CHROMIUM") or next(
        (p for p in (shutil.which("chromium"), shutil.which("chromium-browser")) if p), None
    )
    if not found:
        pytest.fail(
            "the report test needs Chromium: on Debian `apt-get install chromium` "
            "(.ci/run installs it), or set AIDA_KB_CHROMIUM to a Chromium binary"
        )
    return found


def _run(args: list[str], profile: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [_chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args],
        capture_output=True,
        text=True,
        timeout=180,
        check=True,
    )


class _Page(HTMLParser):
    """What the test looks for in the DOM Chromium dumps."""

    def __init__(self) -> None:
        super().__init__()
        self.body: dict[str, str | None] = {}
        self.section: str | None = None
        self.images: dict[str, int] = {}
        self.rows: list[list[str]] = []
        self._row: list[str] | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "body":
            self.body = a
        elif tag == "section" and (a.get("id") or "").startswith("view-"):
            self.section = (a.get("id") or "")[5:]
            self.images[self.section] = 0
        elif tag == "img" and self.section is not None:
            assert (a.get("src") or "").startswith("data:image/"), "images are embedded"
            self.images[self.section] += 1
        elif tag == "tr" and "residual" in (a.get("class") or "").split():
            self._row = []
        elif tag == "td" and self._row is not None:
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag == "section":
            self.section = None
        elif tag == "td" and self._row is not None and self._cell is not None:
            self._row.append("".join(self._cell))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.rows.append(self._row)
            self._row = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


@pytest.mark.slow
def test_demo_report_opens_in_chromium_with_every_stage(demo_run: Any, tmp_path: Path) -> None:
    model_dir = demo_run.root / "model"
    report = model_dir / "report.html"
    assert f"report: {report.resolve()}" in demo_run.out.replace("\n", "")
    text = report.read_text(encoding="utf-8")
    assert "http://" not in text
    assert "https://" not in text  # works offline: nothing to fetch
    url = report.resolve().as_uri()
    done = _run(["--enable-logging=stderr", "--v=0", "--dump-dom", url], tmp_path / "p1")
    console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    assert console == []
    page = _Page()
    page.feed(done.stdout)
    assert int(page.body["data-images"] or 0) > 10
    assert page.body["data-images-decoded"] == page.body["data-images"]  # every image decodes
    assert sorted(page.images) == ["00", "01"]
    assert all(n >= 8 for n in page.images.values()), page.images  # inputs, maps, overlays
    interp = read_interpretation(model_dir / "interpretation.json")
    assert len(page.rows) == len(interp.residuals) > 0
    assert [row[0] for row in page.rows] == [r.label for r in interp.residuals]
    for row, r in zip(page.rows, interp.residuals, strict=True):
        assert row[1] == (r.where or "—")  # the .kb location of each constraint
    knowledge = [
        row[1] for row, r in zip(page.rows, interp.residuals, strict=True) if r.rule == "knowledge"
    ]
    assert len(knowledge) >= 5  # the house's angles, parallels, symmetry ...
    assert all(re.fullmatch(r".*buildings\.kb:\d+:\d+", cell) for cell in knowledge)
    shot = tmp_path / "shot.png"
    _run(["--window-size=1200,2400", f"--screenshot={shot}", url], tmp_path / "p2")
    image = cv2.imread(str(shot))
    assert image is not None
    assert image.shape[:2] == (2400, 1200)
    # content, not a blank or error page: much of it is neither white nor one flat colour,
    # and the overlays' green model edges are there
    not_white = np.mean(np.any(image < 235, axis=2))
    assert not_white > 0.3
    green = (image[:, :, 1] > 180) & (image[:, :, 0] < 110) & (image[:, :, 2] < 110)
    assert np.count_nonzero(green) > 200
