"""Capture transfer (issue 17): channels, auto-increment, pipelined reads, packed encoder; and
capture integrity (issue 13): sample count and time base, with the DAQ drop defect."""

from __future__ import annotations

import math

import numpy as np
import pytest
from daq_twin import SPEED_RPM
from hypothesis import given, settings
from hypothesis import strategies as st

from ripple_hil_drivers.daq_register_map import load_register_map
from ripple_hil_drivers.modbus_daq import (LEGACY_TRANSFER, CaptureIntegrityError, DeviceFailure, ModbusDaq,
                                ModbusTcpSettings, TransferOptions)
from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq, stored_ticks
from hil.errors import InputError
from hil.sim import DriveTwin
from hil.sim.defects import DriveDefects

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

MAP = load_register_map()
RATE_HZ = 20000


def tcp(server, **options) -> ModbusDaq:
    transfer = TransferOptions(**options) if options else TransferOptions()
    return ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=2.0, transfer=transfer)


def speed_rpm(capture) -> float:
    slope = np.polyfit(capture["time_s"], capture["rotor_angle_mech_rad"], 1)[0]
    return slope * 60 / (2 * math.pi)


def test_only_the_channels_asked_for_travel(daq):
    capture = daq.capture(0.01, RATE_HZ, settle_s=0.0, channels=["torque_nm",
                                                                 "rotor_angle_mech_rad"])
    assert set(capture.channels) == {"time_s", "torque_nm", "encoder_counts",
                                     "rotor_angle_mech_rad", "sample_counter"}
    transfer = capture.meta["daq_transfer"]
    assert transfer["words_per_sample"] == 3         # torque + packed encoder + sample counter
    assert transfer["packed"] and transfer["read_mode"] == "auto_increment"
    assert transfer["buffer_requests"] == math.ceil(200 * 3 / 125)
    with pytest.raises(InputError, match="no channel 'speed_rpm'"):
        daq.capture(0.01, RATE_HZ, channels=["speed_rpm"])


@pytest.mark.parametrize("options", [{}, {"in_flight": 1}, {"packed": False},
                                     {"read_mode": "paged"}, {"in_flight": 3, "packed": False}])
def test_every_transfer_mode_reads_the_same_buffer(daq_server, options):
    """One finished capture read with the legacy transfer and with ``options``: same words."""
    with tcp(daq_server, **options) as daq, \
            ModbusDaq(ModbusTcpSettings(*daq_server.address), transfer=LEGACY_TRANSFER) as old:
        daq.arm(RATE_HZ, 700, 0.0, daq.capture_channels(), packed=options.get("packed", True))
        daq.trigger()
        daq.wait_done(10.0)
        new = daq.read_buffer()
        reference = old.read_buffer()
        daq.disarm()
    for name in reference.channels:
        assert np.array_equal(new[name], reference[name]), name
    assert np.array_equal(new["sample_counter"], np.arange(700))
    assert speed_rpm(new) == pytest.approx(SPEED_RPM, rel=0.01)


def test_round_trips_of_a_readout_before_and_after(daq_server):
    """Readout round trips: status, configuration, (first value,) mode, then the buffer."""
    samples = 2000
    traffic = daq_server.device.traffic
    with tcp(daq_server) as new, \
            ModbusDaq(ModbusTcpSettings(*daq_server.address), transfer=LEGACY_TRANSFER) as old:
        old.identity()
        requests = traffic.requests - traffic.requests_while_capturing
        before = old.capture(samples / RATE_HZ, RATE_HZ, settle_s=0.0).meta["daq_transfer"]
        served = traffic.requests - traffic.requests_while_capturing - requests
        new.identity()
        requests = traffic.requests - traffic.requests_while_capturing
        after = new.capture(samples / RATE_HZ, RATE_HZ, settle_s=0.0,
                            channels=["torque_nm", "rotor_angle_mech_rad"]).meta["daq_transfer"]
        served_after = traffic.requests - traffic.requests_while_capturing - requests
    pages_before = math.ceil(samples * 7 / 125)        # 6 words + vab_v's (legacy readout)
    pages_after = math.ceil(samples * 3 / 125)
    assert before["round_trips_readout"] == 3 + 2 * pages_before
    assert after["round_trips_readout"] == 4 + math.ceil(pages_after / 8)
    # the DAQ counts the same requests (the pipelined ones all, but in fewer round trips),
    # plus the status poll that finds the capture done (the others came while it captured)
    assert served == before["round_trips_setup"] + before["round_trips_readout"] + 1
    assert served_after == after["round_trips_setup"] + 4 + pages_after + 1


