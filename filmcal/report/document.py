"""A report as data (a title page, sections of paragraphs, tables, figures and definitions) and its renderings.

`render_html` writes one self-contained HTML page (figures embedded as PNG
data URIs, no scripts, no external files) laid out for screen and for A4
print; `write_pdf` prints that same page to PDF with headless Chromium, fills
the table of contents with the page numbers it finds in the printed PDF
(poppler's ``pdftotext``), and falls back to a figures-only matplotlib PDF,
with a message saying so, where Chromium is not installed.
"""
from __future__ import annotations

import base64
import html
import io
import re
import shutil
import struct
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from matplotlib.figure import Figure

from filmcal._io import atomic_path

__all__ = ["Table", "FigureBlock", "Definitions", "Section", "Report", "PdfResult", "render_html", "write_pdf",
           "find_chromium", "CHROMIUM_FLAGS", "TEXT_WIDTH_IN", "TEXT_HEIGHT_IN"]

#: Resolution of the embedded figure images (dots per inch at their printed size).
FIGURE_DPI = 150
#: Width and height of the printed text area of an A4 page (inches): figures are drawn at most this size.
TEXT_WIDTH_IN = 6.9
TEXT_HEIGHT_IN = 9.4
#: Tallest printed figure image (inches), leaving room for a caption of a few lines on the same page.
FIGURE_MAX_HEIGHT_IN = 8.6
#: Flags of a headless, offline Chromium that prints a local page.
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--disable-quic", "--no-pdf-header-footer",
                  "--generate-pdf-document-outline", "--virtual-time-budget=20000")
_A4_IN = (8.27, 11.69)


@dataclass
class Table:
    """A table of already formatted cells (rendered as an HTML table)."""

    header: list[str]
    rows: list[list[str]]
    caption: str = ""


@dataclass
class FigureBlock:
    """A matplotlib figure with its caption (printed together on one page) and a short title for the contents.

    ``figure`` is None in a block that was `drawn` (its PNG and size kept).
    """

    figure: Figure | None
    caption: str
    title: str = ""
    _png: str | None = field(default=None, init=False, repr=False, compare=False)
    _size_in: tuple[float, float] | None = field(default=None, init=False, repr=False, compare=False)

    def png_base64(self) -> str:
        """The figure as PNG (base64 text), drawn once and kept."""
        if self._png is None:
            buf = io.BytesIO()
            self.figure.savefig(buf, format="png", dpi=FIGURE_DPI)
            self._png = base64.b64encode(buf.getvalue()).decode("ascii")
        return self._png

    @property
    def size_in(self) -> tuple[float, float]:
        """Width and height of the drawn figure (inches)."""
        if self.figure is None:
            return self._size_in
        w, h = self.figure.get_size_inches()
        return float(w), float(h)

    def blank_png_base64(self) -> str:
        """A white PNG of the figure's pixel size: the page is laid out as with the figure, from a few bytes."""
        from PIL import Image

        width, height = struct.unpack(">II", base64.b64decode(self.png_base64()[:32])[16:24])  # the IHDR chunk
        buf = io.BytesIO()
        Image.new("1", (width, height), 1).save(buf, format="PNG")
        return base64.b64encode(buf.getvalue()).decode("ascii")

    def drawn(self) -> "FigureBlock":
        """The same block with its figure drawn to PNG and released (light to send between processes)."""
        out = FigureBlock(None, self.caption, self.title)
        out._png, out._size_in = self.png_base64(), self.size_in
        return out


@dataclass
class Definitions:
    """Terms and their explanations (a glossary), rendered as a definition list."""

    entries: list[tuple[str, str]]


Block = str | Table | FigureBlock | Definitions


@dataclass
class Section:
    """A titled part of the report: blocks (str paragraphs, tables, figures, definitions) in order."""

    title: str
    blocks: list[Block] = field(default_factory=list)

    def add(self, *blocks: Block) -> "Section":
        self.blocks.extend(blocks)
        return self


