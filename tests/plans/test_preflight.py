"""Pre-flight (hil.preflight): a bad point is found from the bench file, the EDS and the DAQ map
alone, before any bench command; every shipped plan point passes it on the simulated bench."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from hil.config import default_sim_bench
from hil.measurement import PointPlan
from hil.preflight import check_point, voltage_limit_v, voltage_needed_v
from hil.requirements import requirement_from_dict
from ripple_hil_testplans import conditions as c

CONFIG = default_sim_bench()


def point(**overrides):
    settings = {"source": "dc_offset", "injection": {"ia_offset_a": 0.2}, "speed_rpm": 500.0,
                "current_a": 20.0, "rule": c.CLOSED_FORM_RULE}
    return PointPlan(**settings | overrides)


def test_a_good_point_has_no_problem():
    assert check_point(point(), CONFIG) == []


@pytest.mark.parametrize("overrides, message", [
    ({"speed_rpm": 3500.0}, "exceeds limits.speed_rpm"),
    ({"current_a": 80.0}, "limits.current_a"),
    ({"speed_rpm": 2900.0}, "peak phase voltage"),
    ({"source": "gain_mismatch", "injection": {"ia_gain_error_pu": 0.01}, "max_order": 1},
     "predicted order 2 is above the analysed band"),
    ({"injection": {"ia_offset_a": 1e6}}, "ia_offset_a"),
    ({"injection": {"ia_ofset_a": 0.2}}, "not a knob of the drive's EDS"),
    ({"speed_rpm": 30.0, "revolutions": 400}, "buffer_capacity_samples"),
    ({"sample_rate_hz": 500_000.0}, "max_sample_rate_hz"),
    ({"sample_rate_hz": 1000.0, "max_order": 48}, "above what 1000 Hz can resolve"),
])
def test_each_kind_of_bad_point_is_named(overrides, message):
    problems = check_point(point(**overrides), CONFIG)
    assert any(message in p for p in problems), problems


def test_a_requirement_on_an_order_outside_the_band_is_refused():
    req = requirement_from_dict({"id": "REQ-7", "name": "order 36", "quantity":
                                 "order_amplitude_pct", "order": 36, "limit": {"max": 1.0},
                                 "injected": "any"})
    problems = check_point(point(max_order=24), CONFIG, [req])
    assert any("REQ-7" in p and "order 36" in p for p in problems), problems


def test_voltage_limit_of_the_table_i_motor():
    # the SVPWM limit is V_dc/√3; the no-load EMF alone reaches it near the motor's top speed
    assert voltage_limit_v(CONFIG) == pytest.approx(12.0 / 3 ** 0.5)
    assert voltage_needed_v(CONFIG, 500, 20, 0.0) < voltage_limit_v(CONFIG)
    assert voltage_needed_v(CONFIG, 3000, 20, 0.0) > voltage_limit_v(CONFIG)


def test_every_shipped_plan_point_passes_preflight(tmp_path):
    """Collecting the shipped plans runs the pre-flight on every point (the plugin's hook)."""
    folder = Path(c.__file__).parent
    result = subprocess.run([sys.executable, "-m", "pytest", str(folder), "--collect-only", "-q",
                             "-p", "no:cacheprovider", "--hil-record", str(tmp_path / "r")],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    collected = [line for line in result.stdout.splitlines() if "::test_" in line]
    assert len(collected) >= 25
    assert not (tmp_path / "r").exists()


def test_a_bad_plan_fails_at_collection_and_nothing_is_sent(tmp_path):
    plan_file = tmp_path / "test_user_plan.py"
    plan_file.write_text(textwrap.dedent('''
        import pytest
        from hil.measurement import PointPlan
        from ripple_hil_testplans import conditions as c

        pytestmark = pytest.mark.ripple_source("gain_mismatch")

        def plan(config, speed_rpm):
            return PointPlan(source="gain_mismatch", injection={"ia_gain_error_pu": 0.01},
                             speed_rpm=speed_rpm, current_a=20.0, rule=c.CLOSED_FORM_RULE)

        @pytest.mark.parametrize("speed_rpm", [500.0, 3500.0])
        def test_user(measure, bench, speed_rpm):
            outcome = measure(plan(bench.config, speed_rpm))
            assert outcome.passed, outcome.summary()
    '''))
    records = tmp_path / "records"
    result = subprocess.run([sys.executable, "-m", "pytest", str(plan_file), "-p",
                             "no:cacheprovider", "--hil-record", str(records)],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == pytest.ExitCode.USAGE_ERROR, result.stdout + result.stderr
    assert "pre-flight refused" in result.stderr
    assert "speed_rpm-3500" in result.stderr or "3500" in result.stderr
    assert not records.exists()          # the bench was never opened: no record, no command


def test_a_plan_imported_from_elsewhere_is_not_taken_for_this_modules_convention(tmp_path):
    """A user module that reuses a shipped plan's ``plan`` under other parameter names is not
    refused at collection (its points are checked when measured)."""
    (tmp_path / "test_reuse.py").write_text(textwrap.dedent('''
        import pytest
        from ripple_hil_testplans.test_dc_offset import plan

        pytestmark = pytest.mark.ripple_source("dc_offset")

        @pytest.mark.parametrize("a, b", [(0.01, 0.0)])
        def test_user(measure, bench, a, b):
            assert measure(plan(bench.config, a, b)).passed
    '''))
    result = subprocess.run([sys.executable, "-m", "pytest", "test_reuse.py", "--collect-only",
                             "-q", "-p", "no:cacheprovider", "--hil-record", str(tmp_path / "r")],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_requirement_naming_an_unknown_knob_is_refused():
    from hil.preflight import check_plans

    req = requirement_from_dict({"id": "REQ-9", "name": "x", "quantity": "pk_pk_pct",
                                 "limit": {"max": 3.0}, "injection": {"nosuch_knob": 1}})
    problems = check_plans({"t": point()}, CONFIG, [req])
    assert any("REQ-9" in p and "nosuch_knob" in p for p in problems), problems


def test_pwm_resolution_without_the_transducer_bandwidth_is_refused_before_any_command(tmp_path):
    """The noise check needs the torque output's bandwidth: a bench file without it is refused at
    pre-flight (not a silent skip of the one check that catches a scaled PWM counter)."""
    import tomllib

    import tomli_w

    from hil.config import example_bench_path

    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["torque"].pop("bandwidth_hz", None)
    bench = tmp_path / "no-bandwidth.toml"
    bench.write_text(tomli_w.dumps(table))
    records = tmp_path / "records"
    result = subprocess.run([sys.executable, "-m", "hil", "run", "--source", "pwm_resolution",
                             "--bench", str(bench), "--record-dir", str(records), "--no-report"],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "[torque] bandwidth_hz" in result.stdout + result.stderr
    assert not records.exists()


def test_pwm_resolution_with_a_loop_delay_the_noise_model_cannot_represent_is_refused(tmp_path):
    """On a real bench file: 90 µs at 20 kHz is 1.8 PWM periods; a double-update drive (issue 30:
    motulator's loop, 37.5 µs) is 0.75. The point is not determinable here, with the reason,
    before the sweep runs; it no longer refuses the whole run (the other plans still run)."""
    from dataclasses import replace

    from hil import validity
    from hil.config import example_bench_path, load_bench
    from ripple_hil_testplans import test_pwm_resolution as plan_module

    config = load_bench(example_bench_path("real-bench"))
    for delay_s in (90e-6, 37.5e-6):
        odd = replace(config, drive=replace(config.drive, current_loop_delay_s=delay_s))
        reasons = validity.problems(plan_module.plan(odd, {"pwm_period_counts": 32}), odd)
        assert any("noise model needs 0.5, 1, 1.5 or 2 periods" in r for r in reasons), reasons
    ok = replace(config, drive=replace(config.drive, current_loop_delay_s=75e-6))
    reasons = validity.problems(plan_module.plan(ok, {"pwm_period_counts": 32}), ok)
    assert not any("noise model" in r for r in reasons)


def test_pwm_resolution_at_negative_speed_models_braking_and_passes_a_correct_drive(tmp_path):
    """In reverse rotation the drive brakes (+I on q against −E). The derived pk-pk model took it
    for mirrored motoring and a correct drive failed its 32-count point at −500 rpm / 30 A; with
    the braking phasor (``forward_phasor_peak_v``, the mirror of the noise model's independently
    written signed-speed phasor) the plan passes it."""
    import cmath
    import tomllib

    import tomli_w

    from hil.config import example_bench_path
    from hil.model import OperatingPoint
    from hil.model.pwm_noise import steady_phasor_peak_v
    from hil.model.pwm_resolution import forward_phasor_peak_v

    reverse = OperatingPoint(speed_rpm=-500.0, current_a=30.0, current_angle_rad=0.3)
    assert cmath.isclose(forward_phasor_peak_v(reverse),
                         -steady_phasor_peak_v(reverse).conjugate(), rel_tol=1e-12)
    forward = OperatingPoint(speed_rpm=500.0, current_a=30.0, current_angle_rad=0.3)
    assert forward_phasor_peak_v(forward) == forward.voltage_phasor_peak_v
    table = tomllib.loads(example_bench_path("sim-bench").read_text())
    table["operating_point"].update(speed_rpm=-500.0, current_a=30.0)
    bench = tmp_path / "reverse.toml"
    bench.write_text(tomli_w.dumps(table))
    result = subprocess.run([sys.executable, "-m", "hil", "run", "--source", "pwm_resolution",
                             "--bench", str(bench), "--record-dir", str(tmp_path / "r"),
                             "--no-report"], capture_output=True, text=True, timeout=300,
                            cwd=tmp_path)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
