"""``hil export RECORD_DIR --mdf4 OUT``: every capture of a record as an MDF4 file that asammdf
reads back with its units and the record's provenance in the header (issue 31 item 4)."""

import json
import math

import numpy as np
import pytest
from asammdf import MDF

from hil.capture import Capture
from hil.cli import main
from hil.config import default_sim_bench
from hil.record import RunRecord


def a_capture():
    time_s = np.arange(4000) / 20_000.0
    mech = 2 * math.pi * 10.0 * time_s
    return Capture({"time_s": time_s, "torque_nm": 1.0 + 0.01 * np.sin(12 * mech),
                    "ia_a": 20.0 * np.cos(2 * mech), "dc_bus_v": np.full(time_s.size, 24.0),
                    "rotor_angle_mech_rad": mech,
                    "encoder_counts": np.floor(mech / (2 * math.pi) * 7200).astype(np.int64)},
                   meta={"pole_pairs": 2, "sample_rate_hz": 20_000.0})


@pytest.fixture
def record(tmp_path):
    record = RunRecord.create(tmp_path / "records", default_sim_bench(), [], name="run")
    info = record.save_capture("testplans/test_x.py::test_point[a]", a_capture())
    return record, info


def test_export_reads_back_in_asammdf_with_units_and_provenance(record, tmp_path, capsys):
    record, info = record
    assert main(["export", str(record.path), "--mdf4", str(tmp_path / "out"), "--json"]) == 0
    written = json.loads(capsys.readouterr().out)["mdf4"]
    assert len(written) == 1
    original = a_capture()
    mdf = MDF(written[0])
    try:
        for name, unit in (("torque_nm", "N*m"), ("ia_a", "A"), ("dc_bus_v", "V"),
                           ("rotor_angle_mech_rad", "rad"), ("encoder_counts", "counts")):
            signal = mdf.get(name)
            assert signal.unit == unit, name
            np.testing.assert_array_equal(signal.samples, original[name])
            np.testing.assert_array_equal(signal.timestamps, original["time_s"])
        comment = mdf.header.comment
        assert record.record_id in comment and info["sha256"] in comment
        assert "test_point[a]" in comment and "git_sha" in comment
    finally:
        mdf.close()
    # and the export analyses like the capture it came from
    assert main(["analyze", str(record.path / info["file"]), "--json", "--order", "6"]) == 0
    native = json.loads(capsys.readouterr().out)
    assert main(["analyze", written[0], "--pole-pairs", "2", "--json", "--order", "6"]) == 0
    exported = json.loads(capsys.readouterr().out)
    for key in ("pk_pk_pu", "mean_torque_nm", "named_amplitude_nm"):
        assert exported[key] == pytest.approx(native[key], rel=1e-12), key


def test_a_capture_that_does_not_match_its_record_is_not_exported(record, tmp_path, capsys):
    record, info = record
    altered = a_capture()
    altered.channels["torque_nm"] = altered["torque_nm"] * 1.01
    altered.save(record.path / info["file"])
    assert main(["export", str(record.path), "--mdf4", str(tmp_path / "out")]) == 2
    assert "SHA-256" in capsys.readouterr().err
    assert not list((tmp_path / "out").glob("*.mf4"))
