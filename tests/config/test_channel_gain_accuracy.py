"""The voltage/current channels' gain bound for the characterisation's U (issue 29): read from
the accuracy class of the instrument that acquires them, as data sheets write it."""

import math
import tomllib

import pytest

from hil.config import BenchConfig, default_sim_bench, example_bench_path
from hil.errors import InputError
from hil.simbench import check_fixed_addresses


def _bench(role: str, accuracy: str, **acquisition) -> BenchConfig:
    data = tomllib.loads(example_bench_path("real-bench").read_text())
    for entry in data["instrument"]:
        if entry["role"] == role:
            entry["accuracy_class"] = accuracy
    if role == "acquisition":
        data["instrument"].append({"role": "acquisition", "model": "scope", "serial_number": "S1",
                                   "accuracy_class": accuracy})
    if acquisition:
        data["acquisition"] = acquisition
    return BenchConfig.from_dict(data)


@pytest.mark.parametrize("written, bound_pct", [
    ("0.5 % FS", 0.5), ("±0.5 % FS", 0.5), ("+/-0.5 %FSR", 0.5), ("0.5 % of reading", 0.5),
    ("±0.2 % rdg", 0.2)])
def test_the_daq_class_bounds_the_gain(written, bound_pct):
    assert _bench("daq", written).daq_gain_u_rel() == pytest.approx(
        bound_pct / 100 / math.sqrt(3))


def test_an_unreadable_daq_class_is_refused_not_read_as_none():
    with pytest.raises(InputError, match="not a percentage of full scale or of reading"):
        _bench("daq", "class A")


def test_a_scope_bench_takes_the_scope_class_not_the_daq_class():
    bench = _bench("acquisition", "1 % of reading", kind="scpi-scope",
                   resource="TCPIP::10.0.0.5::5025::SOCKET")
    assert bench.daq_gain_u_rel() == pytest.approx(0.01 / math.sqrt(3))


def test_a_voltage_gain_the_simulated_scope_cannot_apply_is_refused():
    config = default_sim_bench().with_overrides(
        {"acquisition": {"kind": "scpi-scope"},
         "simulation": {"actual": {"daq_voltage_gain": 1.004}}})
    with pytest.raises(InputError, match="daq_voltage_gain is the Modbus DAQ's"):
        check_fixed_addresses(config)
