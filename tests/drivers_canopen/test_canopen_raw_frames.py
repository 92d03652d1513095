"""Independent checks: the simulated drive against hand-built CAN frames per CiA 301 / CiA 402.

No canopen master here: frames are packed with ``struct`` from the standard's layouts, so the
node is proved against the standard, not only against the library it is built on.
"""

from __future__ import annotations

import struct
import time

import can
import pytest

pytestmark = [pytest.mark.integration, pytest.mark.timeout(20)]

NODE = 5
SDO_RX, SDO_TX, HEARTBEAT, EMCY, TPDO1, RPDO1 = 0x600 + NODE, 0x580 + NODE, 0x700 + NODE, \
    0x080 + NODE, 0x180 + NODE, 0x200 + NODE


@pytest.fixture
def raw(sim_drive, bus_settings):
    with can.Bus(interface="virtual", channel=bus_settings.channel) as bus:
        yield bus


def send(bus, can_id, data):
    bus.send(can.Message(arbitration_id=can_id, data=bytes(data), is_extended_id=False))


def wait_for(bus, can_id, timeout=1.0, predicate=lambda m: True):
    deadline = time.monotonic() + timeout
    while (remaining := deadline - time.monotonic()) > 0:
        msg = bus.recv(timeout=remaining)
        if msg is not None and msg.arbitration_id == can_id and predicate(msg):
            return msg
    return None


def sdo_upload(bus, index, subindex, timeout=0.5):
    """Expedited SDO upload (ccs=2): returns the 8 response bytes or None on silence."""
    send(bus, SDO_RX, struct.pack("<BHB4x", 0x40, index, subindex))
    msg = wait_for(bus, SDO_TX, timeout)
    return None if msg is None else bytes(msg.data)


def sdo_download_u32(bus, index, subindex, value):
    """Expedited SDO download of 4 bytes (ccs=1, e=1, s=1, n=0 → 0x23)."""
    send(bus, SDO_RX, struct.pack("<BHBI", 0x23, index, subindex, value & 0xFFFFFFFF))
    return bytes(wait_for(bus, SDO_TX).data)


def test_sdo_upload_of_device_type(raw):
    response = sdo_upload(raw, 0x1000, 0)
    # scs=2, expedited, size indicated, 4 bytes: 0x43; device type 402 + servo drive info
    assert response[0] == 0x43
    assert struct.unpack_from("<HB", response, 1) == (0x1000, 0)
    assert struct.unpack_from("<I", response, 4)[0] == 0x00020192


def test_sdo_abort_for_missing_object_and_out_of_range_injection(raw, twin):
    response = sdo_upload(raw, 0x2FFF, 0)
    assert response[0] == 0x80 and struct.unpack_from("<I", response, 4)[0] == 0x06020000
    # ia_offset_a is INTEGER32 mA, limit 20000: 25000 mA → abort "value too high"
    response = sdo_download_u32(raw, 0x2001, 0, 25000)
    assert response[0] == 0x80 and struct.unpack_from("<I", response, 4)[0] == 0x06090031
    response = sdo_download_u32(raw, 0x2001, 0, -25000)
    assert struct.unpack_from("<I", response, 4)[0] == 0x06090032
    assert twin.injection.ia_offset_a == 0.0
    response = sdo_download_u32(raw, 0x2001, 0, -1500)
    assert response[0] == 0x60  # download confirmed
    assert twin.injection.ia_offset_a == pytest.approx(-1.5)
    # restore object: a wrong signature is refused, "load" restores
    response = sdo_download_u32(raw, 0x2000, 0, 0x12345678)
    assert struct.unpack_from("<I", response, 4)[0] == 0x08000020
    assert sdo_download_u32(raw, 0x2000, 0, int.from_bytes(b"load", "little"))[0] == 0x60
    assert twin.injection.ia_offset_a == 0.0
    # PDO mapping entries must name a mappable object of the right size
    response = sdo_download_u32(raw, 0x1A00, 1, 0x20010020)  # injection object: not mappable
    assert struct.unpack_from("<I", response, 4)[0] == 0x06040041
    response = sdo_download_u32(raw, 0x1A00, 1, 0x60410020)  # statusword is 16 bits, not 32
    assert struct.unpack_from("<I", response, 4)[0] == 0x06040041


def test_heartbeat_period_and_nmt_states(raw):
    first = wait_for(raw, HEARTBEAT, 0.5)
    second = wait_for(raw, HEARTBEAT, 0.5)
    assert first.data[0] == 0x7F and second.data[0] == 0x7F  # PRE-OPERATIONAL
    assert 0.05 < second.timestamp - first.timestamp < 0.4  # 0x1017 default 100 ms (+ load jitter)
    send(raw, 0x000, [0x01, NODE])  # NMT start remote node
    assert wait_for(raw, HEARTBEAT, 0.5, lambda m: m.data[0] == 0x05) is not None
    send(raw, 0x000, [0x02, 0x00])  # NMT stop, all nodes
    assert wait_for(raw, HEARTBEAT, 0.5, lambda m: m.data[0] == 0x04) is not None
    assert sdo_upload(raw, 0x1000, 0, timeout=0.2) is None  # no SDO while STOPPED
    send(raw, 0x000, [0x81, NODE])  # reset node: boot-up message (state byte 0)
    assert wait_for(raw, HEARTBEAT, 0.5, lambda m: m.data[0] == 0x00) is not None
    assert wait_for(raw, HEARTBEAT, 0.5, lambda m: m.data[0] == 0x7F) is not None


