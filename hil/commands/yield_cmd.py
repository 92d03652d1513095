"""``hil yield TOLERANCES.toml``: Monte Carlo yield of a ripple requirement over tolerances.

Prints the yield with its 95 % confidence interval (Clopper–Pearson), the ripple quantiles the
sample supports (hil/tolerance/stats.py states the rule) and the Sobol' ranking of the
tolerances; writes ``yield.json``, ``histogram.png``/``.svg`` and the resumable campaign
chunks to ``--out``. ``--target-yield 99`` adds the inverse design: the loosest tolerances
(cost ∝ 1/tolerance) that reach 99 % (hil/tolerance/design.py states the algorithm).
"""

from __future__ import annotations

from hil.commands import description

import argparse
import dataclasses
import json
import math
import sys

from hil.errors import InputError

#: The yield engines (hil/tolerance/engines.py's ``ENGINES``; spelled here so that ``hil yield
#: --help`` imports no engine — a test checks the two agree).
ENGINES = ("closed-form", "twin")


def _weights(items: list[str] | None) -> dict[str, float]:
    weights = {}
    for item in items or []:
        name, _, value = item.partition("=")
        try:
            weights[name] = float(value)
        except ValueError:
            raise InputError(f"--cost-weight {item!r} must be NAME=NUMBER") from None
        if not weights[name] > 0 or not math.isfinite(weights[name]):
            raise InputError(f"--cost-weight {item!r}: the weight must be > 0")
    return weights


def requirement_from_file(args: argparse.Namespace):
    """The ``--requirements`` line to judge: ``--requirement-id``, else the file's only
    ``pk_pk_pct`` line with a max."""
    if args.requirements is None:
        if args.requirement_id is not None:
            raise InputError("--requirement-id needs --requirements FILE")
        return None
    if args.limit_pct is not None:
        raise InputError("give --requirements or --limit-pct, not both")
    from hil.requirements import load_requirements
    from hil.tolerance.spec import yield_requirement

    lines = load_requirements(args.requirements)
    if args.requirement_id is not None:
        chosen = [r for r in lines if r.id == args.requirement_id]
        if not chosen:
            raise InputError(f"--requirement-id {args.requirement_id!r} is not in "
                             f"{args.requirements} (ids: {', '.join(r.id for r in lines)})")
    else:
        chosen = [r for r in lines if r.quantity == "pk_pk_pct" and r.limit_max is not None]
        if len(chosen) != 1:
            raise InputError(f"{args.requirements} has {len(chosen)} pk_pk_pct lines with a max: "
                             "name one with --requirement-id")
    return yield_requirement(chosen[0], f"{args.requirements}: requirement {chosen[0].id!r}")


def run(args: argparse.Namespace) -> int:
    from hil.campaign import CampaignInterrupted, TwinSettings
    from hil.tolerance.combiner import CombinerSettings
    from hil.tolerance.design import inverse_design
    from hil.tolerance.run import YieldOptions, run_yield
    from hil.tolerance.spec import DRIVES_RANGE, load_tolerances

    spec = load_tolerances(args.tolerances).with_requirement(args.limit_pct,
                                                             requirement_from_file(args))
    changes = {}
    if args.drives is not None:
        if not DRIVES_RANGE[0] <= args.drives <= DRIVES_RANGE[1]:
            raise InputError(f"--drives {args.drives} must be in {DRIVES_RANGE[0]}..{DRIVES_RANGE[1]}")
        changes["drives"] = args.drives
    if args.seed is not None:
        if args.seed < 0:
            raise InputError(f"--seed {args.seed} must be >= 0")
        changes["seed"] = args.seed
    spec = dataclasses.replace(spec, **changes)
    from_db = _from_db(args, spec, CombinerSettings(bounds=not args.no_bounds)) \
        if args.from_db else None
    if from_db is not None:
        spec = from_db.pop("spec")
    for flag, value in (("--workers", args.workers), ("--chunk-size", args.chunk_size)):
        if value is not None and value < 1:
            raise InputError(f"{flag} {value} must be >= 1")
    if args.target_yield is not None and args.engine != "closed-form":
        raise InputError("--target-yield runs on the closed-form engine (--engine closed-form)")
    options = YieldOptions(engine=args.engine, scheduler=args.scheduler, n_workers=args.workers,
                           chunk_size=args.chunk_size,
                           sobol_n=args.sobol_n if args.sobol_n is not None
                           else (1024 if args.engine == "closed-form" else 32),
                           combiner=CombinerSettings(bounds=not args.no_bounds),
                           twin=TwinSettings(revolutions=args.revolutions),
                           progress=not args.no_progress and sys.stderr.isatty())
    try:
        summary = run_yield(spec, args.out, options)
    except CampaignInterrupted as stop:
        print(f"hil yield: {stop}", file=sys.stderr)
        raise
    if args.target_yield is not None:
        summary["inverse_design"] = inverse_design(spec, args.target_yield / 100.0,
                                                   weights=_weights(args.cost_weight),
                                                   settings=options.combiner)
        from hil.campaign.store import write_atomic
        from pathlib import Path
        write_atomic(Path(args.out) / "yield.json", json.dumps(summary, indent=2).encode())
    if from_db is not None:
        summary["from_db"] = from_db
    if args.json:
        print(json.dumps(summary))
    else:
        print("\n".join(format_summary(summary)))
        if from_db is not None:
            print("\n".join(format_from_db(from_db, summary)))
    return 0


