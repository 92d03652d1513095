"""``hil report RECORD_DIR [-o FILE.pdf] [--reason TEXT]``: the PDF test report of a run record.

Every hash is checked again first: a record or capture that does not verify makes page 1 say
INVALID, names the files, and the command exits 1 (the PDF is still written). A report is never
overwritten: the first report of a record is Rev. 1; a later one is a new revision, needs
``--reason`` and goes to a new file (default ``RECORD_DIR/report-rev<N>.pdf``). The revision
number comes from the signed revision lines of ``record.sig`` (``reports.revisions``), so
deleting a side file cannot issue a second "Rev. 1". The seal's signature and the signing key's
fingerprint are printed (``--json``: ``signature``, ``key_fingerprint``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "report", help="PDF test report of a run record",
        description="Build the PDF report of a record folder (record.json + captures/): "
                    "statements of conformity, method, instruments, per-source plots and tables, "
                    "integrity check; record.json and the captures are attached. Works on a "
                    "partial (interrupted) record and says so. Exit 1 if a hash does not verify.")
    parser.add_argument("record_dir", metavar="RECORD_DIR", type=Path,
                        help="record folder (or its record.json)")
    parser.add_argument("-o", "--output", metavar="FILE.pdf", type=Path, default=None,
                        help="PDF to write; never overwritten (default: RECORD_DIR/report.pdf, "
                             "report-rev<N>.pdf for a later revision)")
    parser.add_argument("--reason", metavar="TEXT", default=None,
                        help="why a new revision is issued (required from Rev. 2 on)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (pdf, report_id, revision, pages, status, "
                             "statements, integrity problems)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from hil.errors import InputError
    from hil.record import load_record, seal_check
    from ripple_hil_reports import issue_report  # fpdf2 loads only for this command
    from ripple_hil_reports.revisions import issued

    record_dir = args.record_dir.parent if args.record_dir.name == "record.json" \
        else args.record_dir
    data = load_record(record_dir)          # an unreadable record: one line, exit 2
    number = len(issued(record_dir)) + 1
    output = args.output or record_dir / ("report.pdf" if number == 1
                                          else f"report-rev{number}.pdf")
    if output.is_dir():
        raise InputError(f"-o {str(output)!r} is a folder; give a file name like report.pdf")
    rendered = issue_report(record_dir, output, reason=args.reason)
    content, statement = rendered.content, rendered.content.statement
    summary = {"pdf": str(output), "report_id": content.report_id,
               "revision": content.revision.number, "pages": rendered.pages,
               "status": content.record.get("status"), "partial": content.partial,
               "overall": content.overall, "requirements": statement.requirements,
               "self_check": statement.self_check,
               "sources": {s.name: s.statement for s in content.sources},
               "integrity_problems": content.capture_problems}
    check = seal_check(record_dir, data)
    summary |= {"signature": None if check is None else check.state,
                "key_fingerprint": None if check is None else check.fingerprint}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {output}: report {content.report_id} (Rev. {content.revision.number}), "
              f"{rendered.pages} pages, overall {content.overall}"
              + (f" (run {content.record.get('status')})" if content.partial else ""))
        print(f"seal: {check.text() if check is not None else 'none (the run never finished)'}")
    if content.capture_problems:
        print(f"hil report: INVALID record: {'; '.join(content.capture_problems)}",
              file=sys.stderr)
        return 1
    return 0
