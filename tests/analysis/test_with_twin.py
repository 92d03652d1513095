"""The analysis on captures of the real simulated drive (``hil.sim.DriveTwin``): each injected
source shows up at the order design.md names, well above the uninjected baseline."""

from __future__ import annotations

import pytest

from hil.analysis import analyze_capture
from hil.capture import Capture
from hil.sim import DriveTwin

SAMPLE_RATE_HZ = 20_000.0


@pytest.fixture(scope="module")
def twin():
    drive = DriveTwin(seed=1)
    drive.speed_rpm = 600.0          # 20 Hz electrical: 4.2 revolutions in 0.21 s
    drive.current_command_a = 20.0
    drive.enable()
    drive.advance(0.02, SAMPLE_RATE_HZ)
    return drive


def _analyze(drive, **injection):
    drive.restore_defaults()
    drive.set_injection(**injection)
    channels = drive.advance(0.21, SAMPLE_RATE_HZ, settle_s=0.02)
    capture = Capture(channels, meta={"pole_pairs": drive.config.motor.parameters.pole_pairs,
                                      "encoder_counts_per_rev": 7200, "source": "simulation"})
    return analyze_capture(capture, max_order=48)


@pytest.mark.parametrize("injection,order", [
    ({"ia_offset_a": 0.2}, 1),
    ({"ia_gain_error_pu": 0.02, "ib_gain_error_pu": -0.02}, 2),
    ({"dead_time_s": 2e-6}, 6),
])
def test_injected_source_appears_at_its_order(twin, injection, order):
    baseline = _analyze(twin)
    res = _analyze(twin, **injection)
    assert res.revolutions == 4
    assert res.dominant_order == order
    assert res.order_power_share(order) > 0.5
    assert res.pk_pk_pu > 3 * baseline.pk_pk_pu + res.uncertainty.expanded_pu
    assert res.mean_torque_nm == pytest.approx(baseline.mean_torque_nm, rel=0.02)