def test_controlword_by_rpdo_and_statusword_by_tpdo(raw, twin):
    send(raw, 0x000, [0x01, NODE])
    for controlword, state_bits in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27)):
        send(raw, RPDO1, struct.pack("<H", controlword))
        msg = wait_for(raw, TPDO1, 0.5, lambda m: struct.unpack_from("<H", m.data)[0] & 0x6F == state_bits)
        assert msg is not None, hex(controlword)
    assert twin.enabled
    send(raw, RPDO1, struct.pack("<H", 0x02))  # quick stop
    assert wait_for(raw, TPDO1, 0.5, lambda m: m.data[0] & 0x6F == 0x07) is not None
    assert not twin.enabled
    # leaving NMT OPERATIONAL takes the drive to SWITCH ON DISABLED, and RPDOs are then ignored
    send(raw, 0x000, [0x80, NODE])
    time.sleep(0.05)
    assert sdo_upload(raw, 0x6041, 0)[4] & 0x4F == 0x40
    send(raw, RPDO1, struct.pack("<H", 0x06))  # shutdown, would give READY TO SWITCH ON
    time.sleep(0.05)
    assert sdo_upload(raw, 0x6041, 0)[4] & 0x4F == 0x40


def test_emcy_frame_on_fault_and_on_reset(raw, sim_drive):
    sim_drive.raise_fault(code=0x3210, text="dcbus")
    msg = wait_for(raw, EMCY)
    code, register = struct.unpack_from("<HB", msg.data)
    assert (code, register) == (0x3210, 0x05)  # generic + voltage bit
    assert bytes(msg.data[3:8]) == b"dcbus"
    assert sdo_upload(raw, 0x603F, 0)[4:6] == struct.pack("<H", 0x3210)
    sdo_download = struct.pack("<BHBH2x", 0x2B, 0x6040, 0, 0x80)  # fault reset, 2 bytes
    send(raw, SDO_RX, sdo_download)
    msg = wait_for(raw, EMCY)
    assert struct.unpack_from("<HB", msg.data) == (0x0000, 0x00)  # error reset
    assert sim_drive.state == "SWITCH ON DISABLED"


def test_tpdo_event_timer_and_sync_transmission(raw):
    send(raw, 0x000, [0x01, NODE])
    stamps = [wait_for(raw, TPDO1).timestamp for _ in range(8)]
    intervals = sorted(b - a for a, b in zip(stamps, stamps[1:]))
    assert 0.005 < intervals[len(intervals) // 2] < 0.03  # median; event timer 0x1800:05 = 10 ms
    send(raw, 0x000, [0x80, NODE])  # PRE-OPERATIONAL to reconfigure TPDO1 as synchronous
    time.sleep(0.02)
    response = sdo_upload(raw, 0x1800, 2)
    assert response[4] == 255
    send(raw, SDO_RX, struct.pack("<BHBB3x", 0x2F, 0x1800, 2, 2))  # every 2nd SYNC
    assert wait_for(raw, SDO_TX).data[0] == 0x60
    send(raw, 0x000, [0x01, NODE])
    time.sleep(0.05)
    while raw.recv(timeout=0) is not None:
        pass
    assert wait_for(raw, TPDO1, 0.1) is None  # no SYNC, no TPDO1
    tpdo_count = 0
    for _ in range(6):
        send(raw, 0x080, [])
        if wait_for(raw, TPDO1, 0.2) is not None:
            tpdo_count += 1
    assert tpdo_count == 3


def test_emcy_and_sync_cob_ids_follow_0x1014_and_0x1005(raw, sim_drive):
    assert sdo_download_u32(raw, 0x1014, 0, 0x0C5)[0] == 0x60          # EMCY now on 0x0C5
    sim_drive.raise_fault(code=0x2310, text="moved")
    assert wait_for(raw, 0x0C5) is not None and wait_for(raw, EMCY, 0.1) is None
    assert sdo_download_u32(raw, 0x1014, 0, 0x800000C5)[0] == 0x60     # bit 31: EMCY off
    sim_drive.raise_fault(code=0x2310, text="quiet")
    assert wait_for(raw, 0x0C5, 0.1) is None
    send(raw, 0x000, [0x80, NODE])                                    # TPDO1 on every SYNC
    time.sleep(0.02)
    send(raw, SDO_RX, struct.pack("<BHBB3x", 0x2F, 0x1800, 2, 1))
    assert wait_for(raw, SDO_TX).data[0] == 0x60
    assert sdo_download_u32(raw, 0x1005, 0, 0x081)[0] == 0x60          # SYNC now on 0x081
    send(raw, 0x000, [0x01, NODE])
    time.sleep(0.05)
    while raw.recv(timeout=0) is not None:
        pass
    send(raw, 0x080, [])
    assert wait_for(raw, TPDO1, 0.1) is None                          # the old SYNC: ignored
    send(raw, 0x081, [])
    assert wait_for(raw, TPDO1, 0.2) is not None


def test_motor_rated_torque_is_writable_and_scales_the_torque_values(raw, twin):
    assert sdo_download_u32(raw, 0x6076, 0, 2000)[0] == 0x60          # 2 N*m rated
    send(raw, SDO_RX, struct.pack("<BHBh2x", 0x2B, 0x6071, 0, 500))   # 500 per mille
    assert wait_for(raw, SDO_TX).data[0] == 0x60
    from hil.motor import TABLE_I
    assert twin.current_command_a == pytest.approx(1.0 / TABLE_I.torque_constant_nm_per_a)
    assert struct.unpack_from("<I", sdo_download_u32(raw, 0x6076, 0, 0), 4)[0] == 0x06090032
