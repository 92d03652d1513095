"""A strict CiA 306 (EDS file format, v1.3) checker for the tests: returns every fault found.

Written from the format description, independently of python-canopen (which imports EDS files
leniently) and of eds-utils (which auto-fixes instead of refusing). Checked:

* sections: [FileInfo], [DeviceInfo], [MandatoryObjects], [OptionalObjects],
  [ManufacturerObjects] present; their required keys and value formats (CreationDate mm-dd-yyyy,
  CreationTime hh:mm(AM|PM), BaudRate_* / boolean keys 0 or 1, Granularity 0..64);
* object lists: ``SupportedObjects`` equals the number of entries, entries numbered 1..n, no index
  twice, Mandatory = communication objects 0x1000/0x1001/0x1018 only (and all of them), Optional in
  0x1000..0x1FFF or 0x6000..0xFFFF, Manufacturer in 0x2000..0x5FFF, every object section listed
  exactly once and every listed index has a section;
* objects: ParameterName (1..241 characters), ObjectType 0x7 / 0x8 / 0x9, sub-index sections only
  under ARRAY / RECORD, ``SubNumber`` = number of sub-index sections, sub 0 UNSIGNED8 holding the
  highest sub-index (PDO mapping objects: the number of mapped objects, at most the entries
  present), no unknown keys;
* variables: DataType one of the CiA 301 basic types, AccessType ro / wo / rw / rwr / rww / const,
  PDOMapping 0 or 1 and 1 only for a numeric type, LowLimit <= HighLimit, limits only on numeric
  types, DefaultValue / limits inside the data type's range and the default inside the limits
  (``$NODEID`` offsets taken at node-ID 1..127).
"""

from __future__ import annotations

import re
from pathlib import Path

# CiA 301 basic data types: code -> (name, bit size or None for strings/domain, signed, float)
DATA_TYPES = {
    0x0001: ("BOOLEAN", 1, False, False), 0x0002: ("INTEGER8", 8, True, False),
    0x0003: ("INTEGER16", 16, True, False), 0x0004: ("INTEGER32", 32, True, False),
    0x0005: ("UNSIGNED8", 8, False, False), 0x0006: ("UNSIGNED16", 16, False, False),
    0x0007: ("UNSIGNED32", 32, False, False), 0x0008: ("REAL32", 32, True, True),
    0x0009: ("VISIBLE_STRING", None, False, False), 0x000A: ("OCTET_STRING", None, False, False),
    0x000B: ("UNICODE_STRING", None, False, False), 0x000F: ("DOMAIN", None, False, False),
    0x0010: ("INTEGER24", 24, True, False), 0x0011: ("REAL64", 64, True, True),
    0x0012: ("INTEGER40", 40, True, False), 0x0013: ("INTEGER48", 48, True, False),
    0x0014: ("INTEGER56", 56, True, False), 0x0015: ("INTEGER64", 64, True, False),
    0x0016: ("UNSIGNED24", 24, False, False), 0x0018: ("UNSIGNED40", 40, False, False),
    0x0019: ("UNSIGNED48", 48, False, False), 0x001A: ("UNSIGNED56", 56, False, False),
    0x001B: ("UNSIGNED64", 64, False, False),
}
ACCESS_TYPES = {"ro", "wo", "rw", "rwr", "rww", "const"}
OBJECT_TYPES = {0x7: "VAR", 0x8: "ARRAY", 0x9: "RECORD"}
VAR_KEYS = {"ParameterName", "Denotation", "ObjectType", "DataType", "AccessType", "DefaultValue",
            "LowLimit", "HighLimit", "PDOMapping", "ObjFlags", "ParameterValue"}
COMPLEX_KEYS = {"ParameterName", "Denotation", "ObjectType", "SubNumber", "ObjFlags"}
FILE_INFO_KEYS = ("FileName", "FileVersion", "FileRevision", "EDSVersion", "Description",
                  "CreationTime", "CreationDate", "CreatedBy")
DEVICE_INFO_KEYS = ("VendorName", "VendorNumber", "ProductName", "ProductNumber",
                    "RevisionNumber", "OrderCode", "BaudRate_10", "BaudRate_20", "BaudRate_50",
                    "BaudRate_125", "BaudRate_250", "BaudRate_500", "BaudRate_800",
                    "BaudRate_1000", "SimpleBootUpMaster", "SimpleBootUpSlave", "Granularity",
                    "DynamicChannelsSupported", "GroupMessaging", "NrOfRXPDO", "NrOfTXPDO",
                    "LSS_Supported")
BOOLEAN_KEYS = tuple(k for k in DEVICE_INFO_KEYS if k.startswith("BaudRate_")) + (
    "SimpleBootUpMaster", "SimpleBootUpSlave", "GroupMessaging", "LSS_Supported")
MANDATORY = {0x1000, 0x1001, 0x1018}
LISTS = ("MandatoryObjects", "OptionalObjects", "ManufacturerObjects")
_OBJECT = re.compile(r"^([0-9A-Fa-f]{4})$")
_SUB = re.compile(r"^([0-9A-Fa-f]{4})sub([0-9A-Fa-f]{1,2})$")


