"""Synthetic run records for the results database's tests and benchmarks — never a measurement.

``synthetic_record`` writes a real, sealed record through the record API (``hil.record``) with
the values the caller chooses, so ingest, queries and statistics can be checked against numbers
known in advance without running a bench.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hil.capture import Capture


def _capture(n: int = 3960, rate_hz: float = 8000.0) -> Capture:
    t = np.arange(n) / rate_hz
    return Capture({"time_s": t, "torque_nm": 1.0 + 0.02 * np.sin(2 * np.pi * 50 * t)},
                   meta={"sample_rate_hz": rate_hz, "pole_pairs": 2, "source": "synthetic"})


def point_entry(index: int, pk_pk_pu: float, u_pu: float, *, source: str = "baseline",
               requirement: tuple[str, float] | None = None, tolerance: tuple[float, float]
               | None = None, order_amplitude_nm: float | None = None) -> dict:
    """One measured point: pk-pk (per unit of the nameplate torque) with expanded U (k = 2),
    a verdict against ``tolerance`` (lower, upper, pu), a requirement verdict (id, max %)."""
    accepted_model = tolerance is None or tolerance[0] + u_pu <= pk_pk_pu <= tolerance[1] - u_pu
    amplitude = pk_pk_pu / 2 if order_amplitude_nm is None else order_amplitude_nm
    entry = {
        "test_id": f"testplans/test_{source}.py::test_{source}[{index}]", "source": source,
        "kind": "measurement", "outcome": "passed" if accepted_model else "failed",
        "phase": "call", "injection": {"knob": float(index)},
        "operating_point": {"speed_rpm": 500.0, "current_a": 20.0, "current_angle_rad": 0.0},
        "measured": {"mean_torque_nm": 1.0, "pk_pk_pu": pk_pk_pu,
                     "top_orders": [{"order": 1, "amplitude_nm": amplitude,
                                     "amplitude_u_nm": u_pu / 4, "phase_rad": 0.5},
                                    {"order": 6, "amplitude_nm": 1e-3,
                                     "amplitude_u_nm": 1e-4, "phase_rad": 0.1}]},
        "uncertainty": {"coverage_factor": 2.0, "expanded_pu": u_pu},
        "requirements": [],
    }
    if tolerance is not None:
        entry["verdict"] = {"decision": "pass" if accepted_model else "fail",
                            "measured_pk_pk_pu": pk_pk_pu, "expanded_uncertainty_pu": u_pu,
                            "predicted_pk_pk_pu": sum(tolerance) / 2,
                            "lower_limit_pu": tolerance[0], "upper_limit_pu": tolerance[1]}
    if requirement is not None:
        req_id, limit_pct = requirement
        value, u = 100 * pk_pk_pu, 100 * u_pu
        ok = value + u <= limit_pct
        entry["requirements"] = [{"id": req_id, "quantity": "pk_pk_pct", "unit": "%",
                                  "limit": {"max": limit_pct}, "measured": value,
                                  "expanded_uncertainty": u, "rule": "guarded",
                                  "decision": "pass" if ok else "fail", "accepted": ok}]
        if not ok:
            entry["outcome"] = "failed"
    return entry


def synthetic_record(root: str | Path, entries: list[dict], *, dut_serial: str = "SN-0001",
                     firmware: str = "1.0.0", station: str = "station-1",
                     diagnosis: dict[str, tuple[float, float]] | None = None,
                     captures: bool = False) -> Path:
    """A sealed record under ``root`` holding ``entries``; ``diagnosis``: name → (estimate,
    standard uncertainty) as the diagnosis plan records them. Returns the record folder."""
    from hil.config import default_sim_bench
    from hil.record import RunRecord

    identities = [{"role": "drive", "identity": {"serial_number": "SIM-DRIVE-1",
                                                 "firmware": firmware}}]
    record = RunRecord.create(root, default_sim_bench(), identities, sections={
        "run": {"dut_serial": dut_serial, "station": station, "operator": "synthetic"}})
    for entry in entries:
        if captures:
            record.save_capture(entry["test_id"], _capture())
        record.add_test(entry)
    if diagnosis:
        record.set_section("diagnosis", {"parameters": [
            {"name": name, "unit": "A" if name.endswith("_a") else "1", "estimate": value,
             "standard_uncertainty": u, "identifiable": True}
            for name, (value, u) in diagnosis.items()]})
    record.finish("complete")
    return record.path
