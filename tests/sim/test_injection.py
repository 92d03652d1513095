"""``hil.sim.Injection`` keeps to the contract table of COMMON.md."""

from __future__ import annotations

import math

import pytest

from hil.sim import Injection

CONTRACT = {  # name: (min, max, default), from the COMMON.md table
    "ia_offset_a": (-20, 20, 0.0), "ib_offset_a": (-20, 20, 0.0),
    "ia_gain_error_pu": (-0.2, 0.2, 0.0), "ib_gain_error_pu": (-0.2, 0.2, 0.0),
    "encoder_decimation": (1, 1800, 1), "hall_mode": (False, True, False),
    "word_length_bits": (0, 32, 0), "pwm_period_counts": (8, 65535, 2000),
    "pwm_frequency_hz": (2000, 50000, 20000), "dead_time_s": (0, 10e-6, 0.0),
    "current_angle_rad": (-math.pi / 2, math.pi / 2, 0.0),
    # the current loop's test signal (issue 29: characterisation, not a fault)
    "loop_test_amplitude_a": (0.0, 10.0, 0.0), "loop_test_order": (1, 400, 1),
}


def test_fields_defaults_and_ranges_match_the_contract():
    assert Injection.FIELDS == tuple(CONTRACT)
    ranges = Injection.ranges()
    defaults = Injection()
    for name, (low, high, default) in CONTRACT.items():
        assert (ranges[name].min, ranges[name].max, ranges[name].default) == (low, high, default)
        assert getattr(defaults, name) == default
        assert ranges[name].unit


@pytest.mark.parametrize("name, value", [
    ("ia_offset_a", 20.5), ("ib_gain_error_pu", -0.3), ("encoder_decimation", 0),
    ("encoder_decimation", 2.5), ("word_length_bits", 5), ("word_length_bits", 33),
    ("pwm_period_counts", 7), ("pwm_frequency_hz", 60000.0), ("dead_time_s", -1e-9),
    ("current_angle_rad", 2.0), ("hall_mode", "yes"), ("ia_offset_a", float("nan")),
    ("dead_time_s", "1e-6"),
])
def test_out_of_range_value_is_refused_naming_field_and_range(name, value):
    with pytest.raises(ValueError) as error:
        Injection(**{name: value})
    assert name in str(error.value)
    assert "[" in str(error.value) or "bool" in str(error.value)


def test_limits_are_accepted_and_with_values_copies():
    edge = Injection(ia_offset_a=-20.0, word_length_bits=6, pwm_period_counts=65535,
                     dead_time_s=10e-6, hall_mode=True, current_angle_rad=math.pi / 2)
    changed = edge.with_values(ia_offset_a=1.0)
    assert changed.ia_offset_a == 1.0 and edge.ia_offset_a == -20.0
    assert changed.word_length_bits == 6
    with pytest.raises(ValueError, match="unknown injection knob"):
        edge.with_values(offset_a_pu=0.01)
    assert set(Injection().as_dict()) == set(CONTRACT)
