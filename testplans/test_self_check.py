"""Bench self-check (runs first): does the bench measure what it claims?

Nothing injected, at the bench's operating point: the transducer's mean torque against the
nameplate K_t·I·cos φ, the DAQ's current channels against the commanded current, the encoder
speed against the dyno setpoint, the sample count and time base (hil.selfcheck). A failed
self-check voids every other verdict of the run (the report says so on page 1).
"""

import pytest

from ripple_hil_testplans import conditions as c

pytestmark = pytest.mark.ripple_source("self_check")


def plan(config):
    return c.self_check_point(config.operating_point)


def test_bench_self_check(measure, bench):
    outcome = measure(plan(bench.config))
    assert outcome.passed, outcome.summary()
