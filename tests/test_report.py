"""The report: opened in headless Chromium with every figure loaded, the PDF rendered to pages by pdftoppm."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from filmcal.hertz import hertz_radius_mm
from filmcal.report import FigureBlock, Report, Section, Table, render_html, write_pdf

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--virtual-time-budget=20000"]
# Appended to a copy of the page: after the load event, the title says how many images decoded.
LOAD_PROBE = ("<script>window.addEventListener('load', () => {const imgs = [...document.images];"
              "const ok = imgs.filter(i => i.complete && i.naturalWidth > 0).length;"
              "document.title = 'loaded ' + ok + '/' + imgs.length;});</script>")


def _tool(name: str) -> str:
    path = shutil.which(name)
    assert path, f"{name} is needed by this test (Debian packages chromium and poppler-utils; .ci/run installs them)"
    return path


def images_loaded_in_chromium(html_path: Path, work: Path) -> tuple[int, int]:
    """(decoded images, images) of the page as Chromium loads it."""
    page = work / "probe.html"
    page.write_text(html_path.read_text(encoding="utf-8").replace("</body>", LOAD_PROBE + "</body>"),
                    encoding="utf-8")
    out = subprocess.run([_tool("chromium"), *CHROMIUM_FLAGS, f"--user-data-dir={work / 'profile'}", "--dump-dom",
                          page.as_uri()], capture_output=True, text=True, timeout=180)
    match = re.search(r"<title>loaded (\d+)/(\d+)</title>", out.stdout)
    assert match, f"Chromium did not run the page's load handler: {out.stderr[-2000:]}"
    return int(match.group(1)), int(match.group(2))


def pdf_pages(pdf_path: Path, work: Path) -> list[np.ndarray]:
    """The PDF's pages rendered by pdftoppm, as greyscale arrays."""
    from matplotlib.image import imread

    subprocess.run([_tool("pdftoppm"), "-r", "30", "-gray", "-png", str(pdf_path), str(work / "page")], check=True,
                   timeout=180)
    return [imread(p) for p in sorted(work.glob("page*.png"))]


def _sine_figure() -> Figure:
    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    x = np.linspace(0, 6, 50)
    ax.plot(x, np.sin(x))
    return fig


def test_html_escapes_text_and_embeds_figures():
    report = Report("A <title>", "sub & title", [Section("S <1>").add("a < b & c", Table(["h<"], [["x&y"]], "cap"),
                                                                     FigureBlock(_sine_figure(), "sine"))])
    page = render_html(report)
    assert "A &lt;title&gt;" in page and "a &lt; b &amp; c" in page and "x&amp;y" in page
    assert page.count('src="data:image/png;base64,') == 1
    assert "<script" not in page and "http://" not in page and "https://" not in page


def test_pdf_flows_long_tables_over_pages(tmp_path):
    rows = [[f"row {i}", f"{i:.3f}"] for i in range(300)]
    report = Report("Long", "many rows", [Section("Table").add(Table(["name", "value"], rows)),
                                          Section("Figure").add(FigureBlock(_sine_figure(), "sine"))])
    pages = pdf_pages(write_pdf(report, tmp_path / "long.pdf"), tmp_path)
    # 300 table lines at ~58 lines per A4 page need at least 5 text pages, plus the figure's page
    assert len(pages) >= 6
    assert all(p.std() > 0 for p in pages)  # nothing blank


def test_report_opens_in_chromium_with_every_figure(quick_study, tmp_path):
    study, summary, _ = quick_study
    html = Path(summary["report"]["html"])
    n_figures = summary["report"]["figures"]
    # summary 0, FE verification 3, Fig. 2 1, design 1, surrogate 1, HS calibration 4, cross-validation 1,
    # wheel-rail 2 + 1 outline
    assert n_figures == 14
    loaded, total = images_loaded_in_chromium(html, tmp_path)
    assert total == n_figures and loaded == total
    text = html.read_text(encoding="utf-8")
    assert "<script" not in text and "src=\"http" not in text  # self-contained, nothing to fetch
    # Hertz's radius for R450 / 75 kN, computed here from the closed form, is in the verification table
    assert f"{hertz_radius_mm(450.0, 75e3):.4f}" in text and "6.031" in text
    assert summary["hash"] in text  # provenance: the settings hash


def test_report_pdf_renders_to_pages(quick_study, tmp_path):
    _, summary, _ = quick_study
    pages = pdf_pages(Path(summary["report"]["pdf"]), tmp_path)
    assert len(pages) >= summary["report"]["figures"] + 1  # one page per figure and the text pages
    assert all(p.std() > 0.01 for p in pages)


def test_report_command_rewrites_from_the_study(quick_study, tmp_path):
    study, _, _ = quick_study
    out = subprocess.run([sys.executable, "-m", "filmcal.cli", "report", "--study-dir", str(study), "--out-dir",
                          str(tmp_path / "rep"), "--json"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "rep" / "report.html").stat().st_size > 100_000
    assert (tmp_path / "rep" / "report.pdf").read_bytes()[:5] == b"%PDF-"


@pytest.mark.parametrize("study", ["missing-folder", "empty-folder"])
def test_report_of_a_non_study_exits_2(tmp_path, study):
    (tmp_path / "empty-folder").mkdir()
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "report", "--study-dir", str(tmp_path / study)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "study_dir" in p.stderr
