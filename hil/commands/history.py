"""``hil history``: the runs in the results database, newest first, filtered by DUT serial,
drive firmware and station (status, overall statement, failed tests, seal hash)."""

from __future__ import annotations

from hil.commands import description

import json


def register(subparsers) -> None:
    from hil.results.cli_options import add_database_options

    parser = subparsers.add_parser("history", help="runs in the results database",
                                   description=description(__doc__))
    parser.add_argument("--dut", metavar="SN", help="only this DUT serial")
    parser.add_argument("--firmware", metavar="V", help="only this drive firmware")
    parser.add_argument("--station", metavar="S", help="only this station")
    parser.add_argument("--limit", type=int, default=50, help="newest N runs (default 50)")
    add_database_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def run(args) -> int:
    from sqlalchemy.exc import SQLAlchemyError

    from hil.errors import InputError
    from hil.results.cli_options import database_error, engine_from_args
    from hil.results.queries import history

    if args.limit < 1:
        raise InputError(f"--limit {args.limit} must be >= 1")
    try:
        rows = history(engine_from_args(args), dut=args.dut, firmware=args.firmware,
                       station=args.station, limit=args.limit)
    except SQLAlchemyError as exc:
        raise database_error(exc, args) from None
    if args.json:
        print(json.dumps({"runs": rows}))
        return 0
    if not rows:
        print("no run in the results database matches")
        return 0
    print(f"{'record':24} {'created (UTC)':20} {'status':10} {'statement':17} {'DUT':14} "
          f"{'firmware':24} {'station':26} failed")
    for r in rows:
        print(f"{r['record_id']:24} {r['created_utc']:20} {r['status'][:10]:10} "
              f"{r['statement']:17} {str(r['dut_serial'])[:14]:14} "
              f"{str(r['drive_firmware'])[:24]:24} {str(r['station'])[:26]:26} "
              f"{r['n_failed']}/{r['n_tests']}")
    return 0