def parse_sections(text: str) -> tuple[dict[str, dict[str, str]], list[str]]:
    """INI sections (keys case-sensitive, comments skipped) and the faults of the syntax itself."""
    sections: dict[str, dict[str, str]] = {}
    faults, current = [], None
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith(";"):
            continue
        if line.startswith("[") and line.endswith("]"):
            current = line[1:-1]
            if current in sections:
                faults.append(f"line {number}: section [{current}] appears twice")
            sections.setdefault(current, {})
        elif "=" in line and current is not None:
            key, value = (part.strip() for part in line.split("=", 1))
            if key in sections[current]:
                faults.append(f"[{current}] {key} given twice")
            sections[current][key] = value
        else:
            faults.append(f"line {number}: not a section header or key=value: {line!r}")
    return sections, faults


def _int(text: str) -> int:
    text = text.strip()
    return int(text, 16) if text.lower().startswith("0x") else int(text, 10)


def _value(text: str, node_ids=(1, 127)) -> list[int | float]:
    """The value(s) a DefaultValue/limit stands for ($NODEID+x at the extreme node-IDs)."""
    compact = text.replace(" ", "")
    if compact.upper().startswith("$NODEID"):
        rest = compact[7:]
        offset = _int(rest[1:]) if rest.startswith("+") else 0
        return [node_id + offset for node_id in node_ids]
    try:
        return [_int(compact)]
    except ValueError:
        return [float(compact)]


def _type_range(code: int) -> tuple[float, float]:
    _, bits, signed, is_float = DATA_TYPES[code]
    if is_float:
        return float("-inf"), float("inf")
    if signed:
        return -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    return 0, (1 << bits) - 1


def check_variable(name: str, entries: dict[str, str]) -> list[str]:
    faults = [f"[{name}] unknown key {key!r}" for key in entries if key not in VAR_KEYS]
    for key in ("ParameterName", "DataType", "AccessType"):
        if key not in entries:
            faults.append(f"[{name}] {key} missing")
    if not 0 < len(entries.get("ParameterName", "x")) <= 241:
        faults.append(f"[{name}] ParameterName must be 1..241 characters")
    if entries.get("AccessType", "ro").lower() not in ACCESS_TYPES:
        faults.append(f"[{name}] AccessType {entries['AccessType']!r} is not one of "
                      f"{sorted(ACCESS_TYPES)}")
    try:
        code = _int(entries.get("DataType", "0x0007"))
    except ValueError:
        return faults + [f"[{name}] DataType {entries['DataType']!r} is not a number"]
    if code not in DATA_TYPES:
        return faults + [f"[{name}] DataType 0x{code:04X} is not a CiA 301 basic data type"]
    numeric = DATA_TYPES[code][1] is not None
    mapping = entries.get("PDOMapping", "0")
    if mapping not in ("0", "1"):
        faults.append(f"[{name}] PDOMapping {mapping!r} must be 0 or 1")
    elif mapping == "1" and not numeric:
        faults.append(f"[{name}] PDOMapping=1 on {DATA_TYPES[code][0]}, which cannot be mapped")
    if not numeric:
        for key in ("LowLimit", "HighLimit"):
            if key in entries:
                faults.append(f"[{name}] {key} on {DATA_TYPES[code][0]}")
        return faults
    low, high = _type_range(code)
    values = {}
    for key in ("LowLimit", "HighLimit", "DefaultValue"):
        if key in entries and entries[key].strip():
            try:
                values[key] = _value(entries[key])
            except ValueError:
                faults.append(f"[{name}] {key} {entries[key]!r} is not a number")
                continue
            if any(not low <= v <= high for v in values[key]):
                faults.append(f"[{name}] {key} {entries[key]} outside {DATA_TYPES[code][0]} "
                              f"range {low}..{high}")
    lo = min(values.get("LowLimit", [low]))
    hi = max(values.get("HighLimit", [high]))
    if lo > hi:
        faults.append(f"[{name}] LowLimit {entries['LowLimit']} > HighLimit {entries['HighLimit']}")
    if any(not lo <= v <= hi for v in values.get("DefaultValue", [])):
        faults.append(f"[{name}] DefaultValue {entries['DefaultValue']} outside "
                      f"LowLimit..HighLimit {lo}..{hi}")
    return faults


