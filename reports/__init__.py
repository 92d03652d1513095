"""PDF compliance report of a run record: ``build_report(record_dir, out_pdf)``.

The names below load ``ripple_hil_reports.build`` (and fpdf2, matplotlib: about 1 s) on first
use, so a run that only asks ``ripple_hil_reports.statement`` what its record states (every
``hil run``, also with ``--no-report``) does not pay for the PDF machinery.
"""

__all__ = ["RenderedReport", "build_report", "issue_report", "render_report"]


def __getattr__(name: str):
    if name in __all__:
        from ripple_hil_reports import build

        return getattr(build, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
