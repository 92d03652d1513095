"""The unit under test's identity (design.md §10: traceability; issue 32 item 2).

Three facts sit side by side in the record's ``dut`` section: the serial *stated* for the unit
(``hil run --dut-serial``, or the station's scan), the drive's *own* CiA 301 identity (0x1018:01
vendor-ID, :02 product code, :03 revision, :04 serial number, read over SDO when the bench opens),
and the *check* between the two, made before anything is written to the drive.

How a stated serial is compared with the drive's serial number (UNSIGNED32): the bench file's
``[drive] serial_label`` (a Python format of ``serial``, e.g. ``"EPS-A-{serial:04d}"``) writes the
label the unit carries for that number, and the stated serial must be that label. Without a
``serial_label`` a stated serial is compared only when it is a plain number (decimal or ``0x``
hex); otherwise the record says it was not compared, and why. A mismatch is refused — one error
line, exit code 2, nothing driven — unless ``--dut-serial-override REASON`` is given; the
override and its reason are recorded and stated on page 1.
"""

from __future__ import annotations

from hil.errors import InputError

#: The record's keys of the drive's 0x1018 identity (``drivers/cia402.py`` IDENTITY_SUBS).
IDENTITY_KEYS = ("vendor", "product", "revision", "serial")
#: ``check`` values of the record's ``dut`` section.
MATCH, MISMATCH_OVERRIDDEN, NOT_COMPARED, NO_SERIAL = (
    "match", "mismatch, overridden", "not compared", "no serial stated")


class DutSerialRefused(InputError):
    """The stated DUT serial is not the drive's, and no override was given (exit code 2)."""


def drive_label(identity: dict, serial_label: str) -> str | None:
    """The label the unit carries for the drive's serial number, by ``serial_label`` (None:
    the drive reports no serial number, or no label format is stated)."""
    serial = identity.get("serial")
    if serial is None or not serial_label:
        return None
    try:
        return serial_label.format(serial=int(serial))
    except (KeyError, IndexError, ValueError) as exc:
        raise InputError(f"drive.serial_label = {serial_label!r} cannot write serial "
                         f"{serial}: {exc} (a Python format of {{serial}}, e.g. "
                         f"\"EPS-A-{{serial:04d}}\")") from None


def _as_number(text: str) -> int | None:
    try:
        return int(text, 16) if text.lower().startswith("0x") else int(text, 10)
    except ValueError:
        return None


def dut_section(stated: str | None, stated_by: str, identity: dict, serial_label: str = "",
                override: str | None = None) -> dict:
    """The record's ``dut`` section; raises :class:`DutSerialRefused` on a mismatch without an
    override. ``identity``: the drive's identity as read (keys of :data:`IDENTITY_KEYS`)."""
    drive = {key: identity.get(key) for key in IDENTITY_KEYS}
    label = drive_label(identity, serial_label)
    section = {"serial": stated, "stated_by": stated_by if stated else None,
               "drive_identity": drive, "drive_label": label, "serial_label": serial_label or None,
               "override": None}
    if not stated:
        return section | {"check": NO_SERIAL, "reason": "no serial was stated for the unit"}
    if drive["serial"] is None:
        return section | {"check": NOT_COMPARED,
                          "reason": "the drive reports no serial number (0x1018:04)"}
    if label is not None:
        same = stated == label
        expected = label
    elif _as_number(stated) is not None:
        same = _as_number(stated) == int(drive["serial"])
        expected = str(drive["serial"])
    else:
        return section | {"check": NOT_COMPARED,
                          "reason": "the bench file states no [drive] serial_label to write "
                                    "the drive's serial number as the unit's label"}
    if same:
        return section | {"check": MATCH, "reason": f"the drive's serial number "
                                                    f"{drive['serial']} is {stated}"}
    reason = (f"the unit's serial {stated} ({stated_by}) is not the drive's: it reports serial "
              f"number {drive['serial']} (0x1018:04), label {expected}")
    if not override:
        raise DutSerialRefused(f"refused, nothing driven: {reason} (scan the unit on the bench, "
                               f"or give --dut-serial-override REASON to run it anyway; the "
                               f"override is recorded)")
    return section | {"check": MISMATCH_OVERRIDDEN, "reason": reason, "override": override}


def item_tested(record: dict) -> str | None:
    """Page 1's words for the unit (its stated serial, the drive's own serial beside it, and an
    override when one was needed); None when the record has no ``dut`` section."""
    dut = record.get("dut")
    if not dut:
        return None
    drive = dut.get("drive_identity") or {}
    own = drive.get("serial")
    parts = [f"{dut['serial']} ({dut.get('stated_by')})" if dut.get("serial")
             else "unit serial not stated"]
    if own is not None:
        others = ", ".join(f"{key} 0x{int(drive[key]):08X}"
                           for key in ("vendor", "product", "revision")
                           if drive.get(key) is not None)
        parts.append(f"drive 0x1018 serial number {own}" + (f" ({others})" if others else ""))
    parts.append(f"serial check: {dut.get('check')}")
    if dut.get("override"):
        parts.append(f"override: {dut['override']}")
    return "; ".join(parts)
