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

import cmath
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
                        encoder_counts_per_rev: int | None = None,
                        encoder_decimation: int | None = None,
                        hall_mode: bool = False) -> float:
    """Angle resolution θ_res in electrical radians from one of the ways to state it: Hall
    sectors, a resolution, or an encoder (counts per revolution, decimation); stating it two ways
    at once is refused (one would be ignored)."""
    if resolution_elec_rad is not None and (encoder_decimation is not None
                                            or encoder_counts_per_rev is not None):
        raise InputError("give resolution_elec_rad or encoder_decimation/encoder_counts_per_rev, "
                         "not both (allowed: one way to state the resolution)")
    if hall_mode and (resolution_elec_rad is not None or encoder_decimation not in (None, 1)
                      or encoder_counts_per_rev is not None):
        raise InputError("hall_mode sets a 60° resolution: give it without resolution_elec_rad, "
                         "encoder_decimation or encoder_counts_per_rev (allowed: one of them)")
    if hall_mode:
        return HALL_RESOLUTION_ELEC_RAD
    if encoder_decimation is None:
        encoder_decimation = 1
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


#: The longest common period (electrical revolutions) a resolution given as an angle is
#: searched for: 2π/θ_res is taken as rational only with a denominator up to this.
MAX_PERIOD_ELEC_REVOLUTIONS = 1000


def count_period(*, pole_pairs: int, resolution_elec_rad: float | None = None,
                 encoder_counts_per_rev: int | None = None, encoder_decimation: int | None = None,
                 hall_mode: bool = False) -> tuple[int, int] | None:
    """(m, K): the staircase repeats every m electrical revolutions, and its count order is K
    over that period (K/m per electrical revolution, eq 8's period θ_res = 2π·m/K).

    The firmware truncates the accumulated encoder count to a multiple of the decimation
    (``hil.sim.firmware``: the steps are uniform, decimation × 2π/counts mechanical, whether or
    not the decimation divides the counts), so per electrical revolution there are
    counts/(pole_pairs·decimation) steps, a fraction m/K in lowest terms: 7200 counts on 10 poles
    at decimation 25 give 288/5 (57.6 per electrical revolution, 288 per mechanical one). An
    analysis over one electrical revolution smears such a line over its neighbours; over m it is
    a whole order. A resolution stated as an angle is rational only within 1e-9 of a fraction
    whose denominator is at most ``MAX_PERIOD_ELEC_REVOLUTIONS`` (None: no common period)."""
    from fractions import Fraction

    if hall_mode:
        return 1, 6
    if resolution_elec_rad is not None:
        order = 2.0 * math.pi / resolution_elec_rad
        ratio = Fraction(order).limit_denominator(MAX_PERIOD_ELEC_REVOLUTIONS)
        if abs(float(ratio) - order) > 1e-9 * order:
            return None
    else:
        counts = DRIVE_COUNTS_PER_REV if encoder_counts_per_rev is None else encoder_counts_per_rev
        ratio = Fraction(int(counts), int(pole_pairs) * int(encoder_decimation or 1))
    return ratio.denominator, ratio.numerator


def torque_pu(gamma_rad: np.ndarray, current_angle_rad: float) -> np.ndarray:
    """Eq 7: torque per unit of (3/2)·E·I/ω_m at position error γ within a count."""
    return np.cos(gamma_rad + current_angle_rad)


def paper_pk_pk(resolution_rad: float, current_angle_rad: float) -> float:
    """Eq 9, exact: max − min of cos(γ + φ) over 0 ≤ γ ≤ θ_res, per unit of (3/2)·E·I/ω_m."""
    lo, hi = current_angle_rad, current_angle_rad + resolution_rad
    values = [math.cos(lo), math.cos(hi)]
    for extreme in (0.0, math.pi):  # the maximum / minimum of cos inside the interval
        if lo < extreme < hi:
            values.append(math.cos(extreme))
    return max(values) - min(values)


def staircase_mean_pu(resolution_rad: float, current_angle_rad: float) -> float:
    """Mean of cos(γ + φ) for γ uniform on [0, θ_res): the staircase's mean torque per unit of
    (3/2)·E·I/ω_m (negative when the count lags the EMF by more than 90° on average)."""
    phi = current_angle_rad
    return (math.sin(phi + resolution_rad) - math.sin(phi)) / resolution_rad


def count_order_amplitude_pu(resolution_rad: float, current_angle_rad: float) -> float:
    """Amplitude of the staircase's count-frequency order N = 2π/θ_res (its fundamental), per
    unit of (3/2)·E·I/ω_m: 2·|c|, c = (1/θ_res)·∫₀^θres cos(γ + φ)·e^(−jNγ) dγ (eq 7 over one
    count, eq 8's period), in closed form with cos(γ + φ) = (e^(j(γ+φ)) + e^(−j(γ+φ)))/2 and
    e^(−jNθ_res) = 1:
    c = [e^(jφ)·(e^(jθ_res) − 1)/(j(1 − N)) − e^(−jφ)·(e^(−jθ_res) − 1)/(j(1 + N))]/(2·θ_res).
    Where cos(γ + φ) is nearly linear over a count it is eq 9's pk-pk/π (a sawtooth's
    fundamental)."""
    n = 2.0 * math.pi / resolution_rad
    phi = current_angle_rad
    c = (cmath.exp(1j * phi) * (cmath.exp(1j * resolution_rad) - 1.0) / (1j * (1.0 - n))
         - cmath.exp(-1j * phi) * (cmath.exp(-1j * resolution_rad) - 1.0) / (1j * (1.0 + n))
         ) / (2.0 * resolution_rad)
    return 2.0 * abs(c)


