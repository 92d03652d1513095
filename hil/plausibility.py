"""Physical plausibility of a bench file's motor and limits (design.md §6), checked at load.

A value in the wrong unit (``phase_inductance_h = 38.5`` where 38.5 µH was meant) is a valid
positive number, so range checks of single keys let it through and every point then reads "not
determinable". These rules look at the quantities the physics ties together and refuse, naming
the value, the unit expected and the likely mistake. The bounds are wide on purpose (a real
motor must never be refused); each is a factor of several beyond what PM synchronous machines
of a few watts to about 100 kW show:

* **Winding time constant** τ = L/R (paper eq 2's electrical pole): 10 µs … 1 s. Both L and R
  grow with machine size, τ roughly with the square of it; small servo and EPS motors have
  0.1–5 ms (Table I: 38.5 µH / 55 mΩ = 0.70 ms), 100 kW machines some 10–50 ms. An inductance
  in µH or mH written as H gives τ of seconds or more; a resistance in mΩ written as Ω gives
  τ below a microsecond.
* **Inductance** L: 1 µH … 1 H, **resistance** R: 0.1 mΩ … 1 kΩ, **dc bus**: 1 V … 1500 V
  (low-voltage drives to 1500 V dc traction), each alone.
* **Back EMF against the bus.** The speed at which the magnet EMF alone reaches the SVPWM limit
  V_dc/√3 (peak phase; E = k_E·ω_m, paper eq 1, k_E the peak phase EMF per mechanical rad/s)
  is n₀ = V_dc/(√3·k_E). Above n₀ a drive can only run by field weakening, which for a surface
  PM motor (characteristic current ψ/L usually above the rated current) reaches a few times n₀
  at most; so the EMF at ``[limits] speed_rpm`` must not exceed 3·V_dc/√3. A Ke in V/krpm written
  as V·s/rad (×104.7) breaks this. Also n₀ ≤ 200 000 rpm (beyond the fastest PM rotors): a Ke in
  mV written as V (÷1000) breaks that.
* **Maximum reactance** X_max = ω_e·L at the motor's top speed: that speed,
  X_max/(L·p)·60/2π, must lie within 10 … 200 000 rpm.
* **Pole count**: at most 100 (PM motors of benches have 2–64 poles; a count of slots or
  encoder pulses is the likely mistake).
* **Current limit against R**: ``[limits] current_a``·R (the ohmic drop at that current) must
  not exceed 10·V_dc/√3; a limit the drive could never approach even at standstill means R (or
  the limit) is in the wrong unit.
"""

from __future__ import annotations

import math

#: (low, high) bounds, SI units, and where each comes from (module docstring).
TIME_CONSTANT_S = (10e-6, 1.0)
INDUCTANCE_H = (1e-6, 1.0)
RESISTANCE_OHM = (1e-4, 1e3)
DC_BUS_V = (1.0, 1500.0)
TOP_SPEED_RPM = (10.0, 200_000.0)
#: Most the EMF at the speed limit may exceed the SVPWM voltage limit V_dc/√3 by (field
#: weakening of a surface PM motor reaches a few times the base speed at most).
EMF_OVER_VOLTAGE_LIMIT = 3.0
MAX_POLE_COUNT = 100
#: Most the ohmic drop at the current limit may exceed V_dc/√3 by.
OHMIC_DROP_OVER_VOLTAGE_LIMIT = 10.0

_PREFIXES = ((1e-6, "µ"), (1e-3, "m"), (1e3, "k"))


def _meant(value: float, unit: str, low: float, high: float) -> str:
    """"did you mean 38.5 µH (38.5e-06 H)?" when one SI prefix brings ``value`` into range."""
    for factor, prefix in _PREFIXES:
        if low <= value * factor <= high:
            return f"; likely {value:g} {prefix}{unit} was meant: write {value * factor:.6g}"
    return ""


def _range(name: str, value: float, unit: str, bounds: tuple[float, float]) -> str | None:
    low, high = bounds
    if low <= value <= high:
        return None
    return (f"motor.{name} = {value:g} {unit} is not a plausible value for a PM motor "
            f"(expected {low:g} … {high:g} {unit})" + _meant(value, unit, low, high))


