"""``hil verify RECORD_DIR``: check a run record's integrity (exit 0 intact, 1 otherwise).

Re-hashes ``record.json`` against its seal (``record.sha256``, written when the run finished)
and every capture the record names against the SHA-256 recorded when it was written; names each
file that is missing, altered or outside the record folder, and each journal line that breaks
its hash chain. A record that was never sealed (status ``running``: the run was killed before it
could finish) is not intact: exit 1, with the captures' check still printed.
"""

from __future__ import annotations

import json
from pathlib import Path


def register(subparsers) -> None:
    parser = subparsers.add_parser("verify", help="check a run record's hashes (record.json and "
                                                  "every capture)",
                                   description=__doc__.splitlines()[0].replace("``", ""))
    parser.add_argument("record_dir", metavar="RECORD_DIR", type=Path,
                        help="record folder (or its record.json)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (record, status, intact, problems)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from hil.record import load_record, verify_record

    folder = args.record_dir.parent if args.record_dir.name == "record.json" else args.record_dir
    data = load_record(folder)
    problems = verify_record(folder, data)
    captures = sum(1 for t in data["tests"] if t.get("capture")) + len(data["pending_captures"])
    sealed = data["status"] != "running"
    if args.json:
        print(json.dumps({"record": str(folder), "record_id": data["record_id"],
                          "status": data["status"], "sealed": sealed,
                          "intact": sealed and not problems, "captures": captures,
                          "problems": problems}))
    elif problems:
        print(f"{folder}: INVALID ({len(problems)} problem(s))"
              + ("; not sealed (the run never finished)" if not sealed else "") + ":")
        for problem in problems:
            print(f"  {problem}")
    elif not sealed:
        print(f"{folder}: not sealed (the run never finished: status running, no "
              f"record.sha256); {captures} capture(s) match their SHA-256")
    else:
        print(f"{folder}: intact (record.json sealed, {captures} capture(s) match their "
              f"SHA-256; status {data['status']})")
    return 0 if sealed and not problems else 1
