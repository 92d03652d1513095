"""hil predict SOURCE: the paper's closed-form ripple prediction for one source (or a derived form).

Options are in the units engineers use (deg, %, µs, bits, rpm, A), the unit in the name; they are
converted to the SI keyword arguments of ``hil.model.predict``. Every keyword a source accepts has
an option, so no error names a Python keyword.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import re
from dataclasses import dataclass
from typing import Any, Callable

from hil.current_loop import LOOP_DESIGNS
from hil.errors import InputError
from hil.model import OperatingPoint, Prediction, SOURCES, predict
from hil.model.core import check_range
from hil.model.encoder import current_angle_for_ripple, encoder_resolution_elec_rad


@dataclass(frozen=True)
class SourceOption:
    """One CLI option: its flag, the model keyword, the conversion to SI and the allowed range."""

    flag: str
    param: str
    sources: tuple[str, ...]
    help: str
    to_si: Callable[[float], Any] = float
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    kind: Any = float
    choices: tuple[str, ...] | None = None


def _pct(value: float) -> float:
    return value / 100.0


SOURCE_OPTIONS: tuple[SourceOption, ...] = (
    SourceOption("--resolution-deg", "resolution_elec_rad", ("encoder",),
                 "angle resolution, electrical degrees per count", math.radians, 0.0, 180.0, True),
    SourceOption("--encoder-decimation", "encoder_decimation", ("encoder",),
                 "firmware uses every N-th count of the encoder", int, 1, 1800, kind=int),
    SourceOption("--encoder-counts-per-rev", "encoder_counts_per_rev", ("encoder",),
                 "encoder counts per mechanical revolution (default 7200)", int, 1, 1e9, kind=int),
    SourceOption("--word-length-bits", "word_length_bits", ("word_length",),
                 "controller fixed-point word length n", int, 6, 32, kind=int),
    SourceOption("--full-scale-current-a", "full_scale_current_a", ("word_length",),
                 "Q-format full-scale current I_max (default 100 A)", float, 0.0, 1e4, True),
    SourceOption("--ia-offset-a", "ia_offset_a", ("dc_offset",), "phase-a sensor offset, A",
                 float, -20.0, 20.0),
    SourceOption("--ib-offset-a", "ib_offset_a", ("dc_offset",), "phase-b sensor offset, A",
                 float, -20.0, 20.0),
    SourceOption("--offset-a-pct", "offset_a_pu", ("dc_offset",),
                 "phase-a sensor offset, % of the current amplitude", _pct, -100.0, 100.0),
    SourceOption("--offset-b-pct", "offset_b_pu", ("dc_offset",),
                 "phase-b sensor offset, % of the current amplitude", _pct, -100.0, 100.0),
    SourceOption("--ia-gain-error-pct", "ia_gain_error_pu", ("gain_mismatch",),
                 "phase-a sensor gain error, % of the nominal gain", _pct, -20.0, 20.0),
    SourceOption("--ib-gain-error-pct", "ib_gain_error_pu", ("gain_mismatch",),
                 "phase-b sensor gain error, % of the nominal gain", _pct, -20.0, 20.0),
    SourceOption("--pwm-bits", "pwm_bits", ("pwm_resolution",),
                 "pulse-width register bits n (the paper's 1/2^(n-1))", int, 4, 17, kind=int),
    SourceOption("--pwm-period-counts", "pwm_period_counts", ("pwm_resolution",),
                 "PWM counter top value (counts per half period)", int, 8, 65535, kind=int),
    SourceOption("--voltage-step-basis", "voltage_step_basis", ("pwm_resolution",),
                 "ΔV relative to the operating voltage (paper) or from the dc bus",
                 str, kind=str, choices=("paper", "dc_bus")),
    SourceOption("--pwm-frequency-hz", "pwm_frequency_hz",
                 ("pwm_switching", "dead_time", "pwm_resolution", "word_length"),
                 "PWM switching frequency (default 20000)", float, 2000.0, 50000.0),
    SourceOption("--dead-time-us", "dead_time_s", ("dead_time",), "inverter dead time, µs",
                 lambda us: us * 1e-6, 0.0, 10.0),
    SourceOption("--nominal-current-a", "nominal_current_a", ("dead_time",),
                 "nominal current of eq 38 (default: --current-a)", float, 0.0, 100.0, True),
    SourceOption("--current-loop-bandwidth-hz", "current_loop_bandwidth_hz",
                 ("dead_time", "pwm_resolution", "word_length"),
                 "current-loop bandwidth (ω_c/2π; α_c/2π of a 2dof loop) for "
                 "model=average_voltage, current_clamping or closed_loop "
                 "(dead_time, pwm_resolution) or derived (word_length)", float, 0.0,
                 25000.0, True),
    SourceOption("--current-loop-delay-us", "current_loop_delay_s",
                 ("dead_time", "pwm_resolution", "word_length"),
                 "current-loop delay for model=average_voltage or derived, µs (the simulated "
                 "drive: 75, i.e. 1.5 PWM periods)", lambda us: us * 1e-6, 0.0, 1000.0),
    SourceOption("--current-loop-design", "current_loop_design", ("dead_time",),
                 "the current loop's design (hil.current_loop): continuous PI (default), "
                 "discrete (pole-matched PI) or 2dof (complex-vector 2-DOF PI)", str, kind=str,
                 choices=LOOP_DESIGNS),
    SourceOption("--current-loop-angle-compensation", "current_loop_angle_compensation",
                 ("dead_time",), "the voltage applied at the angle advanced by ω_e × the loop "
                 "delay: on or off (default)", lambda value: value == "on", kind=str,
                 choices=("on", "off")),
    SourceOption("--adc-bits", "adc_bits", ("word_length",),
                 "current ADC resolution for model=derived (default 12)", int, 6, 24, kind=int),
    SourceOption("--trig-values", "trig_values", ("word_length",),
                 "model=derived: sines of phases b, c by identities from a sin/cos table "
                 "(default) or a table entry per phase", str, kind=str,
                 choices=("identities", "tables")),
    SourceOption("--revolutions-averaged", "revolutions_averaged", ("pwm_resolution",),
                 "model=derived: whole revolutions the capture's synchronous average spans "
                 "(default 8, a hil run point)", int, 1, 1000, kind=int),
    SourceOption("--max-order", "max_order", ("word_length", "pwm_resolution"),
                 "model=derived: highest electrical order the analysis keeps (default 64)", int,
                 1, 10000, kind=int),
    SourceOption("--modulation", "modulation", ("pwm_switching", "pwm_resolution"),
                 "svpwm (default, the drive's) or sine, for model=switched_torque "
                 "(pwm_switching) or derived (pwm_resolution)", str, kind=str,
                 choices=("svpwm", "sine")),
    SourceOption("--current-adc-step-a", "current_adc_step_a", ("pwm_switching",),
                 "the drive's current-ADC step, A (with --loop-gain-per-period: the range's top "
                 "adds what the ADC can add; default: an ideal ADC)", float, 0.0, 10.0),
    SourceOption("--loop-gain-per-period", "loop_gain_per_period", ("pwm_switching",),
                 "the current loop's proportional gain per PWM period K_p·T_s/L (ω_c·T_s for "
                 "the continuous PI)", float, 0.0, 2.0),
    SourceOption("--model", "model",
                 ("pwm_switching", "dead_time", "pwm_resolution", "word_length"),
                 "paper (default) or a physically derived form: switched_torque "
                 "(pwm_switching), average_voltage or current_clamping (dead_time), "
                 "closed_loop or derived (pwm_resolution), derived (word_length)",
                 str, kind=str, choices=("paper", "switched_torque", "average_voltage",
                                         "current_clamping", "closed_loop", "derived")),
    SourceOption("--transducer-bandwidth-hz", "transducer_bandwidth_hz",
                 ("dead_time", "word_length"),
                 "model=current_clamping (dead_time) or derived (word_length): the torque "
                 "transducer's stated first-order bandwidth "
                 "(default: air-gap torque, no transducer)", float, 0.0, 1e6, True),
)


def add_operating_point_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--speed-rpm", type=float, default=1000.0, help="dyno speed (default 1000)")
    parser.add_argument("--current-a", type=float, default=20.0,
                        help="peak phase-current amplitude (default 20 A)")
    parser.add_argument("--current-angle-deg", type=float, default=None,
                        help="lag of the current behind the EMF, electrical degrees (default 0)")
    parser.add_argument("--dc-bus-v", type=float, default=None, help="dc bus (default 12 V)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def add_source_options(parser: argparse.ArgumentParser) -> None:
    for option in SOURCE_OPTIONS:
        extra: dict[str, Any] = ({"choices": option.choices} if option.choices else
                                 {"metavar": option.flag.rsplit("-", 1)[-1].upper()})
        parser.add_argument(option.flag, dest=option.param, type=option.kind, default=None,
                            help=f"[{', '.join(option.sources)}] {option.help}".replace("%", "%%"),
                            **extra)
    parser.add_argument("--hall-mode", action="store_true", default=None,
                        help="[encoder] 60° electrical Hall sectors")


def option_unit(option: SourceOption) -> str:
    """The unit at the end of an option's name, for error messages (" deg", " %", " µs", ...)."""
    suffix = option.flag.rsplit("-", 1)[-1]
    return " " + {"pct": "%", "us": "µs", "a": "A", "hz": "Hz", "rev": "counts/rev"}.get(suffix, suffix)