def problems(motor, limits) -> list[str]:
    """Every implausible value of ``motor`` (:class:`hil.motor.MotorParameters`) with
    ``limits`` (:class:`hil.config.Limits`), each naming the value, the unit expected and the
    likely mistake; empty when all is plausible."""
    found = [text for text in (
        _range("phase_inductance_h", motor.phase_inductance_h, "H", INDUCTANCE_H),
        _range("phase_resistance_ohm", motor.phase_resistance_ohm, "Ω", RESISTANCE_OHM),
        _range("dc_bus_v", motor.dc_bus_v, "V", DC_BUS_V)) if text]
    if found:
        return found
    tau_s = motor.phase_inductance_h / motor.phase_resistance_ohm
    if not TIME_CONSTANT_S[0] <= tau_s <= TIME_CONSTANT_S[1]:
        likely = ("phase_inductance_h in µH or mH written as H, or phase_resistance_ohm in mΩ "
                  "written as Ω" if tau_s > TIME_CONSTANT_S[1] else
                  "phase_resistance_ohm in mΩ written as Ω, or phase_inductance_h in H where "
                  "mH was meant")
        found.append(f"motor.phase_inductance_h = {motor.phase_inductance_h:g} H with "
                     f"phase_resistance_ohm = {motor.phase_resistance_ohm:g} Ω gives L/R = "
                     f"{tau_s:.3g} s, not a PM motor winding (expected "
                     f"{TIME_CONSTANT_S[0]:g} … {TIME_CONSTANT_S[1]:g} s); likely {likely}")
    if motor.pole_count > MAX_POLE_COUNT:
        found.append(f"motor.pole_count = {motor.pole_count} poles is not plausible (expected "
                     f"2 … {MAX_POLE_COUNT}); likely slots or encoder pulses were entered")
    voltage_limit_v = motor.dc_bus_v / math.sqrt(3.0)
    k_e = motor.emf_peak_v_s_per_rad
    n0_rpm = voltage_limit_v / k_e * 60.0 / (2.0 * math.pi)
    emf_at_limit_v = k_e * limits.speed_rpm * 2.0 * math.pi / 60.0
    if emf_at_limit_v > EMF_OVER_VOLTAGE_LIMIT * voltage_limit_v:
        found.append(f"motor.ke_v_s_per_rad = {motor.ke_v_s_per_rad:g} V·s/rad "
                     f"({motor.ke_definition}) gives {emf_at_limit_v:.3g} V peak phase EMF at "
                     f"limits.speed_rpm = {limits.speed_rpm:g}, more than "
                     f"{EMF_OVER_VOLTAGE_LIMIT:g} × V_dc/√3 = "
                     f"{EMF_OVER_VOLTAGE_LIMIT * voltage_limit_v:.3g} V (the EMF alone reaches "
                     f"the {motor.dc_bus_v:g} V bus's limit at {n0_rpm:.3g} rpm); expected "
                     f"V·s per mechanical rad; likely a Ke in V/krpm (÷ 104.7) or "
                     f"mV·s/rad was entered, or dc_bus_v is too low")
    elif n0_rpm > TOP_SPEED_RPM[1]:
        found.append(f"motor.ke_v_s_per_rad = {motor.ke_v_s_per_rad:g} V·s/rad: the EMF would "
                     f"reach the {motor.dc_bus_v:g} V bus's limit only at {n0_rpm:.3g} rpm "
                     f"(expected at most {TOP_SPEED_RPM[1]:g} rpm); expected V·s per "
                     f"mechanical rad; likely Ke was entered some 1000× too small (a V/mV slip) "
                     f"or dc_bus_v too high")
    top_rpm = motor.max_speed_rpm
    if not TOP_SPEED_RPM[0] <= top_rpm <= TOP_SPEED_RPM[1]:
        found.append(f"motor.max_reactance_ohm = {motor.max_reactance_ohm:g} Ω with "
                     f"phase_inductance_h = {motor.phase_inductance_h:g} H puts the motor's top "
                     f"speed at {top_rpm:.3g} rpm (expected {TOP_SPEED_RPM[0]:g} … "
                     f"{TOP_SPEED_RPM[1]:g} rpm); expected ω_e·L in Ω at top speed; likely "
                     f"one of the two in the wrong unit (mΩ, µH)")
    drop_v = limits.current_a * motor.phase_resistance_ohm
    if drop_v > OHMIC_DROP_OVER_VOLTAGE_LIMIT * voltage_limit_v:
        found.append(f"limits.current_a = {limits.current_a:g} A through phase_resistance_ohm = "
                     f"{motor.phase_resistance_ohm:g} Ω needs {drop_v:.3g} V, more than "
                     f"{OHMIC_DROP_OVER_VOLTAGE_LIMIT:g} × V_dc/√3 = "
                     f"{OHMIC_DROP_OVER_VOLTAGE_LIMIT * voltage_limit_v:.3g} V: the drive could "
                     f"never approach that current; likely phase_resistance_ohm in mΩ written "
                     f"as Ω")
    return found


def check(bench, fail) -> None:
    """Refuse an implausible bench (``fail``: the loader's error, raises) with every problem."""
    found = problems(bench.motor, bench.limits)
    if found:
        fail("; ".join(found))