def test_the_packed_encoder_is_the_32_bit_counter(daq):
    # at 1000 rpm the 7200-count counter passes 65536 every 0.55 s: a 0.8 s capture wraps the
    # low word at least once, and the re-anchored counter must not notice
    capture = daq.capture(0.8, 2000, settle_s=0.0, channels=["rotor_angle_mech_rad"])
    counts = capture["encoder_counts"]
    assert capture.meta["daq_transfer"]["packed"]
    assert counts[-1] - counts[0] > 65536
    assert np.all(np.diff(counts) > 0)
    assert speed_rpm(capture) == pytest.approx(SPEED_RPM, rel=0.01)
    # the next capture starts where this one ended (the twin only runs while capturing), at the
    # next PWM counter valley (< 1/20 kHz later: the simulated DAQ's sample clock is synchronised
    # to the carrier): its absolute counts come from encoder_counts_first, not from the low word
    after = daq.capture(0.01, 2000, settle_s=0.0, channels=["rotor_angle_mech_rad"])
    one_pwm_period = SPEED_RPM / 60 * 7200 / 20_000
    assert after["encoder_counts"][0] - counts[-1] == pytest.approx(
        SPEED_RPM / 60 * 7200 / 2000 + one_pwm_period / 2, abs=2 + one_pwm_period / 2)


@settings(max_examples=60, deadline=None)
@given(start=st.integers(0, 2**32 - 1),
       steps=st.lists(st.integers(-32767, 32767), min_size=1, max_size=100))
def test_packed_counter_reassembles_across_both_wraps(start, steps):
    counts = start + np.concatenate(([0], np.cumsum(steps)))
    channel = MAP.channel("encoder_counts")
    raw, _ = channel.to_raw(counts)
    low = channel.from_words(channel.to_words(raw, packed=True), packed=True)
    problems = []
    got = ModbusDaq._counter_counts(channel, low, True,
                                    {"encoder_counts_first": int(raw[0])}, problems)
    assert not problems
    first = start - 2**32 if start >= 2**31 else start     # the 32-bit value, two's complement
    assert np.array_equal(got, first + (counts - start))


def test_packing_is_refused_where_the_encoder_could_move_half_the_low_word(daq):
    # 3000 rpm at 7200 counts/rev: 360,000 counts/s; at 10 Hz a sample may move 36,000 > 32767
    assert not daq._packing_is_safe(["encoder_counts"], 10.0)
    assert daq._packing_is_safe(["encoder_counts"], 12.0)
    assert not daq._packing_is_safe(["torque_nm"], RATE_HZ)      # nothing to pack


# ----------------------------------------------------------------------------- integrity
def dropping_twin(every_nth: int) -> DriveTwin:
    twin = DriveTwin(seed=0, defects=DriveDefects(daq_drop_every_nth=every_nth))
    with twin.lock:
        twin.speed_rpm = SPEED_RPM
        twin.current_command_a = 10.0
        twin.enable()
    return twin


def test_stored_ticks_lose_every_nth_and_keep_the_count():
    assert stored_ticks(5).tolist() == [0, 1, 2, 3, 4]
    assert stored_ticks(12, 5).tolist() == [0, 1, 2, 3, 5, 6, 7, 8, 10, 11, 12, 13]
    ticks = stored_ticks(1000, 10)
    assert len(ticks) == 1000 and not np.any((ticks + 1) % 10 == 0)


