"""Unit tests of the register map file and its word codecs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ripple_hil_drivers.daq_register_map import DEFAULT_MAP_PATH, load_register_map
from ripple_hil_drivers.modbus_daq import unwrap_counter
from hil.errors import InputError

MAP = load_register_map()


def test_shipped_map_has_no_overlapping_registers_and_a_125_word_window():
    for table in ("input", "holding"):
        spans = sorted((r.address, r.address + r.words, r.name)
                       for r in MAP.registers.values() if r.table == table)
        for (_, end, name), (start, _, other) in zip(spans, spans[1:]):
            assert end <= start, f"{name} overlaps {other}"
    assert MAP["buffer_window"].words == MAP.window_words == 125
    bits = [c.bit for c in MAP.channels]
    assert len(set(bits)) == len(bits)
    assert [c.name for c in MAP.channels] == ["ia_a", "ib_a", "encoder_counts", "torque_nm",
                                              "dc_bus_v", "sample_counter", "vab_v"]


@given(st.floats(-3000, 3000, width=32))
def test_float32_register_round_trips(value):
    reg = MAP["dyno_speed_setpoint_rpm"]
    assert reg.decode(reg.encode(value)) == value


@given(st.integers(0, 2**32 - 1))
def test_uint32_register_is_high_word_first(value):
    words = MAP["samples"].encode(value)
    assert words == [value >> 16, value & 0xFFFF]
    assert MAP["samples"].decode(words) == value


def test_string_register_pads_and_strips():
    reg = MAP["model"]
    assert len(reg.encode("AB")) == reg.words
    assert reg.decode(reg.encode("RHIL-DAQ16")) == "RHIL-DAQ16"


@settings(max_examples=50)
@given(st.lists(st.floats(-160, 160), min_size=1, max_size=50))
def test_int16_channel_round_trips_within_half_an_lsb(values):
    channel = MAP.channel("ia_a")
    raw, clipped = channel.to_raw(np.array(values))
    assert not clipped
    back = channel.from_words(channel.to_words(raw)) * channel.scale + channel.offset
    assert np.all(np.abs(back - values) <= channel.scale / 2 + 1e-12)


def test_int16_channel_saturates_and_flags_clipping():
    channel = MAP.channel("torque_nm")
    raw, clipped = channel.to_raw(np.array([0.0, 100.0, -100.0]))
    assert clipped
    assert raw.tolist() == [0, 32767, -32768]


@settings(max_examples=50)
@given(start=st.integers(-2**31, 2**31 - 1),
       steps=st.lists(st.integers(-30000, 30000), min_size=1, max_size=200))
def test_counter_unwraps_across_the_32_bit_wrap(start, steps):
    counts = start + np.concatenate(([0], np.cumsum(steps)))
    channel = MAP.channel("encoder_counts")
    raw, _ = channel.to_raw(counts)
    words = channel.to_words(raw)
    assert np.array_equal(unwrap_counter(channel.from_words(words)), counts)


def test_resolution_of_the_angle_is_one_count():
    assert math.isclose(2 * math.pi / MAP.device["encoder_counts_per_rev"],
                        math.radians(0.05))


def test_a_map_without_channels_is_refused_naming_the_key(tmp_path):
    text = DEFAULT_MAP_PATH.read_text().split("[[channels]]")[0]
    path = tmp_path / "map.toml"
    path.write_text(text)
    with pytest.raises(InputError, match="channels"):
        load_register_map(path)


def test_a_bad_register_type_is_refused(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text(DEFAULT_MAP_PATH.read_text().replace('type = "float32"', 'type = "float64"'))
    with pytest.raises(InputError, match="float64"):
        load_register_map(path)