#: Largest current angle a per-unit prediction is given at (cos 85° = 0.087: the mean torque is
#: still 9 % of its φ = 0 value; nearer 90° a per-unit figure explodes).
MAX_CURRENT_ANGLE_DEG = 85.0


def operating_point(args: argparse.Namespace) -> OperatingPoint:
    check_range("--speed-rpm", args.speed_rpm, -3000.0, 3000.0, unit=" rpm")
    check_range("--current-a", args.current_a, 0.0, 100.0, unit=" A", low_open=True)
    angle_deg = 0.0 if args.current_angle_deg is None else args.current_angle_deg
    check_range("--current-angle-deg", angle_deg, -90.0, 90.0, unit=" deg")
    if abs(angle_deg) > MAX_CURRENT_ANGLE_DEG:
        # a ripple per unit of the mean torque K_t·I·cos φ is undefined where cos φ → 0
        raise InputError(f"--current-angle-deg {angle_deg:g}: the mean torque K_t·I·cos φ is "
                         f"(nearly) zero, so a ripple per unit of it is undefined; allowed "
                         f"|φ| <= {MAX_CURRENT_ANGLE_DEG:g} deg")
    if args.dc_bus_v is not None:
        check_range("--dc-bus-v", args.dc_bus_v, 0.0, 1000.0, unit=" V", low_open=True)
    try:
        return OperatingPoint(args.speed_rpm, args.current_a, math.radians(angle_deg),
                              dc_bus_v=args.dc_bus_v)
    except InputError as error:
        raise in_option_names(error) from None


