"""Identify the motor from the bench's own captures (design.md §11), each value with its GUM
standard uncertainty and its method named.

Phasors are taken per electrical revolution in the angle channel's electrical angle θ (absolute,
the same frame in every capture), x(θ) ≈ Re(X·e^{jθ}) by least squares on {cos θ, sin θ, 1};
the revolution-to-revolution scatter is the type-A part. In θ the motor's phase equation is
V = Z·I + E with Z = R + j·ωe·L (ωe signed), whatever the direction of rotation.

* ψ (the peak phase EMF per mechanical rad/s, paper eq 1: E = ψ·ω_m) from the line-to-line
  voltage ``vab_v`` with the drive disabled and the dyno turning the motor: no current, so the
  terminal voltage is the back EMF; E_an = V_ab/(√3·e^{jπ/6}).
* R and L (Z) from ``vab_v``, ``ia_a`` and the angle with the drive regulating its current at the
  plans' operating point: Z = (V_an − E_an)/I_a, E_an the back EMF measured above scaled to this
  speed. The *terminal* voltage is measured, not the drive's commanded one: the dead time's
  voltage error ((4/π)·V_dc·t_d/T, larger than R·I at a few µs) is in what is measured and so
  never enters R, while a commanded voltage would carry it whole.

Type-B terms: the voltage channel's quantisation (its LSB/√12 per sample, averaged over the
revolution), the uncertainty of the EMF propagated into Z, and the time skew between the voltage
and current channels (bounded by ``skew_bound_s``, rectangular): a skew δt turns the voltage
measured in both captures by ωe·δt, so δZ = j·ωe·δt·Z — it moves mostly ωe·L (δL ≈ δt·R); and
the DAQ channels' gain (``gain_u_rel``, from the DAQ's stated accuracy class:
``hil.config.BenchConfig.daq_gain_u_rel``): a voltage channel reading g× the truth gives ψ g×
the truth, and Z = (V − E)/I, whose V and E come through that same channel, (g_v/g_i)× — so in
Z the voltage gain enters once, not again through E's U.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.capture import Capture
from hil.errors import InputError

#: The fewest samples an electrical revolution's least-squares fit (cos, sin, constant) takes.
MIN_SAMPLES_PER_REVOLUTION = 16

#: v_ab leads v_an by 30° (positive sequence in the electrical angle): V_ab = √3·e^{jπ/6}·V_an
LINE_TO_NEUTRAL = 1.0 / (math.sqrt(3.0) * complex(math.cos(math.pi / 6), math.sin(math.pi / 6)))


@dataclass(frozen=True)
class Identified:
    """One identified parameter: value, standard uncertainty (k = 1), unit, how it was found."""

    name: str
    value: float
    u: float
    unit: str
    method: str

    @property
    def expanded(self) -> float:
        """U = 2·u (k = 2)."""
        return 2.0 * self.u

    def to_dict(self) -> dict:
        return {"name": self.name, "value": self.value, "u": self.u, "U_k2": self.expanded,
                "unit": self.unit, "method": self.method}


def electrical_angle_abs(capture: Capture, pole_pairs: int) -> np.ndarray:
    """The angle channel's electrical angle (rad, unwrapped, *not* re-referenced to the first
    sample: phasors of different captures share its frame)."""
    return np.unwrap(np.asarray(capture["rotor_angle_mech_rad"], dtype=float)) * pole_pairs


def speed_rad_s(capture: Capture) -> float:
    """Mechanical speed (rad/s): slope of the angle channel over the DAQ's time base."""
    theta = np.unwrap(np.asarray(capture["rotor_angle_mech_rad"], dtype=float))
    return float(np.polyfit(np.asarray(capture["time_s"], dtype=float), theta, 1)[0])


def phasors_per_revolution(signal: np.ndarray, theta: np.ndarray, order: int = 1
                           ) -> np.ndarray:
    """X per whole electrical revolution of θ (x ≈ Re(X·e^{j·order·θ}) + c), complex array."""
    return fit_per_revolution(signal, theta, order)[0]


