"""The PWM-switching, PWM-resolution and word-length plans end to end (issue 21 item 3): the
correct simulated drive passes them on a motor that is not Table I, at a negative speed; a drive
that applies the injection at half (or double) its effect fails each of them.

The plans run in a separate pytest process over the real stacks, as ``hil run`` runs them, with
a bench file from ``studies/pwm_calibration.py`` (its holdout motors).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

import ripple_hil_testplans
from hil.record import load_record

pytestmark = [pytest.mark.integration, pytest.mark.slow]

PLANS = Path(ripple_hil_testplans.__file__).parent
STUDY = Path(__file__).resolve().parents[2] / "studies" / "pwm_calibration.py"


def _study():
    spec = importlib.util.spec_from_file_location("pwm_calibration", STUDY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_plans(tmp_path: Path, sources, motor: str | dict, speed_rpm: float, current_a: float,
              defects: dict | None = None, seed: int = 7) -> dict[str, Counter]:
    """Outcomes per source of the plans run on the simulated bench at this motor (a name of the
    study's, or a ``[motor]`` table of one's own) and point."""
    bench = tmp_path / "bench.toml"
    study = _study()
    if isinstance(motor, dict):
        study.MOTORS = {**study.MOTORS, "own": motor}
        motor = "own"
    bench.write_text(study.bench_text(motor, speed_rpm, current_a))
    args = [sys.executable, "-m", "pytest", *[str(PLANS / f"test_{s}.py") for s in sources],
            "-q", "-p", "no:cacheprovider", "--hil-bench", str(bench), "--hil-seed", str(seed),
            "--hil-record", str(tmp_path / "records")]
    for key, value in (defects or {}).items():
        args += ["--hil-sim-defect", f"{key}={value}"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    # record folders only (the results database may sit beside them)
    records = sorted(p for p in (tmp_path / "records").iterdir() if p.is_dir()) \
        if (tmp_path / "records").exists() else []
    assert records, done.stdout[-3000:] + done.stderr[-2000:]
    outcomes: dict[str, Counter] = {}
    for test in load_record(records[-1])["tests"]:
        outcomes.setdefault(test.get("source") or "?", Counter())[test.get("outcome")] += 1
    return outcomes


#: The holdout motor and point the plans run at: 8 poles, 48 V, L/R = 2.5 ms, reverse (braking).
MOTOR, SPEED_RPM, CURRENT_A = "octo_48v", -900.0, 25.0


@pytest.fixture(scope="module")
def holdout_reverse(tmp_path_factory):
    return run_plans(tmp_path_factory.mktemp("holdout"),
                     ["pwm_switching", "pwm_resolution", "word_length"],
                     MOTOR, SPEED_RPM, CURRENT_A)


@pytest.mark.parametrize("source", ["pwm_resolution", "word_length"])
def test_correct_drive_passes_on_a_holdout_motor_in_reverse(holdout_reverse, source):
    """No test fails; each plan judges at least two points."""
    counts = holdout_reverse[source]
    assert not counts["failed"] and not counts["error"], (source, holdout_reverse)
    assert counts["passed"] >= 2, (source, holdout_reverse)


@pytest.mark.xfail(strict=False, reason=(
    "known wrong rejection: the PWM-switching sweep slope's band [0.8, 1.2] was set on the "
    "calibration set (0.924-0.979) and this holdout reads 0.778-0.80 (hil/model/README.md, "
    "'PWM and word-length bands'); whether a run lands at 0.798 +- 0.192 (conditional fail) or "
    "0.80x depends on the bench's history (the carrier locked to the rotor, same README). Open "
    "in issue 30 until the bands are calibrated again"))
def test_correct_drive_passes_pwm_switching_on_a_holdout_motor_in_reverse(holdout_reverse):
    """No PWM-switching test fails; at least two points judged (a point whose U is wider than
    its zone is 'not determinable here', a skip)."""
    counts = holdout_reverse["pwm_switching"]
    assert counts["passed"] >= 2 and not counts["error"], holdout_reverse
    assert not counts["failed"], holdout_reverse


def test_a_drive_applying_half_the_pwm_frequency_and_counter_fails(tmp_path):
    """injection_scale = 0.5: the PWM frequency halves (switching ripple x2) and the counter
    halves (quantisation noise x2): both plans fail."""
    outcomes = run_plans(tmp_path, ["pwm_switching", "pwm_resolution"], MOTOR, SPEED_RPM,
                         CURRENT_A, defects={"injection_scale": 0.5})
    for source in ("pwm_switching", "pwm_resolution"):
        assert outcomes[source]["failed"] >= 1, (source, outcomes)


def test_a_drive_with_half_the_word_length_effect_fails(tmp_path):
    """word_length_offset_bits = 1: the firmware runs one bit longer than injected, so the
    truncation bias (the model's order-1 terms) halves; the word-length plan fails (its slope
    ≈ 0.5 against the calibrated ±0.30, which the old ±0.5 accepted)."""
    outcomes = run_plans(tmp_path, ["word_length"], MOTOR, SPEED_RPM, CURRENT_A,
                         defects={"word_length_offset_bits": 1})
    assert outcomes["word_length"]["failed"] >= 1, outcomes


def test_word_length_refuses_a_motor_below_its_validated_time_constant(tmp_path):
    """The 2-pole 24 V holdout motor (L/R 0.3 ms), where the twin was 1.4x the model: refused
    with the reason; Table I (0.7 ms) and the 8-pole motor (2.5 ms) are inside."""
    from hil.config import load_bench
    from ripple_hil_testplans.test_word_length import outside_region

    study = _study()
    for motor, inside in (("bipolar_24v", False), ("table_i", True), ("octo_48v", True)):
        path = tmp_path / f"{motor}.toml"
        path.write_text(study.bench_text(motor, 500.0, 10.0))
        reason = outside_region(load_bench(path))
        assert (reason is None) == inside, (motor, reason)
        assert inside or "L/R = 0.3 ms" in reason, reason


#: The 14-pole 48 V motor of studies/validity.py (calibration set of studies/switching_sampling.py)
P14_MOTOR = {"model": "14-pole 48 V PMSM (study)", "pole_count": 14, "dc_bus_v": 48.0,
             "phase_resistance_ohm": 0.1, "phase_inductance_h": 0.3e-3, "max_reactance_ohm": 0.5,
             "ke_v_s_per_rad": 0.04, "ke_definition": "peak_phase"}


def test_a_point_below_the_active_state_limit_still_fails_a_drive_at_half_the_pwm_frequency(
        tmp_path):
    """The 14-pole motor braking at -800 rpm / 10 A: the DAQ puts fewer than MIN_ACTIVE_SAMPLES
    phases on the active states at every PWM frequency of the sweep (review h-23: 1.78, 0.85,
    1.28), so a low reading there is not determinable. A drive at half the PWM frequency reads
    ≈ 1.9x high, which missing the extremes cannot cause: the plan still fails it (refusing the
    whole point, as first built, left all three not determinable)."""
    outcomes = run_plans(tmp_path, ["pwm_switching"], P14_MOTOR, -800.0, 10.0,
                         defects={"injection_scale": 0.5})
    assert outcomes["pwm_switching"]["failed"] >= 2, outcomes
