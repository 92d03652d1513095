"""Encoder resolution from the count-frequency line (paper eqs 7-9).

A firmware angle truncated to counts of θ_res makes a staircase torque whose lines sit at the
count frequency 2π/θ_res per electrical revolution and its multiples: mechanical order
m = counts per mechanical revolution after decimation. The resolution is discrete, so it is found
by testing the candidates (every decimation d of the encoder's ``counts_per_rev`` whose line
m = counts_per_rev/d is an electrical order inside the band), lowest order first: a candidate is
accepted when the measured line stands clear of the noise (> :data:`DETECTION_Z` σ at every point)
and its amplitude is within a factor :data:`AMPLITUDE_FACTOR` of the eq 7-9 staircase's
(``hil.model.encoder``, through the transducer's response) at every point, at the line and its
second harmonic. Eq 7 assumes ideal
regulation; the line is passed through the loop's T(jω) at its frequency (the loop overshoots
each count step: README, +20..30 % on the twin), and the remaining model error is why a factor
and a phase window are used rather than a fit.
"""

from __future__ import annotations

import math

import numpy as np

from hil.diagnosis import signatures as sig
from hil.diagnosis.orders import OrderSpectrum
from hil.model import predict

DETECTION_Z = 5.0
AMPLITUDE_FACTOR = 2.0
#: Largest phase between a measured line and its prediction (the staircase's phase is fixed by
#: the count's alignment with the rotor; a chance line of another source has any phase): 60°,
#: the angle at which |e^{jφ} − 1| = 1, the relative discrepancy the factor 2 allows below.
PHASE_TOLERANCE_RAD = math.radians(60.0)
#: Harmonics of the count line checked against eq 7 (the loop's overshoot of each count step
#: grows with frequency, so higher harmonics depart further from the ideal-regulation staircase).
CHECKED_HARMONICS = 2


def staircase_lines(spectrum: OrderSpectrum, setup: sig.DriveSetup, counts_per_rev: int,
                    decimation: int, max_mech_order: int) -> dict[int, complex]:
    """Predicted coefficients (N·m) of the eq 7-9 staircase at its count line and its checked
    harmonics inside the band, through the current loop (each count step is a step of the
    reference the loop follows with its T(jω) at the line's frequency) and the transducer:
    {mechanical order: coefficient}."""
    op = sig.operating_point(spectrum.speed_rpm, spectrum.current_a,
                             spectrum.current_angle_rad, setup)
    pred = predict("encoder", op, encoder_counts_per_rev=counts_per_rev,
                   encoder_decimation=decimation)
    order = int(round(pred.order))
    wave = np.asarray(pred.waveform_pu) * pred.base_nm
    theta = np.asarray(pred.angle_rad)
    out = {}
    top = min(CHECKED_HARMONICS, max_mech_order // (spectrum.pole_pairs * order))
    for harmonic in range(1, top + 1):
        k = harmonic * order
        mech = spectrum.pole_pairs * k
        coefficient = 2.0 * np.mean(wave * np.exp(-1j * k * theta))
        line_rad_s = mech * spectrum.speed_rpm / 60.0 * 2.0 * math.pi
        out[mech] = complex(coefficient * sig.transducer_response(mech, spectrum.speed_rpm, setup)
                            * sig.loop_tracking(line_rad_s, op, setup))
    return out


def candidate_decimations(counts_per_rev: int, pole_pairs: int, max_mech_order: int) -> list[int]:
    """Decimations whose count line is an integer electrical order inside the band, from the
    Hall-sensor level (60° electrical, order 6) up (ascending line order)."""
    out = []
    for mech in range(6 * pole_pairs, max_mech_order + 1, pole_pairs):
        if counts_per_rev % mech == 0:
            out.append(counts_per_rev // mech)
    return out


def _line_ratios(spectra, setup, counts_per_rev, decimation, max_mech) -> np.ndarray | None:
    """|measured|/|predicted| at every point and every checked harmonic of the count line whose
    prediction stands clear of the noise; None when any lies outside the accepted factor or
    phase (a staircase puts its lines at multiples of the count frequency, in known proportions
    and at phases fixed by the count's alignment with the rotor angle)."""
    mech = counts_per_rev // decimation
    ratios = []
    for spectrum in spectra:
        lines = staircase_lines(spectrum, setup, counts_per_rev, decimation, max_mech)
        for m, predicted in lines.items():
            if abs(predicted) <= DETECTION_Z * spectrum.sigma_nm[m] and m != mech:
                continue
            quotient = spectrum.coefficients_nm[m] / predicted
            ratio = abs(quotient)
            if not (1.0 / AMPLITUDE_FACTOR <= ratio <= AMPLITUDE_FACTOR
                    and abs(np.angle(quotient)) <= PHASE_TOLERANCE_RAD):
                return None
            ratios.append(ratio)
    return np.array(ratios)


def detect(spectra: list[OrderSpectrum], setup: sig.DriveSetup,
           counts_per_rev: int | None) -> dict:
    """Find the encoder's effective resolution (module docstring); a JSON-ready dict."""
    if not counts_per_rev:
        return {"detected": False, "identifiable": False,
                "note": "encoder counts per revolution unknown (capture meta "
                        "'encoder_counts_per_rev'); encoder not diagnosed"}
    max_mech = min(s.max_mech_order for s in spectra)
    pole_pairs = spectra[0].pole_pairs
    for decimation in candidate_decimations(counts_per_rev, pole_pairs, max_mech):
        mech = counts_per_rev // decimation
        measured = np.array([s.coefficients_nm[mech] for s in spectra])
        sigma = np.array([s.sigma_nm[mech] for s in spectra])
        if not np.all(np.abs(measured) > DETECTION_Z * sigma):
            continue
        ratios = _line_ratios(spectra, setup, counts_per_rev, decimation, max_mech)
        if ratios is None:
            continue
        ratio = float(np.median(ratios))
        resolution_deg = 360.0 * pole_pairs * decimation / counts_per_rev
        return {"detected": True, "identifiable": True, "decimation": decimation,
                "counts_per_rev_effective": mech, "line_mech_order": mech,
                "line_elec_order": mech // pole_pairs,
                "resolution_elec_deg": resolution_deg,
                "hall_level": math.isclose(resolution_deg, 60.0),
                "amplitude_ratio_measured_to_eq7": ratio,
                "line_amplitude_nm": [float(abs(c)) for c in measured],
                "excluded_mech_orders": list(range(mech, max_mech + 1, mech)),
                "note": f"count-frequency line at mechanical order {mech}: the firmware angle "
                        f"has {mech} counts per revolution ({resolution_deg:.3g}° electrical); "
                        f"measured/eq 7 amplitude {ratio:.2f}"}
    finest = max_mech
    return {"detected": False, "identifiable": True, "decimation": None,
            "counts_per_rev_effective_min": finest, "excluded_mech_orders": [],
            "note": f"no count-frequency line up to mechanical order {finest}: the firmware angle "
                    f"has more than {finest} counts per revolution "
                    f"(decimation below {counts_per_rev / finest:.3g})"}
