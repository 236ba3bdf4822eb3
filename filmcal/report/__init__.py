"""Figures and the calibration report of a study (HTML, and the A4 PDF printed from it)."""
from filmcal.report.document import (Definitions, FigureBlock, PdfResult, Report, Section, Table, render_html,
                                     write_pdf)
from filmcal.report.study_report import build_report, read_study, write_report

__all__ = ["build_report", "read_study", "write_report", "Report", "Section", "Table", "FigureBlock", "Definitions",
           "PdfResult", "render_html", "write_pdf"]
