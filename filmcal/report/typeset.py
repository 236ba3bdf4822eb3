"""The report typeset on A4 with Typst: title page with the answer, contents with page numbers, real tables.

`write_pdf` writes the report's text and tables as one JSON file and its
figures as PNG files into a temporary folder, and compiles the template
``report.typ`` (shipped beside this module) with the Typst compiler of the
``typst`` package (a PyPI wheel, no browser, nothing downloaded: the template
uses no packages). Texts enter the template as JSON strings, so nothing in a
study's files is read as markup.

The fonts are DejaVu Sans where the system has it, else the fonts built into
the compiler. The PDF's creation date is fixed (`timestamp`), so the same
report typesets to the same bytes.
"""
from __future__ import annotations

import base64
import json
import tempfile
import warnings
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from filmcal._io import atomic_path
from filmcal.report.document import (FIGURE_MAX_HEIGHT_IN, TEXT_WIDTH_IN, Definitions, FigureBlock, Report,
                                     Table)

__all__ = ["PdfResult", "write_pdf", "report_data", "FONTS"]

#: Font families in order of preference: DejaVu Sans (the figures' font) where installed, then the compiler's own.
FONTS = ("DejaVu Sans", "Libertinus Serif")


@dataclass
class PdfResult:
    """What `write_pdf` wrote: the file and the engine that typeset it."""

    path: Path
    engine: str = "typst"


#: Characters of table text that fit across the text width (8.5 pt DejaVu Sans on 175 mm, with cell padding).
_TABLE_CHARS = 100


def _column_widths(header: list[str], rows: list[list[str]]) -> list[int] | None:
    """Relative column widths for a table too wide for its natural layout, else None (each column as wide as its text).

    A column is given the width of its longest cell and of its header up to 14 characters: headers wrap,
    numbers and intervals do not.
    """
    longest = [max([len(r[j]) for r in rows] + [1]) for j in range(len(header))]
    if sum(max(n, len(h)) + 2 for n, h in zip(longest, header)) <= _TABLE_CHARS:
        return None
    return [max(n, min(len(h), 14)) + 2 for n, h in zip(longest, header)]


def _table(block: Table) -> dict:
    header = [str(h) for h in block.header]
    rows = [[str(c) for c in row] + [""] * (len(header) - len(row)) for row in block.rows]
    return {"kind": "table", "caption": block.caption, "header": header, "rows": rows,
            "widths": _column_widths(header, rows)}


def _short_title(block: FigureBlock) -> str:
    short = block.title or block.caption
    return short if len(short) <= 95 else short[:92].rsplit(" ", 1)[0] + " ..."


def _figure_width_in(block: FigureBlock) -> float:
    """Printed width: the drawn size, scaled down only to fit the text width and, with its caption, one page."""
    w, h = block.size_in
    return float(min(w, TEXT_WIDTH_IN, w * FIGURE_MAX_HEIGHT_IN / h))


def report_data(report: Report, figure_dir: Path) -> dict:
    """The report as the template's JSON data; each figure written to `figure_dir` as ``figN.png``."""
    sections, n = [], 0
    for s in report.sections:
        blocks = []
        for b in s.blocks:
            if isinstance(b, str):
                blocks.append({"kind": "text", "text": b})
            elif isinstance(b, Table):
                blocks.append(_table(b))
            elif isinstance(b, Definitions):
                blocks.append({"kind": "definitions", "entries": [[str(t), str(d)] for t, d in b.entries]})
            elif isinstance(b, FigureBlock):
                n += 1
                name = f"fig{n}.png"
                (figure_dir / name).write_bytes(base64.b64decode(b.png_base64()))
                blocks.append({"kind": "figure", "path": name, "caption": b.caption, "number": n,
                               "short": _short_title(b), "width_in": round(_figure_width_in(b), 3)})
            else:
                raise TypeError(f"unknown report block {type(b).__name__}")
        sections.append({"title": s.title, "chapter": any(not isinstance(b, str) for b in s.blocks),
                         "blocks": blocks})
    return {"title": report.title, "subtitle": report.subtitle, "fonts": list(FONTS),
            "answer": None if report.answer is None else _table(report.answer),
            "remarks": list(report.remarks), "sections": sections,
            "figures": [{"number": b["number"], "short": b["short"]} for sec in sections for b in sec["blocks"]
                        if b["kind"] == "figure"]}


def write_pdf(report: Report, path: str | Path, timestamp: int = 0) -> PdfResult:
    """Typeset the report to an A4 PDF with Typst (written atomically).

    Parameters
    ----------
    report : Report
    path : str or Path
        The PDF to write.
    timestamp : int, default 0
        The PDF's creation date (seconds since 1970, UTC); fixed, so that the
        same report gives the same file.

    Returns
    -------
    PdfResult
    """
    import typst

    path = Path(path)
    with tempfile.TemporaryDirectory(prefix="filmcal-typeset-") as work:
        root = Path(work)
        (root / "report.typ").write_text(resources.files("filmcal.report").joinpath("report.typ")
                                         .read_text(encoding="utf-8"), encoding="utf-8")
        (root / "report.json").write_text(json.dumps(report_data(report, root), ensure_ascii=False),
                                          encoding="utf-8")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            pdf = typst.compile(str(root / "report.typ"), root=str(root), timestamp=int(timestamp))
        for message in dict.fromkeys(str(w.message) for w in caught):  # the compiler's warnings, once each
            warnings.warn(f"typesetting the report: {message}", RuntimeWarning, stacklevel=2)
    with atomic_path(path) as tmp:
        tmp.write_bytes(pdf)
    return PdfResult(path)
