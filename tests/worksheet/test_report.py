"""``aldpat run JOB.toml --report``: one self-contained HTML page, checked as HTML and in a real
browser (headless Chromium, Debian package ``chromium``; ``.ci/run`` installs it)."""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from tests.cli.fresh import DATA, aldpat

WORKSHEET = """
[settings]
overwrite = true

[[job]]
task = "filter"
algorithm = "gapm"
inputs = ["samp.txt"]
odir = "out"
result = "classified"

[[job]]
task = "evaluate"
inputs = ["out/samp_gapm.txt"]
reference = "samp.txt"
map = "out/calls.png"

[[job]]
task = "dtm"
inputs = ["samp.txt"]
odir = "out"
cell = 2.0

[[job]]
task = "preview"
inputs = ["out/samp_dtm.tif"]
odir = "out"

[[job]]
task = "grid"                   # fails: three points on one line make no triangle
inputs = ["line.txt"]
odir = "bad"

[[job]]
task = "preview"                # blocked: reads what the failed job would have written
inputs = ["bad/*.grd"]
odir = "bad"
"""


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("report")
    rows = np.loadtxt(DATA / "samp24.txt")
    x0, y0 = rows[:, 0].min(), rows[:, 1].min()
    part = rows[(rows[:, 0] < x0 + 80) & (rows[:, 1] < y0 + 60)]
    np.savetxt(root / "samp.txt", part, fmt=["%.2f", "%.2f", "%.2f", "%d"])
    np.savetxt(root / "line.txt", [[0, 0, 1], [1, 1, 1], [2, 2, 1]], fmt="%.1f")
    (root / "project.toml").write_text(WORKSHEET)
    done = aldpat("run", root / "project.toml", "--report", cwd=root)
    assert done.returncode == 1, done.stderr  # job 5 fails, job 6 is blocked
    assert "report: " in done.stderr
    return root / "project.html"


class Page(HTMLParser):
    """The parts of the page the tests look at."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.images: list[dict[str, str | None]] = []
        self.sections: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        for key in ("href", "src"):
            if a.get(key) and tag != "img":
                self.links.append(str(a[key]))
        if tag == "section":
            self.sections.append(str(a.get("id")))

    def handle_data(self, data):
        self.text.append(data)


def parse(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def test_every_job_with_its_state_time_and_outputs(report):
    page = parse(report)
    text = " ".join(" ".join(page.text).split())
    assert page.sections == [f"job-{n}" for n in range(1, 7)]
    for n, state in enumerate(["Done", "Done", "Done", "Done", "Failed", "Blocked"], start=1):
        assert re.search(rf"job {n}: \S+( \S+)? {state}", text), (n, state)
    assert "3 distinct points" in text and "reads the outputs of failed job 5" in text
    points = len(np.loadtxt(report.parent / "samp.txt"))
    assert f"{points:,} points" in text  # the classified output holds every point
    assert "out/samp_dtm.tif" in text and "out/samp_gapm.txt" in text
    assert "window_series" in text and "cli" not in text.split()  # parameters, with their sources


def test_evaluate_table_matches_the_json(report):
    import json

    done = aldpat("evaluate", report.parent / "out" / "samp_gapm.txt", "--reference", report.parent / "samp.txt",
                  "--json").ok()
    scores = json.loads(done.stdout)
    text = " ".join(" ".join(parse(report).text).split())
    for key in ("type1", "type2", "total"):
        assert f"{scores[key]:.2f}" in text
    assert "bare earth rejected (Type I)" in text  # the map's legend


def test_self_contained(report):
    page = parse(report)
    html = report.read_text(encoding="utf-8")
    assert len(page.images) == 2  # the evaluate map and the DTM's hillshade
    for image in page.images:
        assert str(image["src"]).startswith("data:image/png;base64,")
    for link in page.links:  # links open outputs beside the page; nothing is fetched
        assert not re.match(r"^[a-z]+:|^//", link), link
        assert (report.parent / link).exists(), link
    assert "<script" not in html and "@import" not in html and "url(" not in html


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


HEADLESS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync"]


@pytest.mark.skipif(chromium() is None, reason="no chromium on this machine (.ci/run installs Debian's chromium)")
def test_chromium_loads_the_page_and_takes_a_screenshot(report, tmp_path):
    from PIL import Image

    browser = str(chromium())
    common = [browser, *HEADLESS, f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0"]
    url = report.resolve().as_uri()
    dom = subprocess.run([*common, "--dump-dom", url], capture_output=True, text=True, timeout=120, check=False)
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert 'id="job-6"' in dom.stdout and "Blocked" in dom.stdout  # the whole page was parsed
    problems = [line for line in dom.stderr.splitlines()
                if re.search(r"CONSOLE|Uncaught|Failed to load resource|net::ERR_", line)]
    assert problems == []
    shot = tmp_path / "report.png"
    done = subprocess.run([*common, "--window-size=1200,1800", f"--screenshot={shot}", url], capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 0 and shot.exists(), done.stderr[-2000:]
    with Image.open(shot) as image:
        assert image.size == (1200, 1800)
        pixels = np.asarray(image.convert("RGB")).reshape(-1, 3)
    colours = {tuple(c) for c in np.unique(pixels, axis=0)}
    assert len(colours) > 200  # text, badges and pictures, not a blank or error page
    assert (225, 40, 40) in colours and (46, 125, 50) in colours  # a Type I pixel of the map, a Done badge
