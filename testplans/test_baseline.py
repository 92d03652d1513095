"""Baseline: nothing injected. The bench's own ripple (PWM switching, cogging, EMF harmonics,
sensor noise), kept in the record for comparison with every injected point."""

import pytest

from ripple_hil_testplans import conditions as c

pytestmark = pytest.mark.ripple_source("baseline")


def plan(config):
    return c.point(config.operating_point, "baseline", {}, c.BASELINE_RULE)


def test_baseline(measure, bench):
    outcome = measure(plan(bench.config))
    assert outcome.passed, outcome.summary()
