"""Signed seals of run records and their report revisions (issue 22 item 7).

``record.sha256`` (``sha256sum`` format) proves nothing against a user who edits ``record.json``
and hashes it again. So a finished record is also *signed*: ``record.sig`` holds, as its first
line, an Ed25519 signature (``cryptography`` package) over the record's SHA-256 and the journal's
last chain hash, made with a per-station private key kept *outside* the record folder:
``$RIPPLE_HIL_KEY_DIR/station_ed25519`` (default ``~/.config/ripple-hil/``), created mode 0600
on first use. The record itself names the public key (``record.json`` section ``seal``: algorithm,
public key, fingerprint, journal head), so the hash covers it too.

Verification (:func:`check_seal`) re-computes the signature against the public key the seal
names and says whether that key is *trusted*: the station's own public key, plus any given by
``$RIPPLE_HIL_TRUSTED_KEYS`` (``os.pathsep``-separated: a 64-hex-digit public key, or a file
holding one such key per line) or ``hil verify --trusted-key``. A record sealed before signing
existed (no ``seal`` section, no ``record.sig``) is "unsigned (sealed before signing)": its
hashes may match, but anyone could have re-sealed it.

Report revisions: each issued report appends one signed line to ``record.sig``; the line names
the revision number, report ID, PDF, time and reason, and chains on the line before it (``prev``
= SHA-256 of that line), the first on the seal. The next revision number is read from this
chain, not from a side file: deleting ``reports.jsonl`` (the old, unsigned log) changes nothing,
deleting ``record.sig`` breaks the record's signature, and an edited or forged line breaks its
signature or the chain, and ``hil report`` refuses to issue. Limit: lines cut off the *end* of
``record.sig`` leave a valid shorter chain; only a copy kept outside the folder could show that.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import os
import stat
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from hil.errors import HilError, InputError

KEY_DIR_ENV = "RIPPLE_HIL_KEY_DIR"
TRUSTED_ENV = "RIPPLE_HIL_TRUSTED_KEYS"
KEY_FILE = "station_ed25519"
SIG_FILE = "record.sig"
SEAL_FORMAT = "ripple-hil-seal/1"
ALGORITHM = "Ed25519"


class StationKeyError(HilError):
    """The station's signing key cannot be created or read (one line, names the file)."""


# ---------------------------------------------------------------------- keys

def key_dir() -> Path:
    """Where the station's private key lives (outside every record folder)."""
    configured = os.environ.get(KEY_DIR_ENV)
    return Path(configured) if configured else Path.home() / ".config" / "ripple-hil"


def station_key(create: bool = True):
    """The station's Ed25519 private key, created (mode 0600, folder 0700) on first use.

    StationKeyError if it cannot be created or read, or if others may read it."""
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    path = key_dir() / KEY_FILE
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        if not create:
            return None
        key = Ed25519PrivateKey.generate()
        pem = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                serialization.NoEncryption())
        try:
            path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
            # written whole under a temporary name, then linked: another process sees either
            # no key or the complete one, and the first link wins
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{KEY_FILE}.")   # mode 0600
            try:
                with os.fdopen(fd, "wb") as handle:
                    handle.write(pem)
                    handle.flush()
                    os.fsync(handle.fileno())
                os.link(tmp, path)
            finally:
                os.unlink(tmp)
        except FileExistsError:           # another process created it meanwhile
            return station_key(create=False)
        except OSError as exc:
            raise StationKeyError(f"station signing key {path}: cannot create it: "
                                  f"{_os_error_text(exc)} (set {KEY_DIR_ENV} to a private, "
                                  f"writable folder)") from None
        return key
    except OSError as exc:
        raise StationKeyError(f"station signing key {path}: cannot read it: "
                              f"{_os_error_text(exc)}") from None
    mode = stat.S_IMODE(path.stat().st_mode)
    if mode & 0o077:
        raise StationKeyError(f"station signing key {path} is readable by others (mode "
                              f"{mode:04o}); chmod 600 it")
    try:
        key = serialization.load_pem_private_key(raw, password=None)
    except (ValueError, TypeError) as exc:
        raise StationKeyError(f"station signing key {path} is not a PEM private key "
                              f"({exc})") from None
    if not isinstance(key, Ed25519PrivateKey):
        raise StationKeyError(f"station signing key {path} is not an Ed25519 key")
    return key


def public_hex(key) -> str:
    """The raw 32-byte public key of a private key, as 64 hex digits."""
    from cryptography.hazmat.primitives import serialization

    return key.public_key().public_bytes(serialization.Encoding.Raw,
                                         serialization.PublicFormat.Raw).hex()


