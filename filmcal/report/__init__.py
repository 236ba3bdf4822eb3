"""Figures and the calibration report of a study (HTML and PDF)."""
from filmcal.report.document import FigureBlock, Report, Section, Table, render_html, write_pdf
from filmcal.report.study_report import build_report, write_report

__all__ = ["build_report", "write_report", "Report", "Section", "Table", "FigureBlock", "render_html", "write_pdf"]
