"""hil.analysis.switching: the within-PWM-period ripple of the current-based torque estimate.

Synthetic captures carry a known triangular PWM ripple in the torque (through i_q) whose pk-pk is
modulated by a known order-6 envelope; the analysis must recover the envelope's maximum, its order
and phase, and the mean torque. The last tests run the real DriveTwin.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.analysis import DecisionRule, decide
from hil.analysis.switching import analyze_switching, estimated_torque_nm
from hil.capture import Capture
from hil.errors import InputError
from hil.motor import TABLE_I
from hil.sim import DriveTwin

SPEED_RPM = 500.0
ELECTRICAL_HZ = SPEED_RPM / 60.0 * TABLE_I.pole_pairs
PWM_HZ = 20_000.0
#: 9.1 samples per period: the phases walk through the period in 10 periods (one 3° window).
WALKING_RATE_HZ = 182_000.0
MEAN_NM = 1.0
RIPPLE_PK_PK_NM = 0.05
ENVELOPE_DEPTH = 0.2                 # envelope = P·(1 + depth·cos(6θ + phase))
ENVELOPE_PHASE_RAD = 0.7


def triangle(time_s: np.ndarray, frequency_hz: float, phase: float = 0.13) -> np.ndarray:
    """A triangle wave in [-1, 1] (pk-pk 2) at ``frequency_hz``."""
    return 2.0 * np.abs(2.0 * np.mod(time_s * frequency_hz + phase, 1.0) - 1.0) - 1.0


def synthetic_capture(sample_rate_hz: float = WALKING_RATE_HZ, revolutions: float = 4.25,
                      pwm_hz: float = PWM_HZ, **meta) -> Capture:
    """Currents i_a, i_b on the q axis whose torque is MEAN + envelope(θ)/2·triangle(t)."""
    time_s = np.arange(int(revolutions / ELECTRICAL_HZ * sample_rate_hz)) / sample_rate_hz
    angle = 0.4 + 2.0 * math.pi * ELECTRICAL_HZ * time_s
    envelope = RIPPLE_PK_PK_NM * (1.0 + ENVELOPE_DEPTH * np.cos(6 * angle + ENVELOPE_PHASE_RAD))
    torque = MEAN_NM + 0.5 * envelope * triangle(time_s, pwm_hz)
    iq = torque / (1.5 * TABLE_I.emf_peak_v_s_per_rad)           # T = (3/2)·(E/ω_m)·i_q
    channels = {"time_s": time_s, "ia_a": iq * np.sin(angle),
                "ib_a": iq * np.sin(angle - 2.0 * math.pi / 3.0),
                "rotor_angle_mech_rad": angle / TABLE_I.pole_pairs}
    return Capture(channels=channels, units={}, meta={"pole_pairs": TABLE_I.pole_pairs, **meta})


def expected_peak_pu() -> float:
    return RIPPLE_PK_PK_NM * (1.0 + ENVELOPE_DEPTH) / MEAN_NM


def test_estimate_is_the_q_axis_torque():
    capture = synthetic_capture(revolutions=1.0)
    angle = TABLE_I.pole_pairs * capture["rotor_angle_mech_rad"]
    torque = estimated_torque_nm(capture["ia_a"], capture["ib_a"], angle, TABLE_I)
    expected = 1.5 * TABLE_I.emf_peak_v_s_per_rad * capture["ia_a"] / np.sin(angle)
    finite = np.abs(np.sin(angle)) > 0.2
    np.testing.assert_allclose(torque[finite], expected[finite], rtol=1e-9)


def test_recovers_envelope_maximum_order_and_phase():
    result = analyze_switching(synthetic_capture(daq_lsb={"ia_a": 0.005}),
                               pwm_frequency_hz=PWM_HZ, motor=TABLE_I, max_order=24)
    assert result.mean_torque_nm == pytest.approx(MEAN_NM, rel=1e-3)
    # extremes falling between sample phases can only lower the reading, by at most ~2 %
    assert result.pk_pk_pu == pytest.approx(expected_peak_pu(), rel=0.03)
    assert result.pk_pk_pu <= expected_peak_pu() * 1.005
    assert result.dominant_order == 6
    assert result.named_order == 6
    assert result.named_amplitude_nm == pytest.approx(RIPPLE_PK_PK_NM * ENVELOPE_DEPTH, rel=0.05)
    assert abs(np.angle(np.exp(1j * (result.named_phase_rad - ENVELOPE_PHASE_RAD)))) < 0.05
    assert result.order_power_share(6) > 0.95
    assert result.revolutions == 4
    assert any("DAQ current resolution" in row.source for row in result.uncertainty.rows)
    # the expanded uncertainty covers the sampling loss
    assert expected_peak_pu() - result.pk_pk_pu <= result.uncertainty.expanded_pu


def test_result_goes_through_decide():
    result = analyze_switching(synthetic_capture(), pwm_frequency_hz=PWM_HZ, motor=TABLE_I,
                               max_order=24)
    verdict = decide(result, expected_peak_pu(), 6, DecisionRule(rel_tol=0.2, abs_tol_pu=0.002))
    assert verdict.guarded_pass, verdict.reason
    wrong = decide(result, 2 * expected_peak_pu(), 6, DecisionRule(rel_tol=0.2, abs_tol_pu=0.002))
    assert wrong.decision == "fail"


def test_fixed_sample_phases_read_low_and_the_budget_says_so():
    """At exactly 10 samples per period the phases never move: the corners are missed."""
    result = analyze_switching(synthetic_capture(sample_rate_hz=10 * PWM_HZ),
                               pwm_frequency_hz=PWM_HZ, motor=TABLE_I, max_order=24)
    loss = expected_peak_pu() - result.pk_pk_pu
    assert loss > 0.0
    assert loss <= result.uncertainty.expanded_pu
    sampling = [row for row in result.uncertainty.rows if row.source.startswith("sampling")]
    assert sampling and sampling[0].contribution_pu >= loss


def test_encoder_counts_give_the_same_result():
    capture = synthetic_capture()
    cpr = 7200
    counts = np.floor(capture["rotor_angle_mech_rad"] * cpr / (2 * math.pi))
    quantised = Capture(channels={"time_s": capture["time_s"], "ia_a": capture["ia_a"],
                                  "ib_a": capture["ib_a"], "encoder_counts": counts},
                        units={}, meta={"pole_pairs": 2, "encoder_counts_per_rev": cpr})
    exact = analyze_switching(capture, pwm_frequency_hz=PWM_HZ, motor=TABLE_I, max_order=24)
    from_counts = analyze_switching(quantised, pwm_frequency_hz=PWM_HZ, motor=TABLE_I,
                                    max_order=24)
    assert from_counts.pk_pk_pu == pytest.approx(exact.pk_pk_pu, rel=0.01)
    assert from_counts.dominant_order == 6


def test_too_few_samples_per_period_is_refused():
    # 200 kS/s at 40 kHz: 5 samples at the same 5 phases of every period
    with pytest.raises(InputError, match="effective samples per PWM period"):
        analyze_switching(synthetic_capture(sample_rate_hz=200_000.0, pwm_hz=40_000.0),
                          pwm_frequency_hz=40_000.0, motor=TABLE_I, max_order=24)


@pytest.mark.parametrize("missing", ["ia_a", "ib_a", "time_s"])
def test_missing_current_or_time_channel_is_refused(missing):
    capture = synthetic_capture(revolutions=1.5)
    channels = {k: v for k, v in capture.channels.items() if k != missing}
    with pytest.raises(InputError, match=missing):
        analyze_switching(Capture(channels=channels, units={}, meta=capture.meta),
                          pwm_frequency_hz=PWM_HZ, motor=TABLE_I)


def test_missing_angle_is_refused():
    capture = synthetic_capture(revolutions=1.5)
    channels = {k: v for k, v in capture.channels.items() if k != "rotor_angle_mech_rad"}
    with pytest.raises(InputError, match="rotor_angle_mech_rad"):
        analyze_switching(Capture(channels=channels, units={}, meta=capture.meta),
                          pwm_frequency_hz=PWM_HZ, motor=TABLE_I)


@pytest.mark.parametrize("kwargs, match", [
    ({"pwm_frequency_hz": 0.0}, "pwm_frequency_hz"),
    ({"pwm_frequency_hz": math.nan}, "pwm_frequency_hz"),
    ({"max_order": 0}, "max_order"),
    ({"max_order": 100}, "max_order=100"),       # 120 windows per revolution hold order ≤ 59
])
def test_bad_options_are_refused(kwargs, match):
    options = {"pwm_frequency_hz": PWM_HZ, "motor": TABLE_I, "max_order": 24} | kwargs
    with pytest.raises(InputError, match=match):
        analyze_switching(synthetic_capture(revolutions=1.5), **options)


def test_pole_pairs_must_match_the_motor():
    capture = synthetic_capture(revolutions=1.5)
    capture.meta["pole_pairs"] = 3
    with pytest.raises(InputError, match="pole_pairs"):
        analyze_switching(capture, pwm_frequency_hz=PWM_HZ, motor=TABLE_I, max_order=24)


# ------------------------------------------------------------------------ the real DriveTwin
@pytest.fixture(scope="module")
def twin_channels():
    twin = DriveTwin(seed=3)
    twin.set_injection(pwm_frequency_hz=PWM_HZ)
    twin.speed_rpm = SPEED_RPM
    twin.current_command_a = 20.0
    twin.enable()
    return twin.advance(3.25 / ELECTRICAL_HZ, WALKING_RATE_HZ, settle_s=0.05)


def test_estimate_equals_the_twins_electromagnetic_torque(twin_channels):
    angle = TABLE_I.pole_pairs * twin_channels["rotor_angle_mech_rad"]
    torque = estimated_torque_nm(twin_channels["ia_a"], twin_channels["ib_a"], angle, TABLE_I)
    np.testing.assert_allclose(torque, twin_channels["torque_em_nm"], atol=1e-9)


def test_twin_envelope_is_order_6(twin_channels):
    channels = {name: twin_channels[name] for name in ("time_s", "ia_a", "ib_a",
                                                       "rotor_angle_mech_rad")}
    result = analyze_switching(Capture(channels=channels, units={}, meta={"pole_pairs": 2}),
                               pwm_frequency_hz=PWM_HZ, motor=TABLE_I, max_order=24)
    assert result.dominant_order == 6
    assert result.revolutions == 3
    assert 0.0 < result.pk_pk_pu < 0.5


def test_twin_envelope_peaks_midway_between_voltage_zero_crossings(twin_channels):
    """The torque ripple's envelope is largest 30° from the phase-voltage zero crossings, where
    the paper's (phase-current) envelope of eq 31 is zero (see testplans/test_pwm_switching)."""
    from hil.model import OperatingPoint
    from hil.model.pwm_resolution import voltage_phasor

    channels = {name: twin_channels[name] for name in ("time_s", "ia_a", "ib_a",
                                                       "rotor_angle_mech_rad")}
    result = analyze_switching(Capture(channels=channels, units={}, meta={"pole_pairs": 2}),
                               pwm_frequency_hz=PWM_HZ, motor=TABLE_I, max_order=24)
    phasor = voltage_phasor(OperatingPoint(speed_rpm=SPEED_RPM, current_a=20.0))
    voltage_angle = math.atan2(phasor.imag, phasor.real)      # v_a ∝ sin(θ + δ)
    peak_angle = -result.named_phase_rad / 6                   # max of cos(6θ + φ6)
    from_zero_crossing_deg = math.degrees((peak_angle + voltage_angle) % (math.pi / 3))
    assert from_zero_crossing_deg == pytest.approx(30.0, abs=5.0)


