"""Figures and the calibration report of a study (a self-contained HTML page, and the same report typeset on A4)."""
from filmcal.report.document import Definitions, FigureBlock, Report, Section, Table, render_html
from filmcal.report.study_report import build_report, read_study, write_report
from filmcal.report.typeset import PdfResult, write_pdf

__all__ = ["build_report", "read_study", "write_report", "Report", "Section", "Table", "FigureBlock", "Definitions",
           "PdfResult", "render_html", "write_pdf"]