def fingerprint(public_key_hex: str) -> str:
    """``SHA256:<base64>`` of the raw public key (the form ``ssh-keygen -l`` prints)."""
    digest = hashlib.sha256(bytes.fromhex(public_key_hex)).digest()
    return "SHA256:" + base64.b64encode(digest).decode("ascii").rstrip("=")


def trusted_keys(extra: tuple[str, ...] | list[str] = ()) -> dict[str, str]:
    """Trusted public keys (hex) → where each came from: the station's own key, the entries of
    ``$RIPPLE_HIL_TRUSTED_KEYS`` and ``extra`` (each a hex key or a file of hex keys)."""
    trusted = {}
    try:
        own = station_key(create=False)
    except StationKeyError:
        own = None
    if own is not None:
        trusted[public_hex(own)] = f"this station's key ({key_dir() / KEY_FILE})"
    entries = [e for e in os.environ.get(TRUSTED_ENV, "").split(os.pathsep) if e.strip()]
    for entry in [*entries, *extra]:
        for key in _keys_of(entry.strip()):
            trusted.setdefault(key, entry.strip())
    return trusted


def _keys_of(entry: str) -> list[str]:
    if _is_hex_key(entry):
        return [entry.lower()]
    try:
        lines = Path(entry).read_text(encoding="utf-8").split()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"trusted key {entry!r}: neither 64 hex digits nor a readable file "
                         f"({exc})") from None
    keys = [line.lower() for line in lines if _is_hex_key(line)]
    if not keys:
        raise InputError(f"trusted key file {entry!r} holds no 64-hex-digit public key")
    return keys


def _is_hex_key(text: str) -> bool:
    return len(text) == 64 and all(c in "0123456789abcdefABCDEF" for c in text)


# ---------------------------------------------------------------------- signed lines

def _canonical(entry: dict) -> bytes:
    body = {k: v for k, v in entry.items() if k != "signature"}
    return json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def _signed_line(entry: dict, key) -> str:
    entry = dict(entry, algorithm=ALGORITHM, public_key=public_hex(key))
    entry["signature"] = key.sign(_canonical(entry)).hex()
    return json.dumps(entry, sort_keys=True, separators=(",", ":"))


def _signature_ok(entry: dict) -> bool:
    from cryptography.exceptions import InvalidSignature
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

    try:
        public = Ed25519PublicKey.from_public_bytes(bytes.fromhex(entry["public_key"]))
        public.verify(bytes.fromhex(entry["signature"]), _canonical(entry))
    except (InvalidSignature, KeyError, TypeError, ValueError, binascii.Error):
        return False
    return True


def seal_section(key, journal_head: str | None) -> dict:
    """The ``seal`` section a record carries (hashed with it): which key signs it."""
    public = public_hex(key)
    return {"algorithm": ALGORITHM, "public_key": public, "fingerprint": fingerprint(public),
            "journal_head": journal_head, "signature_file": SIG_FILE}


def write_seal(folder: Path, record_id: str, record_sha256: str, journal_head: str | None,
               key, write) -> None:
    """Write ``record.sig`` with the seal line (``write(path, bytes)``: the record's writer)."""
    line = _signed_line({"format": SEAL_FORMAT, "kind": "seal", "record_id": record_id,
                         "record_sha256": record_sha256, "journal_head": journal_head}, key)
    write(Path(folder) / SIG_FILE, (line + "\n").encode("ascii"))


def _read_lines(folder: Path) -> list[str] | None:
    try:
        text = (Path(folder) / SIG_FILE).read_text(encoding="ascii")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{SIG_FILE}: cannot read it ({exc})") from None
    return [line for line in text.split("\n") if line.strip()]


@dataclass
class SealCheck:
    """What :func:`check_seal` found. ``state``: ``signed`` (valid, trusted key),
    ``untrusted`` (valid, key not trusted here), ``bad-signature``, ``missing`` (the record
    names a key but has no valid seal line), ``unsigned`` (sealed before signing)."""

    state: str
    fingerprint: str | None = None
    trusted_by: str | None = None
    problems: list[str] = field(default_factory=list)

    def text(self) -> str:
        """One line for ``hil verify`` and the report."""
        if self.state == "signed":
            return f"signed (Ed25519, key {self.fingerprint}, trusted: {self.trusted_by})"
        if self.state == "untrusted":
            return f"signed by key {self.fingerprint}, which is NOT a trusted key here"
        if self.state == "unsigned":
            return ("unsigned (sealed before signing): its hashes can be rewritten by anyone, "
                    "so they prove nothing against a re-seal")
        key = f" (key {self.fingerprint})" if self.fingerprint else ""
        if self.state == "bad-signature":
            return f"the signature does NOT match{key}"
        return f"no valid signature{key}"


