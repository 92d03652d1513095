"""Modbus DAQ: capture transfer per test plan before and after issue 17, and raw throughput.

Run: ``.venv/bin/python benchmarks/modbus_bench.py`` (prints one line per figure).

Per plan (the 8 sources; each point's capture duration, rate and channels from its
``hil.measurement.PointPlan``) every point is captured twice, back to back, from the simulated DAQ
over TCP loopback: *before* = the transfer before issue 17 (all channels, 32-bit encoder, a
``buffer_page`` write before every 125-register read, one request at a time) and *after* = the
plan's channels, the packed encoder, the sample counter (time-base check), auto-increment reads,
8 reads in flight. Requests and PDU bytes are counted by the DAQ itself, sequential round trips
by the driver; status polls while the DAQ captures are left out (on a real bench they overlap the
capture's own duration). Projections from those counts:

- TCP: round trips x 2 ms + ADU bytes (PDU + 7-byte MBAP header) over 100 Mbit/s;
- RTU at 115200 baud 8E1: every request and answer on the line (PDU + address + CRC, 11 bits per
  byte) plus two t3.5 silences per request (1.75 ms each above 19200 baud, Modbus serial line
  V1.02 §2.5.1.1); RTU has one request in flight, the device's turnaround is taken as 0.

Then the raw figures of earlier versions: registers/s paging a finished buffer (TCP loopback, RTU
on a pty) and whole-capture samples/s.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from ripple_hil_drivers.modbus_daq import (LEGACY_TRANSFER, ModbusDaq, ModbusRtuSettings,
                                ModbusTcpSettings, TransferOptions)
from ripple_hil_drivers.simulated.modbus_daq_server import SimulatedDaq
from operating_twin import operating_twin  # benchmarks/, run as a script

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))     # testplans/

TCP_ROUND_TRIP_S = 2e-3
TCP_LINK_BIT_PER_S = 100e6
TCP_HEADER_BYTES = 7
RTU_BAUD = 115200
RTU_BITS_PER_BYTE = 11            # 8E1: start, 8 data, parity, stop
RTU_FRAME_BYTES = 3               # address + CRC
RTU_T35_S = 1.75e-3               # fixed above 19200 baud
MODES = {"before": LEGACY_TRANSFER, "after": TransferOptions()}


def plan_points(config) -> dict[str, list]:
    """The 8 sources' PointPlans, built by the test plans' own ``plan`` functions."""
    from ripple_hil_testplans import conditions as c
    from ripple_hil_testplans import (test_baseline, test_dc_offset, test_dead_time, test_encoder,
                           test_gain_mismatch, test_pwm_resolution, test_pwm_switching,
                           test_word_length)

    return {
        "baseline": [test_baseline.plan(config)],
        "encoder": [test_encoder.plan(config, i) for i in c.ENCODER_SWEEP],
        "word_length": [test_word_length.plan(config, i) for i in c.WORD_LENGTH_SWEEP],
        "dc_offset": [test_dc_offset.plan(config, a, b) for a, b in c.DC_OFFSET_SWEEP_PU],
        "gain_mismatch": [test_gain_mismatch.plan(config, i) for i in c.GAIN_SWEEP],
        "pwm_resolution": [test_pwm_resolution.plan(config, i)
                           for i in c.PWM_RESOLUTION_SWEEP],
        "pwm_switching": [test_pwm_switching.plan(config, i) for i in c.PWM_SWITCHING_SWEEP],
        "dead_time": [test_dead_time.plan(config, i) for i in c.DEAD_TIME_SWEEP],
    }


@dataclass
class Transfer:
    """What one capture's transfer cost, polls excluded."""

    samples: int = 0
    words_per_sample: int = 0
    requests: int = 0
    round_trips: int = 0
    pdu_bytes: int = 0
    loopback_s: float = 0.0

    def __iadd__(self, other: "Transfer") -> "Transfer":
        for name in ("samples", "requests", "round_trips", "pdu_bytes", "loopback_s"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.words_per_sample = other.words_per_sample
        return self

    @property
    def tcp_bytes(self) -> int:
        return self.pdu_bytes + 2 * TCP_HEADER_BYTES * self.requests

    @property
    def tcp_s(self) -> float:
        return self.round_trips * TCP_ROUND_TRIP_S + self.tcp_bytes * 8 / TCP_LINK_BIT_PER_S

    @property
    def rtu_s(self) -> float:
        line_bytes = self.pdu_bytes + 2 * RTU_FRAME_BYTES * self.requests
        return line_bytes * RTU_BITS_PER_BYTE / RTU_BAUD + 2 * RTU_T35_S * self.requests


def capture_point(server: SimulatedDaq, daq: ModbusDaq, plan, pole_pairs: int,
                  channels) -> Transfer:
    traffic = server.device.traffic
    requests, polls = traffic.requests, traffic.requests_while_capturing
    pdu = traffic.request_pdu_bytes + traffic.response_pdu_bytes
    poll_bytes = traffic.pdu_bytes_while_capturing
    start = time.perf_counter()
    capture = daq.capture(plan.capture_duration_s(pole_pairs), plan.capture_rate_hz(pole_pairs),
                          settle_s=0.0, channels=channels)
    elapsed = time.perf_counter() - start
    meta = capture.meta["daq_transfer"]
    return Transfer(
        samples=len(capture), words_per_sample=meta["words_per_sample"],
        requests=(traffic.requests - requests) - (traffic.requests_while_capturing - polls),
        # + the status poll that finds the capture done (the DAQ counts it outside the capture)
        round_trips=meta["round_trips_setup"] + meta["round_trips_readout"] + 1,
        pdu_bytes=(traffic.request_pdu_bytes + traffic.response_pdu_bytes - pdu)
        - (traffic.pdu_bytes_while_capturing - poll_bytes),
        loopback_s=elapsed)


def per_plan(points_per_plan: int | None) -> None:
    from hil.config import default_sim_bench

    config = default_sim_bench()
    pole_pairs = config.motor.pole_pairs
    twin = operating_twin()
    totals = {mode: Transfer() for mode in MODES}
    rows = []
    with SimulatedDaq(twin) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=5.0,
                      transfer=MODES["before"]) as before, \
            ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=5.0,
                      transfer=MODES["after"]) as after:
        for source, points in plan_points(config).items():
            points = points[:points_per_plan] if points_per_plan else points
            sums = {mode: Transfer() for mode in MODES}
            for plan in points:                    # back to back, point by point
                sums["before"] += capture_point(server, before, plan, pole_pairs, None)
                sums["after"] += capture_point(server, after, plan, pole_pairs,
                                               plan.capture_channels())
            for mode in MODES:
                totals[mode] += sums[mode]
            rows.append((source, len(points), sums))
    print("Modbus transfer per plan, per point (before: all channels, paged, 1 in flight; "
          "after: the plan's channels, packed, auto-increment, 8 in flight; polls excluded)")
    print(f"{'plan':15s} {'pts':>3s} {'samples/pt':>10s} | {'words/sample':>12s} | "
          f"{'requests/pt':>13s} | {'TCP bytes/pt':>19s} | {'TCP 2 ms s/pt':>13s} | "
          f"{'RTU 115200 s/pt':>15s} | {'loopback s/pt':>13s}")
    print(f"{'':30s} | {'before after':>12s} | {'before  after':>13s} | "
          f"{'before     after':>19s} | {'before after':>13s} | {'before  after':>15s} | "
          f"{'before after':>13s}")
    for source, n, sums in rows:
        b, a = sums["before"], sums["after"]
        print(f"{source:15s} {n:3d} {b.samples / n:10.0f} | {b.words_per_sample:6d} "
              f"{a.words_per_sample:5d} | {b.requests / n:6.0f} {a.requests / n:6.0f} | "
              f"{b.tcp_bytes / n:9.0f} {a.tcp_bytes / n:9.0f} | {b.tcp_s / n:6.2f} "
              f"{a.tcp_s / n:6.2f} | {b.rtu_s / n:7.1f} {a.rtu_s / n:7.1f} | "
              f"{b.loopback_s / n:6.3f} {a.loopback_s / n:6.3f}")
    for mode, total in totals.items():
        print(f"Modbus run ({mode}): {total.requests} requests, {total.tcp_bytes / 1e6:.2f} MB "
              f"over TCP, {total.round_trips} round trips; projected TCP at 2 ms round trip "
              f"{total.tcp_s:.1f} s, RTU at 115200 baud 8E1 {total.rtu_s:.1f} s; "
              f"loopback measured {total.loopback_s:.2f} s")