def test_windows_longer_than_the_phase_pattern_give_a_finite_uncertainty():
    """195 kHz at 20 kHz repeats its sample phases every 4 PWM periods; windows of 5 periods
    (8 poles at 500 rpm) then fold two samples onto some phases. The sampling-bias bound divided
    by their zero (or rounding-sized) phase step: U was NaN (the correct drive rejected with "no
    finite expanded uncertainty") or ~1e9 pu. Coincident phases are now one point."""
    for rate in (165_000.0, 175_000.0, 195_000.0):
        # 8.25, 8.75, 9.75 samples per period: the phases repeat every 4 periods, windows of 10
        result = analyze_switching(synthetic_capture(sample_rate_hz=rate), pwm_frequency_hz=PWM_HZ,
                                   motor=TABLE_I, max_order=24)
        u = result.uncertainty.expanded_pu
        assert math.isfinite(u) and u < 0.1 * result.pk_pk_pu, (rate, u)
        assert abs(result.pk_pk_pu - expected_peak_pu()) <= u


@pytest.mark.parametrize("rate_hz, pwm_hz, periods, windows", [
    (197_778.0, 20_000.0, 10, 8), (190_256.0, 10_000.0, 1, 40), (187_000.0, 40_000.0, 3, 24),
    (199_500.0, 20_000.0, 1, 40), (195_000.0, 20_000.0, 5, 8), (200_000.0, 20_000.0, 1, 8)])