def check_seal(folder: str | Path, data: dict, record_sha256: str,
               trusted: dict[str, str] | None = None) -> SealCheck:
    """Check the signature of a finished record whose ``record.json`` hashes to
    ``record_sha256`` (``trusted``: :func:`trusted_keys` when None)."""
    section = data.get("seal")
    lines = _read_lines(Path(folder))
    if not section and lines is None:
        return SealCheck("unsigned")
    if not isinstance(section, dict) or not section.get("public_key"):
        reason = (section or {}).get("unsigned_reason") if isinstance(section, dict) else None
        if reason:
            return SealCheck("missing", problems=[f"record.json was not signed: {reason}"])
        return SealCheck("missing", problems=[
            f"{SIG_FILE} exists but record.json names no signing key (its seal section was "
            f"removed or edited)"])
    printed = fingerprint(section["public_key"]) if _is_hex_key(section["public_key"]) else None
    if not lines:
        return SealCheck("missing", printed, problems=[
            f"record.json names signing key {printed} but {SIG_FILE} is missing or empty"])
    try:
        seal = json.loads(lines[0])
    except json.JSONDecodeError:
        return SealCheck("bad-signature", printed, problems=[f"{SIG_FILE} line 1 is damaged"])
    if not _signature_ok(seal) or seal.get("kind") != "seal":
        return SealCheck("bad-signature", printed, problems=[
            f"{SIG_FILE}: the signature does not match its seal line (edited or forged)"])
    if seal.get("public_key") != section["public_key"]:
        return SealCheck("bad-signature", printed, problems=[
            f"{SIG_FILE} is signed by key {fingerprint(seal['public_key'])}, record.json names "
            f"{printed}"])
    if seal.get("record_sha256") != record_sha256 or seal.get("record_id") != data.get(
            "record_id") or seal.get("journal_head") != section.get("journal_head"):
        return SealCheck("bad-signature", printed, problems=[
            f"the signature does not match record.json: it signs SHA-256 "
            f"{seal.get('record_sha256')}, record.json has {record_sha256} (the record was "
            f"changed and re-hashed after it was signed)"])
    trusted = trusted_keys() if trusted is None else trusted
    if section["public_key"] not in trusted:
        return SealCheck("untrusted", printed, problems=[
            f"signed by key {printed}, which is not a trusted key of this station (trust it "
            f"with {TRUSTED_ENV} or --trusted-key)"])
    return SealCheck("signed", printed, trusted_by=trusted[section["public_key"]])


# ---------------------------------------------------------------------- revisions

def revision_entries(folder: str | Path, trusted: dict[str, str] | None = None
                     ) -> list[dict] | None:
    """The report revisions issued from a signed record (oldest first), every line's signature
    and chain checked; None for a record without ``record.sig`` (sealed before signing).

    InputError when a line is damaged, forged, signed by an untrusted key or out of chain."""
    lines = _read_lines(Path(folder))
    if lines is None:
        return None
    trusted = trusted_keys() if trusted is None else trusted
    out = []
    for number, line in enumerate(lines[1:], start=2):
        where = f"{SIG_FILE} line {number}"
        try:
            entry = json.loads(line)
        except json.JSONDecodeError:
            raise InputError(f"{where} is damaged; the revision history cannot be read") from None
        if not _signature_ok(entry) or entry.get("kind") != "revision":
            raise InputError(f"{where}: its signature does not match (edited or forged); no "
                             f"revision is issued from a history that does not verify")
        if entry.get("public_key") not in trusted:
            raise InputError(f"{where} is signed by key {fingerprint(entry['public_key'])}, "
                             f"which is not trusted here (trust it with {TRUSTED_ENV})")
        if entry.get("prev") != hashlib.sha256(lines[number - 2].encode()).hexdigest() \
                or entry.get("revision") != len(out) + 1:
            raise InputError(f"{where} does not follow the line before it (a revision was "
                             f"removed, reordered or inserted)")
        out.append({k: entry.get(k) for k in ("revision", "report_id", "pdf", "issued_utc",
                                               "reason")})
    return out


def append_revision(folder: str | Path, entry: dict, key=None) -> None:
    """Append one signed report revision to ``record.sig``, chained on its last line."""
    folder = Path(folder)
    lines = _read_lines(folder)
    if not lines:
        raise InputError(f"{folder}: no {SIG_FILE}; a revision can only chain on a signed seal")
    key = key or station_key()
    line = _signed_line(dict(entry, kind="revision",
                             prev=hashlib.sha256(lines[-1].encode()).hexdigest()), key)
    with open(folder / SIG_FILE, "a", encoding="ascii") as handle:
        handle.write(line + "\n")
        handle.flush()
        os.fsync(handle.fileno())


def _os_error_text(exc: OSError) -> str:
    import errno as _errno

    name = _errno.errorcode.get(exc.errno or 0, "")
    return f"{exc.strerror or exc}" + (f" ({name})" if name else "")
