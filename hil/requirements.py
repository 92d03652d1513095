"""The user's own ripple requirements: limits on measured quantities, judged on every point.

A requirement is the customer's specification line, e.g. "REQ-12: total ripple ≤ 3.0 % pk-pk at
800 rpm and 15 A with the production encoder". It names

* ``id`` (traceability to the customer's spec) and ``name``;
* ``quantity`` — one of :data:`QUANTITIES`: ``pk_pk_pct`` (pk-pk of the synchronous average per
  unit of the mean torque, in %), ``order_amplitude_pct`` (amplitude of electrical ``order`` in %
  of the mean torque), ``rms_pct`` (RMS of the AC part in % of the mean torque), ``mean_torque_nm``;
* ``limit`` — ``{max = …}``, ``{min = …}`` or both, in the quantity's ``unit``;
* where it applies — ``source`` (plan names, default every plan), ``speed_rpm`` and ``current_a``
  as a value or an inclusive ``[low, high]`` range, ``injected`` (``"none"``, the default: only
  points with nothing injected — the drive as it is, not the faults the plans inject on purpose;
  ``"any"``: every point, injected or not), ``injection`` (a table of knob = value that the
  point's injection must contain, e.g. ``{encoder_decimation = 100}`` for the production
  encoder; a line that names an injection wants injected points, so its default is ``"any"``
  and ``injected = "none"`` beside it is refused as a contradiction);
* ``rule`` — ``"guarded"`` (ILAC-G8 guarded acceptance, guard band w = U, the default) or
  ``"simple"`` (ILAC-G8 simple acceptance: measured value against the limit, U reported);
* ``demonstration`` — true for a line that exists to show the FAIL path (labelled in the report).

Requirements come from a TOML file of ``[[requirement]]`` tables (``hil run --requirements``, or
``[requirements] file`` in the bench file) or from a plan (``measure(plan, requirements=[...])``).
Each applicable requirement is judged on the recorded measurement and recorded with its verdict
(design.md §7, verdict kind 1). The measured values are per unit of the *measured* mean torque
(what the transducer shows), as a customer's spec means it.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from hil.analysis.decision import classify
from hil.errors import InputError

#: quantity → unit
QUANTITIES = {"pk_pk_pct": "%", "order_amplitude_pct": "%", "rms_pct": "%",
              "mean_torque_nm": "N*m"}
RULES = ("guarded", "simple")
INJECTED = ("none", "any")
_KEYS = {"id", "name", "quantity", "order", "limit", "unit", "source", "speed_rpm", "current_a",
         "injected", "injection", "rule", "demonstration"}
#: Decisions that accept the item under each rule (ILAC-G8: guarded acceptance accepts only when
#: the measured value lies inside the limit by at least the guard band).
ACCEPTED = {"guarded": ("pass",), "simple": ("pass", "conditional pass")}


@dataclass(frozen=True)
class Requirement:
    """One requirement line (see the module docstring for every field's meaning and unit)."""

    id: str
    name: str
    quantity: str
    limit_min: float | None = None
    limit_max: float | None = None
    order: int | None = None
    sources: tuple[str, ...] = ()
    speed_rpm: tuple[float, float] | None = None
    current_a: tuple[float, float] | None = None
    #: "none" | "any"; None: "any" when ``injection`` names knobs, else "none" (the drive as
    #: it is)
    injected: str | None = None
    injection: tuple[tuple[str, Any], ...] = ()
    rule: str = "guarded"
    demonstration: bool = False
    origin: str = field(default="plan", compare=False)

    def __post_init__(self) -> None:
        where = f"requirement {self.id!r}"
        if not self.id or not isinstance(self.id, str):
            raise InputError("requirement: id must be a non-empty string (the customer's spec id)")
        if self.quantity not in QUANTITIES:
            raise InputError(f"{where}: quantity = {self.quantity!r}; allowed: "
                             f"{', '.join(QUANTITIES)}")
        if self.limit_min is None and self.limit_max is None:
            raise InputError(f"{where}: limit needs max, min or both")
        for name in ("limit_min", "limit_max"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float))
                                          and math.isfinite(value)):
                raise InputError(f"{where}: limit {name[6:]} = {value!r} must be a finite number")
        if (self.limit_min is not None and self.limit_max is not None
                and self.limit_min > self.limit_max):
            raise InputError(f"{where}: limit min {self.limit_min} > max {self.limit_max}")
        if self.quantity == "order_amplitude_pct":
            if not isinstance(self.order, int) or self.order < 1:
                raise InputError(f"{where}: quantity order_amplitude_pct needs order = an "
                                 f"electrical order >= 1, got {self.order!r}")
        elif self.order is not None:
            raise InputError(f"{where}: order is only used with quantity = order_amplitude_pct")
        if self.rule not in RULES:
            raise InputError(f"{where}: rule = {self.rule!r}; allowed: {', '.join(RULES)}")
        if self.injected is None:
            object.__setattr__(self, "injected", "any" if self.injection else "none")
        if self.injected not in INJECTED:
            raise InputError(f"{where}: injected = {self.injected!r}; allowed: "
                             f"{', '.join(INJECTED)}")
        if self.injected == "none" and self.injection:
            raise InputError(f"{where}: injected = \"none\" contradicts injection = "
                             f"{dict(self.injection)}; drop one of them")

    @property
    def unit(self) -> str:
        return QUANTITIES[self.quantity]

    def limit_text(self) -> str:
        unit = self.unit
        if self.limit_min is not None and self.limit_max is not None:
            return f"{self.limit_min:g} … {self.limit_max:g} {unit}"
        if self.limit_max is not None:
            return f"≤ {self.limit_max:g} {unit}"
        return f"≥ {self.limit_min:g} {unit}"

    def applies_to_text(self) -> str:
        parts = []
        if self.sources:
            parts.append("plans " + ", ".join(self.sources))
        for label, span, unit in (("", self.speed_rpm, "rpm"), ("", self.current_a, "A")):
            if span is not None:
                low, high = span
                parts.append(f"{low:g} {unit}" if low == high else f"{low:g}…{high:g} {unit}")
        if self.injected == "none":
            parts.append("nothing injected")
        elif not self.injection:
            parts.append("injected or not")
        parts += [f"{knob} = {value}" for knob, value in self.injection]
        return ", ".join(parts)

    def applies(self, *, source: str, speed_rpm: float, current_a: float,
                injection: dict) -> bool:
        """Whether this requirement judges a point of plan ``source`` at that operating point."""
        if self.sources and source not in self.sources:
            return False
        if self.injected == "none" and injection:
            return False
        if any(knob not in injection or injection[knob] != value
               for knob, value in self.injection):
            return False
        for span, value in ((self.speed_rpm, abs(speed_rpm)), (self.current_a, current_a)):
            if span is not None and not span[0] - 1e-9 <= value <= span[1] + 1e-9:
                return False
        return True

    def to_dict(self) -> dict:
        data = asdict(self)
        data["unit"] = self.unit
        return data


