"""An independent CANopen responder for the driver tests, built with ``durand`` (not ``canopen``).

durand (PyPI) implements the responder side of CiA 301: NMT slave, SDO server (expedited,
segmented, block), PDOs, EMCY producer, heartbeat producer. This module gives a durand
``MinimalNode`` the drive's dictionary, read from the shipped EDS with ``configparser`` (not
python-canopen's importer), and a thin CiA 402 layer written from the standard's table
(``cia402_table``), so ``ripple_hil_drivers.cia402.Cia402Drive`` meets a device it did not grow up with:

* 0x1000, 0x1008, 0x100A, 0x1018 and every EDS object durand does not create itself hold the
  EDS values; durand's own communication objects (0x1001, 0x1005, 0x1014, 0x1017, PDO records)
  keep durand's behaviour. durand's TPDO records have no event timer (sub-index 5): one is added
  so the master can write it, and the live values are refreshed every ``live_period_s``, each
  refresh sending the TPDOs (transmission type 255 sends on every update).
* controlword 0x6040 (SDO or RPDO) drives the CiA 402 state; statusword 0x6041 follows it;
  0x6060 is mirrored in 0x6061; 0x2000 <- "load" restores the injection objects 0x2001.. to their
  EDS defaults, any other value is refused (durand aborts 0x08000020); limits are durand's.
* ``raise_fault`` enters FAULT and sends an EMCY; ``stop_heartbeat`` sets 0x1017 to 0.

The heartbeat consumer (0x1016) is stored, not acted on: master-loss handling is the simulated
drive's business and is tested there.
"""

from __future__ import annotations

import configparser
import threading
from pathlib import Path

import can
from durand import CANBusNetwork, MinimalNode, Record, Variable, set_scheduler
from durand.datatypes import DatatypeEnum
from durand.scheduler import SyncScheduler, get_scheduler

import cia402_table as cia402

from ripple_hil_drivers.canopen_eds import DEFAULT_EDS_PATH

RESTORE_SIGNATURE = 0x64616F6C          # "load" (CiA 301 0x1011 convention)
ACCESS = {"ro": "ro", "wo": "wo", "rw": "rw", "rwr": "rw", "rww": "rw", "const": "const"}


def _number(text: str, node_id: int) -> int:
    text = text.strip().replace(" ", "")
    if text.upper().startswith("$NODEID"):
        rest = text[7:]
        return node_id + (int(rest[1:], 0) if rest.startswith("+") else 0)
    return int(text, 0)


def _variable(entries, node_id: int) -> Variable:
    datatype = DatatypeEnum(int(entries["DataType"], 0))
    default = entries.get("DefaultValue")
    if datatype in (DatatypeEnum.VISIBLE_STRING, DatatypeEnum.OCTET_STRING, DatatypeEnum.DOMAIN):
        value = (default or "").encode("ascii")
        return Variable(datatype, ACCESS[entries["AccessType"].lower()], value,
                        name=entries["ParameterName"])
    limits = {key: _number(entries[name], node_id) for key, name in
              (("minimum", "LowLimit"), ("maximum", "HighLimit")) if name in entries}
    return Variable(datatype, ACCESS[entries["AccessType"].lower()],
                    _number(default, node_id) if default else 0, name=entries["ParameterName"],
                    **limits)


def read_eds_objects(path: Path, node_id: int) -> dict[int, Variable | dict[int, Variable]]:
    """Each object of the EDS: a Variable, or {sub-index: Variable} for an ARRAY/RECORD."""
    eds = configparser.RawConfigParser()
    eds.optionxform = str
    eds.read(path, encoding="ascii")
    objects: dict = {}
    for section in eds.sections():
        if len(section) == 4:
            index = int(section, 16)
            if eds.get(section, "ObjectType", fallback="0x7").lower() in ("0x7", "7"):
                objects[index] = _variable(eds[section], node_id)
            else:
                objects[index] = {}
        elif "sub" in section:
            index, sub = int(section[:4], 16), int(section[7:], 16)
            if sub:
                objects[index][sub] = _variable(eds[section], node_id)
    return objects


