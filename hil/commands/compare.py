"""``hil compare RUN_A RUN_B``: two runs' matching points side by side — pk-pk per unit of the
nameplate torque and every order both analysed — each difference b − a with the expanded
uncertainty of the difference U_d = √(U_a² + U_b²), and which changed beyond it and which did not.
RUN: a record ID, a unique prefix of one, or a record folder."""

from __future__ import annotations

from hil.commands import description

import json
from pathlib import Path


def register(subparsers) -> None:
    from hil.results.cli_options import add_database_options

    parser = subparsers.add_parser("compare", help="two runs side by side, differences with U",
                                   description=description(__doc__))
    parser.add_argument("run_a", metavar="RUN_A")
    parser.add_argument("run_b", metavar="RUN_B")
    parser.add_argument("--orders", action="store_true",
                        help="print every compared order, not only the ones that changed")
    parser.add_argument("-o", "--out", metavar="PLOT.png", type=Path,
                        help="plot of the pk-pk differences with ±U_d")
    add_database_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def _fmt(diff: dict, scale: float, digits: int = 3) -> str:
    if diff["difference"] is None:
        return "not comparable (no value or no U)"
    word = ("not judged" if diff["changed"] is None
            else "CHANGED" if diff["changed"] else "unchanged")
    return (f"{diff['a'] * scale:.{digits}f} ± {diff['u_a'] * scale:.{digits}f} → "
            f"{diff['b'] * scale:.{digits}f} ± {diff['u_b'] * scale:.{digits}f}: "
            f"d = {diff['difference'] * scale:+.{digits}f} ± {diff['u_difference'] * scale:.{digits}f}"
            f" {word}")


def run(args) -> int:
    from sqlalchemy.exc import SQLAlchemyError

    from hil.results.cli_options import database_error, engine_from_args
    from hil.results.queries import compare

    try:
        result = compare(engine_from_args(args), args.run_a, args.run_b)
    except SQLAlchemyError as exc:
        raise database_error(exc, args) from None
    if args.out is not None:
        from hil.results.plots import compare_plot

        compare_plot(result, args.out)
        result["plot"] = str(args.out)
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"A {result['run_a']}  →  B {result['run_b']}   ({result['rule']})")
    print("pk-pk, % of the nameplate torque, A ± U_a → B ± U_b: d ± U_d")
    for point in result["points"]:
        print(f"  {point['test_id']}: {_fmt(point['pk_pk_pu'], 100.0)}"
              + ("" if point["same_point"] else "  (operating point or injection differs)"))
        for order in point["orders"]:
            if args.orders or order["changed"]:
                print(f"      order {order['order']:g} (mN·m): {_fmt(order, 1000.0, 3)}")
    print(f"changed beyond U_d: {len(result['changed'])} point(s); unchanged: "
          f"{len(result['unchanged'])}; not comparable: {len(result['not_comparable'])}; "
          f"orders changed: {len(result['orders_changed'])}"
          + (f"; at another operating point or injection (not judged): "
             f"{len(result['different_point'])}" if result["different_point"] else ""))
    for key, text in (("only_in_a", "only in A"), ("only_in_b", "only in B")):
        if result[key]:
            print(f"{text}: {', '.join(result[key])}")
    if args.out is not None:
        print(f"plot: {args.out}")
    return 0
