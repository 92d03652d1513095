"""The tolerance file (TOML): distributions per parameter, operating points, the requirement.

::

    drives = 100000            # Monte Carlo size (the CLI's --drives overrides)
    seed = 2026

    [requirement]              # one line of hil.requirements (pk_pk_pct with a max only)
    id = "REQ-RIPPLE-01"
    name = "ripple at the duty points"
    quantity = "pk_pk_pct"     # pk-pk ripple, % of the mean torque
    limit = { max = 3.0 }      # speed_rpm / current_a = [low, high] restrict it to some points

    [[operating_point]]        # a drive passes when it meets the limit at every point
    speed_rpm = 500
    current_a = 20             # peak phase current, A
    current_angle_deg = 0      # φ, current lag behind the back EMF (eq 4)

    [parameters.ia_offset_a]   # names are the drive's injection knobs, units in the name
    distribution = "normal"    # normal: mean (default nominal), sigma
    sigma = 0.05
    [parameters.dead_time_s]
    distribution = "uniform"   # uniform: mean, half_width (±)
    mean = 2e-6
    half_width = 0.5e-6
    [parameters.encoder_counts_per_rev]
    distribution = "choice"    # choice: values, weights summing to 1 (default equal)
    values = [2048, 7200]
    [parameters.word_length_bits]
    distribution = "fixed"     # fixed: value
    value = 16

Integer and boolean parameters (counts, bits, hall_mode) take ``fixed`` or ``choice`` only.
Every error is one line naming the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hil.errors import InputError
from hil.model.core import OperatingPoint
from hil.tolerance.distributions import Choice, Distribution, Fixed, Normal, Uniform


@dataclass(frozen=True)
class ParameterInfo:
    low: float
    high: float
    nominal: float
    unit: str
    integer: bool = False


#: The parameters a tolerance file may vary: allowed range, nominal (the drive's default), unit.
PARAMETERS: dict[str, ParameterInfo] = {
    "ia_offset_a": ParameterInfo(-20.0, 20.0, 0.0, "A"),
    "ib_offset_a": ParameterInfo(-20.0, 20.0, 0.0, "A"),
    "ia_gain_error_pu": ParameterInfo(-0.2, 0.2, 0.0, "per unit of the nominal sensor gain"),
    "ib_gain_error_pu": ParameterInfo(-0.2, 0.2, 0.0, "per unit of the nominal sensor gain"),
    "dead_time_s": ParameterInfo(0.0, 10e-6, 0.0, "s"),
    "encoder_counts_per_rev": ParameterInfo(4, 10**6, 7200, "counts per mechanical rev", True),
    "encoder_decimation": ParameterInfo(1, 1800, 1, "counts", True),
    "hall_mode": ParameterInfo(0, 1, 0, "bool (1 = Hall sensors, 60° electrical)", True),
    "word_length_bits": ParameterInfo(0, 32, 0, "bits (0 = floating point, else 6..32)", True),
    "pwm_period_counts": ParameterInfo(8, 65535, 2000, "counts per half period", True),
    "pwm_frequency_hz": ParameterInfo(2000.0, 50000.0, 20000.0, "Hz"),
}
QUANTITIES = ("pk_pk_pct",)
TOP_KEYS = {"drives", "seed", "requirement", "operating_point", "parameters"}
DRIVES_RANGE = (1, 10**9)


@dataclass(frozen=True)
class Requirement:
    """Pk-pk ripple limit, % of the mean torque, at the operating points it applies to (a
    ``hil.requirements`` line restricted to ``pk_pk_pct`` with a ``max``)."""

    id: str
    limit_pct: float
    quantity: str = "pk_pk_pct"
    name: str = ""
    speed_rpm: tuple[float, float] | None = None
    current_a: tuple[float, float] | None = None

    @property
    def limit_pu(self) -> float:
        return self.limit_pct / 100.0

    def applies_to(self, op: OperatingPoint) -> bool:
        return all(span is None or span[0] - 1e-9 <= value <= span[1] + 1e-9
                   for span, value in ((self.speed_rpm, abs(op.speed_rpm)),
                                       (self.current_a, op.current_a)))

    def to_dict(self) -> dict:
        return {"id": self.id, "name": self.name, "quantity": self.quantity,
                "limit": {"max": self.limit_pct}, "speed_rpm": self.speed_rpm,
                "current_a": self.current_a}


def yield_requirement(req: Any, where: str) -> Requirement:
    """A ``hil.requirements.Requirement`` as a yield limit: only ``pk_pk_pct`` with a ``max``."""
    if req.quantity not in QUANTITIES:
        raise InputError(f"{where}: quantity = {req.quantity!r}: hil yield judges "
                         f"{', '.join(QUANTITIES)} only")
    if req.limit_max is None or req.limit_min is not None:
        raise InputError(f"{where}: limit must be {{max = PERCENT}} only (an upper pk-pk limit)")
    limit = _number(f"{where}: limit max", req.limit_max, 0.0, 100.0, low_open=True)
    return Requirement(req.id, limit, req.quantity, req.name, req.speed_rpm, req.current_a)


@dataclass(frozen=True)
class ToleranceSpec:
    """A parsed tolerance file: every parameter (nominal ``Fixed`` when not given)."""

    parameters: dict[str, Distribution]
    operating_points: tuple[OperatingPoint, ...]
    requirement: Requirement | None
    drives: int = 100_000
    seed: int = 0
    source: str = "<dict>"
    given: tuple[str, ...] = field(default=())

    @property
    def judged(self) -> list[int]:
        """Indices of the operating points the requirement applies to."""
        if self.requirement is None:
            return []
        return [i for i, op in enumerate(self.operating_points) if self.requirement.applies_to(op)]

    def worst_pu(self, ripple_pu: np.ndarray) -> np.ndarray:
        """Each drive's largest ripple over the judged points, from (drives, points) ripple."""
        return np.asarray(ripple_pu)[:, self.judged].max(axis=1)

    @property
    def varied(self) -> list[str]:
        """Parameters with a spread or a choice: the inputs of the sensitivity analysis."""
        return [name for name, dist in self.parameters.items()
                if dist.spread > 0 or (isinstance(dist, Choice) and len(set(dist.values)) > 1)]

    def with_requirement(self, limit_pct: float | None = None,
                         requirement: Requirement | None = None) -> "ToleranceSpec":
        """The spec judged against ``requirement`` (``--requirements``), else ``limit_pct``
        (``--limit-pct``), else its own ``[requirement]``; it must apply to some point."""
        if requirement is None and limit_pct is not None:
            limit = _number("--limit-pct", limit_pct, 0.0, 100.0, low_open=True)
            requirement = Requirement("command-line limit", limit, name="--limit-pct")
        spec = _replace(self, requirement=requirement or self.requirement)
        if spec.requirement is None:
            raise InputError(f"{self.source}: no [requirement] table and no --limit-pct: "
                             "give the pk-pk limit (% of the mean torque)")
        if not spec.judged:
            raise InputError(f"requirement {spec.requirement.id!r} applies to none of the "
                             f"operating points of {self.source} (its speed_rpm/current_a)")
        return spec

    def with_spreads(self, factors: dict[str, float]) -> "ToleranceSpec":
        """The spec with each named parameter's spread multiplied by its factor."""
        params = dict(self.parameters)
        for name, factor in factors.items():
            params[name] = params[name].scaled(factor)
        return _replace(self, parameters=params)

    def to_dict(self) -> dict:
        return {"source": self.source, "drives": self.drives, "seed": self.seed,
                "requirement": self.requirement.to_dict() if self.requirement else None,
                "operating_points": [{"speed_rpm": op.speed_rpm, "current_a": op.current_a,
                                      "current_angle_deg": math.degrees(op.current_angle_rad)}
                                     for op in self.operating_points],
                "parameters": {name: {**dist.describe(), "unit": PARAMETERS[name].unit}
                               for name, dist in self.parameters.items()},
                "varied": self.varied}


