"""``hil db sync|import|export|verify``: the results database's upkeep.

``sync`` indexes every sealed record under the records folder that the database lacks (a run
whose database was down, an old record); ``import RECORD_DIR…`` indexes the named records;
``export --format csv|parquet -o DIR`` writes every table (parquet needs pyarrow, which the
project does not install: ``pip install pyarrow``); ``verify RECORD_DIR`` checks a record
against its row (seal hash and status). Indexing is idempotent on the record ID.
"""

from __future__ import annotations

from hil.commands import description

import json
import sys
from pathlib import Path

from hil.results.cli_options import add_database_options, database_error, engine_from_args


def register(subparsers) -> None:
    parser = subparsers.add_parser("db", help="results database: sync, import, export, verify",
                                   description=description(__doc__))
    actions = parser.add_subparsers(dest="db_action", metavar="ACTION",
                                    parser_class=type(parser))
    actions.required = True
    sync = actions.add_parser("sync", help="index every sealed record the database lacks")
    imp = actions.add_parser("import", help="index the named record folders")
    imp.add_argument("record_dirs", metavar="RECORD_DIR", nargs="+", type=Path)
    exp = actions.add_parser("export", help="write every table as CSV or Parquet")
    exp.add_argument("--format", choices=("csv", "parquet"), default="csv")
    exp.add_argument("-o", "--out", type=Path, default=Path("results-export"),
                     help="output folder (default: results-export)")
    ver = actions.add_parser("verify", help="check a record folder against its database row")
    ver.add_argument("record_dir", metavar="RECORD_DIR", type=Path)
    for sub in (sync, imp):
        sub.add_argument("--dut-serial", metavar="SN",
                         help="DUT serial to index these records under (default: the one the "
                              "run recorded, else the drive's)")
    for sub in (sync, imp, exp, ver):
        add_database_options(sub)
        sub.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def run(args) -> int:
    from sqlalchemy.exc import SQLAlchemyError

    try:
        return {"sync": _sync, "import": _import, "export": _export,
                "verify": _verify}[args.db_action](args)
    except SQLAlchemyError as exc:
        raise database_error(exc, args) from None


def _report(args, result) -> int:
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(f"indexed {len(result.indexed)}, already present {result.present}, "
              f"failed {len(result.failed)}")
        for record, error in result.failed:
            print(f"  {record}: {error}", file=sys.stderr)
    return 1 if result.failed else 0


def _sync(args) -> int:
    from hil.results.ingest import sealed_records, sync

    engine = engine_from_args(args, create=True)
    folders = sealed_records(args.records) if args.records.exists() else []
    return _report(args, sync(engine, folders, dut_serial=args.dut_serial))


def _import(args) -> int:
    from hil.errors import InputError
    from hil.results.ingest import record_folder, sync

    folders = [record_folder(p) for p in args.record_dirs]
    missing = [str(p) for p in folders if not (p / "record.json").exists()]
    if missing:
        raise InputError(f"not a record folder: {', '.join(missing)}")
    return _report(args, sync(engine_from_args(args, create=True), folders, dut_serial=args.dut_serial))


def _export(args) -> int:
    from hil.results.export import export_tables

    written = export_tables(engine_from_args(args), args.out, args.format)
    if args.json:
        print(json.dumps({"format": args.format, "files": written}))
    else:
        for path, rows in written.items():
            print(f"{path}: {rows} row(s)")
    return 0


def _verify(args) -> int:
    from hil.results.db import resolve_url
    from hil.results.ingest import verify_row

    problems = verify_row(args.record_dir, resolve_url(args.results_db, args.bench, args.records))
    if args.json:
        print(json.dumps({"record": str(args.record_dir), "agrees": not problems,
                          "problems": problems}))
    elif problems:
        print(f"{args.record_dir}: differs from its database row:")
        for problem in problems:
            print(f"  {problem}")
    else:
        print(f"{args.record_dir}: agrees with its database row (seal hash, status)")
    return 1 if problems else 0
