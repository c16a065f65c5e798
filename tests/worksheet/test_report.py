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

from aldpat.worksheet.report import FRAME_RGB
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
        self.by_section: dict[str, list[str]] = {}

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag in ("img", "image"):  # a picture: HTML's, or drawn inside an SVG
            self.images.append(a)
        for key in ("href", "src"):
            if a.get(key) and tag not in ("img", "image"):
                self.links.append(str(a[key]))
        if tag == "section":
            self.sections.append(str(a.get("id")))

    def handle_data(self, data):
        self.text.append(data)
        if self.sections:
            self.by_section.setdefault(self.sections[-1], []).append(data)

    def section_text(self, name: str) -> str:
        return " ".join(" ".join(self.by_section.get(name, [])).split())


def parse(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def test_every_job_with_its_state_time_and_outputs(report):
    page = parse(report)
    text = " ".join(" ".join(page.text).split())
    assert page.sections == ["summary"] + [f"job-{n}" for n in range(1, 7)]
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
    summary = parse(report).section_text("summary")  # the error table is in the summary at the top
    row = f"out/samp_gapm.txt samp.txt {scores['type1']:.2f} {scores['type2']:.2f} {scores['total']:.2f} " \
          f"{scores['kappa']:.4f} {scores['points']:,}"
    assert row in summary, summary
    assert "bare earth rejected (Type I)" in summary  # the map's legend


def test_the_page_opens_on_a_summary_of_states_times_and_ground_shares(report):
    page = parse(report)
    summary = page.section_text("summary")
    assert page.sections[0] == "summary"
    assert re.search(r"^6 jobs: 4 done, 1 failed, 1 blocked; \d+\.\d s in all", summary), summary
    for n, task, state in [(1, "filter gapm", "Done"), (2, "evaluate", "Done"), (3, "dtm", "Done"),
                           (4, "preview", "Done"), (5, "grid", "Failed"), (6, "preview", "Blocked")]:
        assert re.search(rf"\b{n} {task} {state}\b", summary), (n, task, state)
    classes = np.loadtxt(report.parent / "out" / "samp_gapm.txt")[:, -1]
    share = 100 * np.mean(classes == 2)
    assert f"{len(classes):,} points, {share:.1f} % ground" in summary  # job 1, as its output says
    assert re.search(r"dtm Done [\d.]+ s samp\.txt [\d,]+ points, [\d.]+ % ground, [\d,]+ nodes", summary)
    assert "3 distinct points" in summary  # why job 5 failed, at the top
    text = " ".join(page.text)
    assert not re.search(r"\[\s*'|\[-?\d+\.\d+, ", text)  # no Python lists: values as people write them
    assert not re.search(r"overflow(-x)?: *(auto|scroll)", report.read_text(encoding="utf-8"))  # no sideways scrolling


def test_pictures_are_placed_north_up_with_a_scale_and_their_corners(report):
    """The hillshade's world file and corner coordinates are the DTM's own extent (GDAL's), and
    the report draws a north arrow and a scale bar over each picture."""
    import rasterio

    from aldpat.io.worldfile import read_world_file

    out = report.parent / "out"
    with rasterio.open(out / "samp_dtm.tif") as dtm:
        left, bottom, right, top = dtm.bounds
        width, height = dtm.width, dtm.height
        cell = dtm.transform.a
    place = read_world_file(out / "samp_dtm_hillshade.pgw")
    assert (place.west, place.north, place.dx, place.dy) == pytest.approx((left, top, cell, cell))
    points = np.loadtxt(report.parent / "samp.txt")
    calls = read_world_file(out / "calls.pgw")  # the map's upper-left corner: the westmost x, the northmost y
    assert (calls.west, calls.north) == pytest.approx((points[:, 0].min(), points[:, 1].max()), abs=0.001)
    summary = parse(report).section_text("summary")
    for x, y in ((left, top), (right, top), (left, bottom), (right, bottom)):
        assert f"x {x:.1f}, y {y:.1f}" in summary, (x, y)
    assert f"{width} x {height} pixels of {cell:.3g} m; north up" in summary
    html = report.read_text(encoding="utf-8")
    assert html.count('class="north-arrow"') == 2 and html.count('class="scale-bar"') == 2
    assert re.search(r">\d+ m</text>", html)  # the scale bar's length


def test_self_contained(report):
    page = parse(report)
    html = report.read_text(encoding="utf-8")
    assert len(page.images) == 2  # the evaluate map and the DTM's hillshade
    for image in page.images:
        assert str(image.get("src") or image.get("href")).startswith("data:image/png;base64,")
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
    done = subprocess.run([*common, "--window-size=1200,2800", f"--screenshot={shot}", url], capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 0 and shot.exists(), done.stderr[-2000:]
    with Image.open(shot) as image:
        assert image.size == (1200, 2800)
        rgb = np.asarray(image.convert("RGB"))
    pixels = rgb.reshape(-1, 3)
    colours = {tuple(c) for c in np.unique(pixels, axis=0)}
    assert len(colours) > 200  # text, badges and pictures, not a blank or error page
    top = {tuple(c) for c in np.unique(rgb[:500].reshape(-1, 3), axis=0)}
    assert (46, 125, 50) in top and (198, 40, 40) in top  # the summary opens the page: Done and Failed badges
    assert (225, 40, 40) in colours  # a Type I pixel of the map
    # both pictures are drawn at least 1,000 px wide: the rows of their frames' top and bottom edges
    frame = np.all(rgb == FRAME_RGB, axis=2)
    edges = [r for r in range(rgb.shape[0]) if _longest_run(frame[r]) >= 1000]
    assert len(edges) >= 4 and _groups(edges) >= 4, edges  # two frames' top and bottom edges


def _longest_run(row: np.ndarray) -> int:
    padded = np.concatenate([[False], row, [False]]).astype(np.int8)
    starts, stops = np.flatnonzero(np.diff(padded) == 1), np.flatnonzero(np.diff(padded) == -1)
    return int((stops - starts).max()) if len(starts) else 0


def _groups(rows: list[int]) -> int:
    """How many runs of consecutive row numbers."""
    return sum(1 for i, r in enumerate(rows) if i == 0 or r != rows[i - 1] + 1)
