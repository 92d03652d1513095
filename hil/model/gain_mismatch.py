"""Current-sensor gain mismatch (paper section III-C, eqs 21-26), exact ratio form.

Sensors read i_meas = (1 + g)·i with g the contract's ``ia_gain_error_pu``/``ib_gain_error_pu``.
Ideal regulation of the measured currents gives actual amplitudes I·(1 + k) with
1 + k = 1/(1 + g) (the paper's k1, k2 of eqs 21-22 are these actual-current errors; to first
order k = −g). The torque sum with i_c = −(i_a + i_b), generalised to a current angle φ:

    T = (E·I/ω_m)·{(3/2)·cos φ + (√3/2)·[k1·sin(φ + π/3) + k2·sin(φ + 2π/3)]
                   + (√3/2)·(k1 − k2)·sin(2θ − φ − 2π/3)}

At φ = 0 this is eq 24: 3/2 + (3/4)(k1 + k2) + (√3/2)(k1 − k2)·sin(2θ − 2π/3). Per unit of the
(changed) mean torque: eq 25, (2/√3)·(k1 − k2)/(2 + k1 + k2)·sin(2θ − 2π/3), order 2; pk-pk twice
that. Worst case k1 = −k2 = Δk (eq 26): (4/√3)·Δk, the paper's "1 % → 2.31 %"; with sensor gain
errors g = ±Δk the physical ratio is exactly (4/√3)·Δk as well.

The sign of k1 − k2 (issue 21 item 4): as an order-2 phasor, ripple = Re(c₂·e^{j2θ}) with
c₂ = (√3/2)·(k1 − k2)·e^{−j(φ + 7π/6)}/mean (:func:`order2_phasor`; sin x = cos(x − π/2)):
k1 > k2 puts the order-2 phase at −φ − 7π/6, k1 < k2 half a period (π) away. The magnitude is
the same either way.
"""

from __future__ import annotations

import math

import numpy as np

from hil.model.core import OperatingPoint, Prediction, angle_grid, check_range

GAIN_ERROR_RANGE_PU = 0.2
SHIFTED_MEAN_BASE = ("mean torque (E·I/ω_m)·[(3/2)·cos φ + (√3/2)·(k1·sin(φ + π/3) + "
                     "k2·sin(φ + 2π/3))] at the operating point (eq 24)")
SQRT3 = math.sqrt(3.0)


def current_errors(ia_gain_error_pu: float, ib_gain_error_pu: float) -> tuple[float, float]:
    """The paper's k1, k2 (actual-current amplitude errors) from sensor gain errors g: 1/(1+g) − 1."""
    return 1.0 / (1.0 + ia_gain_error_pu) - 1.0, 1.0 / (1.0 + ib_gain_error_pu) - 1.0


def torque_coefficients(k1: float, k2: float, current_angle_rad: float) -> tuple[float, float]:
    """(mean, ripple amplitude) of the torque in units of E·I/ω_m (eq 24 generalised to φ)."""
    phi = current_angle_rad
    mean = 1.5 * math.cos(phi) + SQRT3 / 2 * (k1 * math.sin(phi + math.pi / 3)
                                              + k2 * math.sin(phi + 2 * math.pi / 3))
    return mean, SQRT3 / 2 * (k1 - k2)


def order2_phasor(ia_gain_error_pu: float, ib_gain_error_pu: float,
                  current_angle_rad: float = 0.0) -> complex:
    """c₂ of eq 25 (generalised to φ) per unit of the mean torque, with ripple_pu(θ) =
    Re(c₂·e^{j2θ}) = |c₂|·cos(2θ + arg c₂) — the analysis' phase convention."""
    mean, amplitude = torque_coefficients(*current_errors(ia_gain_error_pu, ib_gain_error_pu),
                                          current_angle_rad)
    return complex(amplitude / mean * np.exp(-1j * (current_angle_rad + 7 * math.pi / 6)))


def pk_pk_pu(ia_gain_error_pu: float, ib_gain_error_pu: float,
             current_angle_rad: float = 0.0) -> float:
    """Pk-pk per unit of the mean torque (eq 25 doubled, exact ratio form)."""
    mean, amplitude = torque_coefficients(*current_errors(ia_gain_error_pu, ib_gain_error_pu),
                                          current_angle_rad)
    return 2.0 * abs(amplitude) / mean


def worst_case_pk_pk_pu(max_gain_error_pu: float, current_angle_rad: float = 0.0) -> float:
    """Eq 26 generalised: the larger of the two opposite-sign cases (4/√3·Δk at φ = 0)."""
    d = abs(max_gain_error_pu)
    return max(pk_pk_pu(d, -d, current_angle_rad), pk_pk_pu(-d, d, current_angle_rad))


def predict_gain_mismatch(op: OperatingPoint, *, ia_gain_error_pu: float = 0.0,
                          ib_gain_error_pu: float = 0.0) -> Prediction:
    """Order-2 ripple of a sensor gain mismatch (eqs 21-25) at the operating point."""
    ga = check_range("ia_gain_error_pu", ia_gain_error_pu, -GAIN_ERROR_RANGE_PU,
                     GAIN_ERROR_RANGE_PU, unit=" per unit of the nominal sensor gain")
    gb = check_range("ib_gain_error_pu", ib_gain_error_pu, -GAIN_ERROR_RANGE_PU,
                     GAIN_ERROR_RANGE_PU, unit=" per unit of the nominal sensor gain")
    phi = op.current_angle_rad
    k1, k2 = current_errors(ga, gb)
    mean, amplitude = torque_coefficients(k1, k2, phi)
    theta = angle_grid()
    base_nm = op.mean_torque_nm * mean / (1.5 * math.cos(phi))
    return Prediction(
        source="gain_mismatch", pk_pk_pu=2.0 * abs(amplitude) / mean,
        base=SHIFTED_MEAN_BASE,
        base_nm=base_nm, order=2.0,
        inputs={"ia_gain_error_pu": ga, "ib_gain_error_pu": gb, "k1": k1, "k2": k2,
                **op.to_dict()},
        equations="eqs 21-26", assumptions=[
            "ideal current regulation of the measured currents",
            "two sensors (a, b), i_c = -(i_a + i_b) (isolated neutral)"],
        angle_rad=theta,
        waveform_pu=amplitude * np.sin(2 * theta - phi - 2 * math.pi / 3) / mean,
        extras={"worst_case_pk_pk_pu": worst_case_pk_pk_pu(max(abs(ga), abs(gb)), phi),
                "order_phase_rad": float(np.angle(order2_phasor(ga, gb, phi))),
                "order_amplitude_pu": float(abs(order2_phasor(ga, gb, phi)))})