def test_compiled_phase_gap_is_the_windows_largest_gap(rate_hz, pwm_hz, periods, windows):
    """The pre-flight's compiled gap search gives, bit for bit, what the analysis's array form
    (_largest_phase_gap on the capture's own sample phases) gives on the same samples."""
    from hil.analysis.switching import _largest_phase_gap, effective_samples_per_period

    period_s = 1.0 / pwm_hz
    window_s = periods * period_s
    time_s = np.arange(int(math.ceil(windows * window_s * rate_hz)) + 1) / rate_hz
    index = np.floor(time_s / window_s + 1e-9).astype(np.int64)
    keep = index < windows
    gap = _largest_phase_gap(np.mod(time_s[keep], period_s), index[keep], period_s)
    assert effective_samples_per_period(rate_hz, pwm_hz, periods, windows) == period_s / gap


def test_compiled_corner_excess_bounds_a_triangle_corner_and_merges_repeated_phases():
    """A triangle of period T sampled off its corner: the excess is the corner's rise above the
    largest sample (the lines through the samples on either side meet at the corner); a sample
    repeated at the same phase with a lower value changes nothing; too few points bound nothing."""
    from hil.analysis.switching import _corner_excess

    period_s = 1.0
    phase = np.array([0.05, 0.2, 0.35, 0.45, 0.6, 0.75, 0.9])
    triangle = np.where(phase < 0.4, phase, 0.4 - (phase - 0.4) * 0.6)
    excess = _corner_excess(phase, triangle, period_s)
    assert excess == pytest.approx(0.4 - triangle.max(), rel=1e-12)
    repeated = _corner_excess(np.append(phase, 0.35), np.append(triangle, 0.1), period_s)
    assert repeated == excess
    assert _corner_excess(phase[:4], triangle[:4], period_s) == 0.0
