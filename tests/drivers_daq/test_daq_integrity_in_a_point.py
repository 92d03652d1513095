"""A capture that fails its integrity check fails the point, with its raw data recorded and the
bench made safe (``hil.measurement`` through the simulated bench)."""

from __future__ import annotations

import numpy as np
import pytest

from ripple_hil_drivers.modbus_daq import CaptureIntegrityError
from hil.capture import Capture
from hil.measurement import PointPlan, measure_point
from hil.sim.defects import DriveDefects

pytestmark = [pytest.mark.integration, pytest.mark.timeout(120)]


def test_a_point_whose_daq_drops_samples_errors_and_keeps_the_data(sim_bench, run_record):
    sim_bench.simulated.twin.defects = DriveDefects(daq_drop_every_nth=10)
    plan = PointPlan(source="baseline", injection={}, speed_rpm=500.0, current_a=20.0,
                     revolutions=2)
    with pytest.raises(CaptureIntegrityError, match="time base not uniform"):
        measure_point(sim_bench, run_record, "dropping-daq", plan)
    assert sim_bench.drive.state == "SWITCH ON DISABLED"
    entry = run_record.tests[-1]
    assert entry["outcome"] == "error" and "samples lost" in entry["error"]
    saved = Capture.load(run_record.path / entry["capture"]["file"])
    assert len(saved) == entry["capture"]["n_samples"] > 0
    steps = np.diff(saved["sample_counter"])
    assert set(steps.tolist()) == {1, 2}                   # the gaps are in the raw data
    assert saved.meta["daq_integrity"]["problems"]
    assert set(saved.channels) >= {"torque_nm", "ia_a", "ib_a", "rotor_angle_mech_rad"}
    assert "dc_bus_v" not in saved                         # the plan did not need it
