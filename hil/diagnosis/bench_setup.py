"""The diagnosis' :class:`DriveSetup` from a bench (file or a record's copy of it), and each
capture's operating point from the run record it belongs to."""

from __future__ import annotations

import json
from dataclasses import fields
from pathlib import Path

from hil.capture import Capture
from hil.diagnosis.signatures import DriveSetup
from hil.motor import MotorParameters

#: The drive's PWM frequency when nothing states another (the EDS default), Hz.
DEFAULT_PWM_FREQUENCY_HZ = 20_000.0


def setup_from_bench_dict(bench: dict, **overrides) -> tuple[DriveSetup, float]:
    """(DriveSetup, transducer accuracy class in %) from a bench as ``BenchConfig.to_dict()``
    writes it (also the ``bench.loaded`` of a record, or ``hil diagnose``'s bench as
    characterised, whose ``loop_tuning`` table is the motor the drive's gains came from).
    ``overrides``: DriveSetup fields that are not None replace the bench's."""
    motor = _motor(bench.get("motor", {}) or {})
    drive = bench.get("drive", {}) or {}
    torque = bench.get("torque", {}) or {}
    values = {"motor": motor,
              "current_loop_bandwidth_hz": drive.get("current_loop_bandwidth_hz"),
              "current_loop_delay_s": drive.get("current_loop_delay_s") or 0.0,
              "pwm_frequency_hz": DEFAULT_PWM_FREQUENCY_HZ,
              "transducer_bandwidth_hz": torque.get("bandwidth_hz")}
    for key in ("current_loop_design", "current_loop_decoupling",
                "current_loop_emf_feedforward", "current_loop_angle_compensation"):
        if drive.get(key) is not None:
            values[key] = drive[key]
    # a bench (or a foreign capture's manifest) that does not say how its loop is built: the
    # family of plausible loops, not the first-order PI (issue 23: a 2-DOF loop read as a PI
    # biased the offsets beyond U)
    values.setdefault("current_loop_design", "unknown")
    if bench.get("loop_tuning"):            # the motor the drive's PI gains were set from
        values["loop_tuning"] = _motor(bench["loop_tuning"])
    values.update({k: v for k, v in overrides.items() if v is not None})
    class_pct = 0.0
    for entry in bench.get("instrument", []) or []:
        if entry.get("role") == "torque" and entry.get("accuracy_class"):
            text = str(entry["accuracy_class"]).split("%")[0].strip()
            try:
                class_pct = float(text)
            except ValueError:
                class_pct = 0.0
    return DriveSetup(**values), class_pct


def _motor(table: dict) -> MotorParameters:
    names = {f.name for f in fields(MotorParameters)}
    return MotorParameters(**{k: v for k, v in table.items() if k in names})


def find_record(capture_path: Path) -> dict | None:
    """The run record (record.json) a capture file sits in (``<record>/captures/x.npz``)."""
    candidate = capture_path.resolve().parent.parent / "record.json"
    if not candidate.is_file():
        return None
    try:
        from hil.record import load_record

        return load_record(candidate.parent)
    except Exception:  # noqa: BLE001 - a damaged record only means: no operating point from it
        try:
            return json.loads(candidate.read_text())
        except (OSError, ValueError):
            return None


def operating_point_of(capture_path: Path, capture: Capture, record: dict | None) -> dict:
    """current_a, current_angle_rad, speed_rpm and a label for one capture: from its test entry
    in the record, else from the capture's meta (simulated captures), else {}."""
    name = capture_path.name
    if record:
        for test in record.get("tests", []):
            cap = test.get("capture") or {}
            if isinstance(cap, dict) and Path(str(cap.get("file", ""))).name == name:
                op = test.get("operating_point") or {}
                if "current_a" in op:
                    label = (f"{op['speed_rpm']:+g} rpm, {op['current_a']:g} A"
                             if op.get("speed_rpm") is not None else test.get("test_id", name))
                    return {"current_a": op["current_a"],
                            "current_angle_rad": op.get("current_angle_rad", 0.0),
                            "speed_rpm": op.get("speed_rpm"), "label": label}
    meta = capture.meta
    if "current_command_a" in meta:
        injection = meta.get("injection") or {}
        return {"current_a": meta["current_command_a"],
                "current_angle_rad": injection.get("current_angle_rad", 0.0),
                "label": meta.get("test_id", name)}
    return {"label": meta.get("test_id", name)}


def check_setup_known(setup: DriveSetup) -> list[str]:
    """Warnings for what the bench does not state (the fit then assumes the ideal case)."""
    out = []
    if setup.current_loop_design == "unknown":
        out.append(f"current-loop design unknown: a family of {len(setup.loop_variants())} "
                   "plausible loops is propagated into every U (state the loop to narrow it)")
    elif setup.current_loop_bandwidth_hz is None:
        out.append("current-loop bandwidth not stated: ideal current regulation assumed "
                   "(the paper's assumption)")
    if setup.transducer_bandwidth_hz is None:
        out.append("transducer bandwidth not stated: a flat transducer response assumed")
    return out