def _replace(spec: ToleranceSpec, **changes: Any) -> ToleranceSpec:
    import dataclasses
    return dataclasses.replace(spec, **changes)


def load_tolerances(path: str | Path) -> ToleranceSpec:
    """Read and validate a tolerance file; InputError (one line, naming the key) if bad."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise InputError(f"tolerance file {path}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"tolerance file {path}: not valid TOML ({exc})") from None
    return parse_tolerances(data, source=str(path))


def parse_tolerances(data: dict[str, Any], *, source: str = "<dict>") -> ToleranceSpec:
    """Validate a tolerance document already read from TOML (see the module docstring)."""
    where = f"{source}:"
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise InputError(f"{where} unknown key {unknown[0]!r} (allowed: {', '.join(sorted(TOP_KEYS))})")
    drives = _integer(f"{where} drives", data.get("drives", 100_000), *DRIVES_RANGE)
    seed = _integer(f"{where} seed", data.get("seed", 0), 0, 2**63 - 1)
    points = data.get("operating_point")
    if points is None:
        raise InputError(f"{where} missing [[operating_point]] (speed_rpm, current_a, "
                         "current_angle_deg)")
    if isinstance(points, dict):
        points = [points]
    if not isinstance(points, list) or not points:
        raise InputError(f"{where} operating_point must be a table or an array of tables")
    ops = tuple(_operating_point(f"{where} operating_point[{i}]", p) for i, p in enumerate(points))
    requirement = None
    if "requirement" in data:
        requirement = _requirement(f"{source}: [requirement]", data["requirement"])
    raw = data.get("parameters", {})
    if not isinstance(raw, dict):
        raise InputError(f"{where} parameters must be a table of [parameters.NAME] tables")
    params: dict[str, Distribution] = {name: Fixed(info.nominal)
                                       for name, info in PARAMETERS.items()}
    for name, table in raw.items():
        params[name] = _distribution(f"{where} parameters.{name}", name, table)
    return ToleranceSpec(params, ops, requirement, drives, seed, source, tuple(raw))


def _operating_point(key: str, table: Any) -> OperatingPoint:
    if not isinstance(table, dict):
        raise InputError(f"{key} must be a table (speed_rpm, current_a, current_angle_deg)")
    allowed = {"speed_rpm", "current_a", "current_angle_deg"}
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InputError(f"{key}.{unknown[0]}: unknown key (allowed: {', '.join(sorted(allowed))})")
    for name in ("speed_rpm", "current_a"):
        if name not in table:
            raise InputError(f"{key}.{name} is missing")
    speed = _number(f"{key}.speed_rpm", table["speed_rpm"], -3000.0, 3000.0)
    if speed == 0:
        raise InputError(f"{key}.speed_rpm=0: ripple over electrical revolutions needs a speed "
                         "(allowed -3000..3000 rpm, not 0)")
    current = _number(f"{key}.current_a", table["current_a"], 0.0, 100.0, low_open=True)
    angle = _number(f"{key}.current_angle_deg", table.get("current_angle_deg", 0.0), -80.0, 80.0)
    try:
        return OperatingPoint(speed, current, math.radians(angle))
    except InputError as exc:  # e.g. beyond the inverter's voltage (SVPWM linear limit)
        raise InputError(f"{key}: {exc}") from None


def _requirement(key: str, table: Any) -> Requirement:
    """The ``[requirement]`` table, in the format of ``hil.requirements`` (one line of it)."""
    from hil.requirements import requirement_from_dict

    if not isinstance(table, dict):
        raise InputError(f"{key} must be a table (id, name, quantity, limit = {{max = ...}})")
    return yield_requirement(requirement_from_dict(table, origin=key), key)


def _distribution(key: str, name: str, table: Any) -> Distribution:
    if name not in PARAMETERS:
        raise InputError(f"{key}: unknown parameter (allowed: {', '.join(PARAMETERS)})")
    info = PARAMETERS[name]
    if not isinstance(table, dict) or "distribution" not in table:
        raise InputError(f"{key} must be a table with distribution = normal | uniform | fixed | "
                         "choice")
    kind = table["distribution"]
    fields = {"normal": {"mean", "sigma"}, "uniform": {"mean", "half_width"},
              "fixed": {"value"}, "choice": {"values", "weights"}}
    if kind not in fields:
        raise InputError(f"{key}.distribution={kind!r} (allowed: normal, uniform, fixed, choice)")
    unknown = sorted(set(table) - fields[kind] - {"distribution"})
    if unknown:
        raise InputError(f"{key}.{unknown[0]}: not a field of a {kind} distribution "
                         f"(allowed: {', '.join(sorted(fields[kind]))})")
    if info.integer and kind in ("normal", "uniform"):
        raise InputError(f"{key}: {name} is an integer ({info.unit}); use distribution = "
                         "fixed or choice")

    def value(field_name: str, raw: Any) -> float:
        number = _number(f"{key}.{field_name}", raw, info.low, info.high, unit=f" {info.unit}")
        if info.integer:
            if number != int(number):
                raise InputError(f"{key}.{field_name}={raw!r} must be an integer ({info.unit})")
            if name == "word_length_bits" and 0 < number < 6:
                raise InputError(f"{key}.{field_name}={raw!r}: word_length_bits is 0 (floating "
                                 "point) or 6..32")
        return number

    if kind == "fixed":
        if "value" not in table:
            raise InputError(f"{key}.value is missing")
        return Fixed(value("value", table["value"]))
    if kind == "choice":
        values = table.get("values")
        if not isinstance(values, list) or not values:
            raise InputError(f"{key}.values must be a non-empty array")
        numbers = tuple(value(f"values[{i}]", v) for i, v in enumerate(values))
        weights = table.get("weights", [1.0 / len(numbers)] * len(numbers))
        if not isinstance(weights, list) or len(weights) != len(numbers):
            raise InputError(f"{key}.weights must be an array as long as values "
                             f"({len(numbers)})")
        weights = tuple(_number(f"{key}.weights[{i}]", w, 0.0, 1e12)
                        for i, w in enumerate(weights))
        try:
            return Choice(numbers, weights)
        except InputError as exc:  # weights not summing to 1: name the parameter
            raise InputError(f"{key}.weights: {exc}") from None
    mean = value("mean", table.get("mean", info.nominal))
    spread_name = "sigma" if kind == "normal" else "half_width"
    if spread_name not in table:
        raise InputError(f"{key}.{spread_name} is missing")
    spread = _number(f"{key}.{spread_name}", table[spread_name], 0.0, info.high - info.low,
                     unit=f" {info.unit}")
    if kind == "normal":
        return Normal(mean, spread, info.low, info.high)
    if mean - spread < info.low or mean + spread > info.high:
        raise InputError(f"{key}: mean ± half_width = [{mean - spread:g}, {mean + spread:g}] "
                         f"leaves the allowed range [{info.low:g}, {info.high:g}] {info.unit}")
    return Uniform(mean, spread, info.low, info.high)


def _number(key: str, raw: Any, low: float, high: float, *, low_open: bool = False,
            unit: str = "") -> float:
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise InputError(f"{key}={raw!r} is not a number (allowed {low:g}..{high:g}{unit})")
    number = float(raw)
    if not math.isfinite(number) or number > high or (number <= low if low_open else number < low):
        raise InputError(f"{key}={raw!r} is out of range (allowed {'(' if low_open else '['}"
                         f"{low:g}, {high:g}]{unit})")
    return number


def _integer(key: str, raw: Any, low: int, high: int) -> int:
    if isinstance(raw, bool) or not isinstance(raw, int) or not low <= raw <= high:
        raise InputError(f"{key}={raw!r} must be an integer in {low}..{high}")
    return raw