def lagging_ripple_pu(resolution_rad: float, current_angle_rad: float) -> float:
    """Pk-pk per unit of the staircase's mean torque (``Prediction.pk_pk_pu``) at angle φ."""
    return paper_pk_pk(resolution_rad, current_angle_rad) / abs(
        staircase_mean_pu(resolution_rad, current_angle_rad))


def current_angle_for_ripple(resolution_rad: float, target_pu: float) -> float:
    """The current angle φ ≥ 0 (lagging the EMF) at which the staircase ripple per unit of its
    mean torque equals ``target_pu``.

    On 0 ≤ φ < π/2 − θ_res/2 the ripple rises monotonically from its value at φ = 0 without
    bound (the mean torque cos(φ + θ_res/2)·sinc falls to zero), so every target at or above the
    φ = 0 value is reached once; smaller targets need a leading current (the minimum,
    1 − cos(θ_res/2) over the mean, is at φ = −θ_res/2) and raise InputError.
    """
    target = check_range("target_pu", target_pu, 0.0, 1e6, low_open=True)
    floor = lagging_ripple_pu(resolution_rad, 0.0)
    if target < floor:
        raise InputError(
            f"target {100 * target:.4g} % is below the {100 * floor:.4g} % of a current in phase "
            f"with the EMF at {math.degrees(resolution_rad):.4g}° resolution: unreachable on the "
            f"lagging branch (allowed: >= {100 * floor:.4g} %; the least ripple, "
            f"{100 * lagging_ripple_pu(resolution_rad, -resolution_rad / 2):.4g} %, needs the "
            f"current leading by {math.degrees(resolution_rad) / 2:.4g}°)")
    if target == floor:
        return 0.0
    high = math.pi / 2 - resolution_rad / 2
    if high <= 0.0:
        raise InputError(f"resolution {math.degrees(resolution_rad):.4g}° leaves no lagging "
                         "branch with a positive mean torque")
    high = min(high * (1 - 1e-12), math.pi / 2)
    if lagging_ripple_pu(resolution_rad, high) < target:
        raise InputError(f"target {100 * target:.4g} % is not reached below φ = 90°")
    from scipy.optimize import brentq  # loaded when asked: hil predict --target-pct

    return brentq(lambda phi: lagging_ripple_pu(resolution_rad, phi) - target, 0.0, high,
                  xtol=1e-13)


def predict_encoder(op: OperatingPoint, *, resolution_elec_rad: float | None = None,
                    encoder_counts_per_rev: int | None = None,
                    encoder_decimation: int | None = None,
                    hall_mode: bool = False) -> Prediction:
    """Staircase ripple of a quantized rotor angle (eqs 7-9), per unit of its own mean torque."""
    res = encoder_resolution_elec_rad(
        pole_pairs=op.motor.pole_pairs, resolution_elec_rad=resolution_elec_rad,
        encoder_counts_per_rev=encoder_counts_per_rev, encoder_decimation=encoder_decimation,
        hall_mode=bool(hall_mode))
    phi = op.current_angle_rad
    mean_pu = staircase_mean_pu(res, phi)  # the mean torque with the staircase present
    if abs(mean_pu) < 1e-9:
        raise InputError(f"the staircase's mean torque is zero at φ = {math.degrees(phi):.4g}° "
                         f"with {math.degrees(res):.4g}° resolution: no ripple per unit of it "
                         "(allowed: another current_angle_rad)")
    paper = paper_pk_pk(res, phi)
    theta = angle_grid()
    # γ = θ − θ_d; the small guard keeps grid points that sit on a count edge in the new count
    gamma = np.maximum(theta - np.floor(theta / res + 1e-9) * res, 0.0)
    waveform = (torque_pu(gamma, phi) - mean_pu) / abs(mean_pu)
    # (3/2)·E·I/ω_m times |mean|: the base is a magnitude even where the mean torque is negative
    base_nm = op.motor.torque_constant_nm_per_a * op.current_a * abs(mean_pu)
    return Prediction(
        source="encoder", pk_pk_pu=paper / abs(mean_pu), base=STAIRCASE_MEAN_BASE,
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
                # the count order's own pk-pk (2·A_N), per unit of the staircase's mean torque:
                # what a rule with quantity "named_order_pk_pk" judges (hil.analysis.decision)
                "order_pk_pk_pu": 2.0 * count_order_amplitude_pu(res, phi) / abs(mean_pu),
                "mean_torque_sign": 1.0 if mean_pu > 0 else -1.0,
                "count_frequency_order": 2.0 * math.pi / res,
                # the staircase's common period (electrical revolutions) and its count order
                # over it (count_period); None: no common period
                "count_period": count_period(
                    pole_pairs=op.motor.pole_pairs, resolution_elec_rad=resolution_elec_rad,
                    encoder_counts_per_rev=encoder_counts_per_rev,
                    encoder_decimation=encoder_decimation, hall_mode=bool(hall_mode))})
