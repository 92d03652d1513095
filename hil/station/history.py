"""The station's history: its past runs, newest first, from the record folders.

Until the results database (``hil/results/``, the fleet issue) is wired in, the record folders
under the station's record root are read directly; a sealed record never changes, so its row
(overall statement from :func:`hil.station.view.final_statement`, i.e. page 1's derivation with
every hash verified) is computed once and cached by its seal.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from hil.record import RECORD_FILE, SEAL_FILE
from hil.station.journal import read_record
from hil.station.view import OPERATOR_STATUS, final_statement, unit_of


def _header(folder: Path) -> dict | None:
    """A running record's header only (no journal replay: the history is read every tick; the
    station's own running unit is shown from its journal follower)."""
    try:
        return json.loads((folder / RECORD_FILE).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None


class History:
    """Rows of the record folders under ``root``."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self._cache: dict[str, tuple[float, dict]] = {}

    def rows(self, limit: int = 20) -> list[dict]:
        try:
            folders = [Path(e.path) for e in os.scandir(self.root)
                       if e.is_dir() and (Path(e.path) / RECORD_FILE).exists()]
        except FileNotFoundError:
            return []
        folders.sort(key=lambda f: f.name, reverse=True)     # record ids start with UTC time
        return [row for row in (self._row(f) for f in folders[:limit]) if row is not None]

    def _row(self, folder: Path) -> dict | None:
        seal = folder / SEAL_FILE
        stamp = seal.stat().st_mtime if seal.exists() else None
        cached = self._cache.get(folder.name)
        if stamp is not None and cached is not None and cached[0] == stamp:
            return cached[1] | {"report": (folder / "report.pdf").exists()}
        record = read_record(folder) if stamp is not None else _header(folder)
        if record is None:
            return None
        row = {"record": folder.name, "record_id": record.get("record_id"),
               "started_utc": record.get("created_utc"),
               "finished_utc": record.get("finished_utc"), "unit": unit_of(record),
               "plans": ((record.get("run") or {}).get("selection") or {}).get("sources") or [],
               "status": record.get("status"),
               "status_text": OPERATOR_STATUS.get(record.get("status"), record.get("status")),
               "overall": None, "report": (folder / "report.pdf").exists()}
        if stamp is not None:
            row["overall"] = final_statement(record, folder)["overall"]
            self._cache[folder.name] = (stamp, row)
        return row
