"""hil analyze CAPTURE: ripple metrics, top orders and uncertainty budget of one capture.

CAPTURE is a ripple-hil ``.npz`` capture, or — with ``--time-col``, ``--torque-col`` and
``--angle-col`` or ``--speed-col`` (and their units) — a CSV or ``.npz`` export of another DAQ, or
an ASAM MDF4 or NI TDMS measurement file, whose units come from the file and whose columns, when
no option names them, are found by their usual names (read by ``hil.capture_import``).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from hil.analysis import (DEFAULT_MAX_ORDER, PK_PK_METHODS, InstrumentUncertainty, RippleResult,
                          analyze_capture)
import zipfile
from pathlib import Path

from hil.capture import Capture
from hil.capture_import import (ANGLE_KINDS, ANGLE_UNITS, SPEED_UNITS, TIME_UNITS, TORQUE_UNITS,
                                import_capture, import_with_defaults, is_measurement_file)
from hil.errors import InputError

#: Options that select the columns of a foreign capture (any of them switches to importing).
COLUMN_OPTIONS = ("time_col", "torque_col", "angle_col", "speed_col")


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "analyze", help="torque-ripple metrics of a capture file",
        description="Resample the torque onto the electrical angle, synchronously average whole "
                    "revolutions and print mean, pk-pk, RMS, order spectrum and the uncertainty "
                    "budget (k = 2).")
    parser.add_argument("capture", metavar="CAPTURE",
                        help="capture file: a ripple-hil .npz, an MDF4 (.mf4) or TDMS file, or "
                             "with --time-col etc. a CSV or .npz export of another DAQ")
    parser.add_argument("--order", type=int, default=None, metavar="K",
                        help="electrical order to report by name (e.g. 6 for dead time)")
    parser.add_argument("--max-order", type=int, default=DEFAULT_MAX_ORDER, metavar="K",
                        help=f"highest electrical order analysed (default {DEFAULT_MAX_ORDER})")
    parser.add_argument("--pk-pk-method", choices=PK_PK_METHODS, default=PK_PK_METHODS[0],
                        help="pk-pk of the Fourier series up to --max-order (default) or of the "
                             "raw angle bins (for step-shaped ripple, with a large --max-order)")
    parser.add_argument("--top", type=int, default=5, metavar="N",
                        help="number of largest orders listed (default 5)")
    parser.add_argument("--rated-torque-nm", type=float, default=None, metavar="NM",
                        help="rated torque for pk-pk per unit of rated")
    parser.add_argument("--pole-pairs", type=int, default=None,
                        help="override the capture's meta pole_pairs")
    parser.add_argument("--transducer-class-pct", type=float, default=0.0, metavar="PCT",
                        help="torque transducer accuracy class, %% of full scale")
    parser.add_argument("--transducer-full-scale-nm", type=float, default=0.0, metavar="NM",
                        help="torque transducer full scale, N*m")
    parser.add_argument("--daq-lsb-nm", type=float, default=None, metavar="NM",
                        help="DAQ resolution: one LSB in N*m")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    other = parser.add_argument_group(
        "captures from other DAQs (CSV with a header row, or .npz of named arrays)")
    other.add_argument("--time-col", metavar="NAME", help="column of the sample times")
    other.add_argument("--torque-col", metavar="NAME", help="column of the shaft torque")
    other.add_argument("--angle-col", metavar="NAME", help="column of the rotor angle")
    other.add_argument("--speed-col", metavar="NAME",
                       help="column of the shaft speed (instead of an angle)")
    other.add_argument("--time-unit", choices=tuple(TIME_UNITS), default=None,
                       help="unit of the time column (default: the file's, else s)")
    other.add_argument("--torque-unit", choices=tuple(TORQUE_UNITS), default=None,
                       help="unit of the torque column (default: the file's, else nm = N*m)")
    other.add_argument("--angle-unit", choices=tuple(ANGLE_UNITS), default=None,
                       help="unit of the angle column (default: the file's, else rad)")
    other.add_argument("--angle-kind", choices=ANGLE_KINDS, default="mech",
                       help="mechanical (default) or electrical angle (divided by --pole-pairs)")
    other.add_argument("--speed-unit", choices=tuple(SPEED_UNITS), default=None,
                       help="unit of the speed column (default: the file's, else rpm)")
    parser.set_defaults(func=run)


def check_options(args: argparse.Namespace) -> None:
    """One-line errors for option values argparse's types let through."""
    if args.max_order < 1:
        raise InputError(f"--max-order {args.max_order} must be at least 1")
    if args.order is not None and not 1 <= args.order <= args.max_order:
        raise InputError(f"--order {args.order} is outside 1..{args.max_order} (--max-order)")
    if args.top < 1:
        raise InputError(f"--top {args.top} must be at least 1 (the number of orders listed)")
    for flag, value, allow_zero in (("--rated-torque-nm", args.rated_torque_nm, False),
                                    ("--daq-lsb-nm", args.daq_lsb_nm, False),
                                    ("--transducer-class-pct", args.transducer_class_pct, True),
                                    ("--transducer-full-scale-nm", args.transducer_full_scale_nm,
                                     True)):
        if value is not None and not (math.isfinite(value)
                                      and (value >= 0 if allow_zero else value > 0)):
            raise InputError(f"{flag} {value:g} must be a finite number "
                             f"{'>= 0' if allow_zero else '> 0'}")