def test_a_daq_that_drops_every_10th_sample_is_caught_with_the_data_kept():
    with SimulatedDaq(dropping_twin(10)) as server, tcp(server) as daq:
        with pytest.raises(CaptureIntegrityError) as caught:
            daq.capture(0.05, RATE_HZ, settle_s=0.0)
        assert daq.status()["state"] == "idle"            # disarmed all the same
    error = caught.value
    assert str(error).startswith("daq: check capture integrity: time base not uniform at "
                                 "20000 Hz: the sample counter skips at 111 of 999 steps "
                                 "(first after sample 8, by 2 ticks; 111 samples lost")
    capture = error.capture                                  # the data as received
    assert len(capture) == 1000
    assert np.diff(capture["time_s"]).max() == pytest.approx(2 / RATE_HZ)
    assert capture.meta["daq_integrity"]["problems"] == error.problems
    assert speed_rpm(capture) == pytest.approx(SPEED_RPM, rel=0.01)    # true times kept


def test_without_the_sample_counter_the_drop_passes_unseen():
    """The time-base check needs the counter: the legacy transfer (no counter) cannot see it."""
    with SimulatedDaq(dropping_twin(10)) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), transfer=LEGACY_TRANSFER) as daq:
        capture = daq.capture(0.05, RATE_HZ, settle_s=0.0)
    assert capture.meta["daq_integrity"] == {"checked_time_base": False, "problems": []}
    assert speed_rpm(capture) == pytest.approx(SPEED_RPM * 1000 / 900, rel=0.01)  # 11 % fast


def test_fewer_samples_than_requested_and_a_wrong_rate_are_named(daq):
    daq.arm(RATE_HZ, 300, 0.0, daq.capture_channels())
    daq.trigger()
    daq.wait_done(10.0)
    with pytest.raises(CaptureIntegrityError, match=r"^daq: check capture integrity: asked for "
                                                    r"320 samples, the DAQ was set to 300 and "
                                                    r"returned 300$") as caught:
        daq.read_buffer(samples_requested=320)
    assert len(caught.value.capture) == 300
    with pytest.raises(CaptureIntegrityError, match="asked for 10000 Hz, the DAQ sampled at "
                                                    "20000 Hz"):
        daq.read_buffer(rate_requested_hz=10000)
    assert len(daq.read_buffer(300, RATE_HZ)) == 300
    daq.disarm()


@pytest.mark.parametrize("kind, options", [("timeout", {}), ("disconnect", {}),
                                           ("timeout", {"read_mode": "paged", "in_flight": 1})])
def test_a_readout_that_loses_an_answer_is_read_again(daq_server, monkeypatch, kind, options):
    """The DAQ keeps its buffer until disarmed: one lost answer or connection costs a second
    readout, not the capture."""
    daq = ModbusDaq(ModbusTcpSettings(*daq_server.address), timeout_s=0.3,
                    transfer=TransferOptions(**options)).connect()
    real_write = daq.write_registers
    injected = []

    def write_then_fail(**values):
        real_write(**values)
        if "buffer_read_mode" in values and not injected:
            injected.append(kind)
            daq_server.fail_next(kind)             # the first buffer request goes unanswered

    monkeypatch.setattr(daq, "write_registers", write_then_fail)
    try:
        capture = daq.capture(0.05, RATE_HZ, settle_s=0.0)
    finally:
        daq.close()
    assert injected == [kind]
    assert capture.meta["daq_transfer"]["readout_retried_after"].startswith("daq: ")
    assert np.array_equal(capture["sample_counter"], np.arange(1000))


def test_a_refusal_mid_readout_is_not_retried(daq_server, monkeypatch, daq):
    real_write = daq.write_registers

    def write_then_refuse(**values):
        real_write(**values)
        if "buffer_read_mode" in values:
            daq_server.fail_next("exception")

    monkeypatch.setattr(daq, "write_registers", write_then_refuse)
    with pytest.raises(DeviceFailure, match="window 0"):
        daq.capture(0.05, RATE_HZ, settle_s=0.0)
