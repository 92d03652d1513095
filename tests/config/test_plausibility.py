"""Bench-file plausibility (issue 32 Build 5, design.md §6): values in the wrong unit are refused
at load with the value, the unit expected and the likely mistake; every motor the project ships,
tests or studies still loads."""

from __future__ import annotations

import functools
import importlib.util
import sys
from pathlib import Path

import pytest

from hil.cli import main
from hil.config import default_sim_bench, example_bench_path, load_bench
from hil.errors import InputError

STUDIES = Path(__file__).resolve().parents[2] / "studies"


def study(name: str):
    spec = importlib.util.spec_from_file_location(f"plausibility_{name}", STUDIES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module               # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def motor_table(motor) -> dict:
    """A [motor] table of a MotorParameters."""
    return {key: getattr(motor, key) for key in (
        "pole_count", "dc_bus_v", "phase_resistance_ohm", "phase_inductance_h",
        "max_reactance_ohm", "ke_v_s_per_rad", "ke_definition")}


@functools.cache
def every_project_motor() -> dict[str, dict]:
    """Table I, the 2-pole 24 V and 8-pole 48 V motors of the validity and PWM studies, the
    10-pole 48 V and 2-pole 24 V holdout motors of the dead-time calibration."""
    motors = {"table_i": {}}
    motors |= {f"validity:{k}": v for k, v in study("validity").MOTORS.items() if v}
    motors |= {f"pwm:{k}": v for k, v in study("pwm_calibration").MOTORS.items() if v}
    dead_time = study("dead_time_calibration")
    motors |= {f"dead_time:{k}": motor_table(v) for k, v in dead_time.MOTORS.items()}
    return motors


@pytest.mark.parametrize("name", list(every_project_motor()))
def test_every_motor_of_the_project_loads(name):
    table = every_project_motor()[name]
    bench = default_sim_bench().with_overrides({"motor": table})
    assert bench.motor.pole_count == table.get("pole_count", 4)


def test_the_shipped_bench_files_load():
    for name in ("sim-bench", "real-bench"):
        load_bench(example_bench_path(name))


@pytest.mark.parametrize("change, expected", [
    # the case: 38.5 µH written as 38.5 H
    ({"phase_inductance_h": 38.5},
     r"motor\.phase_inductance_h = 38\.5 H .*expected 1e-06 … 1 H.*38\.5 µH was meant: "
     r"write 3\.85e-05"),
    # 55 mΩ written as 55 Ω: L/R of 0.7 µs
    ({"phase_resistance_ohm": 55.0},
     r"L/R = 7e-07 s, not a PM motor winding .*phase_resistance_ohm in mΩ written as Ω"),
    # 38.5 µH written as 38.5 mH: L/R 0.7 s is possible, the top speed of 2.8 rpm is not
    ({"phase_inductance_h": 38.5e-3}, r"top speed at 2\.79 rpm .*wrong unit"),
    # a L/R of seconds with an inductance inside its own range
    ({"phase_inductance_h": 0.5, "phase_resistance_ohm": 0.055, "max_reactance_ohm": 300.0},
     r"L/R = 9\.09 s.*phase_inductance_h in µH or mH written as H"),
    # Ke of Table I in V/krpm (2.41) written as V·s/rad
    ({"ke_v_s_per_rad": 2.41}, r"ke_v_s_per_rad = 2\.41 V·s/rad .* V/krpm \(÷ 104\.7\)"),
    ({"ke_v_s_per_rad": 0.023e-3}, r"only at 2\.03e\+06 rpm"),
    ({"pole_count": 200}, r"pole_count = 200 poles .*slots or encoder pulses"),
    ({"dc_bus_v": 12000.0}, r"dc_bus_v = 12000 V .*expected 1 … 1500 V.*12000 mV was meant"),
])
def test_an_implausible_value_is_refused_with_its_unit_and_likely_mistake(change, expected):
    with pytest.raises(InputError, match=expected):
        default_sim_bench().with_overrides({"motor": change})


def test_a_current_limit_the_winding_could_never_carry_is_refused():
    with pytest.raises(InputError, match=r"limits\.current_a = 60 A .*needs 132 V"):
        default_sim_bench().with_overrides({"motor": {"phase_resistance_ohm": 2.2,
                                                      "phase_inductance_h": 2e-3,
                                                      "max_reactance_ohm": 1.2}})


def test_hil_run_refuses_the_microhenry_mistake_before_the_bench(tmp_path, capsys):
    """Before: exit 0 and every point "not determinable", the reason only in record.json."""
    text = example_bench_path("sim-bench").read_text()
    assert "phase_inductance_h = 38.5e-6" in text
    bench = tmp_path / "bench.toml"
    bench.write_text(text.replace("phase_inductance_h = 38.5e-6", "phase_inductance_h = 38.5"))
    assert main(["run", "--bench", str(bench), "--record-dir", str(tmp_path / "records"),
                 "--source", "baseline", "--no-report"]) == 2
    err = capsys.readouterr().err
    assert "phase_inductance_h = 38.5 H" in err and "38.5 µH was meant" in err
    assert not (tmp_path / "records").exists()
