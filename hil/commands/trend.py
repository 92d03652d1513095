"""``hil trend (--requirement ID | --source NAME)``: one observation per run, oldest first —
individuals control chart (x̄ ± 3σ̂, σ̂ = MR̄/1.128), Cp/Cpk with 95 % intervals (χ² for Cp,
Bissell 1990 for Cpk) and the measured yield with its Clopper–Pearson interval."""

from __future__ import annotations

from hil.commands import description

import json
from pathlib import Path


def register(subparsers) -> None:
    from hil.results.cli_options import add_database_options

    parser = subparsers.add_parser("trend", help="control chart, Cp/Cpk and measured yield over "
                                                 "runs", description=description(__doc__)
                                   .replace("``", ""))
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--requirement", metavar="ID", help="a requirement's verdicts")
    what.add_argument("--source", metavar="NAME", help="a source's measured pk-pk")
    parser.add_argument("--point", metavar="TEST_ID",
                        help="with --source: which point (default: the most measured one)")
    parser.add_argument("--limit", type=int, default=10_000, help="newest N runs (default 10000)")
    parser.add_argument("-o", "--out", metavar="CHART.png", type=Path, help="control chart PNG")
    add_database_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def _ci(value, ci, digits=2) -> str:
    if value is None:
        return "not stated"
    return f"{value:.{digits}f} [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]" if ci else \
        f"{value:.{digits}f}"


def run(args) -> int:
    from sqlalchemy.exc import SQLAlchemyError

    from hil.errors import InputError
    from hil.results.cli_options import database_error, engine_from_args
    from hil.results.queries import trend

    if args.point is not None and args.source is None:
        raise InputError("--point needs --source")
    if args.limit < 1:
        raise InputError(f"--limit {args.limit} must be >= 1")
    try:
        result = trend(engine_from_args(args), requirement=args.requirement, source=args.source,
                       point=args.point, limit=args.limit)
    except SQLAlchemyError as exc:
        raise database_error(exc, args) from None
    if args.out is not None:
        from hil.results.plots import control_chart_plot

        control_chart_plot(result, args.out)
        result["plot"] = str(args.out)
    if args.json:
        print(json.dumps(result))
        return 0
    chart, cap, yld = result["control_chart"], result["capability"], result["measured_yield"]
    unit = result["unit"]
    print(f"{result['what']}: {len(result['observations'])} run(s), limits "
          f"[{result['lower_limit']}, {result['upper_limit']}] {unit}")
    if result.get("runs_at_other_points"):
        print(f"left out: {result['runs_at_other_points']} run(s) that measured this test at "
              f"another operating point, injection or motor (another prediction and zone)")
    if not chart["stated"]:
        print(f"control chart: centre {chart['centre']:.4g} {unit}; limits NOT STATED: "
              f"{chart['reason']}")
    elif chart["sigma_short"] is not None:
        lcl = "none" if chart["lcl"] is None else f"{chart['lcl']:.4g}"
        print(f"control chart: centre {chart['centre']:.4g}, limits [{lcl}, "
              f"{chart['ucl']:.4g}] {unit} (σ̂ = MR̄/1.128 = {chart['sigma_short']:.3g}); "
              f"{len(chart['beyond'])} run(s) beyond")
        if chart["lcl_note"]:
            print(f"  {chart['lcl_note']}")
    s_text = cap['s'] if cap['s'] is None else format(cap['s'], '.3g')
    if cap["stated"]:
        print(f"mean {cap['mean']:.4g}, s {s_text}; Cp {_ci(cap['cp'], cap['cp_ci'])}; Cpk "
              f"{_ci(cap['cpk'], cap['cpk_ci'])} (95 %; {cap['method']})")
    else:
        print(f"mean {cap['mean']:.4g}, s {s_text}; Cp/Cpk NOT STATED: {cap['reason']}")
    if yld["total"]:
        print(f"measured yield {yld['passed']}/{yld['total']} = {100 * yld['yield']:.1f} % "
              f"[{100 * yld['ci'][0]:.1f}, {100 * yld['ci'][1]:.1f}] % (95 %, Clopper-Pearson)")
    if args.out is not None:
        print(f"chart: {args.out}")
    return 0
