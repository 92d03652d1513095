"""Issue 21 items 4, 7 and 8: the defects the first mutation suite could not express make the
plans that exist to catch them fail, and the same plans pass a correct drive away from the
default point (reverse rotation, another motor with another pole count, a current angle).

The defect cases are run by ``test_mutations.py`` (with the first suite's); this module runs the
correct drive off the default point, end to end over the real stacks
(``mutation_run.run_plans``), as ``hil run --bench COPY`` does.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hil.config import example_bench_path
from mutation_run import failed_sources, run_plans

pytestmark = [pytest.mark.integration, pytest.mark.slow]

#: The new defects (issue 21 item 8); tests/mutations/test_mutations.py runs them with the
#: first suite's cases (one test for all).
PHASE_CASES = [
    # defect, plans run, plans that must fail
    # offsets on the other sensor: same order-1 magnitude, phase 60..180 degrees away
    ({"sensor_injection_swapped": True}, ["dc_offset", "gain_mismatch"],
     {"dc_offset", "gain_mismatch"}),
    # g applied as 1/(1+g): k_a - k_b changes sign, the order-2 phase flips by pi
    ({"gain_applied_inverse": True}, ["gain_mismatch"], {"gain_mismatch"}),
    # the drive's encoder index 20 degrees (electrical) off: mean torque x cos 20 deg, and the
    # order-2 phase of a gain mismatch moves with the current angle
    ({"encoder_index_offset_rad": 0.35}, ["self_check", "gain_mismatch"],
     {"self_check", "gain_mismatch"}),
    # the transducer lags 1 ms more than the bench file states
    ({"transducer_extra_lag_s": 1e-3}, ["self_check"], {"self_check"}),
    # the firmware compensates 70 % of the dead time: the ripple is 0.3x the model's
    ({"dead_time_compensation_pu": 0.7}, ["dead_time"], {"dead_time"}),
    # the current loop runs at half the bandwidth the bench file states: the characterisation
    # measures it (issue 29) and states it as a finding about the drive; the dead-time plan then
    # predicts with the measured loop (before the characterisation stage it failed instead)
    ({"current_loop_bandwidth_scale": 0.5}, ["dead_time", "characterisation"],
     {"characterisation"}),
]


def bench_at(folder: Path, *, speed_rpm: float, current_a: float, current_angle_deg: float,
             pole_count: int = 4, ke_v_s_per_rad: float = 0.023) -> Path:
    """A copy of the example simulated bench with another operating point and motor."""
    text = example_bench_path("sim-bench").read_text()
    point = (f"[operating_point]\nspeed_rpm = {speed_rpm}\ncurrent_a = {current_a}\n"
             f"current_angle_deg = {current_angle_deg}\n")
    text, n = re.subn(r"\[operating_point\]\n(?:[^\[\n][^\n]*\n)*", point + "\n", text)
    assert n == 1
    text, n = re.subn(r"\npole_count = 4", f"\npole_count = {pole_count}", text)
    assert n == 1
    text, n = re.subn(r"\nke_v_s_per_rad = 0.023", f"\nke_v_s_per_rad = {ke_v_s_per_rad}", text)
    assert n == 1
    path = folder / "bench.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("where", [
    dict(speed_rpm=-800.0, current_a=15.0, current_angle_deg=0.0),
    dict(speed_rpm=300.0, current_a=10.0, current_angle_deg=20.0, pole_count=8,
         ke_v_s_per_rad=0.03),
], ids=["reverse-800rpm-15A", "8-pole-300rpm-10A-20deg"])
def test_a_correct_drive_passes_phase_and_dynamics_off_the_default_point(where, tmp_path):
    run = run_plans(["self_check", "dc_offset", "gain_mismatch"], {}, tmp_path,
                    bench=bench_at(tmp_path, **where))
    assert set(run["outcomes"]) == {"self_check", "dc_offset", "gain_mismatch"}, run["output"]
    assert failed_sources(run) == set(), run["output"]
    assert run["returncode"] == 0, run["output"]
