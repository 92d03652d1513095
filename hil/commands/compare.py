"""``hil compare RUN_A RUN_B``: two runs' matching points side by side — pk-pk per unit of the
nameplate torque and every order both analysed — each difference b − a with the expanded
uncertainty of the difference U_d = √(U_a² + U_b²), and which changed beyond it and which did not.
The points either run judged come first, and the last line says whether B reproduces A within U
on every one of them or names those that differ beyond U and their plans (a bench against its
own twin: ``hil compare TWIN_RUN BENCH_RUN``, d = bench − twin). RUN: a record ID, a unique
prefix of one, or a record folder."""

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


def _fmt(diff: dict, scale: float, digits: int = 3,
         words: tuple[str, str] = ("unchanged", "CHANGED")) -> str:
    if diff["difference"] is None:
        return "not comparable (no value or no U)"
    word = "not judged" if diff["changed"] is None else words[bool(diff["changed"])]
    return (f"{diff['a'] * scale:.{digits}f} ± {diff['u_a'] * scale:.{digits}f} → "
            f"{diff['b'] * scale:.{digits}f} ± {diff['u_b'] * scale:.{digits}f}: "
            f"d = {diff['difference'] * scale:+.{digits}f} ± {diff['u_difference'] * scale:.{digits}f}"
            f" {word}")


def _print_point(point: dict, args, words: tuple[str, str], why: str | None = None) -> None:
    verdicts = ("" if point["outcome_a"] == point["outcome_b"]
                else f"  [verdict {point['outcome_a']} → {point['outcome_b']}]")
    text = f"not comparable: {why}" if why else _fmt(point["pk_pk_pu"], 100.0, words=words)
    print(f"  {point['test_id']}: {text}{verdicts}"
          + ("" if point["same_point"] else "  (operating point or injection differs)"))
    for order in point["orders"]:
        if args.orders or order["changed"]:
            print(f"      order {order['order']:g} (mN·m): {_fmt(order, 1000.0, 3)}")


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
    from hil.results.reproduction import is_judged

    reproduction = result["reproduction"]
    print(f"A {result['run_a']}  →  B {result['run_b']}   ({result['rule']})")
    print("pk-pk, % of the nameplate torque, A ± U_a → B ± U_b: d = B − A ± U_d "
          "(orders: amplitude, U the revolution scatter only)")
    print("judged points (a verdict in A or B):")
    for point in filter(is_judged, result["points"]):
        _print_point(point, args, ("within U", "BEYOND U"),
                     reproduction["not_comparable"].get(point["test_id"]))
    print("points that judge nothing (measured, no verdict; not determinable):")
    for point in (p for p in result["points"] if not is_judged(p)):
        _print_point(point, args, ("unchanged", "CHANGED"))
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
    print(f"B against A: {reproduction['statement']}")
    for test_id in reproduction["beyond_u"]:
        print(f"  beyond U_d: {test_id}")
    for item in reproduction["verdicts_differ"]:
        print(f"  verdict differs: {item['test_id']} ({item['outcome_a']} → {item['outcome_b']})")
    return 0
