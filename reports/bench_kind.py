"""Page 1's "Bench" line: which kind of bench ran the tests, as the record says.

The record's ``run.bench_location`` (written by the plugin from ``hil.bench.Bench.location()``
when the bench opened) names the kind — simulated in this process, simulated in a separate
process (``hil sim-bench``), or real — and each instrument's address. A record written before
that field existed says only whether the bench was simulated; the line then says no more.
"""

from __future__ import annotations

KIND_TEXT = {
    "simulated-in-process": "simulated bench started inside this test run (hil.sim twin behind "
                            "the real protocol stacks; no hardware)",
    "simulated-separate-process": "simulated bench served by a separate process (e.g. hil "
                                  "sim-bench; hil.sim twin, no hardware)",
    "real": "real bench",
}
#: a record without ``run.bench_location``: only the bench file's ``simulated`` flag is known
UNLOCATED_TEXT = {True: "simulated bench (the record does not say in which process)",
                  False: "real bench"}
ROLE_NAMES = {"drive": "drive", "daq": "DAQ", "torque": "transducer"}


def bench_text(record: dict) -> str:
    """The kind, where the instruments were (not for an in-process bench: its loopback
    addresses were made up for the run) and the bench file."""
    bench = record.get("bench") or {}
    location = (record.get("run") or {}).get("bench_location") or {}
    kind = location.get("kind")
    if kind in KIND_TEXT:
        text = KIND_TEXT[kind]
        addresses = location.get("addresses") or {}
        if kind != "simulated-in-process" and addresses:
            text += " at " + "; ".join(f"{ROLE_NAMES.get(role, role)}: {where}"
                                       for role, where in addresses.items())
    else:
        text = UNLOCATED_TEXT[bool(bench.get("simulated"))]
    return f"{text}; file {bench.get('path') or 'not recorded'}"
