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


def requirement_verdict(req_id: str, measured: float, limit_max: float, u: float = 0.11,
                        demonstration: bool = False) -> dict:
    """A requirement verdict as ``hil.requirements.judge`` records it (record contract), with
    the ILAC-G8 guarded decision computed from the numbers given."""
    from hil.analysis.decision import classify

    decision = classify(measured, u, float("-inf"), limit_max)
    return {"id": req_id, "name": "total ripple", "quantity": "pk_pk_pct", "order": None,
            "limit": {"max": limit_max}, "limit_text": f"≤ {limit_max} %", "unit": "%",
            "measured": measured, "expanded_uncertainty": u, "rule": "guarded",
            "decision": decision, "accepted": decision == "pass",
            "demonstration": demonstration, "applies_to": f"{SPEED_RPM:g} rpm, {CURRENT_A:g} A"}


def self_check_entry(passes: bool) -> dict:
    """A bench self-check test entry (``hil.selfcheck`` dicts); ``passes=False``: a transducer
    reading 10 % high."""
    measured = 1.00 if passes else 1.10
    return {"test_id": "testplans/test_self_check.py::test_bench_self_check",
            "source": "self_check", "kind": "self_check",
            "outcome": "passed" if passes else "failed",
            "checks": [{"name": "torque scale", "measured": measured, "expected": 1.0,
                        "unit": "N*m", "tolerance": 0.03, "passed": passes,
                        "detail": "mean torque vs K_t·I·cos φ"},
                       {"name": "speed", "measured": 500.1, "expected": 500.0, "unit": "rpm",
                        "tolerance": 2.5, "passed": True, "detail": "encoder vs dyno"}]}


def map_entries() -> list[dict]:
    """Ripple-map cells over a 2 × 2 grid (pk-pk per unit and dominant order per cell)."""
    out = []
    for speed, current, pk_pk, order in ((250.0, 5.0, 0.012, 6), (750.0, 5.0, 0.018, 6),
                                         (250.0, 20.0, 0.009, 1), (750.0, 20.0, 0.031, 12)):
        out.append({"test_id": f"testplans/test_ripple_map.py::test_ripple_map[{speed:g}rpm-"
                               f"{current:g}A]", "source": "ripple_map", "kind": "ripple_map",
                    "outcome": "passed",
                    "operating_point": {"speed_rpm": speed, "current_a": current},
                    "measured": {"pk_pk_pu": pk_pk, "dominant_order": order}})
    return out


def write_record(root: Path, *, partial: bool = False, name: str = "run", extras: bool = False,
                 self_check_passes: bool = True) -> Path:
    """A record of POINTS (plus a skipped and an errored test). ``partial`` stops after two
    tests and leaves a captured-but-unanalysed test, as a Ctrl-C during analysis would.
    ``extras`` adds what the lead's plans record: a bench self-check (first), requirement
    verdicts (one a failing demonstration), ripple-map cells, a run section, lab details and a
    test-only defect."""
    bench = default_sim_bench()
    rec = RunRecord.create(root, bench, [
        {"role": "drive", "identity": {"vendor_id": 0x00000A1B, "product_code": 402,
                                       "serial_number": "SIM-DRIVE-1",
                                       "firmware_version": "ripple-fw 1.4.2"}},
        {"role": "torque", "identity": {"model": "sim transducer", "serial_number": "SIM-TQ-0001"}}],
        decision_rule=RULE.__dict__ | {"name": "ILAC-G8, guard band w = U (k = 2)"}, name=name,
        sections={"run": {"command_line": "hil run --requirements spec.toml", "operator":
                          "A. Tester", "selection": {"collected": 9, "selected": 9,
                                                     "deselected": 0, "sources": ["dc_offset"]},
                          "exit_status": 1},
                  "lab": {"customer": "ACME Drives GmbH", "authorizer": "Dr. B. Signer",
                          "authorizer_function": "head of laboratory",
                          "item_received": "2026-11-20", "environment": "23 °C, 45 % RH"},
                  "sim_defects": {"hidden_ia_offset_a": 0.5}} if extras else None)
    if extras:
        rec.add_test(self_check_entry(self_check_passes))
    op = OperatingPoint(speed_rpm=SPEED_RPM, current_a=CURRENT_A)
    points = POINTS[:2] if partial else POINTS
    for index, (source, knob, value, factor) in enumerate(points):
        test_id = f"testplans/test_{source}.py::test_{source}[{knob}={value:g}]"
        prediction = predict(source, op, **{knob: value})
        capture, result, verdict = _measure(prediction, factor, index, bench)
        rec.save_capture(test_id, capture)
        requirements = [requirement_verdict("REQ-1", 100 * result.pk_pk_pu, 30.0),
                        requirement_verdict("REQ-9", 100 * result.pk_pk_pu, 0.5,
                                            demonstration=True)] \
            if extras and index == 0 else []
        rec.add_test({
            "test_id": test_id, "nodeid": test_id, "source": source,
            "kind": "measurement", "requirements": requirements,
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
    for entry in map_entries() if extras else []:
        rec.add_test(entry)
    rec.add_test({"test_id": "testplans/test_encoder.py::test_hall", "source": "encoder",
                  "outcome": "skipped", "notes": ["no Hall sensors fitted"]})
    rec.add_test({"test_id": "testplans/test_word_length.py::test_word_length[8]",
                  "source": "word_length", "outcome": "error",
                  "injection": {"word_length_bits": 8},
                  "error": "DriveError: SDO abort 0x06090030 writing word_length_bits"})
    rec.finish("complete")
    return rec.path
