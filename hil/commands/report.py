"""``hil report RECORD_DIR -o FILE.pdf``: the PDF test report of a run record."""

from __future__ import annotations

import json
from pathlib import Path


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "report", help="PDF test report of a run record",
        description="Build the PDF report of a record folder (record.json + captures/): "
                    "statement of conformity, method, instruments, per-source plots and tables, "
                    "capture hashes; record.json and the captures are attached. Works on a "
                    "partial (interrupted) record and says so.")
    parser.add_argument("record_dir", metavar="RECORD_DIR", type=Path,
                        help="record folder (or its record.json)")
    parser.add_argument("-o", "--output", metavar="FILE.pdf", type=Path, default=None,
                        help="PDF to write (default: RECORD_DIR/report.pdf)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (pdf, report_id, pages, status, statements)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from reports import render_report  # matplotlib and fpdf2 load only for this command

    record_dir = args.record_dir.parent if args.record_dir.name == "record.json" \
        else args.record_dir
    output = args.output or record_dir / "report.pdf"
    rendered = render_report(record_dir)
    rendered.save(output)
    content = rendered.content
    summary = {"pdf": str(output), "report_id": content.report_id, "pages": rendered.pages,
               "status": content.record.get("status"), "partial": content.partial,
               "overall": content.overall,
               "sources": {s.name: s.statement for s in content.sources},
               "capture_problems": content.capture_problems}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {output}: report {content.report_id}, {rendered.pages} pages, "
              f"overall {content.overall}{' (PARTIAL record)' if content.partial else ''}")
    return 0