def requirement_from_dict(table: Any, *, origin: str = "plan") -> Requirement:
    """One ``[[requirement]]`` table → :class:`Requirement`; InputError names the bad key."""
    if not isinstance(table, dict):
        raise InputError(f"{origin}: each requirement must be a table, got {type(table).__name__}")
    rid = table.get("id")
    where = f"{origin}: requirement {rid!r}"
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}; allowed: "
                         f"{', '.join(sorted(_KEYS))}")
    for key in ("id", "name", "quantity", "limit"):
        if key not in table:
            raise InputError(f"{where}: missing key {key!r}")
    limit = table["limit"]
    if not isinstance(limit, dict) or not set(limit) <= {"min", "max"} or not limit:
        raise InputError(f"{where}: limit must be a table with max, min or both, got {limit!r}")
    quantity = table["quantity"]
    if "unit" in table and quantity in QUANTITIES and table["unit"] != QUANTITIES[quantity]:
        raise InputError(f"{where}: unit = {table['unit']!r} does not match quantity "
                         f"{quantity!r} (its unit is {QUANTITIES[quantity]!r})")
    source = table.get("source", ())
    sources = (source,) if isinstance(source, str) else tuple(source)
    if not all(isinstance(s, str) for s in sources):
        raise InputError(f"{where}: source must be a plan name or a list of plan names")
    return Requirement(
        id=str(rid), name=str(table["name"]), quantity=quantity,
        limit_min=_number(limit.get("min"), f"{where}: limit min"),
        limit_max=_number(limit.get("max"), f"{where}: limit max"),
        order=table.get("order"), sources=sources,
        speed_rpm=_span(table.get("speed_rpm"), f"{where}: speed_rpm", magnitude=True),
        current_a=_span(table.get("current_a"), f"{where}: current_a", magnitude=True),
        injected=table.get("injected"),
        injection=_knobs(table.get("injection", {}), f"{where}: injection"),
        rule=table.get("rule", "guarded"),
        demonstration=_flag(table.get("demonstration", False), f"{where}: demonstration"),
        origin=origin)


