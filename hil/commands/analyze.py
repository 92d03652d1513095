"""``hil analyze CAPTURE.npz``: ripple metrics, top orders and uncertainty budget of one capture."""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from hil.analysis import (DEFAULT_MAX_ORDER, PK_PK_METHODS, InstrumentUncertainty, RippleResult,
                          analyze_capture)
from hil.capture import Capture
from hil.errors import InputError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "analyze", help="torque-ripple metrics of a capture file",
        description="Resample the torque onto the electrical angle, synchronously average whole "
                    "revolutions and print mean, pk-pk, RMS, order spectrum and the uncertainty "
                    "budget (k = 2).")
    parser.add_argument("capture", metavar="CAPTURE.npz", help="capture file (hil.capture format)")
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
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.order is not None and not 1 <= args.order <= args.max_order:
        raise InputError(f"--order {args.order} is outside 1..{args.max_order} (--max-order)")
    instruments = InstrumentUncertainty(
        transducer_accuracy_class_pct=args.transducer_class_pct,
        transducer_full_scale_nm=args.transducer_full_scale_nm, daq_lsb_nm=args.daq_lsb_nm)
    result = analyze_capture(Capture.load(args.capture), max_order=args.max_order,
                             named_order=args.order, rated_torque_nm=args.rated_torque_nm,
                             instruments=instruments, pole_pairs=args.pole_pairs,
                             pk_pk_method=args.pk_pk_method)
    top = max(1, min(args.top, result.max_order))
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
