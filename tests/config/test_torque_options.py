"""[torque] dialect options from the bench file reach the transducer's dialect."""

import pytest

from ripple_hil_drivers.transducer_dialects import make_dialect
from hil.config import BenchConfig, example_bench_path, load_bench
from hil.errors import InputError


def real_bench(**torque):
    data = load_bench(example_bench_path("real-bench")).to_dict()
    data["torque"].update(torque)
    return BenchConfig.from_dict(data)


def test_dsp7000_channel_and_himmelstein_time_stamps_reach_the_dialect():
    magtrol = real_bench(channel=2).torque
    assert make_dialect(magtrol.dialect, magtrol.dialect_options()).read_command == "OD2"
    himmelstein = real_bench(dialect="himmelstein", baudrate=38400, timestamped=True).torque
    assert make_dialect(himmelstein.dialect, himmelstein.dialect_options()).read_command == "YC"
    default = real_bench(dialect="himmelstein", baudrate=38400).torque
    assert make_dialect(default.dialect, default.dialect_options()).read_command == "DC"


@pytest.mark.parametrize("torque, message", [
    ({"channel": 3}, "channel"),
    ({"dialect": "himmelstein", "baudrate": 38400, "channel": 1}, "Magtrol DSP7000 setting"),
    ({"timestamped": True}, "Himmelstein setting"),
])
def test_options_of_the_wrong_family_are_refused(torque, message):
    with pytest.raises(InputError, match=message):
        real_bench(**torque)