def measure(label: str, daq: ModbusDaq, samples: int, rate_hz: int, repeats: int) -> None:
    daq.identity()
    daq.arm(rate_hz, samples, settle_s=0.0)
    daq.trigger()
    status = daq.wait_done(60.0)
    registers = samples * status["words_per_sample"]
    start = time.perf_counter()
    for _ in range(repeats):
        daq.read_buffer()
    elapsed = time.perf_counter() - start
    requests = daq.read_buffer().meta["daq_transfer"]["buffer_requests"]
    print(f"{label}: buffer paging {registers * repeats / elapsed:,.0f} registers/s "
          f"({registers} registers in {requests} windows, "
          f"{daq.transfer.read_mode}, x{repeats})")
    daq.disarm()
    start = time.perf_counter()
    capture = daq.capture(samples / rate_hz, rate_hz, settle_s=0.0)
    elapsed = time.perf_counter() - start
    print(f"{label}: whole capture of {len(capture)} samples x {len(capture.channels)} channels "
          f"in {elapsed:.3f} s ({len(capture) / elapsed:,.0f} samples/s end to end)")


def throughput(samples: int, rate_hz: int) -> None:
    twin = operating_twin()
    with SimulatedDaq(twin) as server:
        for label, transfer in (("TCP loopback", MODES["before"]),
                                ("TCP loopback pipelined", MODES["after"])):
            with ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=2.0,
                           transfer=transfer) as daq:
                measure(f"Modbus {label}", daq, samples, rate_hz, repeats=3)
    with SimulatedDaq.rtu(twin) as server, \
            ModbusDaq(ModbusRtuSettings(server.port), timeout_s=2.0) as daq:
        measure("Modbus RTU pty (unpaced)", daq, samples // 4, rate_hz, repeats=1)
    with SimulatedDaq.rtu(twin, baudrate=RTU_BAUD, pace_baud=True) as server, \
            ModbusDaq(ModbusRtuSettings(server.port, baudrate=RTU_BAUD), timeout_s=2.0) as daq:
        measure(f"Modbus RTU pty paced at {RTU_BAUD} baud 8E1", daq, 1000, rate_hz, repeats=1)
        rtu_model_check(server, daq, rate_hz)


def rtu_model_check(server: SimulatedDaq, daq: ModbusDaq, rate_hz: int) -> None:
    """The RTU projection's line time against a readout over the pty paced at 11 bits per byte
    (the pty does not keep the t3.5 silences: the model is shown with and without them)."""
    daq.arm(rate_hz, 1000, settle_s=0.0, channels=daq.capture_channels(), packed=True)
    daq.trigger()
    daq.wait_done(60.0)
    traffic = server.device.traffic
    requests, pdu = traffic.requests, traffic.request_pdu_bytes + traffic.response_pdu_bytes
    start = time.perf_counter()
    daq.read_buffer()
    measured = time.perf_counter() - start
    daq.disarm()
    model = Transfer(requests=traffic.requests - requests,
                     pdu_bytes=traffic.request_pdu_bytes + traffic.response_pdu_bytes - pdu)
    gaps = 2 * RTU_T35_S * model.requests
    print(f"Modbus RTU model check: readout of 1000 samples ({model.requests} requests) "
          f"measured {measured:.3f} s on the paced pty; model {model.rtu_s - gaps:.3f} s of "
          f"line time (+ {gaps:.3f} s of t3.5 silences on a real line)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20000)
    parser.add_argument("--rate-hz", type=int, default=20000)
    parser.add_argument("--points-per-plan", type=int, default=None,
                        help="capture only the first N points of each plan (default: all)")
    args = parser.parse_args()
    per_plan(args.points_per_plan)
    throughput(args.samples, args.rate_hz)


if __name__ == "__main__":
    main()
