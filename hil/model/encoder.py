"""Finite encoder resolution (paper section III-A, eqs 1-9), Hall sensors as the 60° case.

The firmware computes the current command from the discrete angle θ_d = θ − γ, 0 ≤ γ < θ_res
(the angle truncated to the last count). With ideal current regulation i_a = I·sin(θ_d − φ) and
e_a = E·sin θ, the torque sum gives eq 7: T = (3/2)·(E·I/ω_m)·cos(γ + φ), periodic in the count
(eq 8). Eq 9's pk-pk is max − min of cos(γ + φ) over one count, per unit of (3/2)·E·I/ω_m.

Paper figure: "4.5 % at 10 electrical degrees" is reproduced with φ = 10° (current lagging the EMF
by one count): cos 10° − cos 20° = 4.51 %. With φ = 0 eq 9 gives only 1.52 %; the worst case over
φ (φ = 85°) gives 17.4 %. So φ is a parameter (``current_angle_rad`` of the operating point).
"""

from __future__ import annotations

import math

import numpy as np

from hil.errors import InputError
from hil.model.core import OperatingPoint, Prediction, angle_grid, check_range

#: The drive's encoder (contract): 7200 counts per mechanical revolution.
DRIVE_COUNTS_PER_REV = 7200
HALL_RESOLUTION_ELEC_RAD = math.pi / 3.0
#: The current angle that reproduces the paper's "4.5 % at 10°" (Fig. 3).
PAPER_FIG3_CURRENT_ANGLE_RAD = math.radians(10.0)


STAIRCASE_MEAN_BASE = ("mean torque (3/2)·E·I/ω_m·mean(cos(γ+φ)) of the staircase at the "
                       "operating point")


def encoder_resolution_elec_rad(*, pole_pairs: int, resolution_elec_rad: float | None = None,
                        encoder_counts_per_rev: int | None = None, encoder_decimation: int = 1,
                        hall_mode: bool = False) -> float:
    """Angle resolution θ_res in electrical radians from one of the ways to state it."""
    if hall_mode:
        return HALL_RESOLUTION_ELEC_RAD
    if resolution_elec_rad is not None:
        return check_range("resolution_elec_rad", resolution_elec_rad, 0.0, math.pi, unit=" rad",
                           low_open=True)
    if encoder_counts_per_rev is None:
        encoder_counts_per_rev = DRIVE_COUNTS_PER_REV
    counts = check_range("encoder_counts_per_rev", encoder_counts_per_rev, 1, 10**9)
    decimation = check_range("encoder_decimation", encoder_decimation, 1, 1800)
    if decimation != int(decimation):
        raise InputError(f"encoder_decimation={encoder_decimation!r} must be an integer 1..1800")
    return 2.0 * math.pi * pole_pairs * decimation / counts


def torque_pu(gamma_rad: np.ndarray, current_angle_rad: float) -> np.ndarray:
    """Eq 7: torque per unit of (3/2)·E·I/ω_m at position error γ within a count."""
    return np.cos(gamma_rad + current_angle_rad)


def paper_pk_pk(resolution_rad: float, current_angle_rad: float) -> float:
    """Eq 9, exact: max − min of cos(γ + φ) over 0 ≤ γ ≤ θ_res, per unit of (3/2)·E·I/ω_m."""
    lo, hi = current_angle_rad, current_angle_rad + resolution_rad
    values = [math.cos(lo), math.cos(hi)]
    if lo < 0.0 < hi:  # the maximum of cos inside the interval
        values.append(1.0)
    return max(values) - min(values)


def predict_encoder(op: OperatingPoint, *, resolution_elec_rad: float | None = None,
                    encoder_counts_per_rev: int | None = None, encoder_decimation: int = 1,
                    hall_mode: bool = False) -> Prediction:
    """Staircase ripple of a quantized rotor angle (eqs 7-9), per unit of its own mean torque."""
    res = encoder_resolution_elec_rad(
        pole_pairs=op.motor.pole_pairs, resolution_elec_rad=resolution_elec_rad,
        encoder_counts_per_rev=encoder_counts_per_rev, encoder_decimation=encoder_decimation,
        hall_mode=bool(hall_mode))
    phi = op.current_angle_rad
    # Mean of cos(γ+φ) for γ uniform on [0, θ_res): the mean torque with the staircase present.
    mean_pu = (math.sin(phi + res) - math.sin(phi)) / res
    paper = paper_pk_pk(res, phi)
    theta = angle_grid()
    # γ = θ − θ_d; the small guard keeps grid points that sit on a count edge in the new count
    gamma = np.maximum(theta - np.floor(theta / res + 1e-9) * res, 0.0)
    waveform = (torque_pu(gamma, phi) - mean_pu) / mean_pu
    base_nm = op.mean_torque_nm / math.cos(phi) * mean_pu
    return Prediction(
        source="encoder", pk_pk_pu=paper / mean_pu, base=STAIRCASE_MEAN_BASE,
        base_nm=base_nm, order=2.0 * math.pi / res, inputs={
            "resolution_elec_rad": res, "resolution_elec_deg": math.degrees(res),
            "hall_mode": bool(hall_mode), "encoder_counts_per_rev": encoder_counts_per_rev,
            "encoder_decimation": encoder_decimation, **op.to_dict()},
        equations="eqs 7-9", assumptions=[
            "ideal current regulation: phase currents follow the staircase command exactly",
            "firmware angle truncated to the last count: 0 <= γ < θ_res",
            "sinusoidal back EMF, no cogging"],
        angle_rad=theta, waveform_pu=waveform,
        extras={"paper_pk_pk_pu": paper, "paper_base": "(3/2)·E·I/ω_m (eq 9)",
                "count_frequency_order": 2.0 * math.pi / res})
