"""PDF compliance report of a run record (tracker issue 7): ``build_report(record_dir, out_pdf)``."""

from reports.build import RenderedReport, build_report, render_report

__all__ = ["RenderedReport", "build_report", "render_report"]
