"""A report as data (sections of paragraphs, tables and figures) and its two renderings.

`render_html` writes one self-contained HTML page (figures embedded as PNG
data URIs, no scripts, no external files); `write_pdf` writes a PDF with
matplotlib alone: text pages for paragraphs and tables, one page per figure.
"""
from __future__ import annotations

import base64
import html
import io
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

from matplotlib.figure import Figure

__all__ = ["Table", "FigureBlock", "Section", "Report", "render_html", "write_pdf"]

_FIGURE_DPI = 110


@dataclass
class Table:
    """A table of already formatted cells."""

    header: list[str]
    rows: list[list[str]]
    caption: str = ""


@dataclass
class FigureBlock:
    """A matplotlib figure with its caption."""

    figure: Figure
    caption: str


@dataclass
class Section:
    """A titled part of the report: blocks (str paragraphs, tables, figures) in order."""

    title: str
    blocks: list[str | Table | FigureBlock] = field(default_factory=list)

    def add(self, *blocks: str | Table | FigureBlock) -> "Section":
        self.blocks.extend(blocks)
        return self


@dataclass
class Report:
    """Title, sections and a provenance table."""

    title: str
    subtitle: str
    sections: list[Section]

    @property
    def figures(self) -> list[FigureBlock]:
        return [b for s in self.sections for b in s.blocks if isinstance(b, FigureBlock)]


def _png_base64(fig: Figure) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_FIGURE_DPI)
    return base64.b64encode(buf.getvalue()).decode("ascii")


_CSS = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.1em; } .subtitle { color: #555; margin-top: 0; }
h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f2f2f2; } td:first-child, th:first-child { text-align: left; }
caption { caption-side: top; text-align: left; font-style: italic; padding-bottom: 0.3em; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.9em; color: #444; } nav ol { columns: 2; }
"""


def _html_block(block, fig_no: list[int]) -> str:
    if isinstance(block, str):
        return f"<p>{html.escape(block)}</p>"
    if isinstance(block, Table):
        head = "".join(f"<th>{html.escape(h)}</th>" for h in block.header)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>"
                       for row in block.rows)
        cap = f"<caption>{html.escape(block.caption)}</caption>" if block.caption else ""
        return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    fig_no[0] += 1
    n = fig_no[0]
    return (f'<figure id="fig{n}"><img alt="Figure {n}: {html.escape(block.caption, quote=True)}" '
            f'src="data:image/png;base64,{_png_base64(block.figure)}">'
            f"<figcaption>Figure {n}. {html.escape(block.caption)}</figcaption></figure>")


def render_html(report: Report) -> str:
    """The report as one self-contained HTML page."""
    fig_no = [0]
    toc = "".join(f'<li><a href="#s{i}">{html.escape(s.title)}</a></li>' for i, s in enumerate(report.sections, 1))
    parts = [f'<section id="s{i}"><h2>{i}. {html.escape(s.title)}</h2>'
             + "".join(_html_block(b, fig_no) for b in s.blocks) + "</section>"
             for i, s in enumerate(report.sections, 1)]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(report.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{html.escape(report.title)}</h1><p class=\"subtitle\">{html.escape(report.subtitle)}</p>"
            f"<nav><ol>{toc}</ol></nav>" + "".join(parts) + "</body></html>\n")


# ------------------------------------------------------------------- PDF
_PAGE_IN = (8.27, 11.69)  # A4 portrait
_LINE = 0.0155  # line height as a fraction of the page height (9 pt text)
_WRAP = 100  # characters per line of body text
_TABLE_CHARS = 118  # monospace characters of 7 pt across the text width


def _table_lines(table: Table) -> list[str]:
    widths = [max(len(str(r[k])) for r in [table.header, *table.rows]) for k in range(len(table.header))]
    fmt = lambda row: "  ".join(str(c).ljust(w) if k == 0 else str(c).rjust(w)  # noqa: E731
                                for k, (c, w) in enumerate(zip(row, widths)))
    lines = [fmt(table.header), "-" * len(fmt(table.header))] + [fmt(r) for r in table.rows]
    return ([table.caption] if table.caption else []) + lines


class _TextPages:
    """Flows title, paragraph and table lines over A4 pages."""

    def __init__(self, pdf) -> None:
        self.pdf = pdf
        self.fig: Figure | None = None
        self.y = 0.0

    def _new_page(self) -> None:
        self.flush()
        self.fig = Figure(figsize=_PAGE_IN)
        self.y = 0.95

    def line(self, text: str, size: float = 9, mono: bool = False, weight: str = "normal", gap: float = 1.0) -> None:
        if self.fig is None or self.y < 0.05:
            self._new_page()
        self.fig.text(0.07, self.y, text, fontsize=size, family="monospace" if mono else "sans-serif",
                      weight=weight, va="top")
        self.y -= _LINE * gap * size / 9

    def flush(self) -> None:
        if self.fig is not None:
            self.pdf.savefig(self.fig)
            self.fig = None


def write_pdf(report: Report, path: str | Path) -> Path:
    """Write the report as PDF: text pages, each figure on its own page after its section's text."""
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    fig_no = 0
    with PdfPages(tmp, metadata={"Title": report.title}) as pdf:
        pages = _TextPages(pdf)
        pages.line(report.title, size=16, weight="bold", gap=1.6)
        for text in textwrap.wrap(report.subtitle, _WRAP):
            pages.line(text)
        for i, section in enumerate(report.sections, 1):
            if pages.fig is not None and pages.y < 0.25:
                pages.flush()
            pages.line("", gap=0.8)
            pages.line(f"{i}. {section.title}", size=12, weight="bold", gap=1.5)
            figures = []
            for block in section.blocks:
                if isinstance(block, str):
                    for text in textwrap.wrap(block, _WRAP):
                        pages.line(text)
                    pages.line("", gap=0.5)
                elif isinstance(block, Table):
                    lines = _table_lines(block)
                    size = min(7.0, 7.0 * _TABLE_CHARS / max(len(t) for t in lines))  # fit the page width
                    for text in lines:
                        pages.line(text, size=size, mono=True)
                    pages.line("", gap=0.5)
                else:
                    fig_no += 1
                    figures.append((fig_no, block))
                    for text in textwrap.wrap(f"Figure {fig_no} (page after): {block.caption}", _WRAP):
                        pages.line(text, size=8)
            if figures:
                pages.flush()
                for n, block in figures:
                    pdf.savefig(block.figure)
        pages.flush()
    tmp.replace(path)
    return path
