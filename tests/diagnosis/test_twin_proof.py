"""The closed loop of proof on the digital twin (reduced count for CI; the full count is
``studies/diagnosis_coverage.py``): hidden faults set on the twin, simulated at the designed
points, diagnosed with the forward models only, estimates against the hidden values; and the
suggested calibration applied through the twin's injection knobs reduces the measured ripple."""

import numpy as np
import pytest

from hil.diagnosis.twin_proof import (HiddenFaults, corrected_config, draw_faults, prove,
                                      simulate_points, twin_config)
from ripple_hil_testplans import diagnosis_design as design

POINTS = design.design_points()
SETTINGS = dict(revolutions_elec=design.REVOLUTIONS_ELEC, sample_rate_hz=design.SAMPLE_RATE_HZ,
                max_mech_order=design.MAX_MECH_ORDER)
#: CI draws per group; the full-count coverage is the study's (≥ 50 drives)
CI_DRIVES = 4


def _cases(seed: int, decimation_1: bool):
    rng = np.random.default_rng(seed)
    cases = []
    while len(cases) < CI_DRIVES:
        faults = draw_faults(rng)
        if (faults.encoder_decimation == 1) != decimation_1:
            continue
        cases.append(prove(faults, POINTS, seed=len(cases), **SETTINGS))
    return cases


def test_random_drives_every_identifiable_estimate_within_its_expanded_uncertainty():
    """Drives whose encoder is fine (no count line in band): every identifiable estimate within
    U (k = 2); one miss in the lot is allowed (the study: 100 % over 14 such drives), more is a
    regression."""
    misses, checked = [], 0
    for index, case in enumerate(_cases(2024, decimation_1=True)):
        for check in case.checks:
            if check["identifiable"]:
                checked += 1
                if not check["covered"]:
                    misses.append((index, check))
    assert checked >= 5 * CI_DRIVES
    assert len(misses) <= 1, misses


def test_random_drives_with_a_coarse_encoder():
    """A count line in band: the decimation is found, dead time is not stated, the gain and the
    offsets are within U (k = 2). The offsets' U carries the dwell term (hil.diagnosis.dwell: the
    reference dwells at zero for the count after each zero crossing, the dead-time voltage of that
    count is bounded by ±ε); without it they were under-covered (study: 80-86 %)."""
    for case in _cases(77, decimation_1=False):
        checks = {c["name"]: c for c in case.checks}
        assert checks["encoder_decimation"]["covered"], case.faults
        assert checks["dead_time_us"]["identifiable"] is False
        assert case.diagnosis.encoder["offset_dwell_bound"]["applied"]
        for name in ("gain_k_diff", "ia_offset_a", "ib_offset_a"):
            assert checks[name]["covered"], checks[name]


def test_a_drive_without_faults_diagnoses_as_clean():
    case = prove(HiddenFaults(), POINTS, seed=7, **SETTINGS)
    d = case.diagnosis
    for name in ("ia_offset_a", "ib_offset_a", "gain_k_diff", "dead_time_us"):
        value, u = d.value(name)
        assert abs(value) <= 2 * u + {"ia_offset_a": 2e-3, "ib_offset_a": 2e-3,
                                      "gain_k_diff": 2e-4, "dead_time_us": 0.05}[name], name
    assert d.encoder["detected"] is False
    assert all(c["covered"] for c in case.checks if c["identifiable"])


def test_a_fault_the_design_cannot_see_is_not_invented():
    """Only a cogging term at a free order: the controller estimates stay at zero and the term
    shows in the motor-side residual with the right amplitude."""
    faults = HiddenFaults(cogging=((10, 0.015, 0.4),))
    d = prove(faults, POINTS, seed=3, **SETTINGS).diagnosis
    value, u = d.value("gain_k_diff")
    assert abs(value) <= 2 * u + 2e-4
    residual = {r["mech_order"]: r for r in d.motor_residual}
    assert residual[10]["constant_nm"] == pytest.approx(0.015, rel=0.05)


def test_suggested_calibration_reduces_the_measured_ripple():
    faults = HiddenFaults(ia_offset_a=0.25, ib_offset_a=-0.12, ia_gain_error_pu=0.015,
                          ib_gain_error_pu=-0.01, dead_time_s=1e-6,
                          cogging=((12, 0.004, 0.5),))
    case = prove(faults, POINTS, seed=11, **SETTINGS)
    d = case.diagnosis
    before = [100 * s.pk_pk_nm() / abs(s.mean_torque_nm) for s in d.spectra]
    after_spectra = simulate_points(corrected_config(twin_config(faults), d), POINTS, seed=12,
                                    **SETTINGS)
    after = [100 * s.pk_pk_nm() / abs(s.mean_torque_nm) for s in after_spectra]
    predicted = [row["pk_pk_pct_after"] for row in d.predicted_after_correction()]
    for b, a, p in zip(before, after, predicted):
        assert a < 0.5 * b                          # the calibration removes most of the ripple
        assert a == pytest.approx(p, rel=0.25, abs=0.05)   # as the diagnosis predicted


def test_phase_currents_separate_an_offset_from_a_rotor_fixed_order_1_torque():
    """A cogging term at mechanical order 2 (electrical 1) beside sensor offsets: from the torque
    alone the diagnosis states it cannot tell them apart (and mis-attributes the order-1 torque
    to the offsets, as it says it does); with the phase currents' dc (a DAQ channel known to
    0.5 mA) both are estimated."""
    import dataclasses

    from hil.diagnosis import diagnose
    from hil.diagnosis.twin_proof import twin_setup

    faults = HiddenFaults(ia_offset_a=0.1, ib_offset_a=-0.05, ia_gain_error_pu=0.01,
                          dead_time_s=1.5e-6, cogging=((2, 0.004, 0.7),))
    config = twin_config(faults)
    spectra = simulate_points(config, POINTS, seed=5, **SETTINGS)
    setup = twin_setup(config)
    torque_only = diagnose(spectra, setup=setup, transducer_class_pct=0.1)
    assert torque_only.aliases and "phase currents" in torque_only.aliases[0]["separate_by"]
    with_currents = diagnose(spectra, setup=dataclasses.replace(setup, current_channel_u_a=5e-4),
                             transducer_class_pct=0.1)
    assert not with_currents.aliases
    expected = faults.expected()
    for name in ("ia_offset_a", "ib_offset_a"):
        value, u = with_currents.value(name)
        assert abs(value - expected[name]) <= 2 * u, (name, value, u)
    term = {t["name"]: t for t in with_currents.motor_terms()}["cogging_m2_nm"]
    assert abs(term["amplitude"] - 0.004) <= term["expanded_uncertainty"]
