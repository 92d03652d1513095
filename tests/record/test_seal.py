"""A seal a user cannot re-seal (issue 22 item 7): the finished record is signed with the
station's Ed25519 key (kept outside the record folder); ``hil verify`` checks the signature and
prints the key's fingerprint; a record edited and re-hashed with ``sha256sum`` fails; a key not
trusted here is named as such; a record sealed before signing is "unsigned", not intact; the
report revision comes from the signed chain, so deleting ``reports.jsonl`` cannot give a second
"Rev. 1"."""

from __future__ import annotations

import hashlib
import json
import stat
from pathlib import Path

import pytest

from hil.cli import main
from hil.config import default_sim_bench
from hil.record import SEAL_FILE, RunRecord, load_record, verify_record
from hil.seal import (KEY_DIR_ENV, KEY_FILE, SIG_FILE, StationKeyError, fingerprint, public_hex,
                      station_key)


@pytest.fixture
def key_dir(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "station-keys"
    monkeypatch.setenv(KEY_DIR_ENV, str(folder))
    monkeypatch.delenv("RIPPLE_HIL_TRUSTED_KEYS", raising=False)
    return folder


def finished_record(root: Path) -> Path:
    record = RunRecord.create(root, default_sim_bench(), [])
    record.add_test({"test_id": "t1", "outcome": "failed", "message": "pk-pk above its limit"})
    record.finish("complete")
    return record.path


def resealed(folder: Path, edit) -> None:
    """What a user with a text editor and ``sha256sum`` does: edit record.json, hash it again."""
    path = folder / "record.json"
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data, indent=1) + "\n")
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    (folder / SEAL_FILE).write_text(f"{digest}  record.json\n")


def test_the_seal_is_signed_by_a_0600_station_key_outside_the_record(key_dir, tmp_path, capsys):
    folder = finished_record(tmp_path / "records")
    key_file = key_dir / KEY_FILE
    assert stat.S_IMODE(key_file.stat().st_mode) == 0o600
    assert not key_file.is_relative_to(folder)
    printed = fingerprint(public_hex(station_key()))
    assert load_record(folder)["seal"]["fingerprint"] == printed
    assert main(["verify", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "intact" in out and printed in out and "signed (Ed25519" in out


def test_an_edited_and_rehashed_record_fails_verify(key_dir, tmp_path, capsys):
    folder = finished_record(tmp_path / "records")
    resealed(folder, lambda data: data["tests"][0].update(outcome="passed", message=None))
    # the sha256sum seal alone would now say intact; the signature does not
    assert hashlib.sha256((folder / "record.json").read_bytes()).hexdigest() in \
        (folder / SEAL_FILE).read_text()
    assert main(["verify", str(folder)]) == 1
    out = capsys.readouterr().out
    assert "INVALID" in out and "the signature does not match record.json" in out
    assert any("signature does not match" in p for p in verify_record(folder))


def test_a_resigned_record_names_a_key_that_is_not_trusted_here(key_dir, tmp_path, capsys,
                                                                  monkeypatch):
    folder = finished_record(tmp_path / "records")
    own = public_hex(station_key())
    monkeypatch.setenv(KEY_DIR_ENV, str(tmp_path / "someone-else"))   # another "station"
    assert main(["verify", str(folder)]) == 1
    out = capsys.readouterr().out
    assert f"signed by key {fingerprint(own)}, which is not a trusted key" in out
    assert main(["verify", str(folder), "--trusted-key", own]) == 0
    monkeypatch.setenv("RIPPLE_HIL_TRUSTED_KEYS", own)
    assert main(["verify", str(folder)]) == 0


def test_a_stripped_signature_is_missing_not_unsigned(key_dir, tmp_path, capsys):
    folder = finished_record(tmp_path / "records")
    (folder / SIG_FILE).unlink()
    assert main(["verify", str(folder)]) == 1
    assert f"{SIG_FILE} is missing" in capsys.readouterr().out


def test_a_record_sealed_before_signing_verifies_as_unsigned(key_dir, tmp_path, capsys):
    folder = finished_record(tmp_path / "records")
    (folder / SIG_FILE).unlink()
    resealed(folder, lambda data: data.pop("seal"))        # as written before this change
    assert verify_record(folder) == []                     # its hashes do match
    assert main(["verify", str(folder)]) == 1
    out = capsys.readouterr().out
    assert "unsigned (sealed before signing)" in out and "intact" not in out
    assert main(["verify", str(folder), "--json"]) == 1
    summary = json.loads(capsys.readouterr().out)
    assert summary["signature"] == "unsigned" and summary["intact"] is False


def test_a_station_key_readable_by_others_is_refused(key_dir):
    station_key()
    (key_dir / KEY_FILE).chmod(0o644)
    with pytest.raises(StationKeyError, match="readable by others"):
        station_key()


def test_deleting_reports_jsonl_does_not_give_a_second_rev_1(key_dir, tmp_path, capsys):
    folder = finished_record(tmp_path / "records")
    assert main(["report", str(folder), "--json"]) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["revision"] == 1 and first["key_fingerprint"].startswith("SHA256:")
    (folder / "reports.jsonl").unlink(missing_ok=True)
    (folder / "report.pdf").unlink()
    assert main(["report", str(folder)]) == 2
    assert "already has report Rev. 1" in capsys.readouterr().err
    assert main(["report", str(folder), "--reason", "customer name corrected", "--json"]) == 0
    second = json.loads(capsys.readouterr().out)
    assert second["revision"] == 2 and second["report_id"].endswith("-R2")
    # a revision line edited by hand breaks its signature: no further revision is issued
    original = (folder / SIG_FILE).read_text().splitlines(keepends=True)
    lines = list(original)
    lines[2] = lines[2].replace("customer name corrected", "typo")
    (folder / SIG_FILE).write_text("".join(lines))
    assert main(["report", str(folder), "--reason", "again"]) == 2
    assert "signature does not match" in capsys.readouterr().err
    # a revision line cut from the middle breaks the chain
    (folder / SIG_FILE).write_text(original[0] + original[2])
    assert main(["report", str(folder), "--reason", "again"]) == 2
    assert "does not follow the line before it" in capsys.readouterr().err


@pytest.mark.parametrize("edit", [
    lambda text: text.replace('"status": "complete"', '"status": "complete "'),  # the issue's
    lambda text: text.replace('"outcome": "failed"', '"outcome": "great"'),
    lambda text: text.replace('"format"', '"formt"'),
    lambda text: text[:-10],                                                      # not JSON
], ids=["status", "outcome", "format", "truncated"])
def test_a_record_edited_into_an_unreadable_one_is_invalid_not_bad_input(key_dir, tmp_path,
                                                                         capsys, edit):
    """However record.json was edited, ``hil verify`` says INVALID and exits 1; only a folder
    without a record.json is bad input (exit 2)."""
    folder = finished_record(tmp_path / "records")
    path = folder / "record.json"
    text = path.read_text()
    assert '"status": "complete"' in text and '"outcome": "failed"' in text
    path.write_text(edit(text))
    assert main(["verify", str(folder)]) == 1
    out = capsys.readouterr().out
    assert out.startswith(f"{folder}: INVALID") and "does not match its seal" in out, out
    assert main(["verify", str(folder), "--json"]) == 1
    assert json.loads(capsys.readouterr().out)["intact"] is False
    assert main(["verify", str(tmp_path / "no-such-record")]) == 2