@dataclass
class Report:
    """Title page (title, subtitle, the answer, remarks), then sections.

    Parameters
    ----------
    title, subtitle : str
    sections : list of Section
    answer : Table, optional
        The result in one table on the title page.
    remarks : list of str
        Short paragraphs under the answer on the title page.
    """

    title: str
    subtitle: str
    sections: list[Section]
    answer: Table | None = None
    remarks: list[str] = field(default_factory=list)

    @property
    def figures(self) -> list[FigureBlock]:
        return [b for s in self.sections for b in s.blocks if isinstance(b, FigureBlock)]


@dataclass
class PdfResult:
    """What `write_pdf` wrote: the file, the engine that typeset it and a remark when it fell back."""

    path: Path
    engine: str
    message: str = ""


# ------------------------------------------------------------------ HTML
_CSS = """
@page { size: A4; margin: 15mm 16mm 16mm 16mm;
        @bottom-right { content: counter(page); font: 8pt "DejaVu Sans", sans-serif; color: #666; } }
@page :first { @bottom-right { content: none; } }
body { font-family: "DejaVu Sans", "Liberation Sans", Arial, sans-serif; font-size: 10pt; line-height: 1.35;
       max-width: 182mm; margin: 1.5em auto; padding: 0 1em; color: #1a1a1a; }
h1 { font-size: 22pt; margin: 0 0 0.3em 0; } .subtitle { color: #555; margin-top: 0; font-size: 9pt; }
h2 { font-size: 14pt; border-bottom: 1px solid #999; padding-bottom: 0.15em; margin-top: 1.6em;
     break-after: avoid; }
p { margin: 0.45em 0; text-align: left; }
table { border-collapse: collapse; margin: 0.7em 0; font-size: 8.5pt; break-inside: auto; }
thead { display: table-header-group; } tr { break-inside: avoid; }
th, td { border: 1px solid #bbb; padding: 0.2em 0.5em; text-align: right; vertical-align: top; }
td.n { white-space: nowrap; }
th { background: #eee; font-weight: bold; } td:first-child, th:first-child { text-align: left; }
caption { caption-side: top; text-align: left; font-style: italic; padding-bottom: 0.25em; break-after: avoid; }
figure { margin: 1em 0; break-inside: avoid; page-break-inside: avoid; }
figure img { display: block; max-width: 100%; height: auto; }
figcaption { font-size: 9pt; color: #333; margin-top: 0.3em; }
figcaption b { color: #000; }
dl { margin: 0.5em 0; } dt { font-weight: bold; margin-top: 0.55em; break-after: avoid; }
dd { margin: 0.1em 0 0 1.6em; }
.title-page { break-after: page; padding-top: 18mm; }
.title-page table { font-size: 9.5pt; width: 100%; }
.remark { font-size: 9.5pt; }
nav.toc { break-after: page; } nav.toc h2 { margin-top: 0; }
nav.toc ol { list-style: none; padding: 0; margin: 0; }
nav.toc li { display: flex; margin: 0.3em 0; }
nav.toc li a { color: inherit; text-decoration: none; }
nav.toc li .dots { flex: 1; border-bottom: 1px dotted #999; margin: 0 0.4em 0.3em 0.4em; }
nav.toc li .page { min-width: 2em; text-align: right; }
nav.toc li.figure { font-size: 8.5pt; margin: 0.15em 0 0.15em 1.6em; color: #333; }
section.chapter { break-before: page; }
section.chapter > h2 { margin-top: 0; } section.brief { break-inside: avoid; }
@media screen { section.chapter { border-top: 1px solid #ddd; margin-top: 2em; } }
"""


def _anchor(i: int) -> str:
    return f"s{i}"


_NOWRAP = ' class="n"'  # short cells (numbers, intervals) are not broken across lines


def _table_html(block: Table) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in block.header)
    body = "".join("<tr>" + "".join(f"<td{_NOWRAP if len(str(c)) <= 24 else ''}>{html.escape(str(c))}</td>"
                                    for c in row) + "</tr>" for row in block.rows)
    cap = f"<caption>{html.escape(block.caption)}</caption>" if block.caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _figure_html(block: FigureBlock, n: int, blank: bool = False) -> str:
    w, h = block.size_in
    # printed at its drawn size, scaled down only to fit the text width and, with its caption, one page
    width_in = min(w, TEXT_WIDTH_IN, w * FIGURE_MAX_HEIGHT_IN / h)
    return (f'<figure id="fig{n}"><img style="width: {width_in:.2f}in" '
            f'alt="Figure {n}: {html.escape(block.caption, quote=True)}" '
            f'src="data:image/png;base64,{block.blank_png_base64() if blank else block.png_base64()}">'
            f"<figcaption><b>Figure {n}.</b> {html.escape(block.caption)}</figcaption></figure>")


