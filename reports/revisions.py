"""Report revisions of a record (issue 11 item 4, issue 22 item 7): a report is never
overwritten silently, and its revision number comes from a signed chain, not a side file.

Every report issued from a signed record appends one Ed25519-signed line to the record's
``record.sig`` (:func:`hil.seal.append_revision`: revision, report ID, PDF path, UTC time,
reason, chained on the line before it and the first on the seal). The first report is Rev. 1;
a later one is Rev. N + 1 and needs a reason; an existing PDF is never replaced. The report ID
names the revision (``RHR-<record id>-<record.json hash>-R<n>``). Deleting ``reports.jsonl``
(the unsigned log of earlier versions) therefore cannot make a second "Rev. 1"; an edited,
forged or re-ordered revision line makes :func:`issued` refuse (InputError). Records sealed
before signing (no ``record.sig``) keep the unsigned ``reports.jsonl`` log.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from hil.errors import InputError

LOG_FILE = "reports.jsonl"


@dataclass(frozen=True)
class Revision:
    number: int
    reason: str | None
    issued_utc: str | None
    supersedes: dict | None      # the previous revision's log entry


def issued(record_dir: str | Path) -> list[dict]:
    """The revisions issued so far (oldest first): from the signed chain in ``record.sig``, or
    for a record sealed before signing, from ``reports.jsonl``."""
    from hil.seal import revision_entries

    signed = revision_entries(record_dir)
    if signed is not None:
        return signed
    path = Path(record_dir) / LOG_FILE
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        return []
    out = []
    for line in lines:
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue          # a torn last line of a crashed write: that revision was not issued
    return out


def next_revision(record_dir: str | Path, reason: str | None, issued_utc: str) -> Revision:
    """The revision a new report of this record gets; a reason is needed from Rev. 2 on."""
    done = issued(record_dir)
    if done and not (reason and reason.strip()):
        last = done[-1]
        raise InputError(f"record {str(record_dir)!r} already has report Rev. {last['revision']} "
                         f"({last['report_id']}, {last['pdf']}); give --reason TEXT to issue "
                         f"Rev. {last['revision'] + 1}")
    return Revision(len(done) + 1, reason.strip() if reason else None, issued_utc,
                    done[-1] if done else None)


def log_revision(record_dir: str | Path, revision: Revision, report_id: str, pdf: Path,
                 issued_utc: str) -> None:
    """Append the issued revision: a signed line of ``record.sig`` (a record sealed before
    signing: one fsynced line of ``reports.jsonl``)."""
    from hil.seal import SIG_FILE, append_revision

    entry = {"revision": revision.number, "report_id": report_id, "pdf": str(pdf),
             "issued_utc": issued_utc, "reason": revision.reason}
    if (Path(record_dir) / SIG_FILE).is_file():
        append_revision(record_dir, entry)
        return
    with open(Path(record_dir) / LOG_FILE, "a", encoding="utf-8") as handle:
        handle.write(json.dumps(entry) + "\n")
        handle.flush()
        os.fsync(handle.fileno())


def refuse_overwrite(target: Path) -> None:
    if target.exists():
        raise InputError(f"{str(target)!r} exists; a report is never overwritten (choose "
                         f"another -o)")
