"""Benchmark of the analysis chain: prints samples per second (the whole chain, 10 M samples).

Run: ``.venv/bin/python benchmarks/analysis_bench.py [--samples N] [--daq-rate-hz R]``.
The chain must be faster than capturing the samples: it prints the analysis rate next to the
DAQ sample rate it is compared with, and the ratio. The headline rate is the best of
``--repeat`` calls (wall clock); a second line gives their median and the process CPU time per
call (all threads), and the load average, because the machine may be shared. The first call
(compiling, or loading the on-disk cache of, the compiled passes) is timed apart and not counted.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from hil.analysis import InstrumentUncertainty, analyze_torque


def synthetic_record(samples: int, sample_rate_hz: float, seed: int = 0):
    """Time, electrical angle (±5 % speed wobble around 66.7 Hz) and noisy order-6/36 torque."""
    time_s = np.arange(samples) / sample_rate_hz
    omega = 2 * np.pi * 66.7
    angle = omega * time_s + omega * 0.05 / (2 * np.pi * 1.3) * np.sin(2 * np.pi * 1.3 * time_s)
    torque = 1.0 + 0.02 * np.cos(6 * angle + 0.7) + 0.005 * np.cos(36 * angle)
    torque += np.random.default_rng(seed).normal(0.0, 0.01, samples)
    return time_s, torque, angle


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000_000)
    parser.add_argument("--daq-rate-hz", type=float, default=100_000.0,
                        help="capture sample rate to compare with (default 100 kS/s)")
    parser.add_argument("--max-order", type=int, default=64)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    time_s, torque, angle = synthetic_record(args.samples, args.daq_rate_hz)
    instruments = InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                        transducer_full_scale_nm=5.0, daq_lsb_nm=1e-3)

    def call():
        return analyze_torque(time_s, torque, angle, max_order=args.max_order, named_order=6,
                              instruments=instruments)

    start = time.perf_counter()
    result = call()
    first_s = time.perf_counter() - start
    walls, cpus = [], []
    for _ in range(args.repeat):
        start, cpu_start = time.perf_counter(), time.process_time()
        result = call()
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu_start)
    best = min(walls)
    rate = args.samples / best
    print(f"samples: {args.samples}, revolutions: {result.revolutions}, "
          f"max_order: {args.max_order}, grid: {result.samples_per_rev} bins/rev")
    print(f"analysis chain: {best:.3f} s (best of {args.repeat}) = {rate:,.0f} samples/s")
    median_wall, median_cpu = statistics.median(walls), statistics.median(cpus)
    print(f"median of {args.repeat}: {median_wall:.3f} s wall "
          f"({args.samples / median_wall:,.0f} samples/s), {median_cpu:.3f} s CPU "
          f"({args.samples / median_cpu:,.0f} samples/s); load average "
          + " ".join(f"{load:.2f}" for load in os.getloadavg()))
    print(f"first call (compile or cache load, plus the chain): {first_s:.3f} s")
    print(f"capture of the same samples at {args.daq_rate_hz:,.0f} S/s: "
          f"{args.samples / args.daq_rate_hz:.1f} s; analysis is {rate / args.daq_rate_hz:.0f}x "
          "faster than capturing")
    print(f"check: order 6 = {result.named_amplitude_nm:.5f} N*m (0.02 injected), "
          f"pk-pk = {result.pk_pk_pu:.5f} pu ± {result.uncertainty.expanded_pu:.5f}")


if __name__ == "__main__":
    main()