def _block_html(block: Block, fig_no: list[int], blank_figures: bool = False) -> str:
    if isinstance(block, str):
        return f"<p>{html.escape(block)}</p>"
    if isinstance(block, Table):
        return _table_html(block)
    if isinstance(block, Definitions):
        return "<dl>" + "".join(f"<dt>{html.escape(t)}</dt><dd>{html.escape(d)}</dd>" for t, d in block.entries) \
            + "</dl>"
    fig_no[0] += 1
    return _figure_html(block, fig_no[0], blank_figures)


def _toc_html(report: Report, page_numbers: dict[str, int] | None) -> str:
    items = []
    fig_no = 0
    for i, s in enumerate(report.sections, 1):
        page = "" if page_numbers is None else str(page_numbers.get(_anchor(i), ""))
        items.append(f'<li><a href="#{_anchor(i)}">{i}. {html.escape(s.title)}</a><span class="dots"></span>'
                     f'<span class="page">{page}</span></li>')
        for b in s.blocks:
            if isinstance(b, FigureBlock):
                fig_no += 1
                short = b.title or b.caption
                short = short if len(short) <= 95 else short[:92].rsplit(" ", 1)[0] + " ..."
                items.append(f'<li class="figure"><a href="#fig{fig_no}">Figure {fig_no}. {html.escape(short)}</a>'
                             "</li>")
    return f'<nav class="toc"><h2>Contents</h2><ol>{"".join(items)}</ol></nav>'


def render_html(report: Report, page_numbers: dict[str, int] | None = None, blank_figures: bool = False) -> str:
    """The report as one self-contained HTML page (screen and A4 print).

    Parameters
    ----------
    report : Report
    page_numbers : dict, optional
        Printed page of each section (``"s1"``, ``"s2"``, ...) for the table of
        contents; without it the contents list has no page numbers.
    blank_figures : bool
        Figures as white images of their size (`FigureBlock.blank_png_base64`):
        the same layout, for the print that only finds the page numbers.
    """
    fig_no = [0]
    title = [f"<h1>{html.escape(report.title)}</h1><p class=\"subtitle\">{html.escape(report.subtitle)}</p>"]
    if report.answer is not None:
        title.append(_table_html(report.answer))
    title += [f'<p class="remark">{html.escape(r)}</p>' for r in report.remarks]
    # a section with figures or tables starts a page; a few lines of text follow on the page before
    parts = [f'<section class="{"chapter" if any(not isinstance(b, str) for b in s.blocks) else "brief"}" '
             f'id="{_anchor(i)}"><h2>{i}. {html.escape(s.title)}</h2>'
             + "".join(_block_html(b, fig_no, blank_figures) for b in s.blocks) + "</section>"
             for i, s in enumerate(report.sections, 1)]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(report.title)}</title><style>{_CSS}</style></head><body>"
            f'<div class="title-page">{"".join(title)}</div>'
            + _toc_html(report, page_numbers) + "".join(parts) + "</body></html>\n")


