"""``hil verify RECORD_DIR``: check a run record's integrity (exit 0 intact, 1 otherwise).

Re-hashes ``record.json`` against its seal (``record.sha256``, written when the run finished),
checks the seal's Ed25519 signature (``record.sig``, :mod:`hil.seal`) and whether its key is
trusted here (this station's key, ``$RIPPLE_HIL_TRUSTED_KEYS``, ``--trusted-key``), and every
capture the record names against the SHA-256 recorded when it was written; names each file
that is missing, altered or outside the record folder, and each journal line that breaks its
hash chain; prints the signing key's fingerprint. A record edited and re-hashed (``sha256sum``)
fails: its signature does not match. Exit 1 also for a record that was never sealed (status
``running``: the run was killed before it could finish) and for one sealed before signing
existed ("unsigned": anyone could have re-sealed it). A ``record.json`` that no longer reads as
a record (edited JSON, an unknown status such as ``"complete "``, a damaged journal) is
INVALID, exit 1, however it was edited; only a folder without a readable ``record.json`` is
bad input (exit 2).
"""

from __future__ import annotations

from hil.commands import description

import json
from pathlib import Path


def register(subparsers) -> None:
    parser = subparsers.add_parser("verify", help="check a run record's hashes and signature "
                                                  "(record.json and every capture)",
                                   description=description(__doc__))
    parser.add_argument("record_dir", metavar="RECORD_DIR", type=Path,
                        help="record folder (or its record.json)")
    parser.add_argument("--trusted-key", action="append", default=[], metavar="HEX|FILE",
                        help="also trust this Ed25519 public key (64 hex digits, or a file of "
                             "them, one a line), e.g. another station's; repeatable")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (record, status, intact, signature, "
                             "key_fingerprint, problems)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from hil.record import load_record, seal_check, verify_record
    from hil.seal import trusted_keys

    from hil.errors import InputError

    folder = args.record_dir.parent if args.record_dir.name == "record.json" else args.record_dir
    try:
        data = load_record(folder)
    except InputError as exc:
        if not _readable(folder):
            raise                          # not a record folder: bad input, exit 2
        return _unreadable_record(args, folder, str(exc))
    trusted = trusted_keys(args.trusted_key)
    problems = verify_record(folder, data, trusted)
    check = seal_check(folder, data, trusted)
    captures = sum(1 for t in data["tests"] if t.get("capture")) + len(data["pending_captures"])
    sealed = data["status"] != "running"
    signed = check is not None and check.state == "signed"
    intact = sealed and signed and not problems
    if args.json:
        print(json.dumps({"record": str(folder), "record_id": data["record_id"],
                          "status": data["status"], "sealed": sealed, "intact": intact,
                          "signature": None if check is None else check.state,
                          "key_fingerprint": None if check is None else check.fingerprint,
                          "captures": captures, "problems": problems}))
    elif problems:
        print(f"{folder}: INVALID ({len(problems)} problem(s))"
              + ("; not sealed (the run never finished)" if not sealed else "") + ":")
        for problem in problems:
            print(f"  {problem}")
        if check is not None:
            print(f"  signature: {check.text()}")
    elif not sealed:
        print(f"{folder}: not sealed (the run never finished: status running, no "
              f"record.sha256); {captures} capture(s) match their SHA-256")
    elif not signed:
        print(f"{folder}: NOT VERIFIED: {check.text() if check else 'format 1, no seal'}; "
              f"record.json matches record.sha256 and {captures} capture(s) match their SHA-256")
    else:
        print(f"{folder}: intact (record.json sealed and {check.text()}; {captures} capture(s) "
              f"match their SHA-256; status {data['status']})")
    return 0 if intact else 1


def _readable(folder: Path) -> bool:
    try:
        (folder / "record.json").read_bytes()
        return True
    except OSError:
        return False


def _unreadable_record(args, folder: Path, reason: str) -> int:
    """A ``record.json`` that is there but no longer reads as a record: INVALID, exit 1, with
    what its seal says of it."""
    from hil.record import SEAL_FILE, _sha256_file

    problems = [reason.removeprefix(f"record {str(folder)!r}: ")]
    try:
        sealed = (folder / SEAL_FILE).read_text(encoding="ascii").split()[0]
    except (OSError, UnicodeDecodeError, IndexError):
        sealed = None
    if sealed is not None and sealed != _sha256_file(folder / "record.json"):
        problems.append(f"record.json does not match its seal {SEAL_FILE}: it was changed "
                        f"after the run finished")
    if args.json:
        print(json.dumps({"record": str(folder), "record_id": None, "status": None,
                          "sealed": sealed is not None, "intact": False, "signature": None,
                          "key_fingerprint": None, "captures": None, "problems": problems}))
    else:
        print(f"{folder}: INVALID ({len(problems)} problem(s)):")
        for problem in problems:
            print(f"  {problem}")
    return 1
