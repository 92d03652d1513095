"""Benchmark of the digital twin: wall seconds per simulated second (target <= 0.02, i.e. 50x
faster than real time), for the full non-ideal drive on one core and for a batch of 16 sets.

Run: ``.venv/bin/python benchmarks/sim_bench.py [--seconds S] [--daq-rate-hz R]``.
"The full non-ideal drive": every injection knob on (20 kHz PWM with 2000 counts, dead time 1 µs,
both current-sensor offsets and gain errors, encoder decimation 10, 16-bit fixed-point firmware,
φ = 0.2 rad) at 1000 rpm and 20 A, sampled at the DAQ rate; printed for the Table I motor and
again with the optional motor imperfections (5th/7th EMF harmonics and cogging). The batch
varies speed and current over 16 full drives (with imperfections) and runs them with
``simulate_batch`` (numba prange over every core). The first calls' compile or cache-load time
is printed apart; the figures are the median of ``--repeats`` runs, wall and CPU seconds of this
process (on a shared machine the CPU figure is the one other load does not inflate; the load
average is printed before and after). The Table I drive is also timed at a 1 MHz output rate,
where writing the samples, not the PWM periods, dominates; and, at 20 kHz and at 1 MHz, with
only the three channels a ripple plan needs (``time_s``, ``rotor_angle_mech_rad``,
``torque_nm``: the engine computes nothing else per sample, issue 17 item 4).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numba

from hil.sim import DriveConfig, Injection, MotorModel, simulate, simulate_batch


#: what a ripple plan's analysis reads (the torque against the rotor angle, and the time base)
PLAN_CHANNELS = ("time_s", "rotor_angle_mech_rad", "torque_nm")


def full_drive(speed_rpm: float = 1000.0, current_a: float = 20.0,
               imperfect_motor: bool = True) -> DriveConfig:
    injection = Injection(ia_offset_a=0.2, ib_offset_a=-0.1, ia_gain_error_pu=0.01,
                          ib_gain_error_pu=-0.01, encoder_decimation=10, word_length_bits=16,
                          pwm_period_counts=2000, pwm_frequency_hz=20000.0, dead_time_s=1e-6,
                          current_angle_rad=0.2)
    motor = MotorModel(emf_harmonics=((5, 0.01, 0.0), (7, 0.005, 0.0)),
                       cogging=((24, 0.005, 0.0),)) if imperfect_motor else MotorModel()
    return DriveConfig(motor=motor, injection=injection, current_command_a=current_a,
                       speed_rpm=speed_rpm)


def median_of(repeats: int, call, clock=time.perf_counter) -> float:
    """Median of ``repeats`` calls on ``clock`` (wall by default; ``time.process_time`` gives
    the CPU seconds of this process, which other load on a shared machine does not inflate)."""
    times = []
    for _ in range(repeats):
        start = clock()
        call()
        times.append(clock() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="simulated seconds per run")
    parser.add_argument("--daq-rate-hz", type=float, default=20_000.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    start = time.perf_counter()
    simulate(full_drive(), 0.001, args.daq_rate_hz)
    simulate_batch([full_drive(), full_drive()], 0.001, args.daq_rate_hz)
    print(f"first calls (compile or cache load): {time.perf_counter() - start:.2f} s")
    print(f"cores: {os.cpu_count()}, numba threads: {numba.get_num_threads()}, "
          f"load average: {os.getloadavg()[0]:.2f}")

    for imperfect, label in ((False, "Table I motor"), (True, "+ EMF harmonics, cogging")):
        config = full_drive(imperfect_motor=imperfect)
        wall = median_of(args.repeats, lambda: simulate(config, args.seconds, args.daq_rate_hz))
        cpu = median_of(args.repeats, lambda: simulate(config, args.seconds, args.daq_rate_hz),
                        time.process_time)
        print(f"one drive, one core, {label:<24}: {wall / args.seconds:.4f} wall s per "
              f"simulated s ({args.seconds / wall:.0f}x real time; issue 17 goal <= 0.006), "
              f"{cpu / args.seconds:.4f} CPU s")
    config = full_drive(imperfect_motor=False)
    for rate_hz, seconds, channels, label in (
            (args.daq_rate_hz, args.seconds, PLAN_CHANNELS, "3 channels"),
            (1e6, args.seconds / 10.0, None, "1 MHz output"),
            (1e6, args.seconds / 10.0, PLAN_CHANNELS, "1 MHz output, 3 channels")):
        def run():
            simulate(config, seconds, rate_hz, channels=channels)
        wall = median_of(args.repeats, run)
        cpu = median_of(args.repeats, run, time.process_time)
        print(f"one drive, one core, Table I motor, {label:<24}: {wall / seconds:.4f} wall s per "
              f"simulated s, {cpu / seconds:.4f} CPU s")

    configs = [full_drive(speed_rpm=200.0 + 100.0 * (k % 8), current_a=10.0 + 10.0 * (k // 8))
               for k in range(16)]
    wall = median_of(args.repeats,
                     lambda: simulate_batch(configs, args.seconds, args.daq_rate_hz))
    print(f"batch of 16, all cores: {wall / args.seconds:.4f} wall s per simulated s of the "
          f"batch, {wall / args.seconds / 16:.4f} per drive-second "
          f"({16 * args.seconds / wall:.0f}x real time per drive)")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
