"""Serial torque transducer throughput: samples per second, both dialects, over a pty.

Run: ``.venv/bin/python benchmarks/transducer_bench.py`` (prints one line per figure). The
simulated transducer is backed by the real ``hil.sim.DriveTwin`` (each reading advances it one
sample period). Figures: polled ``read()`` and pipelined ``stream(n)``, on an unpaced pty (the
software limit) and paced to the family's published default baud rate (the line limit).
"""

from __future__ import annotations

import argparse
import time

from ripple_hil_drivers.simulated.transducer_pty import SimulatedTransducer
from ripple_hil_drivers.torque_transducer import SerialSettings, TorqueTransducer
from ripple_hil_drivers.transducer_dialects import LINE_SETTINGS
from operating_twin import operating_twin  # benchmarks/, run as a script


def rate(label: str, action, n: int) -> None:
    start = time.perf_counter()
    action()
    elapsed = time.perf_counter() - start
    print(f"{label}: {n / elapsed:,.0f} samples/s ({n} in {elapsed:.3f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5000)
    args = parser.parse_args()
    twin = operating_twin()
    n = args.samples
    for dialect in ("magtrol", "himmelstein"):
        published = LINE_SETTINGS[dialect].default_baudrate      # Magtrol 19200, Himmelstein 38400
        for baud in (None, published):
            line = "unpaced pty" if baud is None else f"pty paced at {baud} baud"
            count = n if baud is None else n // 10
            with SimulatedTransducer(twin, dialect=dialect, sample_rate_hz=10000.0,
                                     pace_baud=baud) as sim, \
                    TorqueTransducer(SerialSettings(sim.port), dialect=dialect,
                                     timeout_s=2.0) as tt:
                tt.read()
                rate(f"{dialect} {line}: polled read()",
                     lambda: [tt.read() for _ in range(count // 5)], count // 5)
                rate(f"{dialect} {line}: stream({count})", lambda: tt.stream(count), count)


if __name__ == "__main__":
    main()