# ------------------------------------------------------------------- PDF
def find_chromium() -> str | None:
    """Path of a Chromium (or Chrome) executable on PATH, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def _print_with_chromium(chromium: str, html_text: str, pdf_path: Path, timeout_s: float) -> None:
    with tempfile.TemporaryDirectory(prefix="filmcal-print-") as work:
        page = Path(work) / "report.html"
        page.write_text(html_text, encoding="utf-8")
        cmd = [chromium, *CHROMIUM_FLAGS, f"--user-data-dir={Path(work) / 'profile'}",
               f"--print-to-pdf={pdf_path}", page.as_uri()]
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    if not pdf_path.exists() or pdf_path.read_bytes()[:5] != b"%PDF-":
        raise RuntimeError(f"Chromium did not print the report (exit status {run.returncode}): "
                           f"{run.stderr.strip()[-500:]}")


def _section_pages(pdf_path: Path, report: Report) -> dict[str, int] | None:
    """Page of each section title in a printed PDF (``pdftotext``), or None without poppler."""
    pdftotext = shutil.which("pdftotext")
    if pdftotext is None:
        return None
    run = subprocess.run([pdftotext, "-layout", str(pdf_path), "-"], capture_output=True, text=True, timeout=120)
    if run.returncode != 0:
        return None
    pages = run.stdout.split("\f")
    out: dict[str, int] = {}
    start = 2  # the title page and the contents come first
    for i, s in enumerate(report.sections, 1):
        heading = re.compile(rf"^\s*{i}\.\s+{re.escape(s.title.split()[0])}", re.MULTILINE)
        for k in range(start, len(pages)):
            if heading.search(pages[k]):
                out[_anchor(i)] = k + 1
                start = k
                break
    return out


def _write_matplotlib_pdf(report: Report, path: Path, reason: str) -> None:
    """Figures-only fallback: a cover page that says why, then each figure on an A4 page with its caption."""
    import textwrap

    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.image import imread

    with PdfPages(path, metadata={"Title": report.title}) as pdf:
        cover = Figure(figsize=_A4_IN)
        lines = [report.title, "", *textwrap.wrap(report.subtitle, 90), "",
                 *textwrap.wrap(f"This PDF holds the figures only: {reason} The HTML report beside it is complete.",
                                90)]
        cover.text(0.08, 0.92, "\n".join(lines), va="top", fontsize=10)
        pdf.savefig(cover)
        n = 0
        for section in report.sections:
            for block in section.blocks:
                if not isinstance(block, FigureBlock):
                    continue
                n += 1
                page = Figure(figsize=_A4_IN)
                w, h = block.size_in
                scale = min(1.0, TEXT_WIDTH_IN / w, 8.8 / h)
                pixels = imread(io.BytesIO(base64.b64decode(block.png_base64())))
                ax = page.add_axes([(1 - w * scale / _A4_IN[0]) / 2, 1 - 0.06 - h * scale / _A4_IN[1],
                                    w * scale / _A4_IN[0], h * scale / _A4_IN[1]])
                ax.imshow(pixels)
                ax.axis("off")
                caption = "\n".join(textwrap.wrap(f"Figure {n}. {section.title}: {block.caption}", 100))
                page.text(0.08, 1 - 0.08 - h * scale / _A4_IN[1], caption, va="top", fontsize=9)
                pdf.savefig(page)


def write_pdf(report: Report, path: str | Path, timeout_s: float = 300.0) -> PdfResult:
    """Print the report's HTML to an A4 PDF with headless Chromium (fallback: figures-only matplotlib PDF).

    The page is printed twice when ``pdftotext`` is available: the first print,
    with blank figures of the same size, tells on which page each section
    starts; the second carries those page numbers in the table of contents.

    Parameters
    ----------
    report : Report
    path : str or Path
        The PDF to write (atomically).
    timeout_s : float, default 300
        Limit of each Chromium run (s).

    Returns
    -------
    PdfResult
        ``engine`` is ``"chromium"``, or ``"matplotlib"`` with ``message`` saying why.
    """
    path = Path(path)
    chromium = find_chromium()
    reason = ("Chromium was not found, so the typeset PDF could not be printed (install Debian's chromium "
              "package, or any Chromium/Chrome on PATH).")
    if chromium is not None:
        try:
            with atomic_path(path) as tmp:
                # when a second print follows, the first only finds the pages: blank figures of the same size
                # lay the page out alike and print in half the time
                layout_only = shutil.which("pdftotext") is not None
                _print_with_chromium(chromium, render_html(report, blank_figures=layout_only), tmp, timeout_s)
                pages = _section_pages(tmp, report)
                if pages or layout_only:
                    _print_with_chromium(chromium, render_html(report, page_numbers=pages), tmp, timeout_s)
            return PdfResult(path, "chromium")
        except (OSError, RuntimeError, subprocess.SubprocessError) as err:
            reason = f"Chromium ({chromium}) failed to print the report: {err}"
    with atomic_path(path) as tmp:
        _write_matplotlib_pdf(report, tmp, reason)
    return PdfResult(path, "matplotlib", reason)
