"""Every capture of a run record as an ASAM MDF4 file (``hil export RECORD_DIR --mdf4 OUT``).

Each capture is checked against the SHA-256 its record holds before it is exported (a capture
that does not verify is not exported: the export would state data the record does not); its
MDF4 file carries the channels with their units and, in the header, the record's provenance
(:func:`provenance`). Writing is :func:`hil.capture_mdf.write_mdf4`.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from hil.capture import Capture
from hil.capture_mdf import write_mdf4
from hil.errors import InputError
from hil.record import capture_path, load_record, safe_test_name


def provenance(data: dict, test_id: str, entry: dict) -> dict:
    """What the MDF4 header states about where a capture came from."""
    software = data.get("software") or {}
    bench = data.get("bench") or {}
    return {"record_id": data.get("record_id"), "record_status": data.get("status"),
            "record_created_utc": data.get("created_utc"), "test_id": test_id,
            "capture_file": entry.get("file"), "capture_sha256": entry.get("sha256"),
            "software_version": software.get("version"), "git_sha": software.get("git_sha"),
            "git_dirty": software.get("git_dirty"), "bench_file": bench.get("path"),
            "bench_sha256": bench.get("sha256"), "bench_simulated": bench.get("simulated")}


def captures_of(data: dict) -> list[tuple[str, dict]]:
    """(test id, capture entry) of every capture the record names, tests first."""
    named = [(test["test_id"], test["capture"]) for test in data["tests"] if test.get("capture")]
    named += [(item.get("test_id"), item) for item in data.get("pending_captures", [])]
    return named


def export_mdf4(record_dir: str | Path, out_dir: str | Path) -> list[Path]:
    """Write ``OUT/<test>.mf4`` for every capture of the record; the files written."""
    record_dir = Path(record_dir)
    data = load_record(record_dir)
    folder = record_dir.parent if record_dir.name == "record.json" else record_dir
    named = captures_of(data)
    if not named:
        raise InputError(f"record {str(folder)!r} holds no captures to export")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for test_id, entry in named:
        source = capture_path(folder, entry.get("file"))
        if source is None or not source.is_file():
            raise InputError(f"test {test_id!r}: capture {entry.get('file')!r} is missing or "
                             "outside the record's captures/ folder")
        raw = source.read_bytes()
        if hashlib.sha256(raw).hexdigest() != entry.get("sha256"):
            raise InputError(f"test {test_id!r}: capture {entry.get('file')} does not match the "
                             "SHA-256 in its record (hil verify says more); not exported")
        target = out_dir / f"{safe_test_name(test_id)}.mf4"
        write_mdf4(Capture.load(source), target, provenance(data, test_id, entry))
        written.append(target)
    return written