def source_params(args: argparse.Namespace, source: str) -> dict[str, Any]:
    """Given options converted to SI keywords for ``source``; options of other sources refused."""
    params: dict[str, Any] = {}
    if getattr(args, "hall_mode", None):
        if source != "encoder":
            raise InputError(f"--hall-mode does not apply to source {source} (allowed for: encoder)")
        params["hall_mode"] = True
    for option in SOURCE_OPTIONS:
        value = getattr(args, option.param, None)
        if value is None:
            continue
        if source not in option.sources:
            raise InputError(f"{option.flag} does not apply to source {source} "
                             f"(allowed for: {', '.join(option.sources)})")
        if option.choices is None:
            check_range(option.flag, value, option.low, option.high, low_open=option.low_open,
                        unit=option_unit(option))
        params[option.param] = option.to_si(value)
    return params


def format_prediction(pred: Prediction) -> str:
    order = "broadband" if pred.order is None else f"{pred.order:g} (electrical)"
    lines = [f"{pred.source}: {100 * pred.pk_pk_pu:.4g} % pk-pk ({pred.pk_pk_nm:.4g} N·m)",
             f"  base: {pred.base} = {pred.base_nm:.4g} N·m",
             f"  order: {order}; {pred.equations}"]
    low, high = pred.expected_range_pu or (None, None)
    if low != high:
        lines.append(f"  expected range: {100 * low:.4g} … {100 * high:.4g} % (what the model "
                     "states it cannot resolve; see assumes)")
    lines += [f"  {key} = {value:.6g}" if isinstance(value, float) else f"  {key} = {value}"
              for key, value in pred.inputs.items() if value is not None]
    lines += [f"  assumes: {text}" for text in pred.assumptions]
    return "\n".join(lines)