def _from_db(args: argparse.Namespace, spec, settings: CombinerSettings) -> dict:
    """Tolerances fitted to the diagnosed units in the results database, the yield they predict
    with the fit's own uncertainty, and their measured yield (hil/results/fleet_yield.py and
    fleet_interval.py state the methods)."""
    from hil.results.cli_options import engine_from_args
    from hil.results.fleet_interval import predicted_yield
    from hil.results.fleet_yield import fit_parameters, fitted_spec, unit_yield

    engine = engine_from_args(args)
    fits = fit_parameters(engine)
    req_id = args.measured_requirement or (spec.requirement.id if spec.requirement else None)
    if req_id is None:
        from hil.errors import InputError

        raise InputError("--from-db needs a requirement id for the measured yield: "
                         "--measured-requirement ID")
    fitted = fitted_spec(spec, fits)
    return {"spec": fitted, "fits": fits,
            "predicted": predicted_yield(spec, fits, seed=spec.seed, settings=settings),
            "measured": unit_yield(engine, req_id)}


def format_from_db(d: dict, s: dict) -> list[str]:
    lines = ["tolerances fitted to the diagnosed units (σ: spread less the estimates' u):"]
    for name, f in d["fits"].items():
        lines.append(f"  {name:<14} {f['units']} units: mean {f['mean']:+.4g}, s {f['s']:.3g}, "
                     f"mean u {f['mean_u']:.3g} -> sigma {f['sigma']:.3g}")
    m = d["measured"]
    p = d["predicted"]
    low, high = (100 * x for x in p["interval95"])
    predicted = (f"{100 * p['yield']:.1f} % [{low:.1f}, {high:.1f}] % (95 % prediction "
                 f"interval with the fit's uncertainty from {p['units']} units; {p['method']})"
                 if p["stated"] else f"NOT STATED: {p['reason']}")
    point = f"{100 * s['yield']:.2f} % [{100 * s['yield_ci95'][0]:.2f}, " \
            f"{100 * s['yield_ci95'][1]:.2f}] % ({s['drives']:,} simulated drives; Monte " \
            f"Carlo error only: the fitted values taken as exact)"
    measured = (f"{100 * m['yield']:.1f} % [{100 * m['ci'][0]:.1f}, {100 * m['ci'][1]:.1f}] % "
                f"({m['passed']}/{m['total']} units, {m['requirement']})" if m["total"]
                else f"no unit judged against {m['requirement']}")
    return lines + [f"  predicted  {predicted}",
                    f"  at the fitted values  {point}",
                    f"  measured   {measured} (95 % Clopper-Pearson interval)"]


def _yield(value: float, ci: list[float], drives: int) -> str:
    from hil.tolerance.stats import format_yield

    return f"yield {format_yield(value, ci, drives)}"


def _quantile(label: str, entry: dict, interval: bool = True) -> str:
    """``q99 3.74 [3.62, 3.90]`` (%, with its 95 % interval) or why it is not stated."""
    if entry["value"] is None:
        return f"{label} not stated (needs >= {entry['needs_drives']:,} drives)"
    text = f"{label} {entry['value']:.3g}"
    if interval and entry.get("ci95"):
        text += f" [{entry['ci95'][0]:.3g}, {entry['ci95'][1]:.3g}]"
    return text


