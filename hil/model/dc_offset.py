"""Current-sensor dc offset (paper section III-C, eqs 15-20).

Two sensors (phases a, b) read i_meas = i + offset; phase c is computed, i_c = −(i_a + i_b)
(eq 17, and Kirchhoff for the isolated neutral). Ideal current regulation makes the *measured*
currents sinusoidal, so the actual currents are i_a = I·[sin(θ − φ) + Δ_a] with the paper's
per-unit Δ_a = −offset_a/I (the paper writes +Δ for the sensor offset; the sign only shifts the
ripple by half a period). The torque sum (eq 18, independent of φ for the ripple part):

    T = (E·I/ω_m)·{(3/2)·cos φ + √3·[Δ_a·cos(θ − 2π/3) − Δ_b·cos θ]}

so per unit of the mean torque the ripple is (eq 19, a waveform, not a pk-pk as printed)
(2/√3)·[Δ_a·cos(θ − 2π/3) − Δ_b·cos θ]/cos φ, order 1, with pk-pk
(4/√3)·sqrt(Δ_a² + Δ_b² + Δ_a·Δ_b)/cos φ. Worst case |Δ| ≤ Δ, same sign (eq 20): 2Δ·sin(θ − π/3),
pk-pk 4Δ (the paper's "1 % → 4 %").

Which sensor and which sign (issue 21 item 4): written as an order-1 phasor,
ripple = Re(c₁·e^{jθ}) with c₁ = (2/√3)·(Δ_a·e^{−j2π/3} − Δ_b)/cos φ (:func:`order1_phasor`),
an offset on sensor a alone puts the order-1 phase at π/3 (offset > 0) or −2π/3 (< 0), one on
sensor b alone at 0 or π: the phase names the sensor and the sign, the magnitude cannot.
"""

from __future__ import annotations

import math

import numpy as np

from hil.errors import InputError
from hil.model.core import MEAN_TORQUE_BASE, OperatingPoint, Prediction, angle_grid, check_range

OFFSET_RANGE_A = 20.0


def per_unit_offsets(op: OperatingPoint, *, ia_offset_a: float | None = None,
                     ib_offset_a: float | None = None, offset_a_pu: float | None = None,
                     offset_b_pu: float | None = None) -> tuple[float, float]:
    """Sensor offsets per unit of the current amplitude I, from amperes or per-unit inputs."""
    if ia_offset_a is not None and offset_a_pu is not None:
        raise InputError("give ia_offset_a or offset_a_pu, not both")
    if ib_offset_a is not None and offset_b_pu is not None:
        raise InputError("give ib_offset_a or offset_b_pu, not both")
    values = []
    for amps, pu, name_a, name_pu in ((ia_offset_a, offset_a_pu, "ia_offset_a", "offset_a_pu"),
                                      (ib_offset_a, offset_b_pu, "ib_offset_a", "offset_b_pu")):
        if pu is not None:
            pu = check_range(name_pu, pu, -1.0, 1.0, unit=" per unit of I")
            check_range(name_pu, pu * op.current_a, -OFFSET_RANGE_A, OFFSET_RANGE_A,
                        unit=" A once multiplied by the current amplitude")
            values.append(pu)
        else:
            amps = check_range(name_a, amps or 0.0, -OFFSET_RANGE_A, OFFSET_RANGE_A, unit=" A")
            values.append(amps / op.current_a)
    return values[0], values[1]


def ripple_pu(theta: np.ndarray, offset_a_pu: float, offset_b_pu: float,
              current_angle_rad: float = 0.0) -> np.ndarray:
    """Eq 19 with the physical sign: ripple per unit of the mean torque at electrical angle θ."""
    delta_a, delta_b = -offset_a_pu, -offset_b_pu
    return (2.0 / math.sqrt(3.0)) * (delta_a * np.cos(theta - 2 * math.pi / 3)
                                     - delta_b * np.cos(theta)) / math.cos(current_angle_rad)


def order1_phasor(offset_a_pu: float, offset_b_pu: float,
                  current_angle_rad: float = 0.0) -> complex:
    """c₁ of eq 19 with ripple_pu(θ) = Re(c₁·e^{jθ}) = |c₁|·cos(θ + arg c₁): the analysis'
    convention τ = c₀ + Σ A_k·cos(kθ + φ_k), so arg c₁ is the predicted order-1 phase."""
    delta_a, delta_b = -offset_a_pu, -offset_b_pu
    return complex((2.0 / math.sqrt(3.0)) * (delta_a * np.exp(-2j * math.pi / 3) - delta_b)
                   / math.cos(current_angle_rad))


def pk_pk_pu(offset_a_pu: float, offset_b_pu: float, current_angle_rad: float = 0.0) -> float:
    """Pk-pk of eq 19 per unit of the mean torque: (4/√3)·sqrt(Δa² + Δb² + Δa·Δb)/cos φ."""
    amplitude = math.sqrt(offset_a_pu**2 + offset_b_pu**2 + offset_a_pu * offset_b_pu)
    return 4.0 / math.sqrt(3.0) * amplitude / math.cos(current_angle_rad)


def worst_case_pk_pk_pu(max_offset_pu: float, current_angle_rad: float = 0.0) -> float:
    """Eq 20: both sensors offset by the same Δ gives pk-pk 4Δ (per unit of the mean torque)."""
    return 4.0 * abs(max_offset_pu) / math.cos(current_angle_rad)


def predict_dc_offset(op: OperatingPoint, *, ia_offset_a: float | None = None,
                      ib_offset_a: float | None = None, offset_a_pu: float | None = None,
                      offset_b_pu: float | None = None) -> Prediction:
    """Order-1 ripple of sensor dc offsets (eqs 15-19) at the operating point."""
    da, db = per_unit_offsets(op, ia_offset_a=ia_offset_a, ib_offset_a=ib_offset_a,
                              offset_a_pu=offset_a_pu, offset_b_pu=offset_b_pu)
    phi = op.current_angle_rad
    theta = angle_grid()
    return Prediction(
        source="dc_offset", pk_pk_pu=pk_pk_pu(da, db, phi), base=MEAN_TORQUE_BASE,
        base_nm=op.mean_torque_nm, order=1.0,
        inputs={"ia_offset_a": da * op.current_a, "ib_offset_a": db * op.current_a,
                "offset_a_pu": da, "offset_b_pu": db, **op.to_dict()},
        equations="eqs 15-20", assumptions=[
            "ideal current regulation of the measured currents",
            "two sensors (a, b), i_c = -(i_a + i_b) (isolated neutral)",
            "offset per unit of the current amplitude I at the operating point"],
        angle_rad=theta, waveform_pu=ripple_pu(theta, da, db, phi),
        extras={"worst_case_pk_pk_pu": worst_case_pk_pk_pu(max(abs(da), abs(db)), phi),
                "order_phase_rad": float(np.angle(order1_phasor(da, db, phi))),
                "order_amplitude_pu": float(abs(order1_phasor(da, db, phi)))})
