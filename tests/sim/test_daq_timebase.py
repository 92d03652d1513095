"""The self-check sees the DAQ's time base (issue 30 item 4; hil.daq_timebase).

The holes: DAQ sample instants jittering by ±3/8 of a sample with the tick count nominal passed
every self-check; a DAQ clock 0.5 % slow was caught only by 0.013 rpm of the speed check (and
a 0.4 % one not at all). The simulated defects ``daq_sample_jitter_samples`` and
``daq_clock_scale`` make both happen in the simulated DAQ server; the self-check point, run over
the real stacks (CANopen, Modbus TCP, serial), must fail them by their own checks and pass the
correct DAQ. The bands come from ``studies/daq_timebase_calibration.py`` (hil/model/README.md).
"""

from __future__ import annotations

import pytest

from hil.bench import Bench
from hil.config import default_sim_bench
from hil.measurement import measure_point
from hil.record import RunRecord
from ripple_hil_testplans import conditions as c

CASES = {
    "correct": ({}, set()),
    "clock 0.5 % slow": ({"daq_clock_scale": 0.995}, {"DAQ clock (PWM line)"}),
    "jitter ±3/8 sample": ({"daq_sample_jitter_samples": 0.375},
                           {"DAQ sample instants (encoder)"}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_self_check_sees_the_daq_time_base(tmp_path, case):
    defects, must_fail = CASES[case]
    config = default_sim_bench()
    if defects:
        config = config.with_overrides({"simulation": {"defects": defects}})
    with Bench.open(config, seed=1) as bench:
        record = RunRecord.create(tmp_path, bench.config, bench.identities())
        try:
            outcome = measure_point(bench, record, "self-check",
                                    c.self_check_point(bench.config.operating_point))
        except Exception:
            outcome = None
        entry = record.test("self-check")
        record.finish("complete")
    checks = {item["name"]: item for item in entry["checks"]}
    failed = {name for name, item in checks.items() if not item["passed"]}
    assert must_fail <= failed, {name: checks[name] for name in checks}
    if not defects:
        assert outcome is not None and outcome.passed, failed
    if "clock" in case:       # a clock defect leaves the sample instants coherent
        assert not {n for n in failed if n.startswith("DAQ sample instants")}, failed
        assert checks["DAQ clock (PWM line)"]["line_share"] > 0.5    # the line is there
    if "jitter" in case:      # and jitter smears it (recorded, judged by the encoder)
        assert checks["DAQ clock (PWM line)"]["line_share"] < 0.1
    # the clock read from the PWM line is the defect's, to a few ppm
    if case == "clock 0.5 % slow":
        assert checks["DAQ clock (PWM line)"]["measured"] == pytest.approx(0.995, abs=2e-5)
        # the speed check compares with the setpoint the dyno was given (moved off the carrier
        # lock), so it reads the clock's error alone: neither hidden nor faked by the move
        speed = checks["speed"]
        assert speed["expected"] == entry["operating_point"]["dyno_speed_setpoint_rpm"]
        assert speed["measured"] / speed["expected"] == pytest.approx(1 / 0.995, abs=2e-4)
