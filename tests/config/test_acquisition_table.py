"""``[acquisition]``: which instrument the plans capture with (issue 31 item 3)."""

import tomllib

import pytest

from hil.config import BenchConfig, example_bench_path
from hil.errors import InputError


def real_bench(**acquisition) -> dict:
    data = tomllib.loads(example_bench_path("real-bench").read_text())
    if acquisition:
        data["acquisition"] = acquisition
    return data


def test_the_daq_captures_unless_the_file_says_otherwise():
    bench = BenchConfig.from_dict(real_bench())
    assert bench.acquisition.kind == "modbus-daq" and bench.acquisition.resource is None


def test_a_scope_on_a_real_bench_needs_its_resource():
    with pytest.raises(InputError, match="acquisition.resource is required"):
        BenchConfig.from_dict(real_bench(kind="scpi-scope"))
    bench = BenchConfig.from_dict(real_bench(kind="scpi-scope",
                                             resource="TCPIP::10.0.0.5::5025::SOCKET"))
    assert bench.to_dict()["acquisition"]["resource"] == "TCPIP::10.0.0.5::5025::SOCKET"


@pytest.mark.parametrize("table, words", [
    ({"kind": "modbus-daq", "resource": "TCPIP::x::5025::SOCKET"}, "acquisition.resource"),
    ({"kind": "oscilloscope"}, "acquisition.kind"),
])
def test_a_bad_acquisition_table_is_named(table, words):
    with pytest.raises(InputError, match=words):
        BenchConfig.from_dict(real_bench(**table))
