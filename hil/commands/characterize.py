"""``hil characterize``: measure the bench's motor and current loop (the stage ``hil run`` starts
with), print them beside the bench file, and optionally write the user's own twin.

Opens the bench (the shipped simulated bench by default), runs
:func:`hil.characterisation.stage.characterise` into a record of its own (``--record-dir``,
the raw captures kept), prints stated vs measured with U (k = 2) and the method of each, and with
``--write-twin FILE.toml`` writes a simulated bench file of *this* drive
(``hil.characterisation.twin``): the bench file as stated (the nameplate and documented loop the
drive was configured from), the measured R, L, Ke and loop bandwidth as its
``[simulation.actual]`` physics (each U in a comment), no instrument addresses,
``simulated = true``. ``hil run --bench FILE`` then runs the same plans on that twin;
``hil compare BENCH_RUN TWIN_RUN`` says whether it reproduces the bench within U.
"""

from __future__ import annotations

import json
from pathlib import Path


from hil.commands import description

def register(subparsers) -> None:
    parser = subparsers.add_parser("characterize", help="measure the motor and current loop on "
                                   "the bench (stated vs measured, with U); write its twin",
                                   description=description(__doc__))
    parser.add_argument("--bench", metavar="FILE", help="bench file (default: simulated bench)")
    parser.add_argument("--record-dir", metavar="DIR", type=Path, default=Path("records"),
                        help="folder in which the characterisation's record is created")
    parser.add_argument("--seed", type=int, default=0, help="simulated bench seed")
    parser.add_argument("--write-twin", metavar="FILE.toml", type=Path,
                        help="write a simulated bench file of the drive as measured")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(func=run)


def run(args) -> int:
    from hil.bench import Bench
    from hil.characterisation.stage import SECTION, characterise
    from hil.config import default_sim_bench, load_bench
    from hil.record import RunRecord

    config = load_bench(args.bench) if args.bench else default_sim_bench()
    bench = Bench.open(config, seed=args.seed)
    try:
        record = RunRecord.create(args.record_dir, config, bench.identities(),
                                  sections={"run": {"command": "hil characterize"}})
        try:
            result = characterise(bench, record)
            record.set_section(SECTION, result.to_dict(config))
        except BaseException:
            record.finish("failed")
            raise
        record.finish("complete")
    finally:
        bench.close()
    out = result.to_dict(config) | {"record": str(record.path)}
    if args.write_twin:
        from hil.characterisation.twin import twin_text

        args.write_twin.write_text(twin_text(config, result))
        out["twin"] = str(args.write_twin)
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"characterisation of {config.source} (record {record.path}):")
    for row in out["stated_vs_measured"]:
        flag = "DISAGREES" if row["disagrees"] else "agrees"
        print(f"  {row['name']:28s} stated {row['stated']:.6g}  measured {row['measured']:.6g}"
              f" ± {row['U_k2']:.2g} {row['unit']} (k = 2): {flag}; predictions use "
              f"{row['predictions_use']}")
    for key, why in result.not_identified.items():
        print(f"  {key}: not identified ({why})")
    if args.write_twin:
        print(f"twin written: {args.write_twin} (hil run --bench {args.write_twin})")
    return 0