def format_summary(s: dict) -> list[str]:
    req = s["requirement"]
    n = s["drives"]
    lines = [f"hil yield: {s['engine']} engine, {n:,} drives, "
             f"{len(s['per_point'])} operating point(s), limit {req['limit']['max']:g} % pk-pk "
             f"({req['id']})",
             f"{_yield(s['yield'], s['yield_ci95'], n)}, {s['ci_method']}",
             "worst-point ripple, % of mean torque [95 % interval]: " + "; ".join(
                 _quantile(k, v) for k, v in s["worst_ripple_pct_quantiles"].items())]
    for p in s["per_point"]:
        q = p["ripple_pct_quantiles"]
        judged = _yield(p["yield"], p["yield_ci95"], n) if p["judged"] else "not judged"
        lines.append(f"  {p['speed_rpm']:g} rpm, {p['current_a']:g} A, "
                     f"φ {p['current_angle_deg']:g}°: {judged}; ripple %: "
                     f"{_quantile('median', q['q50'], False)}, {_quantile('q99', q['q99'], False)}")
    if s.get("bounds_added"):
        lines.append("  (word-length and PWM-resolution bounds added to every drive's pk-pk: "
                     "conservative; --no-bounds leaves them out)")
    sobol = s.get("sobol")
    if sobol and sobol["ranking"]:
        basis = sobol["ranked_by"].split()[-1]
        table = sobol["indices"][basis]
        lines.append(f"Sobol' ranking ({sobol['ranked_by']}, {sobol['evaluations']:,} evaluations):")
        for i, name in enumerate(sobol["ranking"], 1):
            row = table[name]
            lines.append(f"  {i}. {name:<24} S_T {row['ST']:.3f} ± {row['ST_conf']:.3f}   "
                         f"S_1 {row['S1']:.3f} ± {row['S1_conf']:.3f}")
        if sobol.get("unresolved"):
            lines.append("  order not resolved by this sample (95 % intervals of S_T overlap): "
                         + ", ".join(f"{a} ~ {b}" for a, b in sobol["unresolved"])
                         + " (a larger --sobol-n narrows the intervals)")
    design = s.get("inverse_design")
    if design:
        lines += format_design(design)
    c = s["campaign"]
    ran = (f"on {c['workers']} worker(s), {c['scheduler']}" if c["chunks_computed"]
           else "nothing left to compute")
    lines.append(f"{c['chunks']} chunks ({c['chunks_resumed']} resumed); {ran}; "
                 f"wall {c['wall_s']:.1f} s")
    figures = s.get("figures", {})
    lines.append(f"written: {c['folder']}/yield.json" + (
        f", {figures['png']}, {figures['svg']}" if figures else ""))
    return lines


def format_design(d: dict) -> list[str]:
    target = 100 * d["target_yield"]
    if not d["feasible"]:
        return [f"inverse design for {target:g} %: not reachable — {d['reason']}"]
    lines = [f"inverse design for {target:g} % (cost ∝ 1/tolerance; {d['algorithm']}):"]
    for name, p in d["parameters"].items():
        lines.append(f"  {name:<24} {p['spread_kind']} {p['file_spread']:.4g} -> "
                     f"{p['design_spread']:.4g}  (x{p['factor']:.3g})")
    check = d["check"]
    lines.append(f"  cost {d['cost']['file']:.3g} -> {d['cost']['design']:.3g}; check on "
                 f"{check['drives']:,} fresh drives: "
                 f"{_yield(check['yield'], check['yield_ci95'], check['drives'])}")
    alone = [f"{n} {a['spread_kind']} {a['spread']:.4g}" for n, a in d["alone"].items() if a]
    lines.append("  one tolerance alone reaching it: " + ("; ".join(alone) if alone else
                                                          "none (several must tighten)"))
    return lines


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("yield", help="Monte Carlo yield of a ripple limit over "
                                   "tolerances", description=description(__doc__))
    parser.add_argument("tolerances", help="tolerance file (TOML), e.g. "
                        "hil/examples/tolerances.toml")
    parser.add_argument("--engine", choices=ENGINES, default="closed-form")
    parser.add_argument("--drives", type=int, help="Monte Carlo drives (overrides the file)")
    parser.add_argument("--seed", type=int, help="campaign seed (overrides the file)")
    parser.add_argument("--limit-pct", type=float,
                        help="pk-pk limit, %% of the mean torque (overrides [requirement])")
    parser.add_argument("--requirements", metavar="FILE",
                        help="requirements file (hil run's format): judge one pk_pk_pct line")
    parser.add_argument("--requirement-id", metavar="ID",
                        help="which line of --requirements (default: its only pk_pk_pct line)")
    parser.add_argument("--out", default="yield-campaign",
                        help="campaign folder: chunks (resumable), yield.json, histograms")
    parser.add_argument("--scheduler", help="tcp://HOST:8786 of an existing Dask cluster, or "
                        "'inline' (this process); default: a LocalCluster on this machine")
    parser.add_argument("--workers", type=int, help="LocalCluster workers (default: cores)")
    parser.add_argument("--chunk-size", type=int, help="drives per chunk (default 50000 "
                        "closed-form, 64 twin)")
    parser.add_argument("--sobol-n", type=int,
                        help="Sobol' base samples, a power of 2: N·(D+2) evaluations "
                        "(default 1024 closed-form, 32 twin; 0: none)")
    parser.add_argument("--revolutions", type=int, default=2,
                        help="twin: electrical revolutions analysed per drive and point")
    parser.add_argument("--no-bounds", action="store_true",
                        help="closed-form: leave the word-length and PWM-resolution bounds out")
    parser.add_argument("--target-yield", type=float, metavar="PCT",
                        help="inverse design: loosest tolerances reaching this yield, %%")
    parser.add_argument("--cost-weight", action="append", metavar="NAME=W",
                        help="inverse design: cost weight of a tolerance (default 1 each)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--from-db", action="store_true",
                        help="fit offsets, gain mismatch and dead time to the diagnosed units in "
                             "the results database; print predicted beside measured yield")
    parser.add_argument("--measured-requirement", metavar="ID",
                        help="--from-db: requirement whose verdicts give the measured yield "
                             "(default: the tolerance file's requirement id)")
    from hil.results.cli_options import add_database_options

    add_database_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)
