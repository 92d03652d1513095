"""A reading command run where no results database is (issue 32 Why 6): it says where it looked
and exits non-zero, instead of creating an empty ``records/results.sqlite`` and finding nothing
in it."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.cli import main

SPEC = Path(__file__).resolve().parents[2] / "hil" / "examples" / "tolerances.toml"


@pytest.mark.parametrize("command", [["history"], ["compare", "A", "B"], ["trend", "--source", "baseline"],
                                     ["yield", str(SPEC), "--from-db"]])
def test_outside_a_records_folder_nothing_is_created(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(command) == 2
    err = capsys.readouterr().err
    assert f"no results database at {tmp_path / 'records' / 'results.sqlite'}" in err
    assert str(tmp_path) in err and "--records" in err
    assert not (tmp_path / "records").exists()


def test_db_sync_still_creates_the_database(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "records").mkdir()
    assert main(["db", "sync"]) == 0
    assert (tmp_path / "records" / "results.sqlite").exists()
