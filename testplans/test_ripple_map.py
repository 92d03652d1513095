"""Ripple map: the drive as it is (nothing injected) over a grid of speed × current within the
bench limits. No model verdict: each cell records pk-pk, RMS and the order spectrum; the user's
requirements (e.g. "≤ 3 % everywhere below 1500 rpm") judge it. The report draws the map."""

import pytest

from ripple_hil_testplans import conditions as c

pytestmark = pytest.mark.ripple_source("ripple_map")


def plan(config, cell):
    speed_rpm, current_a = cell
    return c.point(config.operating_point, "ripple_map", {}, None, kind="ripple_map",
                   speed_rpm=speed_rpm, current_a=current_a)


@pytest.mark.parametrize("cell", c.RIPPLE_MAP_GRID, ids=c.ripple_map_id)
def test_ripple_map(measure, bench, cell):
    outcome = measure(plan(bench.config, cell))
    assert outcome.passed, outcome.summary()
