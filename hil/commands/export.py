"""``hil export RECORD_DIR --mdf4 OUT_DIR``: every capture of a record as an ASAM MDF4 file.

One ``<test>.mf4`` per capture, channels with their units, the record's provenance (record id,
software version and git SHA, bench file hash, the capture's SHA-256) in the file's header; a
capture whose SHA-256 does not match its record is refused (:mod:`hil.record_export`).
"""

from __future__ import annotations

import json
from pathlib import Path


from hil.commands import description

def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "export", help="export a record's captures as ASAM MDF4 files (with units and "
                       "provenance)",
        description=description(__doc__))
    parser.add_argument("record_dir", metavar="RECORD_DIR", type=Path,
                        help="record folder (or its record.json)")
    parser.add_argument("--mdf4", required=True, metavar="OUT_DIR", type=Path,
                        help="folder to write the .mf4 files into (created if needed)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def run(args) -> int:
    from hil.record_export import export_mdf4

    written = export_mdf4(args.record_dir, args.mdf4)
    if args.json:
        print(json.dumps({"record": str(args.record_dir), "mdf4": [str(p) for p in written]}))
    else:
        for path in written:
            print(path)
    return 0
