"""Test-only defects of the simulated drive (``hil.sim.defects``): each does what it says.

A defective twin is compared with a healthy twin told what the defect amounts to (e.g. a hidden
0.25 A offset must produce exactly the run of an injected 0.25 A offset), so every check can fail.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

from hil.config import default_sim_bench, example_bench_path, load_bench
from hil.errors import InputError
from hil.sim import DriveConfig, DriveTwin, Injection
from hil.sim.defects import DriveDefects, parse_defect_option
from hil.simbench import SimulatedBench

OPERATING = DriveConfig(current_command_a=20.0, speed_rpm=500.0)
DURATION_S, RATE_HZ, SETTLE_S = 0.006, 20_000.0, 0.004


def run(injection: dict, defects: DriveDefects | None = None, seed: int = 2) -> tuple:
    """(channels, read-back injection) of a twin commanded ``injection``."""
    twin = DriveTwin(OPERATING, seed=seed, defects=defects)
    if injection:
        twin.set_injection(**injection)
    return twin.advance(DURATION_S, RATE_HZ, settle_s=SETTLE_S), twin.injection


def same_drive(a: dict, b: dict) -> bool:
    return all(np.array_equal(a[name], b[name]) for name in ("ia_a", "ib_a", "torque_em_nm"))


def test_no_defect_is_inactive_and_changes_nothing():
    assert not DriveDefects().active and DriveDefects().to_dict() == {}
    assert DriveDefects().applied(Injection(dead_time_s=2e-6)) == Injection(dead_time_s=2e-6)
    healthy, _ = run({"ia_offset_a": 0.2})
    plain = DriveTwin(OPERATING, seed=2)
    plain.set_injection(ia_offset_a=0.2)
    assert same_drive(healthy, plain.advance(DURATION_S, RATE_HZ, settle_s=SETTLE_S))


@pytest.mark.parametrize("ignored", [("dead_time_s",), ("*",)])
def test_ignored_injection_is_read_back_but_never_applied(ignored):
    defects = DriveDefects(ignore_injection=ignored)
    broken, read_back = run({"dead_time_s": 4e-6}, defects)
    assert read_back.dead_time_s == 4e-6                      # acknowledged
    assert same_drive(broken, run({})[0])                      # ... and not applied
    assert not same_drive(broken, run({"dead_time_s": 4e-6})[0])


def test_ignoring_one_knob_still_applies_the_others():
    defects = DriveDefects(ignore_injection=("dead_time_s",))
    broken, _ = run({"dead_time_s": 4e-6, "ia_offset_a": 0.3}, defects)
    assert same_drive(broken, run({"ia_offset_a": 0.3})[0])


def test_injection_scale_applies_the_scaled_value_and_reads_back_the_commanded_one():
    broken, read_back = run({"ia_offset_a": 0.2, "dead_time_s": 2e-6},
                            DriveDefects(injection_scale=1.5))
    assert read_back.ia_offset_a == 0.2 and read_back.dead_time_s == 2e-6
    assert same_drive(broken, run({"ia_offset_a": 0.2 * 1.5, "dead_time_s": 2e-6 * 1.5})[0])


def test_injection_scale_rounds_integer_knobs_clips_to_range_and_leaves_defaults():
    defects = DriveDefects(injection_scale=1.3)
    applied = defects.applied(Injection(pwm_period_counts=1001, dead_time_s=9e-6))
    assert applied.pwm_period_counts == 1301                   # round(1301.3)
    assert applied.dead_time_s == 10e-6                        # the knob's maximum
    assert applied.encoder_decimation == 1 and applied.pwm_frequency_hz == 20000.0  # defaults


def test_hidden_offsets_act_as_injected_offsets_nobody_commanded():
    defects = DriveDefects(hidden_ia_offset_a=0.25, hidden_ib_offset_a=-0.1)
    broken, read_back = run({}, defects)
    assert read_back == Injection()
    assert same_drive(broken, run({"ia_offset_a": 0.25, "ib_offset_a": -0.1})[0])


def test_word_length_offset_moves_a_fixed_point_word_and_leaves_floating_point():
    defects = DriveDefects(word_length_offset_bits=-2)
    broken, read_back = run({"word_length_bits": 12}, defects)
    assert read_back.word_length_bits == 12
    assert same_drive(broken, run({"word_length_bits": 10})[0])
    assert not same_drive(broken, run({"word_length_bits": 12})[0])
    assert same_drive(run({}, defects)[0], run({})[0])          # 0 = floating point stays


def test_transducer_scale_scales_the_reading_only():
    healthy, _ = run({})
    broken, _ = run({}, DriveDefects(transducer_scale=1.05))
    assert same_drive(broken, healthy)                          # the drive itself is healthy
    np.testing.assert_allclose(broken["torque_nm"], 1.05 * healthy["torque_nm"], rtol=1e-15)
    twin = DriveTwin(OPERATING, seed=2, defects=DriveDefects(transducer_scale=1.05))
    data = twin.advance(DURATION_S, RATE_HZ, settle_s=SETTLE_S)
    assert twin.status()["torque_nm"] == data["torque_nm"][-1]  # the serial transducer's source


def test_from_dict_checks_every_key_and_value():
    defects = DriveDefects.from_dict({"ignore_injection": "dead_time_s, ia_offset_a",
                                      "injection_scale": 2, "daq_drop_every_nth": 10})
    assert defects.ignore_injection == ("dead_time_s", "ia_offset_a")
    assert defects.to_dict() == {"ignore_injection": ["dead_time_s", "ia_offset_a"],
                                 "injection_scale": 2.0, "daq_drop_every_nth": 10}
    assert DriveDefects.from_dict(defects.to_dict()) == defects and defects.active
    for bad, match in [({"injection_scal": 1.2}, "injection_scal"),
                       ({"ignore_injection": ["dead_time"]}, "dead_time"),
                       ({"transducer_scale": 0.0}, "transducer_scale"),
                       ({"transducer_scale": "big"}, "transducer_scale"),
                       ({"word_length_offset_bits": 1.5}, "word_length_offset_bits"),
                       ({"daq_drop_every_nth": 1}, "daq_drop_every_nth"),
                       ({"hidden_ia_offset_a": math.inf}, "hidden_ia_offset_a")]:
        with pytest.raises(InputError, match=match):
            DriveDefects.from_dict(bad)


def test_defect_option_text():
    assert parse_defect_option("injection_scale=1.2") == ("injection_scale", 1.2)
    assert parse_defect_option(" daq_drop_every_nth = 10") == ("daq_drop_every_nth", 10)
    assert parse_defect_option("ignore_injection=dead_time_s,ia_offset_a") == \
        ("ignore_injection", "dead_time_s,ia_offset_a")
    with pytest.raises(InputError, match="KEY=VALUE"):
        parse_defect_option("injection_scale")


def test_bench_file_table_reaches_the_twin():
    bench = default_sim_bench().with_overrides(
        {"simulation": {"defects": {"transducer_scale": 1.05, "daq_drop_every_nth": 10}}})
    assert bench.sim_defects == {"transducer_scale": 1.05, "daq_drop_every_nth": 10}
    assert default_sim_bench().sim_defects == {}
    assert bench.to_dict()["simulation"] == {"defects": bench.sim_defects}
    assert "simulation" not in default_sim_bench().to_dict()
    twin = SimulatedBench(bench).twin                          # built, not started
    assert twin.defects == DriveDefects(transducer_scale=1.05, daq_drop_every_nth=10)
    assert SimulatedBench(default_sim_bench()).twin.defects == DriveDefects()
    with pytest.raises(InputError, match="simulation.defects.transducer_scale"):
        default_sim_bench().with_overrides({"simulation": {"defects": {"transducer_scale": -1}}})
    with pytest.raises(InputError, match="simulation.defect"):
        default_sim_bench().with_overrides({"simulation": {"defect": {}}})


def test_a_real_bench_refuses_defects():
    real = load_bench(example_bench_path("real-bench"))
    with pytest.raises(InputError, match="only with simulated = true"):
        real.with_overrides({"simulation": {"defects": {"injection_scale": 1.2}}})


def test_sim_bench_command_takes_repeatable_defects(monkeypatch):
    """``hil sim-bench --defect`` overrides the file's table before the twin is built."""
    from hil.commands import sim_bench

    built = {}

    class Recording(SimulatedBench):
        def start(self):
            built["defects"] = self.twin.defects
            raise KeyboardInterrupt       # stop before any server starts

    monkeypatch.setattr("hil.simbench.SimulatedBench", Recording)
    monkeypatch.setattr(sim_bench.signal, "signal", lambda *_: None)  # keep pytest's handlers
    args = argparse.Namespace(bench=None, output=None, duration_s=None, seed=0,
                              defect=["injection_scale=1.2", "ignore_injection=dead_time_s"])
    with pytest.raises(KeyboardInterrupt):
        sim_bench.run(args)
    assert built["defects"] == DriveDefects(injection_scale=1.2, ignore_injection=("dead_time_s",))
    args.defect = ["injection_scale"]
    with pytest.raises(InputError, match="KEY=VALUE"):
        sim_bench.run(args)
