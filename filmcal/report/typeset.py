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
import re
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
#: Mean width of a character of numbers and intervals in DejaVu Sans (em): such a column is as wide as its text.
_DIGIT_EM = 0.56


def _column_widths(header: list[str], rows: list[list[str]]) -> list[dict] | None:
    """Column widths for a table too wide for its natural layout, else None (each column as wide as its text).

    A column of short cells (numbers, intervals, which do not wrap) gets the width of its longest cell or of
    the longest word of its header; a column with longer text shares the rest of the line (``fr``). Headers
    wrap.
    """
    longest = [max([len(r[j]) for r in rows] + [1]) for j in range(len(header))]
    if sum(max(n, len(h)) + 2 for n, h in zip(longest, header)) <= _TABLE_CHARS:
        return None
    out = []
    for j, h in enumerate(header):
        word = max((len(w) for w in h.split()), default=1)
        if longest[j] > 24:
            out.append({"fr": True, "size": min(longest[j], 40)})
        else:
            out.append({"fr": False, "size": round(max(longest[j], word) * _DIGIT_EM + 1.0, 2)})
    if not any(w["fr"] for w in out) and sum(w["size"] for w in out) > _TABLE_CHARS * _DIGIT_EM * 0.85:
        out = [{"fr": True, "size": w["size"]} for w in out]
    return out


_BRACKETS = re.compile(r"\[[^\]]*\]")
_RANGE = re.compile(r"(?<=\S) to (?=\S)")
_NUMBER = re.compile(r"^[-+−]?(\d|\.\d|\[|nan|inf|pass|FAILED|not )")


def _cell(text) -> str:
    """A cell's text with intervals and ranges kept whole: a line may break after a median, not inside [a, b]."""
    text = _BRACKETS.sub(lambda m: m.group(0).replace(" ", "\u00a0"), str(text))
    return _RANGE.sub("\u00a0to\u00a0", text) if len(text) <= 24 else text


def _table(block: Table) -> dict:
    header = [str(h) for h in block.header]
    rows = [[_cell(c) for c in row] + [""] * (len(header) - len(row)) for row in block.rows]
    numeric = [j > 0 and all(_NUMBER.match(r[j]) or not r[j] for r in rows) for j in range(len(header))]
    return {"kind": "table", "caption": block.caption, "header": header, "rows": rows,
            "widths": _column_widths(header, rows), "right": numeric}


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
