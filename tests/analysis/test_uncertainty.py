"""Noise, synchronous averaging and the GUM budget of pk_pk_pu."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis_synthetic import ripple, speed_profile_angle
from hil.analysis import InstrumentUncertainty, analyze_torque
from hil.errors import InputError

SAMPLE_RATE_HZ = 20_000.0
MEAN_NM = 1.0


def _noisy(rng, noise_nm, *, duration_s=1.0, amplitude_nm=0.02, order=6, variation=0.05,
           **kwargs):
    time_s = np.arange(int(SAMPLE_RATE_HZ * duration_s)) / SAMPLE_RATE_HZ
    angle = speed_profile_angle(time_s, electrical_hz=40.0, variation=variation)
    torque = ripple(angle, MEAN_NM, {order: (amplitude_nm, 0.3)})
    torque += rng.normal(0.0, noise_nm, time_s.size)
    return analyze_torque(time_s, torque, angle, max_order=32, named_order=order, **kwargs)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("noise_nm", [0.004, 0.02])
def test_noise_bias_within_stated_uncertainty(seed, noise_nm):
    """White noise (up to the ripple amplitude per sample) lifts the pk-pk of the synchronous
    average by no more than the stated expanded uncertainty."""
    res = _noisy(np.random.default_rng(seed), noise_nm)
    true_pu = 2 * 0.02 / MEAN_NM
    assert abs(res.pk_pk_pu - true_pu) <= res.uncertainty.expanded_pu
    assert res.uncertainty.noise_bias_pu > 0


def test_bias_row_tracks_the_real_bias():
    """Over many records the mean excess of pk-pk matches the bias the budget states."""
    excess, stated = [], []
    for seed in range(8):
        res = _noisy(np.random.default_rng(100 + seed), 0.02)
        excess.append(res.pk_pk_pu - 0.04)
        stated.append(res.uncertainty.noise_bias_pu)
    assert np.mean(excess) > 0                                   # the bias is real
    assert np.mean(stated) == pytest.approx(np.mean(excess), rel=0.35)


def test_type_a_shrinks_with_more_revolutions(rng):
    short = _noisy(rng, 0.01, duration_s=0.5)
    long = _noisy(rng, 0.01, duration_s=2.0)
    ratio = short.uncertainty.rows[0].value / long.uncertainty.rows[0].value
    assert ratio == pytest.approx(2.0, rel=0.35)                 # 4x revolutions -> u_A / 2
    assert long.amplitude_u_nm[5] < short.amplitude_u_nm[5]


def test_type_a_amplitude_uncertainty_matches_scatter(rng):
    """u(A_6) predicts the spread of A_6 between independent records."""
    amplitudes, stated = [], []
    for _ in range(12):
        res = _noisy(rng, 0.02, duration_s=0.5)
        amplitudes.append(res.named_amplitude_nm)
        stated.append(res.amplitude_u_nm[5])
    assert np.std(amplitudes, ddof=1) == pytest.approx(np.mean(stated), rel=0.5)


def test_type_b_rows_and_combination(rng):
    instruments = InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                        transducer_full_scale_nm=5.0, daq_bits=16,
                                        daq_range_nm=20.0)
    res = _noisy(rng, 0.004, instruments=instruments)
    budget = res.uncertainty
    rows = {row.source: row for row in budget.rows}
    mean_row = rows["type B: transducer accuracy class, on mean"]
    assert mean_row.value == pytest.approx(0.005)
    assert mean_row.contribution_pu == pytest.approx(
        0.005 / math.sqrt(3) * res.pk_pk_pu / abs(res.mean_torque_nm))
    daq_row = rows["type B: DAQ resolution (1 LSB), on pk-pk"]
    assert daq_row.value == pytest.approx(20.0 / 2 ** 16)
    assert daq_row.divisor == pytest.approx(math.sqrt(6))
    rss = math.sqrt(sum(r.contribution_pu ** 2 for r in budget.rows if r.combination == "rss"))
    assert budget.combined_standard_pu == pytest.approx(rss)
    assert budget.expanded_pu == pytest.approx(2 * rss + abs(budget.noise_bias_pu))
    table = budget.format_table()
    for row in budget.rows:
        assert row.source in table
    assert len(budget.to_dict()["rows"]) == 5


def test_single_revolution_has_no_type_a():
    time_s = np.arange(600) / SAMPLE_RATE_HZ
    angle = speed_profile_angle(time_s, electrical_hz=40.0, start_rad=0.0)
    res = analyze_torque(time_s, ripple(angle, MEAN_NM, {6: (0.02, 0.3)}), angle, max_order=16)
    assert res.revolutions == 1
    assert math.isnan(res.uncertainty.expanded_pu)
    assert any("one revolution" in note for note in res.uncertainty.notes)


@pytest.mark.parametrize("kwargs,name", [
    ({"transducer_accuracy_class_pct": -1.0}, "transducer_accuracy_class_pct"),
    ({"daq_bits": 16}, "daq_range_nm"),
    ({"daq_range_nm": 10.0}, "daq_bits"),
    ({"daq_lsb_nm": -0.1}, "daq_lsb_nm"),
])
def test_instrument_uncertainty_validation_names_the_field(kwargs, name):
    with pytest.raises(InputError, match=name):
        InstrumentUncertainty(**kwargs)