class DurandDrive:
    """A CiA 402 responder node on a python-can bus, made with durand from the shipped EDS."""

    def __init__(self, channel: str, node_id: int = 5, *, eds_path=DEFAULT_EDS_PATH,
                 serial_number: int = 0x0D0D, live_period_s: float = 0.01) -> None:
        self.channel, self.node_id, self.serial_number = channel, node_id, serial_number
        self.eds_path, self.live_period_s = Path(eds_path), live_period_s
        self.state = cia402.SOD
        self.actual = {0x6077: 0, 0x606C: 0, 0x6064: 0}     # torque, velocity, position on the bus
        self._controlword = 0
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    # -- lifecycle ------------------------------------------------------------------------
    def start(self) -> "DurandDrive":
        self._previous_scheduler = get_scheduler()
        self.scheduler = SyncScheduler()
        set_scheduler(self.scheduler)
        self.bus = can.Bus(interface="virtual", channel=self.channel)
        self.network = CANBusNetwork(self.bus)
        self.node = MinimalNode(self.network, self.node_id)
        self._load_dictionary()
        self._threads = [threading.Thread(target=self.scheduler.run, daemon=True,
                                          name="durand-scheduler"),
                         threading.Thread(target=self._live, daemon=True, name="durand-live")]
        for thread in self._threads:
            thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        try:
            self.od.write(0x1017, 0, 0)                   # cancels the heartbeat timer
        except ValueError:                                # the timer was firing just now
            pass
        for entry in list(self.scheduler._sched.queue):
            try:
                self.scheduler.cancel(entry)
            except ValueError:
                pass
        self.scheduler.stop()
        self.scheduler.stop()        # a second wake-up: the first may come before the stop flag
        for thread in self._threads:
            thread.join(timeout=2.0)
        self.network.stop()
        self.bus.shutdown()
        set_scheduler(self._previous_scheduler)

    def __enter__(self) -> "DurandDrive":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- dictionary ---------------------------------------------------------------------
    def _load_dictionary(self) -> None:
        od = self.od = self.node.object_dictionary
        objects = read_eds_objects(self.eds_path, self.node_id)
        for index, obj in objects.items():
            if index in od:
                continue                                   # durand's own object and behaviour
            if isinstance(obj, dict):
                record = Record(name=f"0x{index:04X}")
                for sub, variable in obj.items():
                    record[sub] = variable
                od[index] = record
            else:
                od[index] = obj
        for index in (0x1000, 0x1008, 0x100A):
            if index in objects:
                od[index] = objects[index]
        for sub, variable in objects[0x1018].items():
            od[0x1018][sub] = variable
        od[0x1018][4] = Variable(DatatypeEnum.UNSIGNED32, "ro", self.serial_number,
                                 name="Serial number")
        for number in range(4):                            # event timer, written by the master
            od[0x1800 + number][5] = Variable(DatatypeEnum.UNSIGNED16, "rw", 0,
                                              name="Event timer")
        self.knobs = {index: obj.value for index, obj in objects.items() if 0x2001 <= index < 0x2100}
        od.update_callbacks[(0x6040, 0)].add(self._on_controlword)
        od.update_callbacks[(0x6060, 0)].add(lambda mode: od.write(0x6061, 0, mode))
        od.validate_callbacks[(0x2000, 0)].add(self._check_restore)
        od.update_callbacks[(0x2000, 0)].add(self._restore_defaults)
        self._publish_state()
        od.write(0x1017, 0, objects[0x1017].value)        # EDS default: produce from the start

    def _check_restore(self, value: int) -> None:
        if value != RESTORE_SIGNATURE:
            raise ValueError("restore defaults needs the 'load' signature")

    def _restore_defaults(self, _value: int) -> None:
        for index, default in self.knobs.items():
            self.od.write(index, 0, default)

    # -- CiA 402 -------------------------------------------------------------------------
    def _on_controlword(self, controlword: int) -> None:
        self.state = cia402.next_state(self.state, controlword, self._controlword)
        self._controlword = controlword
        self._publish_state()

    def _publish_state(self) -> None:
        self.od.write(0x6041, 0, cia402.STATUSWORD[self.state] | cia402.REMOTE)

    def raise_fault(self, code: int, register: int = 0x03, data: bytes = b"") -> None:
        """Enter FAULT and send the EMCY (durand's producer on 0x080 + node-ID)."""
        self.state = cia402.FAULT
        self._publish_state()
        self.node.emcy.set(code, register, data)

    def stop_heartbeat(self) -> None:
        self.od.write(0x1017, 0, 0)

    def injection_counts(self) -> dict[int, int]:
        """What the responder holds in each injection object (bus counts)."""
        return {index: self.od.read(index, 0) for index in self.knobs}

    # -- live values: TPDOs at the event-timer rate ----------------------------------------
    def _live(self) -> None:
        while not self._stop.wait(self.live_period_s):
            for index, value in self.actual.items():
                self.od.write(index, 0, value)
            self._publish_state()