def load_requirements(path: str | Path) -> tuple[Requirement, ...]:
    """Read a requirements file (TOML, ``[[requirement]]`` tables); ids must be unique."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"requirements file {path} does not exist or is not a file")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"requirements file {path}: not valid TOML ({exc})") from None
    unknown = sorted(set(data) - {"requirement", "title"})
    if unknown:
        raise InputError(f"requirements file {path}: unknown top-level key(s) "
                         f"{', '.join(unknown)}; expected [[requirement]] tables")
    tables = data.get("requirement", [])
    if not isinstance(tables, list) or not tables:
        raise InputError(f"requirements file {path}: no [[requirement]] table")
    requirements = tuple(requirement_from_dict(t, origin=str(path)) for t in tables)
    check_unique(requirements)
    return requirements


def check_unique(requirements) -> None:
    seen: set[str] = set()
    for req in requirements:
        if req.id in seen:
            raise InputError(f"requirement id {req.id!r} is given twice")
        seen.add(req.id)


def measured_value(req: Requirement, result, *,
                   torque_accuracy_nm: float | None = None) -> tuple[float, float]:
    """``(value, expanded U)`` of ``req.quantity`` from a :class:`hil.analysis.RippleResult`.

    pk-pk: the analysis' value and its expanded uncertainty (k = 2). Order amplitude and RMS:
    per unit of the measured mean torque, U = 2 × the type-A standard uncertainty of the order's
    amplitude (for RMS, of the root-sum-square of the orders' amplitudes) combined with the
    relative part of the pk-pk budget's instrument contribution. Mean torque: in N·m, U = 2 ×
    the root-sum-square of the revolutions' type-A scatter and ``torque_accuracy_nm`` (the
    transducer's accuracy class in N·m, read as a rectangular distribution: u = a/√3).
    """
    mean = abs(result.mean_torque_nm)
    if not mean > 0:
        raise InputError("the measurement has no mean torque; a requirement in % of the mean "
                         "torque cannot be judged")
    if req.quantity == "pk_pk_pct":
        return 100.0 * result.pk_pk_pu, 100.0 * result.uncertainty.expanded_pu
    if req.quantity == "order_amplitude_pct":
        if req.order > result.max_order:
            raise InputError(f"requirement {req.id}: order {req.order} is outside the analysed "
                             f"band 1..{result.max_order}")
        amplitude = float(result.amplitude_nm[req.order - 1])
        u = float(result.amplitude_u_nm[req.order - 1])
        return 100.0 * amplitude / mean, 100.0 * 2.0 * u / mean
    if req.quantity == "rms_pct":
        amplitudes = result.amplitude_nm
        rms = float(math.sqrt(0.5 * float((amplitudes ** 2).sum())))
        u_rms = (float(math.sqrt(0.5 * float(((amplitudes * result.amplitude_u_nm) ** 2).sum())))
                 / rms) if rms > 0 else float(math.sqrt(0.5 * float(
                     (result.amplitude_u_nm ** 2).sum())))
        return 100.0 * rms / mean, 100.0 * 2.0 * u_rms / mean
    # mean torque: the type-A scatter of the revolutions' means, k = 2
    per_rev = result.revolution_matrix_nm.mean(axis=1)
    u = float(per_rev.std(ddof=1) / math.sqrt(len(per_rev))) if len(per_rev) > 1 else math.nan
    u_class = (torque_accuracy_nm or 0.0) / math.sqrt(3.0)
    return float(result.mean_torque_nm), 2.0 * math.hypot(u, u_class)


def judge(req: Requirement, result, *, torque_accuracy_nm: float | None = None) -> dict:
    """The requirement's verdict on one measurement (the record contract's dict)."""
    value, expanded = measured_value(req, result, torque_accuracy_nm=torque_accuracy_nm)
    if not (math.isfinite(value) and math.isfinite(expanded)):
        raise InputError(f"requirement {req.id}: the measurement gives no finite "
                         f"{req.quantity} ({value!r} ± {expanded!r})")
    lower = -math.inf if req.limit_min is None else req.limit_min
    upper = math.inf if req.limit_max is None else req.limit_max
    zone = classify(value, expanded, lower, upper)
    accepted = zone in ACCEPTED[req.rule]
    limit = {k: v for k, v in (("min", req.limit_min), ("max", req.limit_max)) if v is not None}
    return {"id": req.id, "name": req.name, "quantity": req.quantity, "order": req.order,
            "limit": limit, "limit_text": req.limit_text(), "unit": req.unit,
            "measured": value, "expanded_uncertainty": expanded, "rule": req.rule,
            "decision": zone, "accepted": accepted, "demonstration": req.demonstration,
            "applies_to": req.applies_to_text(), "origin": req.origin,
            "statement": (f"{req.id} {req.name} {req.limit_text()}: measured {value:.3g} ± "
                          f"{expanded:.2g} {req.unit} → {zone.upper()}"
                          + ("" if accepted or zone == "fail" else
                             f", not accepted by the {req.rule} rule")
                          + (" (demonstration)" if req.demonstration else ""))}


def applicable(requirements, *, source: str, speed_rpm: float, current_a: float,
               injection: dict) -> list[Requirement]:
    return [r for r in requirements
            if r.applies(source=source, speed_rpm=speed_rpm, current_a=current_a,
                         injection=injection)]


def _number(value: Any, where: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where} = {value!r} must be a finite number")
    return float(value)


def _span(value: Any, where: str, *, magnitude: bool = False) -> tuple[float, float] | None:
    """A value or [low, high]; ``magnitude``: matched against |speed| or the peak current, so a
    negative bound could never match and is refused."""
    span = _parse_span(value, where)
    if magnitude and span is not None and span[0] < 0:
        raise InputError(f"{where} = {value!r}: matched against the magnitude (|speed|, peak "
                         f"current); give values >= 0")
    return span


def _parse_span(value: Any, where: str) -> tuple[float, float] | None:
    if value is None:
        return None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        number = _number(value, where)
        return (number, number)
    if isinstance(value, list) and len(value) == 2:
        low, high = (_number(v, where) for v in value)
        if low > high:
            raise InputError(f"{where} = {value!r}: low > high")
        return (low, high)
    raise InputError(f"{where} = {value!r} must be a number or [low, high]")


def _knobs(value: Any, where: str) -> tuple[tuple[str, Any], ...]:
    if not isinstance(value, dict):
        raise InputError(f"{where} must be a table of knob = value, got {value!r}")
    return tuple(sorted(value.items()))


def _flag(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise InputError(f"{where} = {value!r} must be true or false")
    return value


def scope_problems(requirements, points: dict, *, selected: set[str], known: set[str],
                   measured_elsewhere: set[str] = frozenset()) -> list[str]:
    """Requirement lines that would silently judge nothing (issue 22 item 2), one line each:

    - a ``source`` that is no test plan (``known``: every plan name; e.g. ``"basline"``);
    - a line whose plans are selected in this run (``selected``) but that applies to none of
      their points (``points``: ``{test id: PointPlan}`` built from the bench file; e.g. a
      speed no point runs at, or injected points with the default ``injected = "none"``).

    A line whose plans are all not selected is not refused here (the run's statement 1 names it
    as applied to no measured point); nor is one whose selected plans include one whose points
    the pre-flight cannot build (``measured_elsewhere``: sources with tests outside ``points``)."""
    problems = []
    for req in requirements:
        unknown = [name for name in req.sources if name not in known]
        if unknown:
            problems.append(f"requirement {req.id}: source {', '.join(map(repr, unknown))} is "
                            f"not a test plan; allowed: {', '.join(sorted(known))}")
            continue
        scope = (set(req.sources) or set(selected)) & set(selected)
        if not scope or scope & set(measured_elsewhere):
            continue
        plans = [plan for plan in points.values() if plan.source in scope]
        if any(req.applies(source=p.source, speed_rpm=p.speed_rpm, current_a=p.current_a,
                           injection=p.injection) for p in plans):
            continue
        speeds = sorted({abs(p.speed_rpm) for p in plans})
        currents = sorted({p.current_a for p in plans})
        hint = ""
        anywhere = replace(req, injected="any")
        if req.injected == "none" and any(
                anywhere.applies(source=p.source, speed_rpm=p.speed_rpm, current_a=p.current_a,
                                 injection=p.injection) for p in plans):
            hint = ("; it would judge injected points: give injected = \"any\" or name the "
                    "injection if it should")
        problems.append(f"requirement {req.id} ({req.applies_to_text()}) applies to no point "
                        f"of the selected plan(s) {', '.join(sorted(scope))} (their points: "
                        f"{', '.join(f'{v:g}' for v in speeds)} rpm; "
                        f"{', '.join(f'{v:g}' for v in currents)} A){hint}")
    return problems
