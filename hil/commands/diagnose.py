"""``hil diagnose CAPTURE…``: which controller faults cause the measured ripple (issue 15).

Each capture's operating point comes from the run record it sits in (``<record>/captures/``), else
from its meta (simulated captures), else from ``--current-a``; the speed is measured from the
capture. The drive's current loop, the transducer's bandwidth and accuracy class come from the
record's bench (or ``--bench FILE``); options override them.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from hil.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "diagnose", help="attribute the measured ripple to its sources (offsets, gains, dead "
                         "time, encoder, motor) and suggest the calibration",
        description="Fit the forward models of every ripple source to the captures' order "
                    "spectra; print the attribution table, the calibration and what the captures "
                    "cannot separate.")
    parser.add_argument("captures", nargs="+", metavar="CAPTURE.npz",
                        help="capture files of the same drive (one or more operating points)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--bench", metavar="FILE", help="bench file (default: the record's bench)")
    parser.add_argument("--current-a", type=float, default=None, metavar="A",
                        help="peak phase current of captures whose operating point is not "
                             "recorded")
    parser.add_argument("--current-angle-deg", type=float, default=None, metavar="DEG",
                        help="current angle φ of such captures (default 0)")
    parser.add_argument("--loop-bandwidth-hz", type=float, default=None, metavar="HZ",
                        help="current-loop bandwidth (overrides the bench)")
    parser.add_argument("--loop-delay-s", type=float, default=None, metavar="S",
                        help="current-loop delay (overrides the bench)")
    parser.add_argument("--transducer-bandwidth-hz", type=float, default=None, metavar="HZ",
                        help="torque transducer's first-order bandwidth (overrides the bench)")
    parser.add_argument("--pwm-frequency-hz", type=float, default=None, metavar="HZ",
                        help="PWM frequency (default 20000)")
    parser.add_argument("--current-channel-u-a", type=float, default=None, metavar="A",
                        help="standard uncertainty of the DAQ current channels' dc; when given, "
                             "the captures' phase-current dc is fitted too (separates a sensor "
                             "offset from a torque fixed in the rotor angle)")
    parser.add_argument("--dead-time-bound-s", type=float, default=None, metavar="S",
                        help="upper bound of the inverter's effective dead time (drive data); "
                             "with a coarse encoder it sizes the offsets' dwell term (default: "
                             "the fitted nuisance dead time × 3, which reads low)")
    parser.add_argument("--max-mech-order", type=int, default=128, metavar="M",
                        help="highest mechanical order analysed (default 128)")
    parser.set_defaults(func=run)


def _bench_dict(args, records: list[dict | None]) -> dict:
    if args.bench:
        from hil.config import load_bench

        return load_bench(args.bench).to_dict()
    for record in records:
        if record and isinstance(record.get("bench"), dict) and record["bench"].get("loaded"):
            return record["bench"]["loaded"]
    from hil.config import default_sim_bench

    return {"motor": default_sim_bench().to_dict()["motor"]}


def run(args) -> int:
    from hil.capture import Capture
    from hil.diagnosis import diagnose, spectra_from_captures
    from hil.diagnosis.bench_setup import (check_setup_known, find_record, operating_point_of,
                                           setup_from_bench_dict)

    if not 8 <= args.max_mech_order <= 4096:
        raise InputError(f"--max-mech-order {args.max_mech_order} must be in 8..4096")
    pairs, records = [], []
    for name in args.captures:
        path = Path(name)
        capture = Capture.load(path)
        record = find_record(path)
        records.append(record)
        op = operating_point_of(path, capture, record)
        if "current_a" not in op:
            if args.current_a is None:
                raise InputError(f"{name}: no recorded operating point; give --current-a "
                                 "(peak phase current, A)")
            op["current_a"] = args.current_a
        if args.current_angle_deg is not None:
            op["current_angle_rad"] = math.radians(args.current_angle_deg)
        op.pop("speed_rpm", None)      # measured from the capture itself (signed)
        pairs.append((capture, op))
    _check_one_drive_state(args.captures, [c for c, _ in pairs])
    setup, class_pct = setup_from_bench_dict(
        _bench_dict(args, records), current_loop_bandwidth_hz=args.loop_bandwidth_hz,
        current_loop_delay_s=args.loop_delay_s,
        transducer_bandwidth_hz=args.transducer_bandwidth_hz,
        pwm_frequency_hz=args.pwm_frequency_hz, current_channel_u_a=args.current_channel_u_a,
        dead_time_bound_s=args.dead_time_bound_s)
    spectra = spectra_from_captures(pairs, max_mech_order=args.max_mech_order)
    result = diagnose(spectra, setup=setup, transducer_class_pct=class_pct)
    result.notes.extend(check_setup_known(setup))
    if args.json:
        json.dump(result.to_dict(), sys.stdout, indent=1, allow_nan=False)
        print()
    else:
        print(result.table())
        for note in result.notes:
            print(f"note: {note}")
    return 0


def _check_one_drive_state(names, captures) -> None:
    """A diagnosis is of one drive as it is: captures recorded with different injections are
    different drives to the fit (their shares and calibration would be meaningless)."""
    states = {json.dumps(c.meta.get("injection") or {}, sort_keys=True) for c in captures}
    if len(states) > 1:
        raise InputError(f"the {len(names)} captures were recorded with different injections "
                         f"({'; '.join(sorted(states))}); a diagnosis is of one drive state: "
                         "give captures with the same injection (hil run --source diagnosis "
                         "records such a set)")
