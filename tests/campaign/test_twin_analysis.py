"""The twin campaign's analysis: ripple figures only (no uncertainty budget), bit for bit the
same as the full analysis; and LocalCluster workers without distributed's malloc trim setting."""

import dataclasses
import os

import numpy as np

from hil.analysis import analyze_torque
from hil.campaign.twin import TwinSettings, twin_ripple_pu
from hil.sim import DriveConfig, Injection, simulate_batch


def drives():
    """A drive with sensor offsets, a gain mismatch and dead time, and one with Hall sensors
    (a step-shaped ripple), both at 500 rpm."""
    faulty = Injection(ia_offset_a=0.05, ib_offset_a=-0.02, ia_gain_error_pu=0.004,
                       dead_time_s=1.2e-6)
    return [DriveConfig(speed_rpm=500, current_command_a=20, injection=faulty),
            DriveConfig(speed_rpm=500, current_command_a=20, injection=Injection(hall_mode=True))]


def test_ripple_figures_without_budget_equal_the_full_analysis_bit_for_bit():
    settings = TwinSettings(revolutions=3)
    for config in drives():
        pole_pairs = config.motor.parameters.pole_pairs
        rate_hz = settings.samples_per_pwm * config.injection.pwm_frequency_hz
        result = simulate_batch([config], settings.duration_s(500, pole_pairs), rate_hz,
                                settle_s=settings.settle_s, parallel=False)[0]
        args = (result["time_s"], result["torque_em_nm"],
                pole_pairs * result["rotor_angle_mech_rad"])
        full = analyze_torque(*args, max_order=64)
        lean = analyze_torque(*args, max_order=64, uncertainty_budget=False)
        assert full.uncertainty is not None and lean.uncertainty is None
        assert lean.to_dict()["uncertainty"] is None
        for item in dataclasses.fields(full):
            if item.name == "uncertainty":
                continue
            a, b = getattr(full, item.name), getattr(lean, item.name)
            if isinstance(a, np.ndarray):
                assert np.array_equal(a, b, equal_nan=True), item.name
            else:
                assert a == b or (a != a and b != b), item.name
        assert full.pk_pk_pu > 0.005  # a real ripple is compared, not a flat line
        # the campaign's per-drive figure is that same pk-pk
        assert twin_ripple_pu([config], settings)[0] == full.pk_pk_pu


def test_local_cluster_workers_do_not_inherit_a_malloc_trim_threshold(client_one):
    """distributed's default MALLOC_TRIM_THRESHOLD_=65536 froze glibc's mmap threshold and made
    the twin's chunks 1.3-2.4x slower on a worker than in-process (hil/campaign/engine.py)."""
    found = client_one.run(lambda: os.environ.get("MALLOC_TRIM_THRESHOLD_"))
    assert found and set(found.values()) == {None}, found
