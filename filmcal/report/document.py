"""A report as data (a title page, sections of paragraphs, tables, figures and definitions) and its HTML page.

`render_html` writes one self-contained HTML page (figures embedded as PNG
data URIs, no scripts, no external files) for the screen; the A4 PDF of the
same report is typeset by :mod:`filmcal.report.typeset`.
"""
from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field

from matplotlib.figure import Figure

__all__ = ["Table", "FigureBlock", "Definitions", "Section", "Report", "render_html", "TEXT_WIDTH_IN",
           "TEXT_HEIGHT_IN"]

#: Resolution of the embedded figure images (dots per inch at their printed size).
FIGURE_DPI = 150
#: Width and height of the printed text area of an A4 page (inches): figures are drawn at most this size.
TEXT_WIDTH_IN = 6.9
TEXT_HEIGHT_IN = 9.4
#: Tallest printed figure image (inches), leaving room for a caption of a few lines on the same page.
FIGURE_MAX_HEIGHT_IN = 8.6


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


def _figure_html(block: FigureBlock, n: int) -> str:
    w, h = block.size_in
    # printed at its drawn size, scaled down only to fit the text width and, with its caption, one page
    width_in = min(w, TEXT_WIDTH_IN, w * FIGURE_MAX_HEIGHT_IN / h)
    return (f'<figure id="fig{n}"><img style="width: {width_in:.2f}in" '
            f'alt="Figure {n}: {html.escape(block.caption, quote=True)}" '
            f'src="data:image/png;base64,{block.png_base64()}">'
            f"<figcaption><b>Figure {n}.</b> {html.escape(block.caption)}</figcaption></figure>")


def _block_html(block: Block, fig_no: list[int]) -> str:
    if isinstance(block, str):
        return f"<p>{html.escape(block)}</p>"
    if isinstance(block, Table):
        return _table_html(block)
    if isinstance(block, Definitions):
        return "<dl>" + "".join(f"<dt>{html.escape(t)}</dt><dd>{html.escape(d)}</dd>" for t, d in block.entries) \
            + "</dl>"
    fig_no[0] += 1
    return _figure_html(block, fig_no[0])


def _toc_html(report: Report) -> str:
    items = []
    fig_no = 0
    for i, s in enumerate(report.sections, 1):
        items.append(f'<li><a href="#{_anchor(i)}">{i}. {html.escape(s.title)}</a></li>')
        for b in s.blocks:
            if isinstance(b, FigureBlock):
                fig_no += 1
                short = b.title or b.caption
                short = short if len(short) <= 95 else short[:92].rsplit(" ", 1)[0] + " ..."
                items.append(f'<li class="figure"><a href="#fig{fig_no}">Figure {fig_no}. {html.escape(short)}</a>'
                             "</li>")
    return f'<nav class="toc"><h2>Contents</h2><ol>{"".join(items)}</ol></nav>'


def render_html(report: Report) -> str:
    """The report as one self-contained HTML page, with its contents linked to the sections and figures."""
    fig_no = [0]
    title = [f"<h1>{html.escape(report.title)}</h1><p class=\"subtitle\">{html.escape(report.subtitle)}</p>"]
    if report.answer is not None:
        title.append(_table_html(report.answer))
    title += [f'<p class="remark">{html.escape(r)}</p>' for r in report.remarks]
    # a section with figures or tables starts a page; a few lines of text follow on the page before
    parts = [f'<section class="{"chapter" if any(not isinstance(b, str) for b in s.blocks) else "brief"}" '
             f'id="{_anchor(i)}"><h2>{i}. {html.escape(s.title)}</h2>'
             + "".join(_block_html(b, fig_no) for b in s.blocks) + "</section>"
             for i, s in enumerate(report.sections, 1)]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(report.title)}</title><style>{_CSS}</style></head><body>"
            f'<div class="title-page">{"".join(title)}</div>'
            + _toc_html(report) + "".join(parts) + "</body></html>\n")