#: Keyword names of the model that are not source options, and the CLI options that set them.
OTHER_NAMES = {"speed_rpm": "--speed-rpm", "current_a": "--current-a", "dc_bus_v": "--dc-bus-v",
               "current_angle_rad": "--current-angle-deg", "hall_mode": "--hall-mode",
               "target_pu": "--target-pct"}


def in_option_names(error: InputError) -> InputError:
    """The same error with the model's keyword names replaced by the CLI options that set them."""
    message = str(error)
    names = {option.param: option.flag for option in SOURCE_OPTIONS} | OTHER_NAMES
    for name, flag in names.items():
        message = re.sub(rf"(?<![\w-]){name}(?![\w-])", flag, message)
    return InputError(message)


def encoder_target(args: argparse.Namespace, op: OperatingPoint,
                   params: dict[str, Any]) -> float | None:
    """With ``--target-pct``: the current angle φ (rad, lagging) giving that encoder ripple."""
    target = getattr(args, "target_pct", None)
    if target is None:
        return None
    if args.source != "encoder":
        raise InputError(f"--target-pct does not apply to source {args.source} "
                         "(allowed for: encoder)")
    if args.current_angle_deg is not None:
        raise InputError("--target-pct finds the current angle: give it without "
                         "--current-angle-deg (allowed: one of them)")
    check_range("--target-pct", target, 0.0, 1e6, unit=" %", low_open=True)
    resolution = encoder_resolution_elec_rad(pole_pairs=op.motor.pole_pairs, **params)
    return current_angle_for_ripple(resolution, target / 100.0)


def run(args: argparse.Namespace) -> int:
    op = operating_point(args)
    try:
        params = source_params(args, args.source)
        angle = encoder_target(args, op, params)
        if angle is not None:
            op = dataclasses.replace(op, current_angle_rad=angle)
        pred = predict(args.source, op, **params)
    except InputError as error:
        raise in_option_names(error) from None
    if args.json:
        data = pred.to_dict()
        if not args.waveform:
            data.pop("angle_rad")
            data.pop("waveform_pu")
        if angle is not None:
            data["target"] = {"pk_pk_pct": args.target_pct, "current_angle_deg":
                              math.degrees(angle), "branch": "lagging"}
        print(json.dumps(data))
    else:
        if angle is not None:
            print(f"current angle for {args.target_pct:g} % pk-pk: {math.degrees(angle):.4g}° "
                  "electrical, lagging the EMF")
        print(format_prediction(pred))
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("predict", help="closed-form ripple prediction of one source",
                                   description=__doc__.split("\n\n")[0])
    parser.add_argument("source", metavar="SOURCE", choices=list(SOURCES),
                        help=f"one of: {', '.join(SOURCES)}")
    add_operating_point_options(parser)
    add_source_options(parser)
    parser.add_argument("--waveform", action="store_true",
                        help="with --json: include angle_rad and waveform_pu (3600 points)")
    parser.add_argument("--target-pct", type=float, default=None, metavar="PCT",
                        help="[encoder] find the current angle (lagging the EMF) whose ripple "
                             "is PCT %% of the mean torque, and predict there")
    parser.set_defaults(func=run)
