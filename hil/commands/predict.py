"""``hil predict SOURCE``: the paper's closed-form ripple prediction for one source.

Options are in the units engineers use (deg, %, µs, bits, rpm, A), the unit in the name; they are
converted to the SI keyword arguments of ``hil.model.predict``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from dataclasses import dataclass
from typing import Any, Callable

from hil.errors import InputError
from hil.model import OperatingPoint, Prediction, SOURCES, predict
from hil.model.core import check_range


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
    SourceOption("--pwm-frequency-hz", "pwm_frequency_hz", ("pwm_switching", "dead_time"),
                 "PWM switching frequency", float, 2000.0, 50000.0),
    SourceOption("--dead-time-us", "dead_time_s", ("dead_time",), "inverter dead time, µs",
                 lambda us: us * 1e-6, 0.0, 10.0),
    SourceOption("--nominal-current-a", "nominal_current_a", ("dead_time",),
                 "nominal current of eq 38 (default: --current-a)", float, 0.0, 100.0, True),
    SourceOption("--current-loop-bandwidth-hz", "current_loop_bandwidth_hz",
                 ("dead_time", "pwm_resolution"),
                 "PI current-loop bandwidth for model=average_voltage or closed_loop", float, 0.0,
                 25000.0, True),
    SourceOption("--current-loop-delay-us", "current_loop_delay_s", ("dead_time",),
                 "current-loop delay for model=average_voltage, µs (the drive: 1.5 PWM periods)",
                 lambda us: us * 1e-6, 0.0, 1000.0),
    SourceOption("--modulation", "modulation", ("pwm_switching",),
                 "svpwm (default, the drive's) or sine, for model=switched_torque", str, kind=str,
                 choices=("svpwm", "sine")),
    SourceOption("--model", "model", ("pwm_switching", "dead_time", "pwm_resolution"),
                 "paper (default) or a physically derived form: switched_torque "
                 "(pwm_switching), average_voltage (dead_time), closed_loop (pwm_resolution)",
                 str, kind=str, choices=("paper", "switched_torque", "average_voltage",
                                         "closed_loop")),
)


def add_operating_point_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--speed-rpm", type=float, default=1000.0, help="dyno speed (default 1000)")
    parser.add_argument("--current-a", type=float, default=20.0,
                        help="peak phase-current amplitude (default 20 A)")
    parser.add_argument("--current-angle-deg", type=float, default=0.0,
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


def operating_point(args: argparse.Namespace) -> OperatingPoint:
    check_range("--speed-rpm", args.speed_rpm, -3000.0, 3000.0, unit=" rpm")
    check_range("--current-a", args.current_a, 0.0, 100.0, unit=" A", low_open=True)
    check_range("--current-angle-deg", args.current_angle_deg, -90.0, 90.0, unit=" deg")
    if args.dc_bus_v is not None:
        check_range("--dc-bus-v", args.dc_bus_v, 0.0, 1000.0, unit=" V", low_open=True)
    return OperatingPoint(args.speed_rpm, args.current_a, math.radians(args.current_angle_deg),
                          dc_bus_v=args.dc_bus_v)


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
    lines += [f"  {key} = {value:.6g}" if isinstance(value, float) else f"  {key} = {value}"
              for key, value in pred.inputs.items() if value is not None]
    lines += [f"  assumes: {text}" for text in pred.assumptions]
    return "\n".join(lines)


def in_option_names(error: InputError) -> InputError:
    """The same error with the model's keyword names replaced by the CLI options that set them."""
    message = str(error)
    for option in SOURCE_OPTIONS:
        message = re.sub(rf"(?<![\w-]){option.param}(?=[=,]| \(|$)", option.flag, message)
    for name in ("speed_rpm", "current_a", "dc_bus_v"):
        flag = "--" + name.replace("_", "-")
        message = re.sub(rf"(?<![\w-]){name}(?=[=,]| \(| !|$)", flag, message)
    return InputError(message)


def run(args: argparse.Namespace) -> int:
    op = operating_point(args)
    try:
        pred = predict(args.source, op, **source_params(args, args.source))
    except InputError as error:
        raise in_option_names(error) from None
    if args.json:
        data = pred.to_dict()
        if not args.waveform:
            data.pop("angle_rad")
            data.pop("waveform_pu")
        print(json.dumps(data))
    else:
        print(format_prediction(pred))
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("predict", help="closed-form ripple prediction of one source",
                                   description=__doc__.splitlines()[0])
    parser.add_argument("source", metavar="SOURCE", choices=list(SOURCES),
                        help=f"one of: {', '.join(SOURCES)}")
    add_operating_point_options(parser)
    add_source_options(parser)
    parser.add_argument("--waveform", action="store_true",
                        help="with --json: include angle_rad and waveform_pu (3600 points)")
    parser.set_defaults(func=run)
