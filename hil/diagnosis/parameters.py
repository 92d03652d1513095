"""The parameters a diagnosis can estimate, each with its signature (N·m per unit, per mechanical
order) at an operating point and its model's standard uncertainty.

Controller parameters: sensor offsets ``ia_offset_a``/``ib_offset_a`` (A), the gain difference
``gain_k_diff`` = k_a − k_b (paper eqs 21-22, actual-current errors), the effective dead time
``dead_time_us`` (µs). Motor-side parameters: cogging ``cogging_m{m}_re_nm``/``_im_nm`` (constant
complex coefficient at mechanical order m) and EMF-harmonic torque ``emf_m{m}_re_nm_per_a``/
``_im_nm_per_a`` (proportional to the current, fixed in the electrical angle).

Model uncertainty (standard, relative to the source's own torque at that point):
* sensor errors: the torque transducer's accuracy class (rectangular, /√3) plus 20 % of the
  current loop's correction |T − 1|, isotropic in the complex plane (magnitude and phase): the
  loop is modelled in continuous time while the firmware samples it (on the twin this term
  covers the sampled PI's errors of 0.4 % of k_a − k_b). What the loop *is* is a separate
  uncertainty: the diagnosis evaluates every signature over the loops the bench's statement
  allows (``DriveSetup.loop_variants``: bandwidth ± 10 % and delay ± half a PWM period for a
  stated design, a family from a slow PI to a fast 2-DOF loop for "unknown") and propagates the
  spread, complex, into the covariance (hil.diagnosis.core._loop_terms);
* dead time: 10 % at electrical order 6, the stated agreement of the average-voltage model with a
  time-domain run (hil/model/README.md), growing in proportion to the order (20 % at order 12),
  plus the transducer class; 100 % when it is only a nuisance term (a coarse encoder);
* motor-side terms are free coefficients: only the transducer class.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from hil.diagnosis import signatures as sig
from hil.diagnosis.orders import OrderSpectrum

#: Share of the loop's correction |T − 1| taken as the standard uncertainty of its continuous-time
#: evaluation (the stated loop's own uncertainty is the variants' spread, core._loop_terms).
LOOP_CORRECTION_REL_UNCERTAINTY = 0.2
#: The average-voltage dead-time model against a time-domain run (hil/model/README.md): 10 % at
#: order 6; taken as growing in proportion to the order (its errors are the timing of the current's
#: sign changes near the zero crossings, and a timing error moves harmonic k by k times the angle).
DEAD_TIME_MODEL_REL_UNCERTAINTY = 0.10
#: A term fitted only so its torque does not bias the others, its model known not to hold: 100 %.
NUISANCE_REL_UNCERTAINTY = 1.0


@dataclass(frozen=True)
class Parameter:
    """One estimable parameter: name, unit, source it belongs to, and how it acts."""

    name: str
    unit: str
    source: str
    description: str
    #: (spectrum, setup, max_mech_order) → ({mech order: coefficient per unit}, relative model u:
    #: one number, or {mech order: number})
    signature: Callable[[OrderSpectrum, sig.DriveSetup, int], tuple[dict[int, complex], float]]
    controller: bool = True


def _op(spectrum: OrderSpectrum, setup: sig.DriveSetup):
    return sig.operating_point(spectrum.speed_rpm, spectrum.current_a,
                               spectrum.current_angle_rad, setup)


def _with_transducer(orders: dict[int, complex], spectrum: OrderSpectrum,
                     setup: sig.DriveSetup) -> dict[int, complex]:
    return {m: c * sig.transducer_response(m, spectrum.speed_rpm, setup)
            for m, c in orders.items()}


def _transducer_class_rel(setup_class_pct: float) -> float:
    return setup_class_pct / 100.0 / math.sqrt(3.0)


def _sensor_signature(kind: str, class_pct: float):
    def build(spectrum: OrderSpectrum, setup: sig.DriveSetup, max_mech_order: int):
        op = _op(spectrum, setup)
        ideal = sig.DriveSetup(motor=setup.motor, pwm_frequency_hz=setup.pwm_frequency_hz)
        if kind == "gain":
            looped = sig.gain_difference_orders(op, setup)
            flat = sig.gain_difference_orders(op, ideal)
        else:
            looped, flat = sig.offset_orders(op, setup, kind), sig.offset_orders(op, ideal, kind)
        scale = float(np.max(np.abs(flat[1:]))) or 1.0
        correction = float(np.max(np.abs(looped[1:] - flat[1:]))) / scale
        rel = math.hypot(LOOP_CORRECTION_REL_UNCERTAINTY * correction,
                         _transducer_class_rel(class_pct))
        orders = sig.to_mech(looped, spectrum.pole_pairs, max_mech_order)
        return _with_transducer(orders, spectrum, setup), rel
    return build


def _dead_time_signature(class_pct: float, nuisance: bool = False):
    def build(spectrum: OrderSpectrum, setup: sig.DriveSetup, max_mech_order: int):
        op = _op(spectrum, setup)
        orders = sig.to_mech(sig.dead_time_orders(op, setup), spectrum.pole_pairs, max_mech_order)
        p = spectrum.pole_pairs
        rel = {m: (NUISANCE_REL_UNCERTAINTY if nuisance else
                   math.hypot(DEAD_TIME_MODEL_REL_UNCERTAINTY * (m / p) / 6.0,
                              _transducer_class_rel(class_pct)))
               for m in orders}
        return _with_transducer(orders, spectrum, setup), rel
    return build


def _cogging_signature(mech_order: int, part: complex, class_pct: float):
    def build(spectrum: OrderSpectrum, setup: sig.DriveSetup, max_mech_order: int):
        orders = {mech_order: part} if mech_order <= max_mech_order else {}
        return _with_transducer(orders, spectrum, setup), _transducer_class_rel(class_pct)
    return build


def _emf_signature(mech_order: int, part: complex, class_pct: float):
    def build(spectrum: OrderSpectrum, setup: sig.DriveSetup, max_mech_order: int):
        orders = {mech_order: part * spectrum.current_a} if mech_order <= max_mech_order else {}
        return _with_transducer(orders, spectrum, setup), _transducer_class_rel(class_pct)
    return build


OFFSET_TEXT = ("current-sensor {x} dc offset referred to the actual current, o_{x}/(1 + g_{x}) "
               "(eqs 15-19; the torque sees the offset through the sensor's gain)")


def controller_parameters(class_pct: float, *, dead_time: bool = True,
                          dead_time_nuisance: bool = False) -> list[Parameter]:
    params = [
        Parameter("ia_offset_a", "A", "dc_offset", OFFSET_TEXT.format(x="a"),
                  _sensor_signature("a", class_pct)),
        Parameter("ib_offset_a", "A", "dc_offset", OFFSET_TEXT.format(x="b"),
                  _sensor_signature("b", class_pct)),
        Parameter("gain_k_diff", "1", "gain_mismatch",
                  "k_a − k_b: actual-current gain errors of phases a and b (eqs 21-25)",
                  _sensor_signature("gain", class_pct)),
    ]
    if dead_time:
        params.append(Parameter("dead_time_us", "µs", "dead_time",
                                "effective (uncompensated) dead time, average-voltage model "
                                "with the bench's current loop (eqs 32-38, derived form)",
                                _dead_time_signature(class_pct, dead_time_nuisance)))
    return params


def cogging_parameters(mech_order: int, class_pct: float) -> list[Parameter]:
    return [Parameter(f"cogging_m{mech_order}_{tag}_nm", "N*m", "motor_cogging",
                      f"{label} part of a torque fixed in the mechanical angle, not scaling with "
                      f"current, mechanical order {mech_order}",
                      _cogging_signature(mech_order, part, class_pct), controller=False)
            for tag, label, part in (("re", "real", 1.0 + 0j), ("im", "imaginary", 1j))]


def emf_parameters(mech_order: int, class_pct: float) -> list[Parameter]:
    return [Parameter(f"emf_m{mech_order}_{tag}_nm_per_a", "N*m/A", "motor_emf",
                      f"{label} part of a torque proportional to current (EMF harmonics), "
                      f"mechanical order {mech_order}",
                      _emf_signature(mech_order, part, class_pct), controller=False)
            for tag, label, part in (("re", "real", 1.0 + 0j), ("im", "imaginary", 1j))]
