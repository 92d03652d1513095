"""The shipped EDS: CiA 301/402 objects, and the fault-injection objects against the contract."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ripple_hil_drivers.canopen_eds import (DEFAULT_EDS_PATH, COUNTS_PER_SI_UNIT, current_command_object,
                                 injection_objects, load_dictionary, parse_scaled_name)
from cia306 import check_eds
from eds_text import drop_objects, get_key, set_key, shipped_text, write
from hil.motor import TABLE_I

# The shipped drive's knob ranges (knobs: docs/drive-profile.md), written out independently of
# the EDS: (low, high, default).
CONTRACT = {
    "ia_offset_a": (-20.0, 20.0, 0.0), "ib_offset_a": (-20.0, 20.0, 0.0),
    "ia_gain_error_pu": (-0.2, 0.2, 0.0), "ib_gain_error_pu": (-0.2, 0.2, 0.0),
    "encoder_decimation": (1, 1800, 1), "hall_mode": (False, True, False),
    "word_length_bits": (0, 32, 0), "pwm_period_counts": (8, 65535, 2000),
    "pwm_frequency_hz": (2000, 50000, 20000), "dead_time_s": (0.0, 10e-6, 0.0),
    "current_angle_rad": (-math.pi / 2, math.pi / 2, 0.0),
    # the current loop's test signal (issue 29: characterisation, not a fault)
    "loop_test_amplitude_a": (0.0, 10.0, 0.0), "loop_test_order": (1, 400, 1),
}


def _one_count(obj) -> float:
    return 1.0 / obj.counts_per_si


def test_every_contract_knob_is_one_eds_object_with_the_contract_range():
    objects = injection_objects()
    assert set(objects) == set(CONTRACT)
    assert len({obj.index for obj in objects.values()}) == len(objects)
    for knob, (low, high, default) in CONTRACT.items():
        obj = objects[knob]
        assert 0x2000 <= obj.index <= 0x2FFF
        # Limits equal the contract to within one count of the fixed-point encoding (pi/2 in urad).
        assert obj.low_si == pytest.approx(low, abs=_one_count(obj)), knob
        assert obj.high_si == pytest.approx(high, abs=_one_count(obj)), knob
        assert obj.default_si == default, knob
        # and never allow more than the contract
        assert obj.low_si >= low and obj.high_si <= high, knob


def test_eds_agrees_with_the_sim_injection_ranges():
    from hil.sim import Injection

    ranges = Injection.ranges()
    objects = injection_objects()
    assert set(ranges) == set(objects)
    for knob, spec in ranges.items():
        low, high, default = spec[0], spec[1], spec[2]
        obj = objects[knob]
        assert obj.low_si == pytest.approx(low, abs=_one_count(obj)), knob
        assert obj.high_si == pytest.approx(high, abs=_one_count(obj)), knob
        assert obj.default_si == pytest.approx(default), knob


def test_cia402_identity_and_profile_objects():
    od = load_dictionary(node_id=5)
    assert od[0x1000].default & 0xFFFF == 402
    for index in (0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x606C, 0x6071, 0x6077, 0x60FF, 0x6502,
                  0x1017, 0x100A):
        assert index in od, hex(index)
    for sub in range(1, 5):
        assert sub in od[0x1018]
    for index in (0x6040, 0x6041, 0x6061, 0x6064, 0x606C, 0x6077):
        assert od[index].pdo_mappable, hex(index)
    # supported modes: profile velocity/torque, cyclic synchronous velocity/torque
    assert od[0x6502].default == 0x4 | 0x8 | 0x100 | 0x200
    # default COB-IDs carry the node id (predefined connection set)
    assert od[0x1800][1].default == 0x185
    assert od[0x1400][1].default == 0x205


def test_rated_torque_is_the_table_i_torque_at_rated_current():
    od = load_dictionary()
    rated_current_a = od[0x6075].default / 1000.0
    rated_torque_nm = od[0x6076].default / 1000.0
    assert rated_torque_nm == pytest.approx(TABLE_I.torque_constant_nm_per_a * rated_current_a,
                                            abs=0.0005)
    assert current_command_object().high_si == 100.0


@pytest.mark.parametrize("name, expected", [
    ("dead_time_s [ns]", ("dead_time_s", "ns")),
    ("hall_mode [bool]", ("hall_mode", "bool")),
    ("Statusword", None),
    ("dead_time_s [fortnights]", None),
])
def test_parameter_name_convention(name, expected):
    assert parse_scaled_name(name) == expected


def test_fixed_point_encoding_round_trips_and_quantises():
    objects = injection_objects()
    dead = objects["dead_time_s"]
    assert dead.to_count(2.5e-6) == 2500 and dead.to_si(2500) == 2.5e-6
    offset = objects["ia_offset_a"]
    assert offset.to_si(offset.to_count(0.01234)) == 0.012  # nearest mA
    assert objects["hall_mode"].to_si(1) is True
    assert objects["encoder_decimation"].to_si(100) == 100
    assert set(COUNTS_PER_SI_UNIT) >= {obj.unit for obj in objects.values()}


@pytest.mark.parametrize("knob, value, message", [
    ("ia_offset_a", 20.5, "outside -20..20"),
    ("dead_time_s", -1e-9, "outside 0..1e-05"),
    ("encoder_decimation", 2.5, "must be an integer"),
    ("encoder_decimation", 0, "outside 1..1800"),
    ("current_angle_rad", float("nan"), "outside"),
    ("ia_gain_error_pu", "big", "expected a number"),
])
def test_check_si_names_knob_and_range(knob, value, message):
    with pytest.raises(ValueError, match=message) as info:
        injection_objects()[knob].check_si(value)
    assert knob in str(info.value)


def test_eds_file_is_shipped_as_package_data():
    assert DEFAULT_EDS_PATH.name == "ripple_drive.eds" and DEFAULT_EDS_PATH.is_file()


def test_object_table_is_rendered_from_the_eds():
    from ripple_hil_drivers.canopen_eds import object_table_markdown
    table = object_table_markdown()
    assert "| 0x200A | `dead_time_s` | ns | 0..1e-05 | 0.0 |" in table
    assert "0x64616F6C" in table
    assert len(table.splitlines()) == 2 + len(CONTRACT) + 2


@given(data=st.data())
@settings(max_examples=200, deadline=None)
def test_any_in_range_value_is_accepted_and_quantised_to_half_a_count(data):
    objects = injection_objects()
    obj = objects[data.draw(st.sampled_from(sorted(objects)))]
    if obj.is_bool:
        value = data.draw(st.booleans())
    elif obj.is_integer:
        value = data.draw(st.integers(obj.low_count, obj.high_count))
    else:
        value = data.draw(st.floats(obj.low_si, obj.high_si, allow_nan=False))
    count = obj.check_si(value)
    assert obj.low_count <= count <= obj.high_count
    assert abs(obj.to_si(count) - value) <= 0.5 / obj.counts_per_si + 1e-12


# ------------------------------------------------------------------ CiA 306, strictly
def test_communication_objects_the_drive_uses_are_described():
    od = load_dictionary(node_id=5)
    assert od[0x1005].default == 0x80                  # SYNC consumed on 0x080
    assert od[0x1014].default == 0x80 + 5               # EMCY produced on 0x080 + node-ID
    for index in (0x1005, 0x1014, 0x6075, 0x6076):      # CiA 301 / CiA 402: rw
        assert od[index].access_type == "rw", hex(index)
    assert od[0x6076].min >= 1                          # a divisor of every per-mille value


def test_the_shipped_eds_passes_the_strict_cia306_check_and_eds_utils():
    from eds_utils.core.file_io.read_eds import read_eds
    assert check_eds(DEFAULT_EDS_PATH) == []
    assert read_eds(str(DEFAULT_EDS_PATH))[1] == []


def _planted():
    """(what, edit) pairs, each one CiA 306 fault, and the words the checker must report."""
    high = get_key(shipped_text(), "2002", "HighLimit")
    return {
        "object count": (lambda t: set_key(t, "OptionalObjects", "SupportedObjects", "36"),
                         "[OptionalObjects] SupportedObjects=36 but 37 entries"),
        "data type": (lambda t: set_key(t, "2001", "DataType", "0x0099"),
                      "[2001] DataType 0x0099 is not a CiA 301 basic data type"),
        "access type": (lambda t: set_key(t, "6040", "AccessType", "rx"),
                        "[6040] AccessType 'rx'"),
        "default above limit": (lambda t: set_key(t, "2002", "DefaultValue", str(int(high) + 1)),
                                f"[2002] DefaultValue {int(high) + 1} outside LowLimit..HighLimit"),
        "mapped string": (lambda t: set_key(t, "1008", "PDOMapping", "1"),
                          "[1008] PDOMapping=1 on VISIBLE_STRING"),
        "sub number": (lambda t: set_key(t, "1018", "SubNumber", "4"),
                       "[1018] SubNumber=4 but 5 sub-index sections"),
    }


@pytest.mark.parametrize("fault", ["object count", "data type", "access type",
                                   "default above limit", "mapped string", "sub number"])
def test_each_planted_fault_is_rejected_by_name(tmp_path, fault):
    edit, words = _planted()[fault]
    faults = check_eds(write(edit(shipped_text()), tmp_path / "faulty.eds"))
    assert len(faults) == 1 and words in faults[0], faults


def test_a_copy_with_four_planted_faults_is_rejected(tmp_path):
    """The issue's case: python-canopen imported such a copy without a word."""
    planted = _planted()
    text = shipped_text()
    for fault in ("object count", "data type", "access type", "default above limit"):
        text = planted[fault][0](text)
    path = write(text, tmp_path / "four-faults.eds")
    faults = check_eds(path)
    for fault in ("object count", "data type", "access type", "default above limit"):
        assert sum(planted[fault][1] in f for f in faults) == 1, (fault, faults)
    assert len(faults) == 4
    load_dictionary(path)        # what the project relied on before: it raises nothing


def test_leaving_out_optional_identity_objects_keeps_the_eds_valid(tmp_path):
    path = write(drop_objects(shipped_text(), [0x1008, 0x100A]), tmp_path / "lean.eds")
    assert check_eds(path) == []
    assert 0x1008 not in load_dictionary(path) and 0x1018 in load_dictionary(path)