def check_lists(sections: dict) -> tuple[dict[int, str], list[str]]:
    listed: dict[int, str] = {}
    faults = []
    for group in LISTS:
        if group not in sections:
            faults.append(f"[{group}] missing")
            continue
        table = dict(sections[group])
        try:
            count = _int(table.pop("SupportedObjects"))
        except (KeyError, ValueError):
            faults.append(f"[{group}] SupportedObjects missing or not a number")
            continue
        if sorted(table) != sorted(str(n) for n in range(1, len(table) + 1)):
            faults.append(f"[{group}] entries are not numbered 1..{len(table)}")
        if count != len(table):
            faults.append(f"[{group}] SupportedObjects={count} but {len(table)} entries")
        for value in table.values():
            index = _int(value)
            if index in listed:
                faults.append(f"[{group}] 0x{index:04X} already listed in [{listed[index]}]")
            listed[index] = group
            allowed = {"MandatoryObjects": index in MANDATORY,
                       "OptionalObjects": 0x1000 <= index <= 0x1FFF or index >= 0x6000,
                       "ManufacturerObjects": 0x2000 <= index <= 0x5FFF}[group]
            if not allowed:
                faults.append(f"[{group}] 0x{index:04X} does not belong in this list")
    missing = MANDATORY - {i for i, g in listed.items() if g == "MandatoryObjects"}
    faults += [f"[MandatoryObjects] 0x{index:04X} missing" for index in sorted(missing)]
    return listed, faults


def check_header(sections: dict) -> list[str]:
    faults = []
    info = sections.get("FileInfo", {})
    faults += [f"[FileInfo] {key} missing" for key in FILE_INFO_KEYS if key not in info]
    for key in ("CreationDate", "ModificationDate"):
        if key in info and not re.fullmatch(r"(0[1-9]|1[0-2])-(0[1-9]|[12]\d|3[01])-\d{4}",
                                            info[key]):
            faults.append(f"[FileInfo] {key} {info[key]!r} is not mm-dd-yyyy")
    for key in ("CreationTime", "ModificationTime"):
        if key in info and not re.fullmatch(r"(0\d|1[0-2]):[0-5]\d(AM|PM)", info[key]):
            faults.append(f"[FileInfo] {key} {info[key]!r} is not hh:mm(AM|PM)")
    for key in ("FileVersion", "FileRevision"):
        if key in info and not 0 <= _int(info[key]) <= 255:
            faults.append(f"[FileInfo] {key} is an UNSIGNED8")
    device = sections.get("DeviceInfo", {})
    faults += [f"[DeviceInfo] {key} missing" for key in DEVICE_INFO_KEYS if key not in device]
    faults += [f"[DeviceInfo] {key} must be 0 or 1" for key in BOOLEAN_KEYS
               if key in device and device[key] not in ("0", "1")]
    if "Granularity" in device and not 0 <= _int(device["Granularity"]) <= 64:
        faults.append("[DeviceInfo] Granularity must be 0..64")
    return faults


def check_eds(path: str | Path) -> list[str]:
    """Every CiA 306 fault of the EDS file at ``path`` (empty list: the file is accepted)."""
    sections, faults = parse_sections(Path(path).read_text(encoding="ascii"))
    faults += check_header(sections)
    listed, list_faults = check_lists(sections)
    faults += list_faults
    objects = {int(m[1], 16): name for name in sections if (m := _OBJECT.match(name))}
    subs: dict[int, dict[int, str]] = {}
    for name in sections:
        if m := _SUB.match(name):
            subs.setdefault(int(m[1], 16), {})[int(m[2], 16)] = name
    faults += [f"[{name}] object section not listed in any object list"
               for index, name in objects.items() if index not in listed]
    faults += [f"0x{index:04X} listed in [{group}] but has no section"
               for index, group in listed.items() if index not in objects]
    faults += [f"[{index:04X}sub*] sub-index sections of an object without a section"
               for index in subs if index not in objects]
    for index, name in objects.items():
        entries = sections[name]
        try:
            object_type = _int(entries.get("ObjectType", "0x7"))
        except ValueError:
            object_type = -1
        if object_type not in OBJECT_TYPES:
            faults.append(f"[{name}] ObjectType {entries.get('ObjectType')!r} is not 0x7/0x8/0x9")
            continue
        if object_type == 0x7:
            faults += check_variable(name, entries)
            if index in subs:
                faults.append(f"[{name}] a VAR has sub-index sections")
            continue
        faults += [f"[{name}] unknown key {key!r}" for key in entries if key not in COMPLEX_KEYS]
        own = subs.get(index, {})
        if "SubNumber" not in entries:
            faults.append(f"[{name}] SubNumber missing")
        elif _int(entries["SubNumber"]) != len(own):
            faults.append(f"[{name}] SubNumber={entries['SubNumber']} but {len(own)} sub-index "
                          f"sections")
        if 0 not in own:
            faults.append(f"[{name}] sub 0 missing")
        for sub, sub_name in own.items():
            faults += check_variable(sub_name, sections[sub_name])
        if 0 in own:
            sub0 = sections[own[0]]
            if sub0.get("DataType") and _int(sub0["DataType"]) != 0x0005:
                faults.append(f"[{own[0]}] sub 0 must be UNSIGNED8")
            default = sub0.get("DefaultValue")
            mapping = 0x1600 <= index <= 0x17FF or 0x1A00 <= index <= 0x1BFF
            if default is not None and mapping and _value(default)[0] > max(own):
                faults.append(f"[{own[0]}] maps {default} objects but only {max(own)} entries "
                              f"exist")
            elif default is not None and not mapping and _value(default)[0] != max(own):
                faults.append(f"[{own[0]}] DefaultValue {default} is not the highest "
                              f"sub-index {max(own)}")
    return faults