def load_capture(args: argparse.Namespace) -> Capture:
    """The capture named on the command line: imported by columns, or a ripple-hil capture."""
    path = Path(args.capture)
    if any(getattr(args, name) is not None for name in COLUMN_OPTIONS):
        if args.time_col is None or args.torque_col is None:
            raise InputError("a capture from another DAQ needs --time-col and --torque-col, and "
                             "--angle-col or --speed-col")
        return import_capture(path, time_col=args.time_col, torque_col=args.torque_col,
                              angle_col=args.angle_col, speed_col=args.speed_col,
                              time_unit=args.time_unit, torque_unit=args.torque_unit,
                              angle_unit=args.angle_unit, speed_unit=args.speed_unit,
                              angle_kind=args.angle_kind, pole_pairs=args.pole_pairs)
    if is_measurement_file(path):
        return import_with_defaults(path, pole_pairs=args.pole_pairs)
    hint = ("for a CSV or another DAQ's .npz give --time-col, --torque-col and --angle-col or "
            "--speed-col")
    if path.is_dir():
        raise InputError(f"{str(path)!r} is a directory, not a capture file")
    if not path.is_file():
        raise InputError(f"capture file {str(path)!r} does not exist")
    if not zipfile.is_zipfile(path):
        raise InputError(f"{str(path)!r} is not a ripple-hil .npz capture (not a zip archive); "
                         f"{hint}")
    with zipfile.ZipFile(path) as archive:
        if "__header__.npy" not in archive.namelist():
            raise InputError(f"{str(path)!r} is an .npz without a ripple-hil header; {hint}")
    return Capture.load(path)


def run(args: argparse.Namespace) -> int:
    check_options(args)
    instruments = InstrumentUncertainty(
        transducer_accuracy_class_pct=args.transducer_class_pct,
        transducer_full_scale_nm=args.transducer_full_scale_nm, daq_lsb_nm=args.daq_lsb_nm)
    result = analyze_capture(load_capture(args), max_order=args.max_order,
                             named_order=args.order, rated_torque_nm=args.rated_torque_nm,
                             instruments=instruments, pole_pairs=args.pole_pairs,
                             pk_pk_method=args.pk_pk_method)
    top = min(args.top, result.max_order)
    if args.json:
        data = result.to_dict(top=top)
        data["capture"] = str(args.capture)
        print(json.dumps(data, allow_nan=False))
    else:
        print(format_result(result, top))
    return 0


def format_result(result: RippleResult, top: int = 5) -> str:
    """Human-readable metrics, largest orders and uncertainty budget."""
    u = result.uncertainty
    lines = [
        f"revolutions used     {result.revolutions} electrical "
        f"({result.samples_per_rev} angle bins each, orders 1..{result.max_order}, "
        f"pk-pk {result.pk_pk_method})",
        f"mean torque          {result.mean_torque_nm:.6g} N*m",
        f"pk-pk (sync average) {result.pk_pk_nm:.6g} N*m = {_pu(result.pk_pk_pu)} of mean "
        f"(U = {_pu(u.expanded_pu)}, k = {u.coverage_factor:g})",
    ]
    if result.pk_pk_rated_pu is not None:
        lines.append(f"pk-pk of rated       {_pu(result.pk_pk_rated_pu)} of "
                     f"{result.rated_torque_nm:g} N*m")
    lines += [f"RMS of AC part       {result.rms_ac_nm:.6g} N*m",
              f"dominant order       {result.dominant_order}"]
    if result.named_order is not None:
        lines.append(f"order {result.named_order:<14} {result.named_amplitude_nm:.6g} N*m at "
                     f"{np.rad2deg(result.named_phase_rad):.2f} deg")
    lines += ["", f"{'order':>5} {'amplitude N*m':>14} {'u(A) N*m':>10} {'phase deg':>10} "
                  f"{'AC power':>9}"]
    for row in result.top_orders(top):
        lines.append(f"{row['order']:>5} {row['amplitude_nm']:>14.6g} "
                     f"{row['amplitude_u_nm']:>10.3g} {np.rad2deg(row['phase_rad']):>10.2f} "
                     f"{row['power_share']:>9.1%}")
    lines += ["", "uncertainty budget of pk-pk per unit of mean:", u.format_table()]
    return "\n".join(lines)


def _pu(value: float) -> str:
    return "n/a" if not math.isfinite(value) else f"{value:.4g} pu ({100 * value:.3g} %)"
