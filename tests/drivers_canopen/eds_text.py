"""Edited copies of the shipped EDS for tests (planted faults, objects left out).

Works on the text, line by line inside one section, so a copy differs from the shipped file
only where a test says so; CRLF line endings are kept.
"""

from __future__ import annotations

import re
from pathlib import Path

from ripple_hil_drivers.canopen_eds import DEFAULT_EDS_PATH


def shipped_text() -> str:
    return DEFAULT_EDS_PATH.read_bytes().decode("ascii").replace("\r\n", "\n")


def set_key(text: str, section: str, key: str, value: str) -> str:
    """``key=value`` in ``[section]`` (the key must exist there)."""
    pattern = re.compile(rf"(^\[{re.escape(section)}\]\n(?:(?!\[).*\n)*?){re.escape(key)}=.*$",
                         re.MULTILINE)
    edited, count = pattern.subn(lambda m: f"{m.group(1)}{key}={value}", text, count=1)
    if count != 1:
        raise KeyError(f"[{section}] has no key {key!r}")
    return edited


def get_key(text: str, section: str, key: str) -> str:
    block = text.split(f"[{section}]\n", 1)[1].split("\n\n", 1)[0]
    return next(line.split("=", 1)[1] for line in block.splitlines() if line.startswith(key + "="))


def drop_objects(text: str, indices: list[int]) -> str:
    """The EDS without the objects ``indices``: their sections and their object-list entries."""
    names = {f"{index:04X}" for index in indices}
    kept = [block for block in text.split("\n\n")
            if not any(block.lstrip("\n").startswith(f"[{n}]") or
                       block.lstrip("\n").startswith(f"[{n}sub") for n in names)]
    text = "\n\n".join(kept)
    for group in ("MandatoryObjects", "OptionalObjects", "ManufacturerObjects"):
        head, rest = text.split(f"[{group}]\n", 1)
        block, tail = rest.split("\n\n", 1)
        entries = [line.split("=", 1)[1] for line in block.splitlines()[1:]]
        entries = [e for e in entries if f"{int(e, 16):04X}" not in names]
        block = f"SupportedObjects={len(entries)}\n" + "\n".join(
            f"{n}={e}" for n, e in enumerate(entries, 1))
        text = f"{head}[{group}]\n{block}\n\n{tail}"
    return text


def write(text: str, path: Path) -> Path:
    path.write_bytes(text.replace("\n", "\r\n").encode("ascii"))
    return path
