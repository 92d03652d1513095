"""PDF compliance report of a run record: ``build_report(record_dir, out_pdf)``."""

from ripple_hil_reports.build import RenderedReport, build_report, issue_report, render_report

__all__ = ["RenderedReport", "build_report", "issue_report", "render_report"]
