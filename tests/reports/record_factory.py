"""A realistic run record for report tests, written through RunRecord.

Each point injects a knob, takes the paper's prediction from ``hil.model.predict``, and builds a
synthetic capture whose ripple is that prediction times a chosen factor (so the measured ripple
is known by construction) plus white noise. The capture goes through the real
``hil.analysis.analyze_capture`` and ``decide``, exactly as a test plan would record it. The
factors put points on every side of the guard band; for the two conditional decisions the factor
is solved for (a few secant steps) so that the measured value sits half a guard band inside or
outside the upper limit.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from hil.analysis import DecisionRule, analyze_capture, decide
from hil.capture import Capture
from hil.config import default_sim_bench
from hil.model import OperatingPoint, predict
from hil.motor import TABLE_I
from hil.record import RunRecord

SPEED_RPM = 500.0
CURRENT_A = 20.0
SAMPLE_RATE_HZ = 10_000.0
MAX_ORDER = 40
RULE = DecisionRule()

# (source, knob, value, ripple factor over the prediction, or the decision to place it at)
POINTS = [
    ("dc_offset", "ia_offset_a", 0.1, 1.0),
    ("dc_offset", "ia_offset_a", 0.2, "conditional pass"),
    ("dc_offset", "ia_offset_a", 0.4, 1.0),
    ("dead_time", "dead_time_s", 1e-6, "conditional fail"),
    ("dead_time", "dead_time_s", 2e-6, 2.5),
]
EXPECTED_DECISIONS = ["pass", "conditional pass", "pass", "conditional fail", "fail"]


def synthetic_capture(order: float, pk_pk_nm: float, mean_nm: float, seed: int,
                      revolutions: float = 7.3) -> Capture:
    """Torque = mean + a cosine of electrical ``order`` with the given pk-pk + 0.2 % noise."""
    pole_pairs = TABLE_I.pole_pairs
    elec_hz = SPEED_RPM / 60.0 * pole_pairs
    t = np.arange(int(revolutions / elec_hz * SAMPLE_RATE_HZ)) / SAMPLE_RATE_HZ
    mech = 2 * math.pi * SPEED_RPM / 60.0 * t
    ripple = 0.5 * pk_pk_nm * np.cos(order * pole_pairs * mech + 0.3)
    noise = np.random.default_rng(seed).normal(0.0, 0.002 * mean_nm, t.size)
    counts = np.floor(mech / (2 * math.pi) * 7200).astype(np.int64)
    return Capture({"time_s": t, "rotor_angle_mech_rad": mech, "encoder_counts": counts,
                    "torque_nm": mean_nm + ripple + noise,
                    "speed_rpm": np.full(t.size, SPEED_RPM)},
                   meta={"pole_pairs": pole_pairs, "sample_rate_hz": SAMPLE_RATE_HZ,
                         "encoder_counts_per_rev": 7200, "source": "simulation"})


def _measure(prediction, factor, seed: int, bench):
    """Capture and analyse a ripple of ``factor`` × the prediction (or solve the factor)."""
    order = int(prediction.order)
    target = None if isinstance(factor, float) else factor
    factor = 1.0 if target else factor
    for _ in range(6):
        capture = synthetic_capture(order, factor * prediction.pk_pk_nm, prediction.base_nm, seed)
        result = analyze_capture(capture, max_order=MAX_ORDER, named_order=order,
                                 instruments=bench.instrument_uncertainty())
        verdict = decide(result, prediction.pk_pk_pu, order, RULE)
        if target is None or verdict.decision == target:
            return capture, result, verdict
        half_guard = 0.5 * verdict.guard_band_pu
        goal = verdict.upper_limit_pu + (half_guard if target == "conditional fail" else -half_guard)
        factor *= goal / result.pk_pk_pu
    raise AssertionError(f"could not place a point at {target!r}")


def write_record(root: Path, *, partial: bool = False, name: str = "run") -> Path:
    """A record of POINTS (plus a skipped and an errored test). ``partial`` stops after two
    tests and leaves a captured-but-unanalysed test, as a Ctrl-C during analysis would."""
    bench = default_sim_bench()
    rec = RunRecord.create(root, bench, [
        {"role": "drive", "identity": {"vendor_id": 0x00000A1B, "product_code": 402,
                                       "serial_number": "SIM-DRIVE-1",
                                       "firmware_version": "ripple-fw 1.4.2"}},
        {"role": "torque", "identity": {"model": "sim transducer", "serial_number": "SIM-TQ-0001"}}],
        decision_rule=RULE.__dict__ | {"name": "ILAC-G8, guard band w = U (k = 2)"}, name=name)
    op = OperatingPoint(speed_rpm=SPEED_RPM, current_a=CURRENT_A)
    points = POINTS[:2] if partial else POINTS
    for index, (source, knob, value, factor) in enumerate(points):
        test_id = f"testplans/test_{source}.py::test_{source}[{knob}={value:g}]"
        prediction = predict(source, op, **{knob: value})
        capture, result, verdict = _measure(prediction, factor, index, bench)
        rec.save_capture(test_id, capture)
        rec.add_test({
            "test_id": test_id, "nodeid": test_id, "source": source,
            "outcome": "passed" if verdict.guarded_pass else "failed",
            "started_utc": "2026-11-21T05:00:00Z", "finished_utc": "2026-11-21T05:00:05Z",
            "injection": {knob: value}, "operating_point": op.to_dict(),
            "measured": result.to_dict(arrays=(source == "dc_offset")),
            "prediction": prediction.to_dict(), "uncertainty": result.uncertainty.to_dict(),
            "verdict": verdict.to_dict(), "notes": []})
    if partial:
        rec.save_capture("testplans/test_dead_time.py::test_dead_time[dead_time_s=1e-06]",
                         synthetic_capture(6, 0.01, 1.0, seed=9))
        return rec.path
    rec.add_test({"test_id": "testplans/test_encoder.py::test_hall", "source": "encoder",
                  "outcome": "skipped", "notes": ["no Hall sensors fitted"]})
    rec.add_test({"test_id": "testplans/test_word_length.py::test_word_length[8]",
                  "source": "word_length", "outcome": "error",
                  "injection": {"word_length_bits": 8},
                  "error": "DriveError: SDO abort 0x06090030 writing word_length_bits"})
    rec.finish("complete")
    return rec.path