def fit_per_revolution(signal: np.ndarray, theta: np.ndarray, order: int = 1
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(X, c) per whole electrical revolution of θ: the least-squares x ≈ Re(X·e^{j·order·θ}) + c,
    complex and real arrays."""
    direction = 1.0 if theta[-1] >= theta[0] else -1.0
    turns = np.floor((theta - theta[0]) * direction / (2.0 * math.pi))
    phasors, constants = [], []
    for turn in np.unique(turns)[:-1]:
        pick = turns == turn
        if pick.sum() < MIN_SAMPLES_PER_REVOLUTION:
            continue
        angle = order * theta[pick]
        basis = np.column_stack([np.cos(angle), np.sin(angle), np.ones(pick.sum())])
        (a, b, c), *_ = np.linalg.lstsq(basis, np.asarray(signal, dtype=float)[pick], rcond=None)
        phasors.append(complex(a, -b))
        constants.append(float(c))
    if len(phasors) < 2:
        whole = max(len(np.unique(turns)) - 1, 0)
        per_turn = len(theta) / max(whole, 1)
        raise InputError(
            f"the characterisation needs two whole electrical revolutions of at least "
            f"{MIN_SAMPLES_PER_REVOLUTION} samples each; the capture has {whole} of ~"
            f"{per_turn:.3g} samples: the electrical frequency is too high for the capture's "
            "rate (a lower speed, or fewer poles at this speed)")
    return np.array(phasors), np.array(constants)


def _mean_and_u(values: np.ndarray) -> tuple[complex, float, float]:
    """Mean of per-revolution complex values and the type-A u of its real and imaginary parts."""
    n = values.size
    return (complex(values.mean()), float(np.std(values.real, ddof=1) / math.sqrt(n)),
            float(np.std(values.imag, ddof=1) / math.sqrt(n)))


def _lsb_u(capture: Capture, channel: str) -> float:
    """u (same unit as the channel) of a least-squares phasor component from the channel's
    quantisation (capture meta ``daq_lsb``): each sample is off by at most LSB/2, so a component
    (2/N)·Σ x·cos θ by at most (LSB/2)·(4/π); not averaged down (on a slow sinusoid the
    quantisation error is not white), rectangular."""
    table = capture.meta.get("daq_lsb")
    lsb = table.get(channel) if isinstance(table, dict) else None
    if not lsb:
        return 0.0
    return float(lsb) / 2.0 * 4.0 / math.pi / math.sqrt(3.0)


@dataclass(frozen=True)
class BackEmf:
    """The back EMF measured with no current: E_an phasor per mechanical rad/s and ψ."""

    phasor_per_rad_s: complex      # E_an / ω_m (V·s/rad), in the angle channel's frame
    psi: Identified                # peak phase EMF per mechanical rad/s (V·s/rad)
    #: ψ's standard uncertainty without the voltage channel's gain term (V·s/rad): what
    #: propagates into Z, where that gain enters through V − E as a whole
    u_without_gain: float = 0.0


def back_emf(capture: Capture, pole_pairs: int, *, gain_u_rel: float = 0.0) -> BackEmf:
    """ψ from a capture with the drive disabled (``vab_v`` and the angle channel);
    ``gain_u_rel``: the voltage channel's relative gain uncertainty (module docstring)."""
    theta = electrical_angle_abs(capture, pole_pairs)
    omega_m = speed_rad_s(capture)
    values = phasors_per_revolution(capture["vab_v"], theta) * LINE_TO_NEUTRAL / omega_m
    mean, u_re, u_im = _mean_and_u(values)
    magnitude = abs(mean)
    u_a = math.hypot(u_re * mean.real, u_im * mean.imag) / magnitude
    u_q = _lsb_u(capture, "vab_v") / math.sqrt(3.0) / abs(omega_m)
    u_channel = math.hypot(u_a, u_q)
    psi = Identified("emf_peak_v_s_per_rad", magnitude,
                     math.hypot(u_channel, gain_u_rel * magnitude), "V*s/rad",
                     f"back EMF: fundamental of vab_v (÷√3∠30°) over {values.size} electrical "
                     f"revolutions per rad/s of the angle channel's speed, drive disabled, the "
                     f"dyno turning the motor at {omega_m * 60 / (2 * math.pi):.4g} rpm; "
                     + _gain_note(gain_u_rel))
    return BackEmf(mean, psi, u_channel)


def _gain_note(gain_u_rel: float) -> str:
    if gain_u_rel <= 0:
        return "no DAQ gain uncertainty (no accuracy class stated for the DAQ)"
    return (f"DAQ channel gain u = {gain_u_rel * 100:.3g} % (its stated accuracy class, "
            f"rectangular)")


def winding(capture: Capture, emf: BackEmf, pole_pairs: int, *, skew_bound_s: float,
            gain_u_rel: float = 0.0) -> tuple[Identified, Identified]:
    """(R in Ω, L in H) from a capture with the drive regulating current: Z = (V_an − E_an)/I_a.

    ``skew_bound_s``: bound of the time skew between the voltage and the current channels;
    ``gain_u_rel``: each DAQ channel's relative gain uncertainty (voltage and current channels
    independent: Z's relative u from them is √2 × it)."""
    theta = electrical_angle_abs(capture, pole_pairs)
    omega_m = speed_rad_s(capture)
    omega_e = pole_pairs * omega_m
    volts = phasors_per_revolution(capture["vab_v"], theta) * LINE_TO_NEUTRAL
    amps = phasors_per_revolution(capture["ia_a"], theta)
    count = min(volts.size, amps.size)
    volts, amps = volts[:count], amps[:count]
    e_an = emf.phasor_per_rad_s * omega_m
    values = (volts - e_an) / amps
    z, u_re, u_im = _mean_and_u(values)
    i_mean = complex(amps.mean())
    # EMF: δZ = −δE/I, δE = ω_m·δψ along E's direction
    dz_emf = abs(omega_m) * emf.u_without_gain / abs(i_mean)
    dz_gain = math.sqrt(2.0) * gain_u_rel * z          # g_v/g_i: the two channels' gains
    e_dir = e_an / abs(e_an) / (i_mean / abs(i_mean))
    # skew: the channel's δt turns V and the EMF measured through it alike, so V − E by ωe·δt:
    # δZ = j·ωe·δt·Z (δL ≈ δt·R), δt rectangular in ±skew_bound_s
    dz_skew = abs(omega_e) * skew_bound_s / math.sqrt(3.0) * z * 1j
    u_q = math.hypot(_lsb_u(capture, "vab_v") / math.sqrt(3.0),
                     _lsb_u(capture, "ia_a") * abs(z)) / abs(i_mean)
    u_r = math.sqrt(u_re ** 2 + (dz_emf * e_dir.real) ** 2 + dz_skew.real ** 2 + u_q ** 2
                    + dz_gain.real ** 2)
    u_x = math.sqrt(u_im ** 2 + (dz_emf * e_dir.imag) ** 2 + dz_skew.imag ** 2 + u_q ** 2
                    + dz_gain.imag ** 2)
    where = (f"at {abs(i_mean):.4g} A peak, {omega_m * 60 / (2 * math.pi):.4g} rpm, over {count} "
             f"electrical revolutions")
    method = ("terminal voltage vab_v (÷√3∠30°) less the back EMF measured with the drive "
              "disabled, over the phase current ia_a: Z = (V − E)/I = R + jωe·L, {part}; "
              + where + f"; voltage/current skew bound {skew_bound_s * 1e6:.3g} µs; "
              + _gain_note(gain_u_rel) + "; the dead time's voltage error is in the measured "
              "terminal voltage, not in R")
    resistance = Identified("phase_resistance_ohm", z.real, u_r, "ohm",
                            method.format(part="R = Re Z"))
    inductance = Identified("phase_inductance_h", z.imag / omega_e, u_x / abs(omega_e), "H",
                            method.format(part="L = Im Z/ωe"))
    return resistance, inductance
