"""Modbus DAQ throughput: registers per second over TCP loopback and RTU on a pty.

Run: ``.venv/bin/python benchmarks/modbus_bench.py`` (prints one line per figure). The simulated
DAQ is backed by the real ``hil.sim.DriveTwin``; the figures are wall-clock rates of the driver
paging a finished capture buffer out (a page = write ``buffer_page`` + read 125 registers), and
of whole captures (configure, arm, trigger, simulate, page out, convert).
"""

from __future__ import annotations

import argparse
import time

from drivers.modbus_daq import ModbusDaq, ModbusRtuSettings, ModbusTcpSettings
from drivers.simulated.modbus_daq_server import SimulatedDaq
from operating_twin import operating_twin  # benchmarks/, run as a script


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
    pages = -(-registers // 125)
    print(f"{label}: buffer paging {registers * repeats / elapsed:,.0f} registers/s "
          f"({2 * pages * repeats / elapsed:,.0f} transactions/s, {registers} registers "
          f"in {pages} pages, x{repeats})")
    daq.disarm()
    start = time.perf_counter()
    capture = daq.capture(samples / rate_hz, rate_hz, settle_s=0.0)
    elapsed = time.perf_counter() - start
    print(f"{label}: whole capture of {len(capture)} samples x 7 channels in {elapsed:.3f} s "
          f"({len(capture) / elapsed:,.0f} samples/s end to end)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20000)
    parser.add_argument("--rate-hz", type=int, default=20000)
    args = parser.parse_args()
    twin = operating_twin()
    with SimulatedDaq(twin) as server, \
            ModbusDaq(ModbusTcpSettings(*server.address), timeout_s=2.0) as daq:
        measure("Modbus TCP loopback", daq, args.samples, args.rate_hz, repeats=3)
    with SimulatedDaq.rtu(twin) as server, \
            ModbusDaq(ModbusRtuSettings(server.port), timeout_s=2.0) as daq:
        measure("Modbus RTU pty (unpaced)", daq, args.samples // 4, args.rate_hz, repeats=1)
    baud = 115200
    with SimulatedDaq.rtu(twin, baudrate=baud, pace_baud=True) as server, \
            ModbusDaq(ModbusRtuSettings(server.port, baudrate=baud), timeout_s=2.0) as daq:
        measure(f"Modbus RTU pty paced at {baud} baud", daq, 1000, args.rate_hz, repeats=1)


if __name__ == "__main__":
    main()
